// Palette textures as plain colours (see palette.h).
#include "atlas/palette.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include "atlas/source_atlas.h"
#include "image/color.h"

namespace meshmux {
namespace {

constexpr int kMaxFootprint = 64;  // texels per side a face may cover and still be checked

// Whether a material may be a palette: a decoded base colour texture and nothing else.
bool palette_candidate(const Scene& scene, const Material& m) {
  if (!m.base_color.present() || !m.base_color.transform.is_identity()) return false;
  if (size_t(m.base_color.image) >= scene.images.size() ||
      !scene.images[size_t(m.base_color.image)].decoded())
    return false;
  for (const TextureRef* t : texture_refs(m))
    if (t != &m.base_color && t->present()) return false;
  return true;
}

// The one RGBA value (packed) every texel of a face's bilinear footprint holds, or nullopt.
std::optional<uint32_t> face_color(const Image& img, const TextureRef& ref, Vec2 a, Vec2 b,
                                   Vec2 c) {
  const Vec2 cell = face_uv_cell(a, b, c);
  const bool repeat_s = ref.sampler.wrap_s != Wrap::kClampToEdge;
  const bool repeat_t = ref.sampler.wrap_t != Wrap::kClampToEdge;
  const float ox = repeat_s ? cell.x : 0, oy = repeat_t ? cell.y : 0;
  const float lo_u = std::min({a.x, b.x, c.x}) - ox, hi_u = std::max({a.x, b.x, c.x}) - ox;
  const float lo_v = std::min({a.y, b.y, c.y}) - oy, hi_v = std::max({a.y, b.y, c.y}) - oy;
  if (!std::isfinite(lo_u + hi_u + lo_v + hi_v)) return std::nullopt;
  // glTF samples texel centres at (i + 0.5) / w; bilinear reads floor(x − 0.5) and the next.
  const int x0 = int(std::floor(lo_u * float(img.width) - 0.5f));
  const int x1 = int(std::floor(hi_u * float(img.width) - 0.5f)) + 1;
  const int y0 = int(std::floor(lo_v * float(img.height) - 0.5f));
  const int y1 = int(std::floor(hi_v * float(img.height) - 0.5f)) + 1;
  if (x1 - x0 > kMaxFootprint || y1 - y0 > kMaxFootprint) return std::nullopt;
  auto index = [](int i, int n, bool repeat) {
    return repeat ? ((i % n) + n) % n : std::clamp(i, 0, n - 1);
  };
  std::optional<uint32_t> color;
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const size_t at = (size_t(index(y, img.height, repeat_t)) * size_t(img.width) +
                         size_t(index(x, img.width, repeat_s))) *
                        4;
      uint32_t v = 0;
      for (int k = 0; k < 4; ++k) v = v << 8 | img.rgba[at + size_t(k)];
      if (color && *color != v) return std::nullopt;
      color = v;
    }
  return color;
}

// Per face of a primitive: its palette colour; empty when some face has none.
std::vector<uint32_t> primitive_colors(const Scene& scene, const Primitive& p, const Material& m) {
  const TextureRef& ref = m.base_color;
  if (!p.colors.empty() || ref.tex_coord >= p.uvs.size()) return {};
  const std::vector<Vec2>& uv = p.uvs[ref.tex_coord];
  if (uv.size() != p.vertex_count()) return {};
  const Image& img = scene.images[size_t(ref.image)];
  std::vector<uint32_t> out(p.triangle_count());
  for (size_t f = 0; f < out.size(); ++f) {
    auto c = face_color(img, ref, uv[p.indices[3 * f]], uv[p.indices[3 * f + 1]],
                        uv[p.indices[3 * f + 2]]);
    if (!c) return {};
    out[f] = *c;
  }
  return out;
}

// `m` with its texture replaced by factor × the colour (sRGB bytes decoded; alpha linear).
Material plain(const Material& m, uint32_t rgba) {
  Material out = m;
  out.base_color = {};
  out.base_color_factor.x *= srgb_to_linear(uint8_t(rgba >> 24));
  out.base_color_factor.y *= srgb_to_linear(uint8_t(rgba >> 16));
  out.base_color_factor.z *= srgb_to_linear(uint8_t(rgba >> 8));
  out.base_color_factor.w *= float(rgba & 255) / 255.0f;
  return out;
}

// The faces of `p` whose colour is `color`, as a primitive of their vertices only.
Primitive faces_of(const Primitive& p, const std::vector<uint32_t>& colors, uint32_t color) {
  Primitive out;
  out.flat = p.flat;
  out.uvs.resize(p.uvs.size());
  std::vector<uint32_t> remap(p.vertex_count(), UINT32_MAX);
  for (size_t f = 0; f < colors.size(); ++f) {
    if (colors[f] != color) continue;
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = p.indices[3 * f + size_t(k)];
      if (remap[v] == UINT32_MAX) {
        remap[v] = uint32_t(out.positions.size());
        out.positions.push_back(p.positions[v]);
        if (!p.normals.empty()) out.normals.push_back(p.normals[v]);
        for (size_t s = 0; s < p.uvs.size(); ++s)
          if (!p.uvs[s].empty()) out.uvs[s].push_back(p.uvs[s][v]);
      }
      out.indices.push_back(remap[v]);
    }
  }
  return out;
}

}  // namespace

std::optional<Scene> palette_as_plain_colors(const Scene& scene, size_t* replaced) {
  *replaced = 0;
  // Per material: whether every face of every primitive using it reads one colour.
  const size_t n = scene.materials.size();
  std::vector<char> palette(n, 0), used(n, 0);
  for (size_t i = 0; i < n; ++i) palette[i] = palette_candidate(scene, scene.materials[i]);
  std::vector<std::vector<std::vector<uint32_t>>> colors(scene.meshes.size());
  for (size_t m = 0; m < scene.meshes.size(); ++m)
    for (const Primitive& p : scene.meshes[m].primitives) {
      colors[m].emplace_back();
      if (p.material < 0 || size_t(p.material) >= n || !palette[size_t(p.material)]) continue;
      if (p.indices.empty()) continue;
      used[size_t(p.material)] = 1;
      colors[m].back() = primitive_colors(scene, p, scene.materials[size_t(p.material)]);
      if (colors[m].back().empty()) palette[size_t(p.material)] = 0;
    }
  for (size_t i = 0; i < n; ++i) palette[i] = palette[i] && used[i];
  *replaced = size_t(std::count(palette.begin(), palette.end(), 1));
  if (*replaced == 0) return std::nullopt;
  Scene out = scene;
  std::map<std::pair<int32_t, uint32_t>, int32_t> plain_material;  // (material, colour) → new
  for (size_t m = 0; m < out.meshes.size(); ++m) {
    std::vector<Primitive> prims;
    for (size_t k = 0; k < scene.meshes[m].primitives.size(); ++k) {
      const Primitive& p = scene.meshes[m].primitives[k];
      if (p.material < 0 || size_t(p.material) >= n || !palette[size_t(p.material)] ||
          p.indices.empty()) {
        prims.push_back(p);
        continue;
      }
      std::vector<uint32_t> order;  // colours in first-use order (deterministic)
      for (uint32_t c : colors[m][k])
        if (std::find(order.begin(), order.end(), c) == order.end()) order.push_back(c);
      for (uint32_t c : order) {
        auto [it, fresh] = plain_material.try_emplace({p.material, c}, 0);
        if (fresh) {
          it->second = int32_t(out.materials.size());
          out.materials.push_back(plain(scene.materials[size_t(p.material)], c));
        }
        prims.push_back(faces_of(p, colors[m][k], c));
        prims.back().material = it->second;
      }
    }
    out.meshes[m].primitives = std::move(prims);
  }
  return out;
}

}  // namespace meshmux
