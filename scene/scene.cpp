#include "scene/scene.h"

#include <set>

namespace meshmux {

std::vector<TextureRef*> texture_refs(Material& m) {
  std::vector<TextureRef*> refs = {&m.base_color,  &m.metallic_roughness, &m.normal,
                                   &m.occlusion,   &m.emissive,           &m.sheen_color,
                                   &m.transmission};
  for (TextureRef& t : m.layers) refs.push_back(&t);
  return refs;
}

std::vector<const TextureRef*> texture_refs(const Material& m) {
  std::vector<TextureRef*> refs = texture_refs(const_cast<Material&>(m));
  return {refs.begin(), refs.end()};
}

std::vector<size_t> instance_counts(const Scene& scene) {
  std::vector<size_t> counts(scene.meshes.size(), 0);
  for (const Instance& inst : scene.instances)
    if (inst.mesh < counts.size()) ++counts[inst.mesh];
  return counts;
}

SceneStats compute_stats(const Scene& scene) {
  SceneStats s;
  s.meshes = scene.meshes.size();
  s.instances = scene.instances.size();
  s.materials = scene.materials.size();
  std::vector<size_t> counts = instance_counts(scene);
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    uint64_t tris = 0;
    for (const Primitive& p : scene.meshes[m].primitives) {
      tris += p.triangle_count();
      s.vertices += p.vertex_count();
    }
    s.primitives += scene.meshes[m].primitives.size();
    s.unique_triangles += tris;
    s.scene_triangles += tris * counts[m];
    if (counts[m] >= kMinGpuInstances)
      s.draw_calls += scene.meshes[m].primitives.size();
    else
      s.draw_calls += scene.meshes[m].primitives.size() * counts[m];
  }
  std::set<int32_t> used;
  for (const Material& mat : scene.materials)
    for (const TextureRef* t :
         {&mat.base_color, &mat.metallic_roughness, &mat.normal, &mat.occlusion, &mat.emissive})
      if (t->present()) used.insert(t->image);
  s.textures = used.size();
  for (int32_t i : used)
    if (i < int32_t(scene.images.size()) && scene.images[i].decoded())
      s.texture_pixels += uint64_t(scene.images[i].width) * uint64_t(scene.images[i].height);
  return s;
}

Bounds mesh_bounds(const Mesh& mesh) {
  Bounds b;
  for (const Primitive& p : mesh.primitives)
    for (Vec3 v : p.positions) b.add(v);
  return b;
}

Scene empty_like(const Scene& scene, bool with_images) {
  Scene out;
  out.materials = scene.materials;
  if (with_images) out.images = scene.images;
  out.lines = scene.lines;
  out.source = scene.source;
  out.normalization_scale = scene.normalization_scale;
  return out;
}

Bounds scene_bounds(const Scene& scene) {
  Bounds b;
  for (const Instance& inst : scene.instances) {
    if (inst.mesh >= scene.meshes.size()) continue;
    for (const Primitive& p : scene.meshes[inst.mesh].primitives)
      for (Vec3 v : p.positions) b.add(inst.world.transform_point(v));
  }
  return b;
}

namespace {
bool finite(Vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

Status check_texture(const Scene& scene, const TextureRef& t, const std::string& where) {
  if (t.image >= int32_t(scene.images.size()))
    return Status::error(where + ": image " + std::to_string(t.image) + " out of range (" +
                             std::to_string(scene.images.size()) + " images)",
                         ErrorKind::kInput);
  return Status::ok();
}
}  // namespace

Status validate(const Scene& scene, const std::string& stage) {
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const Mesh& mesh = scene.meshes[m];
    for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
      const Primitive& p = mesh.primitives[pi];
      std::string where =
          stage + ": mesh " + std::to_string(m) + " primitive " + std::to_string(pi);
      size_t n = p.positions.size();
      if (!p.normals.empty() && p.normals.size() != n)
        return Status::error(where + ": " + std::to_string(p.normals.size()) + " normals for " +
                                 std::to_string(n) + " vertices",
                             ErrorKind::kInput);
      if (!p.colors.empty() && p.colors.size() != n)
        return Status::error(where + ": " + std::to_string(p.colors.size()) + " colours for " +
                                 std::to_string(n) + " vertices",
                             ErrorKind::kInput);
      for (size_t u = 0; u < p.uvs.size(); ++u)
        if (p.uvs[u].size() != n)
          return Status::error(where + ": uv set " + std::to_string(u) + " has " +
                                   std::to_string(p.uvs[u].size()) + " entries for " +
                                   std::to_string(n) + " vertices",
                               ErrorKind::kInput);
      if (p.indices.size() % 3 != 0)
        return Status::error(where + ": " + std::to_string(p.indices.size()) +
                                 " indices is not a whole number of triangles",
                             ErrorKind::kInput);
      for (size_t i = 0; i < p.indices.size(); ++i)
        if (p.indices[i] >= n)
          return Status::error(where + ": index " + std::to_string(p.indices[i]) +
                                   " out of range (" + std::to_string(n) + " vertices)",
                               ErrorKind::kInput);
      for (size_t v = 0; v < n; ++v)
        if (!finite(p.positions[v]))
          return Status::error(where + ": vertex " + std::to_string(v) + " position is not finite",
                               ErrorKind::kInput);
      if (p.material >= int32_t(scene.materials.size()))
        return Status::error(where + ": material " + std::to_string(p.material) +
                                 " out of range (" + std::to_string(scene.materials.size()) +
                                 " materials)",
                             ErrorKind::kInput);
    }
  }
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const Instance& inst = scene.instances[i];
    std::string where = stage + ": instance " + std::to_string(i);
    if (inst.mesh >= scene.meshes.size())
      return Status::error(where + ": mesh " + std::to_string(inst.mesh) + " out of range (" +
                               std::to_string(scene.meshes.size()) + " meshes)",
                           ErrorKind::kInput);
    for (double x : inst.world.m)
      if (!std::isfinite(x))
        return Status::error(where + ": transform is not finite", ErrorKind::kInput);
  }
  for (size_t m = 0; m < scene.materials.size(); ++m) {
    const Material& mat = scene.materials[m];
    std::string where = stage + ": material " + std::to_string(m);
    for (const TextureRef* t :
         {&mat.base_color, &mat.metallic_roughness, &mat.normal, &mat.occlusion, &mat.emissive}) {
      Status s = check_texture(scene, *t, where);
      if (!s) return s;
    }
  }
  for (size_t i = 0; i < scene.images.size(); ++i) {
    const Image& img = scene.images[i];
    if (!img.rgba.empty() && img.rgba.size() != size_t(img.width) * size_t(img.height) * 4)
      return Status::error(stage + ": image " + std::to_string(i) + ": pixel buffer size " +
                               std::to_string(img.rgba.size()) + " does not match " +
                               std::to_string(img.width) + "x" + std::to_string(img.height),
                           ErrorKind::kInput);
  }
  return Status::ok();
}

}  // namespace meshmux
