// The multiplexer (Yang, Shen and Kuo, "Progressive coding of 3D textured graphic model via
// joint mesh-texture optimization" §3): builds the mesh layers (refinement batches of the
// progressive record, with the bytes meshoptimizer's order-preserving codecs give them) and the
// texture layers (the atlas's mip levels, with their JPEG/PNG bytes), renders states (i, j)
// from the views of a viewing sphere, measures their distortion against the full-quality
// render, and orders the stream by steepest descent; the three baselines of Yang, Shen and Kuo come
// from the same cached renders.
#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "core/progress.h"
#include "multiplex/render.h"
#include "multiplex/schedule.h"
#include "multiplex/viewpoints.h"
#include "scene/progressive.h"
#include "scene/texture_levels.h"
#include "stream/format.h"
#include "stream/mesh_stream.h"

namespace meshmux {

// What a render's distortion against the full-quality one is (multiplex/distortion.h), over the
// pixels either covers: the mean squared error per RGB channel, or the mean CIEDE2000.
enum class DistortionMetric { kMse, kCiede2000 };
inline const char* metric_name(DistortionMetric m) {
  return m == DistortionMetric::kMse ? "mse" : "ciede2000";
}

struct MultiplexOptions {
  int view_layers = 1;                        // viewing sphere subdivision: 1 → 10 views
  // The order's measure. MSE (PSNR's), the measure the client's frames judge the order by
  // (bench/rd_client.mjs) and the fidelity harness judges appearance by: CIEDE2000 ranked texture
  // levels above mesh layers whose silhouettes the client's PSNR weighs more.
  DistortionMetric metric = DistortionMetric::kMse;
  RenderOptions render = physical_shading();  // image size and shading (256², physical)
  ViewOptions views{};                        // framing
  int min_mesh_layers = 4;           // the refinements are cut into this many batches at least
  int max_mesh_layers = 12;          // and at most this many
  uint64_t layer_bytes = 24 * 1024;  // target bytes per mesh batch, between those bounds
  // Where the order is forced (one mesh layer or one texture level: the descent has no choice
  // to make), the renders only draw report.json's curve and the package's expected distortions:
  // with forced_view_layers ≥ 0 they are measured from that many viewing-sphere layers (0: the
  // 4 tetrahedron views) at forced_image_size² instead. Off by default (< 0): 4 views at 128²
  // do not track the full measurement (bench/render_plan.sh: the metric, a mean over covered
  // pixels, weighs silhouettes more at lower resolution).
  int forced_view_layers = -1;
  int forced_image_size = 128;
  // The display the order is made for, in device pixels (the table's "display"): the renders
  // sample textures with a pixel's footprint there (RenderOptions::display_scale: the display's
  // smaller side over the image's, both framed alike), so texture levels are ranked by what they
  // change at that size. 0 × 0: the images' own pixels.
  int display_width = 1920;
  int display_height = 1080;
  // Renders on a cut: for a scene of more triangles than this, no render draws a level whose
  // error is under a display pixel's footprint at the nearest point of the bounding sphere in
  // any view (the display's pixel: the images' over display_scale); finer levels change nothing
  // such a pixel shows, and the full mesh of a multi-million-triangle scan cost most of the
  // renders' time. Layers that then draw the same selection share their cells. Under it, every
  // layer is drawn as it is (outputs as before the cut existed).
  uint64_t cut_renders_above = 1'000'000;
  EncodeCounts* counts = nullptr;  // observer: every mesh part encoded is counted here
};

// The package's bound (the completion step, stream/format.h "Completion"): what the
// multiplexer needs from the stages after it, asked once the mesh layers are encoded.
struct PackageBound {
  uint64_t max_bytes = 0;  // the package's bytes at most (0: no bound, no completion)
  // The package's bytes besides its chunks (the base as stored), given the mesh streams' heads
  // (the base's vertex order). The header and table are estimated here.
  std::function<Result<uint64_t>(const std::vector<MeshStreamBase>&)> fixed_bytes;
  // The completion of the meshes listed (their full detail, single-rate), in that order; asked
  // only when the package with every mesh layer would be over max_bytes.
  std::function<Result<std::vector<CompletionMesh>>(const std::vector<uint32_t>& meshes)>
      completion;
};

// Where the completion went (report.json "completion").
struct CompletionReport {
  bool used = false;
  std::string why;             // "bound" (the latest layer within it) or "slope" (earlier:
                               // the completion's slope beats the descent's next mesh step);
                               // unused: why not, where the splits were over the bound
  size_t after_layer = 0;      // the mesh layer it follows (0: the base)
  size_t chain_layers = 0;     // mesh layers of the whole chain
  uint64_t bytes = 0;          // its bitstreams
  uint64_t tail_bytes = 0;     // the splits it stands in for
  uint64_t planned_bytes = 0;  // the package as planned with it (header and table estimated)
  uint64_t chain_bytes = 0;    // ... and with every split instead
  double area = 0;             // area under the descent with it
  double chain_area = 0;       // ... over the whole chain of splits (the same views)
};

struct MultiplexResult {
  std::vector<uint64_t> mesh_bytes;               // per mesh layer (0: the base geometry)
  std::vector<uint64_t> texture_bytes;            // per texture level (0: the 128² level)
  std::vector<uint32_t> layer_triangles;          // scene triangles after each mesh layer
  std::vector<std::vector<size_t>> layer_levels;  // per mesh layer: per mesh its progressive level
  // The mesh stream, encoded once: per mesh its table entry and base faces, and per mesh layer
  // the parts that take the meshes from the layer before to it (layer 0, the base: none).
  std::vector<MeshStreamBase> mesh_streams;
  std::vector<std::vector<EncodedMeshPart>> layer_parts;
  // Per mesh layer, its chunk's payload: the parts' bytes in order (mesh_chunk_payload; the
  // parts above keep their sizes and bit counts, their bytes move here, held once);
  // mesh_bytes[k] is its size (layer 0: the base's bytes, no payload).
  std::vector<std::vector<uint8_t>> layer_chunks;
  // Per mesh: state_digest of a client after every part shipped (with a completion, the state
  // its splits reach before it).
  std::vector<uint32_t> stream_digests;
  // The completion (the last mesh layer, when used): its meshes' bitstreams, in mesh order;
  // layer_chunks' last entry is their concatenation.
  std::vector<CompletionMesh> completion;
  CompletionReport completion_report;
  RdPath rd, mesh_first, texture_first, constant_ratio;
  std::string metric;  // the measure (metric_name), over covered pixels, averaged over views
  size_t views = 0;
  size_t renders = 0;          // images rendered (cells evaluated × views, plus references)
  size_t cells_descent = 0;    // cells the steepest descent alone evaluated (lazily)
  size_t cells_evaluated = 0;  // cells evaluated once the baselines ran too
  size_t cells_total = 0;      // m × n
  double seconds_layers = 0, seconds_render = 0, seconds_total = 0;
  double empty_distortion = 0;  // the metric for showing nothing yet (blank frames against the
                                // references): where every download starts
  Bounds bounds;  // the full detail's world-space box, in the model's units (the views frame
                  // it; report.json's "bounds", a world's layout reads it)
  // The texture levels shipped (width, height, bytes; smallest first) and those dropped, with
  // why: copied from the TextureLevels the stream was made of, for report.json.
  std::vector<std::array<uint64_t, 3>> texture_levels_shipped;
  std::vector<DroppedTextureLevel> texture_levels_dropped;
  std::vector<std::string> texture_channels;  // the maps every texture level carries, in order
  ViewTable view_table;                       // every cell evaluated, per view
  // Renders on a cut (MultiplexOptions::cut_renders_above): the error a pixel stands for
  // (fractions of the scene's diagonal) and the triangles of the finest selection drawn; 0 and
  // the full detail's triangles without a cut.
  double cut_error = 0;
  uint64_t cut_triangles = 0;
};

// `ps` is the progressive record of the atlased scene; `levels` its texture levels, encoded
// (none for an untextured scene: one empty texture layer). Errors: kUnavailable when no
// offscreen OpenGL is available, kInternal otherwise.
// `progress` (optional) receives the fraction done: renders so far over the most the grid can
// need (every cell from every view, plus the references).
// `bound` (optional): the package's bound; past it the chain of splits ends in the completion.
Result<MultiplexResult> multiplex(const ProgressiveScene& ps, const TextureLevels& levels,
                                  const MultiplexOptions& options = {},
                                  Progress* progress = nullptr,
                                  const PackageBound* bound = nullptr);

}  // namespace meshmux
