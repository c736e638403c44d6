// A generated, heavily instanced scene for the simplification benchmark: one lumpy "bush"
// submesh (a noisy UV sphere of ~200 triangles with a uv seam) instanced on a grid with varied
// rotation, scale and jitter, standing on a ground mesh with a single instance. Instances per
// submesh are far above IAS's 1.75 threshold, the case instance-aware simplification is for.
// Deterministic: the same options give the same scene.
#pragma once

#include "scene/scene.h"

namespace meshmux::bench {

struct InstancedSceneOptions {
  int bushes_per_side = 20;  // the bush is instanced bushes_per_side² times (400 by default)
  int bush_slices = 10;      // around the bush; triangles = 2 × slices × (stacks − 1)
  int bush_stacks = 11;      // pole to pole
  int ground_cells = 20;     // ground grid per side; triangles = 2 × cells²
};

Scene make_instanced_scene(const InstancedSceneOptions& options = {});

}  // namespace meshmux::bench
