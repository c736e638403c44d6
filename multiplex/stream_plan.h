// The stream package's steps and orders from a multiplexing result (Yang, Shen and Kuo,
// "Progressive coding of 3D textured graphic model via joint mesh-texture optimization" §3–4): one
// step per move of the steepest-descent path, and the three baselines (mesh-first, texture-first,
// constant ratio) as permutations of those same steps, so one file can replay every order.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "multiplex/multiplex.h"
#include "stream/format.h"

namespace meshmux {

struct StreamPlan {
  std::vector<StreamStep> steps;    // the descent's moves, in order
  double base_distortion = 0;       // distortion of state (0, 0)
  std::vector<StreamOrder> orders;  // the baselines, by name
};

// Fails (kInternal) when a path is not a monotone walk of unit moves from (0, 0) to the far
// corner, or when the baselines do not visit the same moves as the descent. O(m + n).
Result<StreamPlan> stream_plan(const MultiplexResult& r);

// The table's "view": the framing and shading `options` measured the distortion with.
PackageView package_view(const MultiplexOptions& options);

}  // namespace meshmux
