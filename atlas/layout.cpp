// Chart sizing (formula 2) and power-of-two-safe packing, pages included (see layout.h; Terrace,
// Cheslack-Postava, Levis and Freedman, "Unsupervised conversion of 3D models for interactive
// metaverses" §4.3–4.4).
#include "atlas/layout.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>
#include <string>

#include "scene/position_key.h"

namespace meshmux {

namespace {

constexpr double kVertexColorTexelsPerVertex = 256;  // 16 × 16 texels of atlas per vertex

// Σ over a chart's faces of their area in the source textures, in texels: per face the densest
// texture its material samples (base colour, normal, occlusion, metallic-roughness, emissive),
// so a chart whose detail lives in a normal map keeps that map's density.
double source_texels(const Scene& scene, const MeshView& mv, const Chart& chart) {
  double sum = 0;
  for (uint32_t f : chart.faces) {
    const FaceRef& r = mv.faces[f];
    const Primitive& p = mv.mesh.primitives[r.primitive];
    if (p.material < 0) continue;
    const Material& m = scene.materials[size_t(p.material)];
    double densest = 0;
    for (const TextureRef* t :
         {&m.base_color, &m.normal, &m.occlusion, &m.metallic_roughness, &m.emissive}) {
      if (!t->present() || t->tex_coord >= p.uvs.size() || size_t(t->image) >= scene.images.size())
        continue;
      const Image& img = scene.images[size_t(t->image)];
      if (!img.decoded()) continue;
      const std::vector<Vec2>& uv = p.uvs[t->tex_coord];
      Vec2 a = uv[mv.corner(f, 0)], b = uv[mv.corner(f, 1)], c = uv[mv.corner(f, 2)];
      double area =
          0.5 * std::abs(double(b.x - a.x) * (c.y - a.y) - double(c.x - a.x) * (b.y - a.y));
      area *= std::abs(double(t->transform.scale[0]) * t->transform.scale[1]);
      densest = std::max(densest, area * img.width * img.height);
    }
    sum += densest;
  }
  return sum;
}

// The source texels one atlas channel stands for: per channel kind (base colour, normal,
// occlusion and metallic-roughness, emissive), the pixels of the distinct images of that kind
// the materials reference; the largest kind's.
double channel_pixels(const Scene& scene) {
  double most = 0;
  auto kind = [&](auto ref_of) {
    double total = 0;
    std::vector<char> seen(scene.images.size(), 0);
    for (const Material& mat : scene.materials)
      for (const TextureRef* t : ref_of(mat))
        if (t->present() && size_t(t->image) < seen.size() && !seen[size_t(t->image)]) {
          seen[size_t(t->image)] = 1;
          const Image& img = scene.images[size_t(t->image)];
          if (img.decoded()) total += double(img.width) * img.height;
        }
    most = std::max(most, total);
  };
  using Refs = std::vector<const TextureRef*>;
  kind([](const Material& m) { return Refs{&m.base_color}; });
  kind([](const Material& m) { return Refs{&m.normal}; });
  kind([](const Material& m) { return Refs{&m.occlusion, &m.metallic_roughness}; });
  kind([](const Material& m) { return Refs{&m.emissive}; });
  return most;
}

// T for a scene whose only texture is vertex colour: the colours live at the vertices, so the
// atlas gets a few texels per vertex (enough for bilinear filtering to reproduce the linear
// blend across each face), at least 128² and at most vertex_color_target².
double vertex_color_texels(const Scene& scene, const AtlasOptions& o) {
  double vertices = 0;
  for (const Mesh& m : scene.meshes)
    for (const Primitive& p : m.primitives) vertices += double(p.vertex_count());
  const double side = std::max(64, o.vertex_color_target);
  return std::clamp(kVertexColorTexelsPerVertex * vertices, 128.0 * 128.0, side * side);
}

// The charts' own texels stay within this × the distinct source texels of a channel (size_charts).
constexpr double kReuseBound = 1.1;

}  // namespace

double referenced_pixels(const Scene& scene) {
  double total = 0;
  std::vector<char> seen(scene.images.size(), 0);
  for (const Material& mat : scene.materials)
    if (mat.base_color.present() && size_t(mat.base_color.image) < seen.size() &&
        !seen[size_t(mat.base_color.image)]) {
      seen[size_t(mat.base_color.image)] = 1;
      const Image& img = scene.images[size_t(mat.base_color.image)];
      total += double(img.width) * img.height;
    }
  return total;
}

Items size_charts(const Scene& scene, const std::vector<MeshView>& views, const FlatCharts& fc,
                  const AtlasOptions& o) {
  const std::vector<Chart>& charts = fc.charts.charts;
  const std::vector<ChartUv>& uvs = fc.uvs;
  std::vector<double> inst_scale2(scene.meshes.size(), 0);
  std::vector<size_t> inst_count(scene.meshes.size(), 0);
  for (const Instance& inst : scene.instances) {
    inst_scale2[inst.mesh] += std::pow(std::abs(inst.world.det3()), 2.0 / 3.0);
    ++inst_count[inst.mesh];
  }
  for (size_t m = 0; m < scene.meshes.size(); ++m)
    inst_scale2[m] = inst_count[m] ? inst_scale2[m] / double(inst_count[m]) : 1.0;
  double sum_l2 = 0, sum_a = 0, sum_src = 0;
  std::vector<double> l2(charts.size()), a3(charts.size()), src(charts.size());
  for (size_t i = 0; i < charts.size(); ++i) {
    const Chart& c = charts[i];
    if (!c.textured) continue;
    l2[i] = uvs[i].stretch_l2 * uvs[i].stretch_l2;
    a3[i] = uvs[i].area_3d * inst_scale2[c.mesh];
    src[i] = source_texels(scene, views[c.mesh], c);
    sum_l2 += l2[i], sum_a += a3[i], sum_src += src[i];
  }
  double max_t = double(o.max_size) * o.max_size;
  // T: "the total original texture area referenced by all triangles" (Σ A'_c), at most the
  // largest atlas; formula 2 shares it among charts that sample no source texels of their own.
  Items it;
  double T = sum_src > 0 ? std::min(sum_src, max_t) : vertex_color_texels(scene, o);
  it.target_texels = T;
  double pixels = referenced_pixels(scene);
  it.reference_texels = sum_src > 0 && pixels > 0 ? pixels : T;
  // The bytes bound (the atlas's encoded bytes ≤ 1.1× those of the sources it
  // replaces). Σ A'_c counts the texels several charts reuse (mirrored halves, one decal on six
  // faces) once per use, and each use is a copy in the atlas that costs its bytes again, while
  // empty and dilated texels cost almost nothing: so the charts' own texels, not the atlas's,
  // stay within kReuseBound × the distinct source texels of a channel; charts keep their
  // native density wherever the sources are not reused that much.
  const double distinct = channel_pixels(scene);
  it.reuse_scale =
      sum_src > distinct * kReuseBound && distinct > 0 ? kReuseBound * distinct / sum_src : 1.0;
  it.any_textured = sum_a > 0;
  std::map<std::array<uint32_t, 10>, size_t> flat_slot;
  it.chart_item.resize(charts.size());
  for (size_t i = 0; i < charts.size(); ++i) {
    const Chart& c = charts[i];
    if (!c.textured) {
      std::array<uint32_t, 10> key{float_bits(c.color.x),    float_bits(c.color.y),
                                   float_bits(c.color.z),    float_bits(c.color.w),
                                   float_bits(c.orm.y),      float_bits(c.orm.z),
                                   float_bits(c.emissive.x), float_bits(c.emissive.y),
                                   float_bits(c.emissive.z), float_bits(c.orm.x)};
      auto [slot, fresh] = flat_slot.emplace(key, it.rects.size());
      if (fresh) {
        int side = o.flat_block + 2 * std::max(0, o.bake.gutter);  // block and dilation rings
        it.rects.push_back({side, side});
        it.item_scale.push_back(0);
        it.item_chart.push_back(i);
        it.item_native.push_back(0);
      }
      it.chart_item[i] = slot->second;
      continue;
    }
    double share =
        sum_src > 0
            ? std::cbrt((l2[i] / sum_l2) * (a3[i] / sum_a) * (src[i] > 0 ? src[i] / sum_src : 0.0))
            : std::sqrt((l2[i] / sum_l2) * (a3[i] / sum_a));
    if (!(share > 0))
      share = std::sqrt((l2[i] / sum_l2) * (a3[i] / sum_a));  // untextured piece, textured scene
    if (!std::isfinite(share) || !(share > 0)) share = 1e-6;  // degenerate input: a token size
    // A chart that samples source texels keeps their density (`density` of them; the packing
    // may grow it further); bytes, not texels, bound the atlas. Formula 2 sizes the rest.
    double texels = src[i] > 0 ? src[i] * std::max(o.density, 1e-6) * it.reuse_scale : share * T;
    double uv_area = std::max(1e-30, uvs[i].area_3d);
    double scale = std::sqrt(texels / uv_area);
    it.item_scale.push_back(std::isfinite(scale) && scale > 0 ? scale : 1.0);
    it.item_chart.push_back(i);
    it.item_native.push_back(src[i] > 0);
    it.chart_item[i] = it.rects.size();
    it.rects.push_back({});
  }
  it.flat_colors = flat_slot.size();
  return it;
}

namespace {

// The textured items' rectangles at factor f of their sizes: each side in texels (at least 1,
// at most max_size) plus `gutter` texels each side.
void size_textured_rects(Items& it, const std::vector<ChartUv>& uvs, const AtlasOptions& o,
                         int gutter, double f) {
  std::vector<PackRect>& rects = it.rects;
  for (size_t k = 0; k < rects.size(); ++k) {
    if (it.item_scale[k] == 0) continue;
    const ChartUv& u = uvs[it.item_chart[k]];
    double sc = it.item_scale[k] * f;
    auto texels = [&](double extent) {
      double t = std::ceil(extent * sc);
      return std::isfinite(t) ? int(std::clamp(t, 1.0, double(o.max_size))) : 1;
    };
    rects[k].w = texels(u.size.x) + 2 * gutter;
    rects[k].h = texels(u.size.y) + 2 * gutter;
  }
}

// Step 3, packing (Terrace et al. §4.4: "within a power of two of the target size"). The atlas is
// W × W or W × W/2 (powers of two: every mip level of either keeps aligned cells apart); one
// factor f scales every textured chart (keeping their proportions) and is searched as large as
// still packs. The size is the smallest that packs every chart at f = 1 (each textured chart
// at its source's density), up to max_size, where f < 1 may be all that fits; where charts are
// sized from source texels f stays ≤ 1 (texels past a source's density only cost bytes; the
// free space stays empty, which JPEG codes for almost nothing). Around each chart: the
// baker's dilation rings plus one texel for its conservative rasterization (texel centres
// within half a texel of a triangle). Then each chart not sized from source texels grows to
// fill the cell it owns (pack_cells).
Result<Packing> pack_charts(Items& it, const std::vector<ChartUv>& uvs, const AtlasOptions& o) {
  Packing pk;
  int gutter = pk.gutter = std::max(0, o.bake.gutter) + 1;
  std::vector<PackRect>& rects = it.rects;
  auto rects_for = [&](double f) { size_textured_rects(it, uvs, o, gutter, f); };
  // The sizes, by area: W × W/2 then W × W, W a power of two.
  struct Size {
    int w, h;
    double area() const { return double(w) * h; }
  };
  std::vector<Size> sizes;
  for (int w = 4; w <= std::max(4, o.max_size); w *= 2) {
    if (w / 2 >= 2) sizes.push_back({w, w / 2});
    sizes.push_back({w, w});
  }
  // A flat colour's block stays one colour down to the stream's smallest texture level (at
  // least 1/64 of the atlas width: levels stop at 128 px or less, every other mip level), so the
  // first picture shows plain parts in their colour, not in their neighbours' average.
  auto flat_block_for = [&](const Size& s) { return std::max(o.flat_block, s.w / 64); };
  auto set_flat = [&](const Size& s) {
    const int side = flat_block_for(s) + 2 * std::max(0, o.bake.gutter);
    for (size_t k = 0; k < rects.size(); ++k)
      if (it.item_scale[k] == 0) rects[k] = {side, side};
  };
  auto fits = [&](double f, const Size& s) {
    rects_for(f);
    set_flat(s);
    return pack_cells_into(rects, s.w, s.h).ok;
  };
  auto best_factor = [&](const Size& s) {
    double lo = 0, hi = 1;
    while (fits(hi, s) && hi < 1024) lo = hi, hi *= 2;
    for (int iter = 0; iter < 24; ++iter) {
      double mid = 0.5 * (lo + hi);
      if (fits(mid, s))
        lo = mid;
      else
        hi = mid;
    }
    return lo;
  };
  double shrink = 1;
  size_t pick = 0;
  const int min_side = std::max(o.min_size, 1);
  const bool native =
      std::find(it.item_native.begin(), it.item_native.end(), 1) != it.item_native.end();
  if (!it.any_textured) {
    // A palette of flat colours: the smallest size that holds the blocks.
    while (pick + 1 < sizes.size() && !fits(1, sizes[pick])) ++pick;
  } else {
    // The smallest size that holds every chart at its size (f ≥ 1: sources at their native
    // density), up to the largest; there the charts shrink to what fits.
    double need = 0;
    rects_for(1);
    for (const PackRect& r : rects) need += double(r.w) * r.h;
    while (pick + 1 < sizes.size() &&
           (sizes[pick].area() < need || sizes[pick].h < min_side || !fits(1, sizes[pick])))
      ++pick;
    shrink = best_factor(sizes[pick]);
    if (native) shrink = std::min(shrink, 1.0);
    // Many small charts (500 separate textured triangles) may not fit even at the smallest
    // scale, each needing a texel and its gutters: the atlas grows until they do.
    while (!(shrink > 0) && pick + 1 < sizes.size()) shrink = best_factor(sizes[++pick]);
  }
  if (!it.any_textured && !fits(1, sizes[pick])) shrink = 0;
  if (!(shrink > 0))
    return Status::error("atlas: " + std::to_string(rects.size()) + " charts do not fit in " +
                             std::to_string(sizes[pick].w) + "x" + std::to_string(sizes[pick].h) +
                             " even at one texel each",
                         ErrorKind::kInput);
  rects_for(shrink);
  set_flat(sizes[pick]);
  pk.flat_block = flat_block_for(sizes[pick]);
  pk.packed = pack_cells_into(rects, sizes[pick].w, sizes[pick].h);
  if (!pk.packed.ok) return Status::error("atlas: packing failed", ErrorKind::kInternal);
  pk.shrink = shrink;
  pk.grow.assign(rects.size(), 1.0);
  double used = 0;
  for (size_t k = 0; k < rects.size(); ++k) {
    if (it.item_scale[k] > 0) {
      double cw = pk.packed.cells[k].w - 2 * gutter, ch = pk.packed.cells[k].h - 2 * gutter;
      const ChartUv& u = uvs[it.item_chart[k]];
      double s = it.item_scale[k] * shrink;
      // The chart's exact texel extent is size * s; grow until one side fills its cell.
      double fx = u.size.x * s > 0 ? cw / std::max(u.size.x * s, 1e-9) : 1e30;
      double fy = u.size.y * s > 0 ? ch / std::max(u.size.y * s, 1e-9) : 1e30;
      double& g = pk.grow[k];
      g = it.item_native[k] ? 1.0 : std::max(1.0, std::min(fx, fy) * 0.999);
      if (!std::isfinite(g) || g > 1e6) g = 1.0;
      rects[k].w = std::min(pk.packed.cells[k].w, int(std::ceil(u.size.x * s * g)) + 2 * gutter);
      rects[k].h = std::min(pk.packed.cells[k].h, int(std::ceil(u.size.y * s * g)) + 2 * gutter);
    }
    used += double(rects[k].w) * rects[k].h;
  }
  pk.utilization = used / (double(pk.packed.size) * pk.packed.height);
  return pk;
}

// Step 4: where each chart lands in the atlas.
AtlasLayout make_layout(const Items& it, const Packing& pk, size_t charts, const AtlasOptions& o) {
  AtlasLayout layout;
  layout.size = pk.packed.size;
  layout.height = pk.packed.height;
  layout.offset.resize(charts);
  layout.scale.resize(charts);
  layout.block.resize(charts);
  for (size_t i = 0; i < charts; ++i) {
    size_t k = it.chart_item[i];
    const PackPlacement& pl = pk.packed.placed[k];
    if (it.item_scale[k] == 0) {
      int ring = std::max(0, o.bake.gutter);
      layout.offset[i] = {float(pl.x + ring), float(pl.y + ring)};
      layout.scale[i] = 0;
      layout.block[i] = pk.flat_block;
    } else {
      layout.offset[i] = {float(pl.x + pk.gutter), float(pl.y + pk.gutter)};
      layout.scale[i] = it.item_scale[k] * pk.shrink * pk.grow[k];
      layout.block[i] = std::max(it.rects[k].w, it.rects[k].h);
    }
  }
  return layout;
}

// The items of page `page` (item_page) with their charts, renumbered within the page.
Page page_of_items(const Items& it, const std::vector<int32_t>& item_page, int32_t page) {
  Page pg;
  for (uint32_t ci = 0; ci < it.chart_item.size(); ++ci)
    if (item_page[it.chart_item[ci]] == page) pg.charts.push_back(ci);
  std::vector<size_t> local_chart(it.chart_item.size(), 0), local_item(it.rects.size(), 0);
  for (size_t li = 0; li < pg.charts.size(); ++li) local_chart[pg.charts[li]] = li;
  Items& s = pg.items;
  s.reuse_scale = it.reuse_scale;
  s.target_texels = it.target_texels;
  s.reference_texels = it.reference_texels;
  for (size_t k = 0; k < it.rects.size(); ++k) {
    if (item_page[k] != page) continue;
    local_item[k] = s.rects.size();
    s.rects.push_back(it.rects[k]);
    s.item_scale.push_back(it.item_scale[k]);
    s.item_chart.push_back(local_chart[it.item_chart[k]]);
    s.item_native.push_back(it.item_native[k]);
    s.any_textured |= it.item_scale[k] > 0;
    s.flat_colors += it.item_scale[k] == 0;
  }
  for (uint32_t ci : pg.charts) s.chart_item.push_back(local_item[it.chart_item[ci]]);
  return pg;
}

}  // namespace

FlatCharts page_charts(const FlatCharts& fc, const Page& pg) {
  FlatCharts out;
  for (uint32_t ci : pg.charts) {
    out.charts.charts.push_back(fc.charts.charts[ci]);
    out.uvs.push_back(fc.uvs[ci]);
  }
  return out;
}

Result<std::vector<Page>> plan_pages(const FlatCharts& fc, Items& items, const AtlasOptions& o) {
  const std::vector<PackRect> sized = items.rects;  // before pack_charts sizes them
  auto packing = pack_charts(items, fc.uvs, o);
  if (!packing.ok()) return packing.status();
  std::vector<Page> pages;
  const bool native =
      std::find(items.item_native.begin(), items.item_native.end(), 1) != items.item_native.end();
  if (native && packing->shrink < 1) {
    Items native_items = items;
    native_items.rects = sized;
    size_textured_rects(native_items, fc.uvs, o, std::max(0, o.bake.gutter) + 1, 1);
    const int flat = std::max(o.flat_block, o.max_size / 64) + 2 * std::max(0, o.bake.gutter);
    for (size_t k = 0; k < native_items.rects.size(); ++k)
      if (native_items.item_scale[k] == 0) native_items.rects[k] = {flat, flat};
    PagedCells paged = pack_cells_pages(native_items.rects, o.max_size, o.max_size);
    for (size_t p = 0; p < paged.pages && paged.pages > 1; ++p) {
      Page pg = page_of_items(items, paged.page, int32_t(p));
      pg.items.rects.assign(pg.items.rects.size(), PackRect{});
      auto packed = pack_charts(pg.items, page_charts(fc, pg).uvs, o);
      if (!packed.ok()) return packed.status();
      pg.packing = packed.take();
      pg.layout = make_layout(pg.items, pg.packing, pg.charts.size(), o);
      pages.push_back(std::move(pg));
    }
  }
  if (pages.empty()) {
    Page pg;
    pg.charts.resize(fc.charts.charts.size());
    std::iota(pg.charts.begin(), pg.charts.end(), 0);
    pg.items = std::move(items);
    pg.packing = packing.take();
    pg.layout = make_layout(pg.items, pg.packing, pg.charts.size(), o);
    pages.push_back(std::move(pg));
  }
  return pages;
}

}  // namespace meshmux
