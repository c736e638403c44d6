// The stream package's steps and orders from a multiplexing result (paper 004 §3–4): one step
// per move of the steepest-descent path, and the three baselines (mesh-first, texture-first,
// constant ratio) as permutations of those same steps, so one file can replay every order.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "multiplex/multiplex.h"

namespace meshmux {

// One step of the multiplexed order.
struct StreamStep {
  enum Kind { kMesh, kTexture } kind = kMesh;
  size_t mesh_layer = 0;     // kMesh: the mesh layer that arrives (MultiplexResult::layer_parts)
  size_t texture_level = 0;  // kTexture: the texture level (index into TextureLevels::levels)
  double distortion = 0;     // expected distortion once this step is applied
};

// A further order of the same steps (a baseline): a permutation of step indices keeping the
// mesh steps' relative order, with the distortion after each step.
struct StreamOrder {
  std::string name;
  std::vector<uint32_t> steps;
  std::vector<double> distortion;
};

struct StreamPlan {
  std::vector<StreamStep> steps;    // the descent's moves, in order
  double base_distortion = 0;       // distortion of state (0, 0)
  std::vector<StreamOrder> orders;  // the baselines, by name
};

// Fails (kInternal) when a path is not a monotone walk of unit moves from (0, 0) to the far
// corner, or when the baselines do not visit the same moves as the descent. O(m + n).
Result<StreamPlan> stream_plan(const MultiplexResult& r);

}  // namespace meshmux
