#include "condition/flatten.h"

#include <map>
#include <tuple>

namespace meshmux {

Scene flatten(const Scene& in) {
  Scene out;
  out.materials = in.materials;
  out.images = in.images;
  out.source = in.source;
  out.normalization_scale = in.normalization_scale;
  Mesh mesh;
  mesh.name = "flattened";
  std::map<std::tuple<int32_t, bool, size_t, bool>, size_t> slot;
  for (const Instance& inst : in.instances) {
    if (inst.mesh >= in.meshes.size()) continue;
    bool mirror = inst.world.det3() < 0;
    for (const Primitive& p : in.meshes[inst.mesh].primitives) {
      auto key = std::make_tuple(p.material, !p.normals.empty(), p.uvs.size(), !p.colors.empty());
      auto it = slot.find(key);
      if (it == slot.end()) {
        it = slot.emplace(key, mesh.primitives.size()).first;
        mesh.primitives.emplace_back();
        mesh.primitives.back().material = p.material;
        mesh.primitives.back().uvs.resize(p.uvs.size());
      }
      Primitive& q = mesh.primitives[it->second];
      uint32_t base = uint32_t(q.positions.size());
      for (Vec3 v : p.positions) q.positions.push_back(inst.world.transform_point(v));
      for (Vec3 n : p.normals) q.normals.push_back(inst.world.transform_normal(n));
      for (size_t k = 0; k < p.uvs.size(); ++k)
        q.uvs[k].insert(q.uvs[k].end(), p.uvs[k].begin(), p.uvs[k].end());
      q.colors.insert(q.colors.end(), p.colors.begin(), p.colors.end());
      for (size_t i = 0; i + 2 < p.indices.size(); i += 3) {
        uint32_t a = p.indices[i], b = p.indices[i + 1], c = p.indices[i + 2];
        if (mirror) std::swap(b, c);
        q.indices.insert(q.indices.end(), {base + a, base + b, base + c});
      }
    }
  }
  out.meshes.push_back(std::move(mesh));
  out.instances.push_back({0, Mat4::identity(), "flattened"});
  return out;
}

}  // namespace meshmux
