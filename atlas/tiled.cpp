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

}  // namespace meshmux
