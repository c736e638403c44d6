// The source's own texture as the atlas (see source_atlas.h). Paper 000 §4.4 resamples source
// textures into charts; this is the case where the source is already one chart set in one
// image, so the resampling step is the identity and is skipped.
#include "atlas/source_atlas.h"

#include <algorithm>
#include <cmath>

#include "image/color.h"

namespace meshmux {

namespace {

bool power_of_two(int v) { return v > 0 && (v & (v - 1)) == 0; }

constexpr float kUvSlack = 1e-3f;  // uv units a coordinate may lie outside [0, 1]

}  // namespace

Vec2 face_uv_cell(Vec2 a, Vec2 b, Vec2 c) {
  return {std::floor(std::min({a.x, b.x, c.x}) + kUvSlack),
          std::floor(std::min({a.y, b.y, c.y}) + kUvSlack)};
}

std::optional<SourceAtlas> find_source_atlas(const Scene& scene, int max_size) {
  std::optional<SourceAtlas> found;
  for (const Mesh& mesh : scene.meshes)
    for (const Primitive& p : mesh.primitives) {
      if (p.indices.empty()) continue;
      if (p.material < 0 || size_t(p.material) >= scene.materials.size() || !p.colors.empty())
        return std::nullopt;
      const Material& m = scene.materials[size_t(p.material)];
      const TextureRef& t = m.base_color;
      if (!t.present() || !t.transform.is_identity() || t.tex_coord >= p.uvs.size())
        return std::nullopt;
      SourceAtlas here{t.image, t.tex_coord, m.base_color_factor};
      if (!found) {
        found = here;
      } else if (found->image != here.image || found->tex_coord != here.tex_coord ||
                 !(found->factor == here.factor)) {
        return std::nullopt;
      }
      // Each face within one unit cell of uv space; a cell other than [0, 1] only where the
      // sampler repeats (the shift to [0, 1] then shows the same texels).
      const std::vector<Vec2>& uv = p.uvs[t.tex_coord];
      for (size_t i = 0; i + 2 < p.indices.size(); i += 3) {
        Vec2 c[3];
        for (int k = 0; k < 3; ++k) {
          if (p.indices[i + size_t(k)] >= uv.size()) return std::nullopt;
          c[k] = uv[p.indices[i + size_t(k)]];
        }
        const Vec2 cell = face_uv_cell(c[0], c[1], c[2]);
        if (!std::isfinite(cell.x) || !std::isfinite(cell.y)) return std::nullopt;
        if ((cell.x != 0 && t.sampler.wrap_s != Wrap::kRepeat) ||
            (cell.y != 0 && t.sampler.wrap_t != Wrap::kRepeat))
          return std::nullopt;
        for (const Vec2& q : c)
          if (q.x - cell.x > 1 + kUvSlack || q.y - cell.y > 1 + kUvSlack) return std::nullopt;
      }
    }
  if (!found || size_t(found->image) >= scene.images.size()) return std::nullopt;
  const Image& image = scene.images[size_t(found->image)];
  if (!image.decoded() || !power_of_two(image.width) || !power_of_two(image.height) ||
      image.width > max_size || image.height > max_size)
    return std::nullopt;
  return found;
}

Image source_atlas_image(const Scene& scene, const SourceAtlas& source) {
  const Image& in = scene.images[size_t(source.image)];
  Image out;
  out.name = "atlas";
  out.width = in.width;
  out.height = in.height;
  out.rgba = in.rgba;
  const Vec4 f = source.factor;
  if (f.x == 1 && f.y == 1 && f.z == 1 && f.w == 1) return out;
  for (size_t i = 0; i + 3 < out.rgba.size(); i += 4) {
    out.rgba[i + 0] = linear_to_srgb(srgb_to_linear(out.rgba[i + 0]) * f.x);
    out.rgba[i + 1] = linear_to_srgb(srgb_to_linear(out.rgba[i + 1]) * f.y);
    out.rgba[i + 2] = linear_to_srgb(srgb_to_linear(out.rgba[i + 2]) * f.z);
    out.rgba[i + 3] = uint8_t(std::lround(std::clamp(out.rgba[i + 3] * f.w, 0.0f, 255.0f)));
  }
  return out;
}

}  // namespace meshmux
