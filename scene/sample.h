// The built-in demo scene (`meshmux sample`), generated in code so it exists everywhere:
// a textured ground grid, a textured crate, and one column mesh instanced many times
// (the case instance-aware simplification is for). Its texture is generated pixels (decoded
// RGBA8, no encoded bytes: exporters encode it). Deterministic.
#pragma once

#include "scene/scene.h"

namespace meshmux {

struct SampleOptions {
  int columns_per_side = 12;  // the column mesh is instanced columns_per_side² times
  int column_segments = 24;   // around each column
  int ground_cells = 32;      // ground grid resolution per side
  int texture_size = 256;     // generated texture, pixels per side
};

Scene make_sample_scene(const SampleOptions& options = {});

}  // namespace meshmux
