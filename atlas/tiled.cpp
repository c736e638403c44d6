#include "atlas/tiled.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "atlas/material_sample.h"

namespace meshmux {

namespace {

bool repeats(Wrap w) { return w == Wrap::kRepeat || w == Wrap::kMirroredRepeat; }

// Union-find root with path halving.
uint32_t root_of(std::vector<uint32_t>& parent, uint32_t v) {
  while (parent[v] != v) v = parent[v] = parent[parent[v]];
  return v;
}

// Whether some connected piece of `p` spans more than `periods` along a repeating axis of
// `ref` (its uvs transformed as the sampler sees them).
bool spans_periods(const Primitive& p, const TextureRef& ref, double periods) {
  if (ref.tex_coord >= p.uvs.size() || p.uvs[ref.tex_coord].size() != p.positions.size())
    return false;
  const std::vector<Vec2>& uv = p.uvs[ref.tex_coord];
  const size_t n = uv.size();
  std::vector<uint32_t> parent(n);
  std::iota(parent.begin(), parent.end(), 0u);
  for (size_t i = 0; i + 2 < p.indices.size(); i += 3) {
    const uint32_t a = p.indices[i], b = p.indices[i + 1], c = p.indices[i + 2];
    if (a >= n || b >= n || c >= n) continue;
    parent[root_of(parent, b)] = root_of(parent, a);
    parent[root_of(parent, c)] = root_of(parent, a);
  }
  std::vector<float> lo_u(n, INFINITY), hi_u(n, -INFINITY), lo_v(n, INFINITY), hi_v(n, -INFINITY);
  std::vector<char> used(n, 0);
  for (uint32_t i : p.indices)
    if (i < n) used[i] = 1;
  for (uint32_t i = 0; i < n; ++i) {
    if (!used[i]) continue;
    const Vec2 t = apply_transform(ref.transform, uv[i]);
    if (!std::isfinite(t.x) || !std::isfinite(t.y)) continue;
    const uint32_t r = root_of(parent, i);
    lo_u[r] = std::min(lo_u[r], t.x), hi_u[r] = std::max(hi_u[r], t.x);
    lo_v[r] = std::min(lo_v[r], t.y), hi_v[r] = std::max(hi_v[r], t.y);
  }
  for (uint32_t r = 0; r < n; ++r) {
    if (parent[r] != r || !used[r]) continue;
    if (repeats(ref.sampler.wrap_s) && hi_u[r] - lo_u[r] > periods) return true;
    if (repeats(ref.sampler.wrap_t) && hi_v[r] - lo_v[r] > periods) return true;
  }
  return false;
}

// Every texture reference of a material, for remapping image indices.
std::vector<TextureRef*> refs_of(Material& m) {
  return {&m.base_color, &m.metallic_roughness, &m.normal,      &m.occlusion,
          &m.emissive,   &m.sheen_color,        &m.transmission};
}

}  // namespace

std::vector<char> find_tiled_materials(const Scene& scene, double periods) {
  std::vector<char> tiled(scene.materials.size(), 0);
  for (const Mesh& mesh : scene.meshes)
    for (const Primitive& p : mesh.primitives) {
      if (p.material < 0 || size_t(p.material) >= scene.materials.size() || tiled[size_t(p.material)])
        continue;
      const TextureRef& ref = scene.materials[size_t(p.material)].base_color;
      if (!ref.present() || size_t(ref.image) >= scene.images.size() ||
          !scene.images[size_t(ref.image)].decoded())
        continue;
      if (!repeats(ref.sampler.wrap_s) && !repeats(ref.sampler.wrap_t)) continue;
      if (spans_periods(p, ref, periods)) tiled[size_t(p.material)] = 1;
    }
  return tiled;
}

TiledSplit split_tiled(const Scene& scene, const std::vector<char>& tiled) {
  TiledSplit out;
  out.rest = scene;
  out.kept.source = scene.source;
  out.kept.normalization_scale = scene.normalization_scale;
  auto is_tiled = [&](const Primitive& p) {
    return p.material >= 0 && size_t(p.material) < tiled.size() && tiled[size_t(p.material)];
  };
  std::vector<int32_t> material_map(scene.materials.size(), -1), image_map(scene.images.size(), -1);
  // Per source mesh, the kept meshes its instances also place.
  std::vector<std::vector<uint32_t>> kept_parts(scene.meshes.size());
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    std::vector<Primitive>& rest_prims = out.rest.meshes[m].primitives;
    rest_prims.erase(std::remove_if(rest_prims.begin(), rest_prims.end(), is_tiled), rest_prims.end());
    for (const Primitive& p : scene.meshes[m].primitives) {
      if (!is_tiled(p) || p.indices.empty()) continue;
      int32_t& mat = material_map[size_t(p.material)];
      if (mat < 0) {
        Material copy = scene.materials[size_t(p.material)];
        for (TextureRef* ref : refs_of(copy)) {
          if (!ref->present() || size_t(ref->image) >= scene.images.size()) {
            ref->image = -1;
            continue;
          }
          int32_t& img = image_map[size_t(ref->image)];
          if (img < 0) {
            img = int32_t(out.kept.images.size());
            out.kept.images.push_back(scene.images[size_t(ref->image)]);
          }
          ref->image = img;
        }
        mat = int32_t(out.kept.materials.size());
        out.kept.materials.push_back(std::move(copy));
      }
      Mesh part;
      part.name = scene.meshes[m].name + " (tiled)";
      part.primitives.push_back(p);
      part.primitives.back().material = mat;
      kept_parts[m].push_back(uint32_t(out.kept.meshes.size()));
      out.kept.meshes.push_back(std::move(part));
    }
  }
  for (const Instance& inst : scene.instances)
    if (inst.mesh < kept_parts.size())
      for (uint32_t part : kept_parts[inst.mesh]) {
        Instance copy = inst;
        copy.mesh = part;
        out.kept.instances.push_back(std::move(copy));
      }
  for (size_t i = 0; i < tiled.size(); ++i)
    if (tiled[i]) out.rest.materials[i] = Material{};  // unused now: its textures not counted
  out.kept_materials = out.kept.materials.size();
  return out;
}

void append_scene(Scene& out, const Scene& extra) {
  const int32_t image_base = int32_t(out.images.size());
  const int32_t material_base = int32_t(out.materials.size());
  const uint32_t mesh_base = uint32_t(out.meshes.size());
  out.images.insert(out.images.end(), extra.images.begin(), extra.images.end());
  for (Material m : extra.materials) {
    for (TextureRef* ref : refs_of(m))
      if (ref->present()) ref->image += image_base;
    out.materials.push_back(std::move(m));
  }
  for (Mesh mesh : extra.meshes) {
    for (Primitive& p : mesh.primitives)
      if (p.material >= 0) p.material += material_base;
    out.meshes.push_back(std::move(mesh));
  }
  for (Instance inst : extra.instances) {
    inst.mesh += mesh_base;
    out.instances.push_back(std::move(inst));
  }
}

}  // namespace meshmux
