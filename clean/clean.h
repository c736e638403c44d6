// Clean and normalize (Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion
// of 3D models for interactive metaverses" §4.1): the first conditioning stage.
//
// Per primitive, in mesh space (instancing is untouched, so every instance stays clean):
// 1. vertices whose attributes all agree bit for bit are welded into one;
// 2. degenerate triangles (two corners on one vertex, or zero area) are removed;
// 3. duplicate triangles (the same three vertices in the same winding, in any rotation) are
//    removed; back-to-back twins (opposite winding) are kept: they are two-sided geometry;
// 4. unreferenced vertices are removed;
// 5. missing or broken normals (absent, zero, non-finite) are generated: angle-weighted face
//    normals averaged across corners that share a position, except across edges sharper than
//    the crease angle, which stay hard (the vertex is split there).
// Primitives left without triangles are dropped, meshes left without primitives are dropped
// with their instances (each counted in the report).
// Finally the normalization scale (1 / scene bounding-box diagonal) is stored in
// Scene::normalization_scale; positions keep the author's units.
// Complexity: O(V + T) expected (hashing), plus O(valence²) per position for normals.
#pragma once

#include <cstdint>

#include "scene/scene.h"

namespace meshmux {

struct CleanOptions {
  float crease_angle_degrees = 60;  // generated normals: sharper edges than this stay hard
  bool weld = true;                 // weld vertices whose attributes all agree
  bool remove_degenerate = true;    // remove triangles with repeated corners or zero area
  bool remove_duplicates = true;    // remove repeated triangles (same winding)
  bool generate_normals = true;     // generate missing or broken normals
};

struct CleanReport {
  uint64_t vertices_in = 0, vertices_out = 0;    // over unique meshes
  uint64_t triangles_in = 0, triangles_out = 0;  // over unique meshes
  uint64_t degenerate_removed = 0;               // triangles with a repeated corner or zero area
  uint64_t duplicates_removed = 0;               // repeated triangles
  uint64_t primitives_with_generated_normals = 0;
  uint64_t primitives_dropped = 0;  // left without triangles
  uint64_t meshes_dropped = 0;      // left without primitives (their instances go too)
};

// Takes the scene by value: a caller done with it moves it in, and its images (the largest part,
// untouched here) move across instead of being copied.
Scene clean(Scene scene, const CleanOptions& options, CleanReport* report = nullptr);

}  // namespace meshmux
