// The source's own texture as the atlas (see source_atlas.h). Terrace, Cheslack-Postava, Levis and
// Freedman, "Unsupervised conversion of 3D models for interactive metaverses" §4.4 resamples source
// textures into charts; this is the case where the source is already one chart set in one image, so
// the resampling step is the identity and is skipped. Plain colours get aligned blocks (Terrace
// et al. §4.4's power-of-two rule: an aligned 2^k block stays one colour down to mip level k) where
// no textured face samples.
#include "atlas/source_atlas.h"

#include <algorithm>
#include <cmath>

#include "atlas/material_sample.h"
#include "core/parallel.h"
#include "image/color.h"
#include "image/resize.h"

namespace meshmux {

namespace {

constexpr float kUvSlack = 1e-3f;  // uv units a coordinate may lie outside its unit cell
constexpr double kMargin = 8;      // texels kept clear between textured faces and a block
constexpr int kMaxBlock = 64, kMinBlock = 4;  // block sides tried, texels

double cross2(double ax, double ay, double bx, double by) { return ax * by - ay * bx; }

// Distance from (px, py) to segment a-b.
double segment_distance(double px, double py, double ax, double ay, double bx, double by) {
  const double dx = bx - ax, dy = by - ay, len2 = dx * dx + dy * dy;
  double t = len2 > 0 ? ((px - ax) * dx + (py - ay) * dy) / len2 : 0;
  t = std::clamp(t, 0.0, 1.0);
  const double qx = ax + t * dx - px, qy = ay + t * dy - py;
  return std::sqrt(qx * qx + qy * qy);
}

// Marks every texel whose centre lies within `reach` texels of the triangle (texel units).
void mark_triangle(const double x[3], const double y[3], double reach, int w, int h,
                   std::vector<uint8_t>& used) {
  const int x0 = std::max(0, int(std::floor(std::min({x[0], x[1], x[2]}) - reach)));
  const int x1 = std::min(w - 1, int(std::ceil(std::max({x[0], x[1], x[2]}) + reach)));
  const int y0 = std::max(0, int(std::floor(std::min({y[0], y[1], y[2]}) - reach)));
  const int y1 = std::min(h - 1, int(std::ceil(std::max({y[0], y[1], y[2]}) + reach)));
  const double area = cross2(x[1] - x[0], y[1] - y[0], x[2] - x[0], y[2] - y[0]);
  for (int ty = y0; ty <= y1; ++ty)
    for (int tx = x0; tx <= x1; ++tx) {
      uint8_t& u = used[size_t(ty) * size_t(w) + size_t(tx)];
      if (u) continue;
      const double px = tx + 0.5, py = ty + 0.5;
      bool inside = false;
      if (area != 0) {
        const double s = area > 0 ? 1 : -1;
        inside = s * cross2(x[1] - x[0], y[1] - y[0], px - x[0], py - y[0]) >= 0 &&
                 s * cross2(x[2] - x[1], y[2] - y[1], px - x[1], py - y[1]) >= 0 &&
                 s * cross2(x[0] - x[2], y[0] - y[2], px - x[2], py - y[2]) >= 0;
      }
      if (inside || segment_distance(px, py, x[0], y[0], x[1], y[1]) <= reach ||
          segment_distance(px, py, x[1], y[1], x[2], y[2]) <= reach ||
          segment_distance(px, py, x[2], y[2], x[0], y[0]) <= reach)
        u = 1;
    }
}

// Aligned free b×b cells of `used` (w×h), in scan order, at most `need`.
std::vector<std::pair<int, int>> free_cells(const std::vector<uint8_t>& used, int w, int h, int b,
                                            size_t need) {
  // Summed-area table of used texels.
  std::vector<uint32_t> sat(size_t(w + 1) * size_t(h + 1), 0);
  auto at = [&](int x, int y) -> uint32_t& { return sat[size_t(y) * size_t(w + 1) + size_t(x)]; };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      at(x + 1, y + 1) =
          used[size_t(y) * size_t(w) + size_t(x)] + at(x, y + 1) + at(x + 1, y) - at(x, y);
  std::vector<std::pair<int, int>> out;
  for (int y = 0; y + b <= h && out.size() < need; y += b)
    for (int x = 0; x + b <= w && out.size() < need; x += b)
      if (at(x + b, y + b) + at(x, y) - at(x + b, y) - at(x, y + b) == 0) out.push_back({x, y});
  return out;
}

void put(uint8_t* p, Vec4 c) {
  p[0] = linear_to_srgb(c.x);
  p[1] = linear_to_srgb(c.y);
  p[2] = linear_to_srgb(c.z);
  p[3] = uint8_t(std::lround(std::clamp(c.w, 0.0f, 1.0f) * 255.0f));
}

}  // namespace

Vec2 face_uv_cell(Vec2 a, Vec2 b, Vec2 c) {
  return {std::floor(std::min({a.x, b.x, c.x}) + kUvSlack),
          std::floor(std::min({a.y, b.y, c.y}) + kUvSlack)};
}

int flat_color_index(const Scene& scene, const SourceAtlas& source, int32_t material) {
  Vec4 c{1, 1, 1, 1};
  if (material >= 0 && size_t(material) < scene.materials.size()) {
    const Material& m = scene.materials[size_t(material)];
    if (m.base_color.present()) return -1;
    c = m.base_color_factor;
  }
  for (size_t i = 0; i < source.flat_colors.size(); ++i)
    if (source.flat_colors[i] == c) return int(i);
  return -1;
}

namespace {

bool same_ref(const TextureRef& a, const TextureRef& b) {
  return a.image == b.image &&
         (!a.present() || (a.tex_coord == b.tex_coord && a.scale == b.scale &&
                           a.transform.is_identity() && b.transform.is_identity()));
}

// The channels other than base colour, compared.
bool same_channels(const Material& a, const Material& b) {
  return same_ref(a.normal, b.normal) && same_ref(a.occlusion, b.occlusion) &&
         same_ref(a.metallic_roughness, b.metallic_roughness) && same_ref(a.emissive, b.emissive) &&
         same_ref(a.sheen_color, b.sheen_color) && a.metallic_factor == b.metallic_factor &&
         a.roughness_factor == b.roughness_factor && a.emissive_factor == b.emissive_factor &&
         a.sheen_color_factor == b.sheen_color_factor &&
         a.sheen_roughness_factor == b.sheen_roughness_factor;
}

bool any_channel_texture(const Material& m) {
  return m.normal.present() || m.occlusion.present() || m.metallic_roughness.present() ||
         m.emissive.present() || m.sheen_color.present();
}

// Rows [rows, height) of a `width`-wide RGBA image whose first `rows` rows are the image's
// part: what the atlas's sampler must show past the part's edges (glTF 2.0 §3.8.4.4). Clamped:
// copies of row rows − 1 (what a clamped sampler shows past the edge, so filtering and mip
// levels across the boundary see no other colour). Repeating (height = 2 · rows): the first
// `keep` rows are the part's first (they continue it across its bottom edge as REPEAT does),
// the last `keep` the part's last (the atlas, wrapping, shows them above the part's top edge),
// so every box-filtered mip level down to log2(keep) reads across either edge what the
// source's own level reads there; the rows between repeat the last of the first ones (plain
// columns: the encoded image grows by little). `rgba` is resized to height rows.
void extend_part(std::vector<uint8_t>& rgba, size_t width, size_t rows, size_t height, Wrap wrap_t,
                 size_t keep) {
  rgba.resize(width * height * 4);
  if (rows == 0) return;
  const size_t row = width * 4;
  keep = std::min(keep, rows);
  for (size_t y = rows; y < height; ++y) {
    size_t from = rows - 1;
    if (wrap_t == Wrap::kRepeat)
      from = y < rows + keep || y + keep >= height ? y % rows : std::max<size_t>(keep, 1) - 1;
    std::copy(rgba.begin() + std::ptrdiff_t(from * row),
              rgba.begin() + std::ptrdiff_t((from + 1) * row),
              rgba.begin() + std::ptrdiff_t(y * row));
  }
}

}  // namespace

std::optional<SourceAtlas> find_source_atlas(const Scene& scene, int max_size) {
  std::optional<SourceAtlas> found;
  std::vector<Vec4> flat;
  std::vector<int32_t> flat_material;
  const Material default_material;
  bool repeat_s = true, repeat_t = true;  // every textured face's sampler repeats on the axis
  // Pass 1: one image, one uv set, one factor; the plain colours.
  for (const Mesh& mesh : scene.meshes)
    for (const Primitive& p : mesh.primitives) {
      if (p.indices.empty()) continue;
      if (!p.colors.empty() || p.material >= int32_t(scene.materials.size())) return std::nullopt;
      if (p.material < 0 || !scene.materials[size_t(p.material)].base_color.present()) {
        const Material& m = p.material < 0 ? default_material : scene.materials[size_t(p.material)];
        if (any_channel_texture(m)) return std::nullopt;
        const Vec4 c = m.base_color_factor;
        auto at = std::find(flat.begin(), flat.end(), c);
        if (at == flat.end()) {
          flat.push_back(c);
          flat_material.push_back(p.material);
        } else {
          const int32_t other = flat_material[size_t(at - flat.begin())];
          if (!same_channels(m, other < 0 ? default_material : scene.materials[size_t(other)]))
            return std::nullopt;
        }
        continue;
      }
      const Material& m = scene.materials[size_t(p.material)];
      const TextureRef& t = m.base_color;
      if (!t.transform.is_identity() || t.tex_coord >= p.uvs.size()) return std::nullopt;
      for (const TextureRef* c :
           {&m.normal, &m.occlusion, &m.metallic_roughness, &m.emissive, &m.sheen_color})
        if (c->present() &&
            (c->tex_coord != t.tex_coord || !c->transform.is_identity() ||
             size_t(c->image) >= scene.images.size() || !scene.images[size_t(c->image)].decoded()))
          return std::nullopt;
      repeat_s = repeat_s && t.sampler.wrap_s == Wrap::kRepeat;
      repeat_t = repeat_t && t.sampler.wrap_t == Wrap::kRepeat;
      SourceAtlas here;
      here.image = t.image;
      here.tex_coord = t.tex_coord;
      here.factor = m.base_color_factor;
      here.material = p.material;
      if (!found) {
        found = here;
      } else if (found->image != here.image || found->tex_coord != here.tex_coord ||
                 !(found->factor == here.factor) ||
                 !same_channels(m, scene.materials[size_t(found->material)])) {
        return std::nullopt;
      }
    }
  if (!found || found->image < 0 || size_t(found->image) >= scene.images.size())
    return std::nullopt;
  const Image& image = scene.images[size_t(found->image)];
  if (!image.decoded()) return std::nullopt;
  // Sides that are not powers of two are rounded up (the image resampled): texture levels halve.
  const int w = next_power_of_two(image.width), h = next_power_of_two(image.height);
  if (w > max_size || h > max_size) return std::nullopt;
  found->wrap_s = repeat_s ? Wrap::kRepeat : Wrap::kClampToEdge;
  found->wrap_t = repeat_t ? Wrap::kRepeat : Wrap::kClampToEdge;
  // Pass 2: each textured face inside one unit cell (moved to [0, 1]² where the sampler
  // repeats); with plain colours to place, the texels the faces come near are marked.
  std::vector<uint8_t> used(flat.empty() ? 0 : size_t(w) * size_t(h), 0);
  float beyond_t = 0;  // the most a face reaches past its cell's far edge in v (repeating)
  for (const Mesh& mesh : scene.meshes)
    for (const Primitive& p : mesh.primitives) {
      if (p.indices.empty() || p.material < 0) continue;
      const TextureRef& t = scene.materials[size_t(p.material)].base_color;
      if (!t.present()) continue;
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
        // Past the cell's far edge only on a repeating axis, by less than a period: the atlas
        // keeps the sampler's REPEAT there, so the face reads across the edge what the original
        // reads (a lightmap's faces reaching v = 1.014 were refused and re-baked into a 4096²
        // atlas at 1 % use, 15 s). An appended half must continue the image that far (below).
        for (const Vec2& q : c) {
          const float over_x = q.x - cell.x - 1, over_y = q.y - cell.y - 1;
          if ((over_x > kUvSlack && (!repeat_s || over_x >= 1)) ||
              (over_y > kUvSlack && (!repeat_t || over_y >= 1)))
            return std::nullopt;
          beyond_t = std::max(beyond_t, over_y);
        }
        if (flat.empty()) continue;
        // The face, and on a repeating axis its copies one period away: near an edge the
        // original's filtering and mip levels read the texels across it.
        for (int sy = repeat_t ? -1 : 0; sy <= (repeat_t ? 1 : 0); ++sy)
          for (int sx = repeat_s ? -1 : 0; sx <= (repeat_s ? 1 : 0); ++sx) {
            double x[3], y[3];
            for (int k = 0; k < 3; ++k) {
              x[k] = (double(c[k].x - cell.x) + sx) * w;
              y[k] = (double(c[k].y - cell.y) + sy) * h;
            }
            mark_triangle(x, y, kMargin, w, h, used);
          }
      }
    }
  found->width = found->part_width = w;
  found->height = found->part_height = h;
  if (flat.empty()) return found;
  // Pass 3: blocks for the plain colours, the largest side that fits them all; else below the
  // image, in a second image height.
  std::vector<std::pair<int, int>> cells;
  int block = 0;
  for (int b = std::min({kMaxBlock, w, h}); b >= kMinBlock && cells.size() < flat.size(); b /= 2) {
    cells = free_cells(used, w, h, b, flat.size());
    block = b;
  }
  if (cells.size() < flat.size()) {
    if (2 * h > max_size) return std::nullopt;
    found->height = 2 * h;
    // Clamped: the upper rows stay the image's edge (its last row repeated, see
    // source_atlas_image), the blocks from the bottom up, as far from it as they can be.
    // Repeating: the appended half copies the image, whose first and last `block` rows stay
    // (they continue the image across its bottom edge and, wrapping, across its top), the
    // blocks between them.
    const bool repeat = found->wrap_t == Wrap::kRepeat;
    block = std::max(1, std::min({kMaxBlock, w, repeat ? h / 4 : h / 2}));
    const int top = repeat ? h + block : h, bottom = repeat ? 2 * h - block : 2 * h;
    cells.clear();
    for (int y = bottom - block; y >= top && cells.size() < flat.size(); y -= block)
      for (int x = 0; x + block <= w && cells.size() < flat.size(); x += block)
        cells.push_back({x, y});
    if (cells.size() < flat.size()) return std::nullopt;
    // A face past the image's bottom edge reads the appended half's first rows: the image's top
    // rows only as far as they are copied.
    if (beyond_t > kUvSlack && (!repeat || double(beyond_t) * h > block - kMargin))
      return std::nullopt;
  }
  found->block = block;
  found->flat_colors = flat;
  found->flat_material = flat_material;
  for (size_t i = 0; i < flat.size(); ++i) {
    found->flat_x.push_back(cells[i].first);
    found->flat_y.push_back(cells[i].second);
    found->flat_uv.push_back({float((cells[i].first + 0.5 * block) / found->width),
                              float((cells[i].second + 0.5 * block) / found->height)});
  }
  return found;
}

Image source_atlas_image(const Scene& scene, const SourceAtlas& source) {
  const Image& in = scene.images[size_t(source.image)];
  Image out;
  out.name = "atlas";
  out.width = source.width;
  out.height = source.height;
  if (in.width == source.part_width && in.height == source.part_height)
    out.rgba = in.rgba;
  else
    out.rgba = resize_cubic(in, source.part_width, source.part_height, true).rgba;
  const Vec4 f = source.factor;
  if (!(f.x == 1 && f.y == 1 && f.z == 1 && f.w == 1))
    for (size_t i = 0; i + 3 < out.rgba.size(); i += 4) {
      out.rgba[i + 0] = linear_to_srgb(srgb_to_linear(out.rgba[i + 0]) * f.x);
      out.rgba[i + 1] = linear_to_srgb(srgb_to_linear(out.rgba[i + 1]) * f.y);
      out.rgba[i + 2] = linear_to_srgb(srgb_to_linear(out.rgba[i + 2]) * f.z);
      out.rgba[i + 3] = uint8_t(std::lround(std::clamp(out.rgba[i + 3] * f.w, 0.0f, 255.0f)));
    }
  const size_t w = size_t(out.width);
  if (source.height > source.part_height)  // the appended half: past the part's edges
    extend_part(out.rgba, w, size_t(source.part_height), size_t(out.height), source.wrap_t,
                size_t(source.block));
  for (size_t c = 0; c < source.flat_colors.size(); ++c) {
    uint8_t px[4];
    put(px, source.flat_colors[c]);
    for (int y = source.flat_y[c]; y < source.flat_y[c] + source.block; ++y)
      for (int x = source.flat_x[c]; x < source.flat_x[c] + source.block; ++x)
        std::copy(px, px + 4, &out.rgba[(size_t(y) * w + size_t(x)) * 4]);
  }
  return out;
}

Image source_atlas_channel(const Scene& scene, const SourceAtlas& source, AtlasChannel channel,
                           float emissive_scale) {
  Image out;
  out.width = source.width;
  out.height = source.height;
  out.rgba.assign(size_t(out.width) * size_t(out.height) * 4, 255);
  const float es = emissive_scale > 0 && std::isfinite(emissive_scale) ? emissive_scale : 1.0f;
  // `uvs`: the caller's scratch (one per thread), the uv set read at source.tex_coord.
  auto value = [&](int32_t material, Vec2 uv, uint8_t* px, std::vector<Vec2>& uvs) {
    uvs[source.tex_coord] = uv;
    auto byte = [](double v) { return uint8_t(std::lround(std::clamp(v, 0.0, 1.0) * 255.0)); };
    switch (channel) {
      case AtlasChannel::kNormal: {
        Vec3 m = sample_normal_map(scene, material, uvs);
        double l = std::sqrt(double(m.x) * m.x + double(m.y) * m.y + double(m.z) * m.z);
        if (!(l > 0) || !std::isfinite(l)) m = {0, 0, 1}, l = 1;
        px[0] = byte(0.5 + 0.5 * m.x / l);
        px[1] = byte(0.5 + 0.5 * m.y / l);
        px[2] = byte(0.5 + 0.5 * m.z / l);
        break;
      }
      case AtlasChannel::kOcclusionRoughnessMetallic: {
        const Vec3 v = sample_occlusion_roughness_metallic(scene, material, uvs);
        px[0] = byte(v.x), px[1] = byte(v.y), px[2] = byte(v.z);
        break;
      }
      case AtlasChannel::kSheen: {
        const Vec3 c = sample_sheen_color(scene, material, uvs);
        px[0] = linear_to_srgb(c.x);
        px[1] = linear_to_srgb(c.y);
        px[2] = linear_to_srgb(c.z);
        break;
      }
      case AtlasChannel::kEmissive: {
        const Vec3 e = sample_emissive(scene, material, uvs);
        px[0] = linear_to_srgb(e.x / es);
        px[1] = linear_to_srgb(e.y / es);
        px[2] = linear_to_srgb(e.z / es);
        break;
      }
    }
    px[3] = 255;
  };
  const size_t w = size_t(out.width);
  // Rows on every core (each texel written once, by its row's thread: the same bytes).
  const size_t uv_sets = size_t(source.tex_coord) + 1;
  const int pw = source.part_width, ph = source.part_height;
  parallel_chunks(size_t(ph), 16, [&](size_t row_begin, size_t row_end) {
    std::vector<Vec2> uvs(uv_sets, Vec2{0, 0});
    for (int y = int(row_begin); y < int(row_end); ++y)
      for (int x = 0; x < pw; ++x)
        value(source.material, {float((x + 0.5) / pw), float((y + 0.5) / ph)},
              &out.rgba[(size_t(y) * w + size_t(x)) * 4], uvs);
  });
  // Plain colours: their material's factors (no texture samples, so the uv is irrelevant).
  std::vector<Vec2> flat_uvs(uv_sets, Vec2{0, 0});
  auto flat_value = [&](size_t c, uint8_t* px) {
    value(c < source.flat_material.size() ? source.flat_material[c] : -1, {0, 0}, px, flat_uvs);
    if (channel == AtlasChannel::kNormal) px[0] = 128, px[1] = 128, px[2] = 255;
  };
  if (source.height > ph)
    extend_part(out.rgba, w, size_t(ph), size_t(out.height), source.wrap_t, size_t(source.block));
  for (size_t c = 0; c < source.flat_colors.size(); ++c) {
    uint8_t px[4];
    flat_value(c, px);
    for (int y = source.flat_y[c]; y < source.flat_y[c] + source.block; ++y)
      for (int x = source.flat_x[c]; x < source.flat_x[c] + source.block; ++x)
        std::copy(px, px + 4, &out.rgba[(size_t(y) * w + size_t(x)) * 4]);
  }
  return out;
}

}  // namespace meshmux
