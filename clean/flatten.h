// Flattening: every instance expanded into world space as one mesh (Azim, Cheslack-Postava and
// Levis, "Instance-aware simplification of 3D polygonal meshes" §4: below 1.75 instances per
// submesh, flatten-then-simplify beats instance-aware simplification; also the peers' baseline in
// bench/simplify). One mesh per (material, vertex layout), each one primitive with one identity
// instance; mirroring transforms get their winding flipped back so front faces stay front.
// Materials, images and the normalization scale carry over. O(scene vertices).
#pragma once

#include "scene/scene.h"

namespace meshmux {

// By value: a caller done with the scene moves it in, and its images move across uncopied.
Scene flatten(Scene scene);
// As flatten, without the images (left empty): for a stage that reads only the geometry.
Scene flatten_geometry(const Scene& scene);

// Instances per used submesh (Azim et al.'s IPS): instances / meshes with at least one instance.
double instances_per_submesh(const Scene& scene);

// Azim et al. §4's threshold: below this many instances per submesh, flatten.
constexpr double kFlattenBelowIps = 1.75;

// The one flattening decision (the pipeline after the atlas, the simplifier's fallback): more
// than one instance and fewer than `below_ips` instances per used submesh.
bool should_flatten(const Scene& scene, double below_ips = kFlattenBelowIps);

}  // namespace meshmux
