// Flattening: every instance expanded into world space as one mesh (paper 001 §4: below 1.75
// instances per submesh, flatten-then-simplify beats instance-aware simplification; also the
// peers' baseline in bench/simplify). One primitive per (material, vertex layout), one
// identity instance; mirroring transforms get their winding flipped back so front faces stay
// front. Materials, images and the normalization scale carry over. O(scene vertices).
#pragma once

#include "scene/scene.h"

namespace meshmux {

Scene flatten(const Scene& scene);

// Instances per used submesh (paper 001's IPS): instances / meshes with at least one instance.
double instances_per_submesh(const Scene& scene);

}  // namespace meshmux
