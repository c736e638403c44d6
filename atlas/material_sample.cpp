// Base-colour sampling of a source material (see material_sample.h).
//
// References implemented:
// - KHR_texture_transform (Khronos glTF extension): uv' = T(offset) · R(rotation) · S(scale) · uv,
//   R written row-major as (cos r, sin r; −sin r, cos r). Check: the spec's example (offset
//   (0, 1), rotation π/2, scale 0.5) must select the lower-left quadrant, which this reading does.
// - glTF 2.0 sampler semantics: texel centres at (i + 0.5) / width, uv (0, 0) at the top-left,
//   REPEAT / CLAMP_TO_EDGE / MIRRORED_REPEAT applied per axis to integer texel coordinates,
//   bilinear filtering on sRGB-decoded (linear) values.
#include "atlas/material_sample.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

#include "image/color.h"

namespace meshmux {
namespace {

// Reduces a coordinate (uv units) to a range where the wrap mode gives the same texels, so that
// the texel arithmetic below cannot overflow: REPEAT has period 1, MIRRORED_REPEAT period 2,
// CLAMP_TO_EDGE clamps anything beyond one texture width outside [0, 1].
double reduce(double u, Wrap wrap) {
  if (!std::isfinite(u)) return 0;
  switch (wrap) {
    case Wrap::kClampToEdge:
      return std::clamp(u, -1.0, 2.0);
    case Wrap::kMirroredRepeat:
      return u - 2.0 * std::floor(u / 2.0);
    case Wrap::kRepeat:
    default:
      return u - std::floor(u);
  }
}

// Integer texel coordinate i (any integer) → a texel in [0, n).
int wrap_index(long long i, int n, Wrap wrap) {
  if (i >= 0 && i < n) return int(i);
  switch (wrap) {
    case Wrap::kClampToEdge:
      return int(std::clamp<long long>(i, 0, n - 1));
    case Wrap::kMirroredRepeat: {
      long long period = 2LL * n;
      long long m = ((i % period) + period) % period;
      return int(m < n ? m : period - 1 - m);
    }
    case Wrap::kRepeat:
    default:
      return int(((i % n) + n) % n);
  }
}

Vec4 fetch(const Image& image, int x, int y, bool srgb) {
  const uint8_t* p = &image.rgba[(size_t(y) * size_t(image.width) + size_t(x)) * 4];
  if (!srgb) return {p[0] / 255.0f, p[1] / 255.0f, p[2] / 255.0f, p[3] / 255.0f};
  return {srgb_to_linear(p[0]), srgb_to_linear(p[1]), srgb_to_linear(p[2]), p[3] / 255.0f};
}

Vec4 bilinear(const Image& image, const Sampler& sampler, Vec2 uv, bool srgb) {
  if (!image.decoded() || image.rgba.size() < size_t(image.width) * size_t(image.height) * 4)
    return {1, 1, 1, 1};
  const int w = image.width, h = image.height;
  double x = reduce(uv.x, sampler.wrap_s) * w - 0.5;
  double y = reduce(uv.y, sampler.wrap_t) * h - 0.5;
  double fx0 = std::floor(x), fy0 = std::floor(y);
  double fx = x - fx0, fy = y - fy0;
  long long x0 = (long long)fx0, y0 = (long long)fy0;
  int xa = wrap_index(x0, w, sampler.wrap_s), xb = wrap_index(x0 + 1, w, sampler.wrap_s);
  int ya = wrap_index(y0, h, sampler.wrap_t), yb = wrap_index(y0 + 1, h, sampler.wrap_t);
  Vec4 c00 = fetch(image, xa, ya, srgb), c10 = fetch(image, xb, ya, srgb);
  Vec4 c01 = fetch(image, xa, yb, srgb), c11 = fetch(image, xb, yb, srgb);
  auto mix = [&](float a, float b, float c, float d) {
    double top = a + (b - a) * fx;
    double bottom = c + (d - c) * fx;
    return float(top + (bottom - top) * fy);
  };
  return {mix(c00.x, c10.x, c01.x, c11.x), mix(c00.y, c10.y, c01.y, c11.y),
          mix(c00.z, c10.z, c01.z, c11.z), mix(c00.w, c10.w, c01.w, c11.w)};
}

// The texel of `ref` at the point (sRGB-decoded when `srgb`), or nullopt when the reference is
// absent or its image is not decoded.
std::optional<Vec4> sample_ref(const Scene& scene, const TextureRef& ref,
                               const std::vector<Vec2>& uvs, bool srgb) {
  if (!ref.present() || size_t(ref.image) >= scene.images.size()) return std::nullopt;
  const Image& image = scene.images[size_t(ref.image)];
  if (!image.decoded()) return std::nullopt;
  Vec2 uv = ref.tex_coord < uvs.size() ? uvs[ref.tex_coord] : Vec2{0, 0};
  return bilinear(image, ref.sampler, apply_transform(ref.transform, uv), srgb);
}

const Material* material_at(const Scene& scene, int32_t material) {
  if (material < 0 || size_t(material) >= scene.materials.size()) return nullptr;
  return &scene.materials[size_t(material)];
}

}  // namespace

Vec2 apply_transform(const TextureTransform& t, Vec2 uv) {
  if (t.is_identity()) return uv;
  double su = double(uv.x) * t.scale[0];
  double sv = double(uv.y) * t.scale[1];
  double c = std::cos(double(t.rotation)), s = std::sin(double(t.rotation));
  double ru = c * su + s * sv;
  double rv = -s * su + c * sv;
  return {float(ru + t.offset[0]), float(rv + t.offset[1])};
}

Vec4 sample_image(const Image& image, const Sampler& sampler, Vec2 uv) {
  return bilinear(image, sampler, uv, true);
}

Vec4 sample_image_data(const Image& image, const Sampler& sampler, Vec2 uv) {
  return bilinear(image, sampler, uv, false);
}

Vec4 sample_base_color(const Scene& scene, int32_t material, const std::vector<Vec2>& uvs,
                       Vec4 vertex_color) {
  // The glTF default material (and an index out of range) is plain white; COLOR_0 still
  // multiplies it.
  if (material < 0 || size_t(material) >= scene.materials.size()) return vertex_color;
  const Material& m = scene.materials[size_t(material)];
  Vec4 c{m.base_color_factor.x * vertex_color.x, m.base_color_factor.y * vertex_color.y,
         m.base_color_factor.z * vertex_color.z, m.base_color_factor.w * vertex_color.w};
  const TextureRef& ref = m.base_color;
  if (!ref.present() || size_t(ref.image) >= scene.images.size()) return c;
  const Image& image = scene.images[size_t(ref.image)];
  if (!image.decoded()) return c;  // undecoded: as if untextured
  Vec2 uv = ref.tex_coord < uvs.size() ? uvs[ref.tex_coord] : Vec2{0, 0};
  Vec4 t = sample_image(image, ref.sampler, apply_transform(ref.transform, uv));
  return {c.x * t.x, c.y * t.y, c.z * t.z, c.w * t.w};
}

}  // namespace meshmux

namespace meshmux {

// glTF 2.0 §3.9.2–3.9.4: occlusionTexture.r with its strength, metallicRoughnessTexture's g
// (roughness) and b (metallic) times the factors; emissiveTexture (sRGB) times emissiveFactor.
Vec3 sample_occlusion_roughness_metallic(const Scene& scene, int32_t material,
                                         const std::vector<Vec2>& uvs) {
  const Material* m = material_at(scene, material);
  if (!m) return {1, 1, 1};
  Vec3 orm{1, m->roughness_factor, m->metallic_factor};
  if (std::optional<Vec4> t = sample_ref(scene, m->metallic_roughness, uvs, false)) {
    orm.y *= t->y;
    orm.z *= t->z;
  }
  if (std::optional<Vec4> t = sample_ref(scene, m->occlusion, uvs, false))
    orm.x = 1 + m->occlusion.scale * (t->x - 1);
  return {std::clamp(orm.x, 0.0f, 1.0f), std::clamp(orm.y, 0.0f, 1.0f),
          std::clamp(orm.z, 0.0f, 1.0f)};
}

Vec3 sample_emissive(const Scene& scene, int32_t material, const std::vector<Vec2>& uvs) {
  const Material* m = material_at(scene, material);
  if (!m) return {0, 0, 0};
  Vec3 e = m->emissive_factor;
  if (std::optional<Vec4> t = sample_ref(scene, m->emissive, uvs, true))
    e = {e.x * t->x, e.y * t->y, e.z * t->z};
  return e;
}

Vec3 sample_sheen_color(const Scene& scene, int32_t material, const std::vector<Vec2>& uvs) {
  const Material* m = material_at(scene, material);
  if (!m) return {0, 0, 0};
  Vec3 c = m->sheen_color_factor;
  if (std::optional<Vec4> t = sample_ref(scene, m->sheen_color, uvs, true))
    c = {c.x * t->x, c.y * t->y, c.z * t->z};
  return c;
}

Vec3 sample_normal_map(const Scene& scene, int32_t material, const std::vector<Vec2>& uvs) {
  const Material* m = material_at(scene, material);
  if (!m) return {0, 0, 1};
  std::optional<Vec4> t = sample_ref(scene, m->normal, uvs, false);
  if (!t) return {0, 0, 1};
  const float s = std::isfinite(m->normal.scale) ? m->normal.scale : 1.0f;
  return {(2 * t->x - 1) * s, (2 * t->y - 1) * s, 2 * t->z - 1};
}

bool normal_map_uv(const Scene& scene, int32_t material, uint32_t* tex_coord,
                   TextureTransform* transform) {
  const Material* m = material_at(scene, material);
  if (!m || !m->normal.present() || size_t(m->normal.image) >= scene.images.size() ||
      !scene.images[size_t(m->normal.image)].decoded())
    return false;
  *tex_coord = m->normal.tex_coord;
  *transform = m->normal.transform;
  return true;
}

}  // namespace meshmux
