// A big primitive cut into spatial parts, so that model.glb's Draco encoding runs on every core
// and each encoder holds only its part (issue-free contract: one primitive in, parts out).
#pragma once

#include <cstddef>
#include <vector>

#include "scene/scene.h"

namespace meshmux {

// Cuts `p` into ceil(triangles / max_triangles) parts of (nearly) equal triangle counts, each a
// compact region: faces grouped by the Morton code of their centroid (quantized to 10 bits
// per axis over the primitive's bounds), partitioned by selection, not fully sorted. Each part
// keeps the faces of its group in their original relative order, the vertices they use in
// order of first use (every attribute carried), and p's material and flat flag; vertices on a
// part's border are repeated in each part that uses them. A primitive within the limit (or
// max_triangles 0) comes back whole, as the one part. Deterministic.
// Complexity: O(T log K + V) for T triangles, V vertices and K parts; memory: the parts.
std::vector<Primitive> split_primitive(const Primitive& p, size_t max_triangles);

}  // namespace meshmux
