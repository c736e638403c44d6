// The conversion pipeline (docs/ARCHITECTURE.md "Data flow"): one function runs the stages in order
// on an imported scene and returns the bytes of every output. The CLI, the tests and the benches
// all call it; nothing else strings the stages together.
//
//   clean → atlas (→ flatten when few instances per submesh) → texture levels (encoded once)
//   → model.glb → simplify (progressive record) → multiplex (renders, order, mesh parts
//   encoded once) → stream package, base.glb, report.json + rd.svg
//
// Each thing is computed once and handed on: the texture levels feed model.glb (top level),
// base.glb and the package's base (level 0), the multiplexer (decoded for rendering) and the
// package's texture chunks; the multiplexer's encoded mesh parts are the package's mesh chunks.
// Whether the model can be streamed is decided right after the atlas, before the expensive
// stages. Importing is the caller's; writing files is the caller's (see the CLI for atomic
// writes). Deterministic: the same scene and options give byte-identical outputs.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "atlas/atlas.h"
#include "clean/clean.h"
#include "core/progress.h"
#include "core/status.h"
#include "exporters/gltf.h"
#include "image/texture_levels.h"
#include "multiplex/multiplex.h"
#include "scene/scene.h"
#include "simplify/simplify.h"

namespace meshmux {

struct ConvertOptions {
  CleanOptions clean{};            // welding, normals (crease angle), degenerate removal
  bool atlas = true;               // one material and one texture set (false: keep the sources)
  AtlasOptions atlas_options{};    // charts, parameterization, packing, baking
  SimplifyOptions simplify{};      // the progressive record and where the base stops
  TextureLevelOptions textures{};  // the pyramid; its top level is model.glb's texture
  MultiplexOptions multiplex{};    // views, renders, mesh layers
  GltfExportOptions gltf{};        // Draco quantization of model.glb and base.glb
  bool stream = true;  // false: model.glb only (the CLI's `-o X.glb`); nothing else is run
  bool report = true;  // stream: render the rate-distortion order (report, svg, package)
  // The first picture's bound, in bytes of base.glb, on models the stream refines (≥
  // simplify.ship_whole_below triangles): min(base_max_bytes, max(base_min_bytes,
  // base_model_share × model.glb's bytes)) — 256 KiB is 1.4 s at 1.5 Mbit/s. The stopping
  // rule's base stands when it fits; otherwise the finest coarser base that fits, or the
  // coarsest the record has (said in the progress). base_model_share ≤ 0: no bound.
  double base_model_share = 0.1;
  uint64_t base_min_bytes = 64 * 1024;   // the bound is never below this (small models)
  uint64_t base_max_bytes = 256 * 1024;  // nor above this (large models)
  // The package at most this times model.glb's bytes (the completion step, multiplex.h
  // PackageBound): past it the chain of splits ends in the full mesh single-rate. 0: no bound.
  double max_package_ratio = 1.2;
  // ... and at most this (or max_package_ratio, the larger; 0 there: no bound) for a package whose
  // meshes stream as block hierarchies (stream/format.h "Blocks": block parts cost more than the
  // chain, ~6% while they named parents by stream number, ~0.3% since format 17 codes them against
  // the block's candidates; the issue "Big content" bounds such packages at 1.3×), so that the
  // base keeps the first picture's bytes.
  double max_block_package_ratio = 1.3;
  // Observer (tests, tools): every image file and mesh part the conversion encodes is counted
  // here, where it is encoded; it overrides the stage options' own. Null: nothing counted.
  EncodeCounts* counts = nullptr;
  // model.glb is encoded beside the simplifier on scenes under this many unique triangles, and
  // before it on larger ones: the peak memory is then the larger of the two instead of their
  // sum, and the time their sum instead of the larger (the scan-like 4M mesh, back to back:
  // 1.76 → 1.26 GB, 31.3 → 37.5 s). Memory comes before time (and a 20M scan's sum is what a
  // laptop cannot hold), so from 1M triangles on, the big-content threshold, it goes first.
  uint64_t concurrent_model_below = 1'000'000;
};

struct ConvertOutputs {
  std::vector<uint8_t> model_glb;   // full quality, always
  std::vector<uint8_t> base_glb;    // stream: what the stream shows first, Draco-coded
  std::vector<uint8_t> package;     // stream + report + streamable: model.mmxp
  std::string report_json, rd_svg;  // stream + report (when a renderer is available)
  std::string not_streamed;         // why there is no package, when there is none
  SceneStats input, output;         // the imported and the converted (full-quality) scene
  uint64_t base_triangles = 0;      // scene triangles of the base
  size_t texture_levels = 0;        // levels built (0: untextured)
  size_t mesh_chunks = 0, texture_chunks = 0;  // chunks in the package
  std::optional<MultiplexResult> multiplexed;  // the multiplexer's result (curves, renders)
};

// The first picture's bound for a model.glb of `model_bytes` (ConvertOptions above); 0 when
// `o.base_model_share` ≤ 0 (no bound).
uint64_t first_picture_bytes(uint64_t model_bytes, const ConvertOptions& o);

// Runs the pipeline. Errors name the stage; kUnavailable never surfaces (no offscreen OpenGL
// only skips the report and the package, with a warning). Progress may be null. The scene is
// taken by value and released once cleaned (callers done with it move it in): at millions of
// triangles each copy of the geometry held through the later stages costs ~25 bytes per
// triangle.
Result<ConvertOutputs> convert(Scene input, const ConvertOptions& options, Warnings* warnings,
                               Progress* progress);

}  // namespace meshmux
