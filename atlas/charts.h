// Chart segmentation for the texture atlas (Terrace, Cheslack-Postava, Levis and Freedman,
// "Unsupervised conversion of 3D models for interactive metaverses" §4.2, after Garland, Willmott
// and Heckbert 2001, "Hierarchical face clustering on polygonal surfaces"): every face starts as
// its own chart; adjacent charts merge greedily, cheapest first, by a cost that adds the planarity
// error of the merged chart (the fit plane's mean squared distance, area-weighted) and its
// compactness (perimeter² / (4π area) − 1), so charts stay disc-like and flat enough to flatten
// with little stretch. Merging stops at Terrace et al. formula 1,
// log(1 + E_current) / log(1 + E_max) ≥ 0.9, E_current the merge being made and E_max the
// dearest merge still queued.
//
// Rules: charts never span meshes; a textured face (its material samples a texture of any
// channel, or its primitive has varying vertex colours) merges only with textured faces; a
// flat-colour face (constant colour: factor × constant vertex colour, with its material's
// occlusion-roughness-metallic and emissive factors) merges only with faces of exactly the same
// colour and factors; two faces that are back-to-back twins (same three positions, opposite
// winding) never share a chart; faces meet across an edge when they share its two positions (so uv
// seams and material borders of the input do not block merging, but the rules above do).
// Deterministic. Complexity O(F log F) per mesh.
#pragma once

#include <cstdint>
#include <vector>

#include "scene/scene.h"

namespace meshmux {

// Faces of a Mesh are numbered over its primitives in order: primitive 0's triangles, then
// primitive 1's, and so on. FaceRef turns a number back into (primitive, triangle).
struct FaceRef {
  uint32_t primitive = 0;
  uint32_t triangle = 0;  // index of the triangle within the primitive
};
std::vector<FaceRef> mesh_faces(const Mesh& mesh);

struct Chart {
  uint32_t mesh = 0;            // Scene mesh the chart belongs to
  std::vector<uint32_t> faces;  // mesh face numbers, ascending
  bool textured = true;         // false: one flat colour (see `color`)
  Vec4 color{1, 1, 1, 1};       // the flat colour (linear RGBA) when !textured
  Vec3 orm{1, 1, 1};            // when !textured: occlusion, roughness, metallic factors
  Vec3 emissive{0, 0, 0};       // when !textured: emissive factor (linear, may exceed 1)
  Vec3 sheen{0, 0, 0};          // when !textured: sheen colour factor (linear)
};

struct ChartOptions {
  float stop_ratio = 0.9f;          // Terrace et al. formula 1 threshold
  float compactness_weight = 1.0f;  // weight of the compactness term against planarity
  uint32_t max_faces = 1u << 20;    // never grow a chart beyond this many faces
};

struct ChartSet {
  std::vector<Chart> charts;                      // all meshes' charts, mesh by mesh
  std::vector<std::vector<uint32_t>> face_chart;  // per Scene mesh, per face: its chart index
};

ChartSet segment_charts(const Scene& scene, const ChartOptions& options = {});

}  // namespace meshmux
