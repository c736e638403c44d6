#include "importers/skinning.h"

#include <cmath>

namespace meshmux {

Primitive pose_skinned(const Primitive& p, const SkinInfluences& in,
                       const std::vector<Mat4>& joint_matrices) {
  Primitive out = p;
  const size_t n = p.positions.size();
  const size_t per = size_t(4 * in.sets);
  if (per == 0 || in.joints.size() < n * per || in.weights.size() < n * per) return out;
  for (size_t i = 0; i < n; ++i) {
    const uint32_t* j = &in.joints[i * per];
    const float* w = &in.weights[i * per];
    double sum = 0;
    for (size_t k = 0; k < per; ++k)
      if (std::isfinite(w[k]) && w[k] > 0 && j[k] < joint_matrices.size()) sum += w[k];
    double px = 0, py = 0, pz = 0, nx = 0, ny = 0, nz = 0;
    auto add = [&](const Mat4& m, double weight) {
      const Vec3 q = m.transform_point(p.positions[i]);
      px += weight * q.x, py += weight * q.y, pz += weight * q.z;
      if (!p.normals.empty()) {
        const Vec3 nn = m.transform_normal(p.normals[i]);
        nx += weight * nn.x, ny += weight * nn.y, nz += weight * nn.z;
      }
    };
    if (sum > 0) {
      for (size_t k = 0; k < per; ++k)
        if (std::isfinite(w[k]) && w[k] > 0 && j[k] < joint_matrices.size())
          add(joint_matrices[j[k]], w[k] / sum);
    } else if (j[0] < joint_matrices.size()) {
      add(joint_matrices[j[0]], 1);
    } else {
      continue;  // no usable influence: the vertex stays as it was
    }
    out.positions[i] = {float(px), float(py), float(pz)};
    if (!p.normals.empty()) out.normals[i] = normalize(Vec3{float(nx), float(ny), float(nz)});
  }
  return out;
}

}  // namespace meshmux
