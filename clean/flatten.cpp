#include "clean/flatten.h"

#include <map>
#include <tuple>

namespace meshmux {

namespace {

// Flattens the instances for which `take` is true into world space: one mesh per (material,
// vertex layout), each one primitive with one identity instance (so every part stays a
// streamable submesh); the other instances keep their meshes, renumbered after them.
// `out` comes in holding what the scene keeps besides geometry (materials, images...).
Scene flatten_where(const Scene& in, const std::vector<char>& take, Scene out) {
  std::vector<Primitive> parts;
  std::map<std::tuple<int32_t, bool, size_t, bool, bool>, size_t> slot;
  for (size_t ii = 0; ii < in.instances.size(); ++ii) {
    const Instance& inst = in.instances[ii];
    if (inst.mesh >= in.meshes.size() || !take[ii]) continue;
    bool mirror = inst.world.det3() < 0;
    for (const Primitive& p : in.meshes[inst.mesh].primitives) {
      auto key =
          std::make_tuple(p.material, !p.normals.empty(), p.uvs.size(), !p.colors.empty(), p.flat);
      auto it = slot.find(key);
      if (it == slot.end()) {
        it = slot.emplace(key, parts.size()).first;
        parts.emplace_back();
        parts.back().material = p.material;
        parts.back().flat = p.flat;
        parts.back().uvs.resize(p.uvs.size());
      }
      Primitive& q = parts[it->second];
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
  for (Primitive& part : parts) {
    Mesh mesh;
    mesh.name = "flattened";
    if (parts.size() > 1) mesh.name += " " + std::to_string(out.meshes.size() + 1);
    mesh.primitives.push_back(std::move(part));
    out.instances.push_back({uint32_t(out.meshes.size()), Mat4::identity(), mesh.name});
    out.meshes.push_back(std::move(mesh));
  }
  std::vector<int32_t> remap(in.meshes.size(), -1);
  for (size_t ii = 0; ii < in.instances.size(); ++ii) {
    const Instance& inst = in.instances[ii];
    if (inst.mesh >= in.meshes.size() || take[ii]) continue;
    if (remap[inst.mesh] < 0) {
      remap[inst.mesh] = int32_t(out.meshes.size());
      out.meshes.push_back(in.meshes[inst.mesh]);
    }
    Instance copy = inst;
    copy.mesh = uint32_t(remap[inst.mesh]);
    out.instances.push_back(std::move(copy));
  }
  return out;
}

}  // namespace

Scene flatten(Scene in) {
  Scene out = flatten_geometry(in);
  out.images = std::move(in.images);
  return out;
}

Scene flatten_geometry(const Scene& in) {
  return flatten_where(in, std::vector<char>(in.instances.size(), 1),
                       empty_like(in, /*with_images=*/false));
}

double instances_per_submesh(const Scene& scene) {
  std::vector<size_t> counts = instance_counts(scene);
  size_t used = 0;
  for (size_t c : counts) used += c > 0;
  return used ? double(scene.instances.size()) / double(used) : 0.0;
}

bool should_flatten(const Scene& scene, double below_ips) {
  double ips = instances_per_submesh(scene);
  return scene.instances.size() > 1 && ips > 0 && ips < below_ips;
}

}  // namespace meshmux
