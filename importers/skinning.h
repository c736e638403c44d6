// Linear blend skinning (glTF 2.0 §3.7.3): a skinned primitive posed by its joints, as a viewer
// shows the file when nothing animates it. The pose is the joints' node transforms at rest; a
// vertex goes to Σ wᵢ · (jointWorldᵢ · inverseBindᵢ) · v, in world space (the skinned mesh's
// own node transform does not apply). Weights are normalised to sum 1 as three.js's loader does
// (all zero: joint 0 alone).
#pragma once

#include <cstdint>
#include <vector>

#include "scene/scene.h"

namespace meshmux {

// Per vertex, `sets` groups of 4 joint indices and 4 weights (JOINTS_n / WEIGHTS_n): vertex i's
// k-th influence is joints[i * 4 * sets + k], weights[i * 4 * sets + k].
struct SkinInfluences {
  int sets = 0;
  std::vector<uint32_t> joints;
  std::vector<float> weights;
  bool empty() const { return sets == 0; }
};

// `p` posed by `joint_matrices` (jointWorld · inverseBind per joint of the skin). Joint
// indices past the matrices leave that influence out. Normals follow each matrix's inverse
// transpose, blended and renormalised. O(vertices × influences).
Primitive pose_skinned(const Primitive& p, const SkinInfluences& influences,
                       const std::vector<Mat4>& joint_matrices);

}  // namespace meshmux
