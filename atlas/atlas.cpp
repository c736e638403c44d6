// The atlas stage: Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion of
// 3D models for interactive metaverses" §4.2 (charts), §4.3 (parameterization and formula 2
// sizing), §4.4 (power-of-two-safe packing and baking). This file orchestrates and flattens the
// charts; the steps live in charts, parameterize, layout (sizing, packing, pages), bake and
// assemble (the output scene).
#include "atlas/atlas.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <map>
#include <numeric>
#include <unordered_map>

#include "atlas/assemble.h"
#include "atlas/atlas_types.h"
#include "atlas/kept.h"
#include "atlas/layout.h"
#include "atlas/palette.h"
#include "atlas/source_atlas.h"
#include "core/parallel.h"
#include "scene/dvec3.h"
#include "scene/position_key.h"

namespace meshmux {

namespace {

// Splits a chart's faces into edge-connected components (faces sharing two positions).
std::vector<std::vector<uint32_t>> components(const MeshView& mv,
                                              const std::vector<uint32_t>& faces) {
  std::unordered_map<uint64_t, std::vector<uint32_t>> by_edge;
  auto pos_key = [](Vec3 p) { return position_hash(p); };
  for (uint32_t i = 0; i < faces.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      uint64_t a = pos_key(mv.position(faces[i], k)),
               b = pos_key(mv.position(faces[i], (k + 1) % 3));
      by_edge[a < b ? a * 31 + b : b * 31 + a].push_back(i);
    }
  std::vector<uint32_t> parent(faces.size());
  std::iota(parent.begin(), parent.end(), 0);
  std::function<uint32_t(uint32_t)> find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (auto& [key, list] : by_edge)
    for (size_t j = 1; j < list.size(); ++j) parent[find(list[j])] = find(list[0]);
  std::map<uint32_t, std::vector<uint32_t>> groups;
  for (uint32_t i = 0; i < faces.size(); ++i) groups[find(i)].push_back(faces[i]);
  std::vector<std::vector<uint32_t>> out;
  for (auto& [root, g] : groups) out.push_back(std::move(g));
  return out;
}

// Halves a face set along the longest axis of its centroids' bounding box (median split).
std::pair<std::vector<uint32_t>, std::vector<uint32_t>> bisect(const MeshView& mv,
                                                               std::vector<uint32_t> faces) {
  Bounds b;
  std::vector<Vec3> c(faces.size());
  for (size_t i = 0; i < faces.size(); ++i) {
    c[i] = (mv.position(faces[i], 0) + mv.position(faces[i], 1) + mv.position(faces[i], 2)) *
           (1.0f / 3);
    b.add(c[i]);
  }
  Vec3 e = b.max - b.min;
  int axis = e.x >= e.y && e.x >= e.z ? 0 : e.y >= e.z ? 1 : 2;
  std::vector<uint32_t> order(faces.size());
  std::iota(order.begin(), order.end(), 0);
  auto coord = [&](uint32_t i) { return axis == 0 ? c[i].x : axis == 1 ? c[i].y : c[i].z; };
  std::stable_sort(order.begin(), order.end(),
                   [&](uint32_t a, uint32_t b2) { return coord(a) < coord(b2); });
  std::vector<uint32_t> lo, hi;
  for (size_t i = 0; i < order.size(); ++i)
    (i < order.size() / 2 ? lo : hi).push_back(faces[order[i]]);
  std::sort(lo.begin(), lo.end());
  std::sort(hi.begin(), hi.end());
  return {lo, hi};
}

// Parameterizes a textured chart, splitting it (components, then halves) until every piece
// flattens without flips or overlap.
void flatten_chart(const Scene& scene, const MeshView& mv, const Chart& chart,
                   const AtlasOptions& o, std::vector<Chart>& out_charts,
                   std::vector<ChartUv>& out_uvs, size_t* split) {
  std::vector<std::vector<uint32_t>> work;
  auto comps = components(mv, chart.faces);
  if (comps.size() > 1) ++*split;
  for (auto& c : comps) work.push_back(std::move(c));
  while (!work.empty()) {
    std::vector<uint32_t> faces = std::move(work.back());
    work.pop_back();
    Chart piece = chart;
    piece.faces = faces;
    ChartUv uv = parameterize_chart(scene, piece, o.parameterize);
    if (uv.valid || faces.size() == 1) {
      out_charts.push_back(std::move(piece));
      out_uvs.push_back(std::move(uv));
      continue;
    }
    ++*split;
    auto [lo, hi] = bisect(mv, faces);
    for (auto* half : {&hi, &lo})
      for (auto& c : components(mv, *half)) work.push_back(std::move(c));
  }
}

bool needs_atlas(const Scene& scene) {
  if (scene.materials.size() > 1) return true;
  for (const Material& m : scene.materials)
    if (m.base_color.present()) return true;
  for (const Mesh& mesh : scene.meshes)
    for (const Primitive& p : mesh.primitives)
      if (!p.colors.empty() || p.material != (scene.materials.empty() ? -1 : 0)) return true;
  return false;
}

void name_channels(ChannelImages& c) {
  c.normal.name = "atlas normal";
  c.orm.name = "atlas occlusion-roughness-metallic";
  c.emissive.name = "atlas emissive";
  c.sheen.name = "atlas sheen";
}

// Which channels besides base colour the output needs as textures: a channel some
// material in use samples a texture for, or whose factors differ between the materials in use
// (a metal part and a plastic one). Otherwise the factor they share is the output's.
double primitive_area(const Primitive& p) {
  double area = 0;
  for (size_t i = 0; i + 2 < p.indices.size(); i += 3) {
    if (p.indices[i] >= p.positions.size() || p.indices[i + 1] >= p.positions.size() ||
        p.indices[i + 2] >= p.positions.size())
      continue;
    const Vec3 a = p.positions[p.indices[i]], b = p.positions[p.indices[i + 1]],
               c = p.positions[p.indices[i + 2]];
    area += 0.5 * double(length(cross(b - a, c - a)));
  }
  return area;
}

ChannelNeeds channel_needs(const Scene& scene) {
  ChannelNeeds need;
  bool first = true;
  double sheen_roughness = 0, sheen_area = 0;
  auto decoded = [&](const TextureRef& t) {
    return t.present() && size_t(t.image) < scene.images.size() &&
           scene.images[size_t(t.image)].decoded();
  };
  for (const Mesh& mesh : scene.meshes)
    for (const Primitive& p : mesh.primitives) {
      if (p.indices.empty()) continue;
      Material def;  // the glTF default material
      const Material& m = p.material >= 0 && size_t(p.material) < scene.materials.size()
                              ? scene.materials[size_t(p.material)]
                              : def;
      const Vec3 orm{1, m.roughness_factor, m.metallic_factor};
      need.bake.normal |= decoded(m.normal);
      need.bake.orm |= decoded(m.metallic_roughness) || decoded(m.occlusion);
      need.bake.emissive |= decoded(m.emissive) && !(m.emissive_factor == Vec3{0, 0, 0});
      need.bake.sheen |= decoded(m.sheen_color) && !(m.sheen_color_factor == Vec3{0, 0, 0});
      if (first) {
        need.orm = orm;
        need.emissive = m.emissive_factor;
        need.sheen = m.sheen_color_factor;
        first = false;
      }
      need.bake.orm |= !(orm == need.orm);
      need.bake.emissive |= !(m.emissive_factor == need.emissive);
      need.bake.sheen |= !(m.sheen_color_factor == need.sheen);
      if (!(m.sheen_color_factor == Vec3{0, 0, 0})) {
        const double area = primitive_area(p);
        sheen_roughness += area * m.sheen_roughness_factor;
        sheen_area += area;
      }
      for (float v : {m.emissive_factor.x, m.emissive_factor.y, m.emissive_factor.z})
        if (std::isfinite(v)) need.bake.emissive_scale = std::max(need.bake.emissive_scale, v);
    }
  need.sheen_roughness = sheen_area > 0 ? float(sheen_roughness / sheen_area) : 0.0f;
  if (!(need.bake.emissive_scale > 0)) need.bake.emissive = false;
  if (!need.bake.emissive) need.bake.emissive_scale = 1;
  return need;
}

// Step 1: textured charts flattened (split where they will not flatten); flat charts pass.
FlatCharts flatten_charts(const Scene& scene, const std::vector<MeshView>& views,
                          const ChartSet& seg, const AtlasOptions& o, size_t* split) {
  FlatCharts fc;
  fc.charts.face_chart.resize(scene.meshes.size());
  for (size_t m = 0; m < scene.meshes.size(); ++m)
    fc.charts.face_chart[m].assign(views[m].faces.size(), 0);
  // Charts flatten independently, on every core (core/parallel.h); each chart's pieces are
  // kept apart and joined in chart order, so the result is the same whatever the threads.
  struct Pieces {
    std::vector<Chart> charts;
    std::vector<ChartUv> uvs;
    size_t split = 0;
  };
  std::vector<Pieces> per_chart(seg.charts.size());
  parallel_chunks(seg.charts.size(), 1, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const Chart& c = seg.charts[i];
      Pieces& out = per_chart[i];
      if (!c.textured) {  // a palette block: every corner at its centre, no parameterization
        out.charts.push_back(c);
        out.uvs.emplace_back();
        continue;
      }
      flatten_chart(scene, views[c.mesh], c, o, out.charts, out.uvs, &out.split);
    }
  });
  for (Pieces& p : per_chart) {
    for (size_t k = 0; k < p.charts.size(); ++k) {
      fc.charts.charts.push_back(std::move(p.charts[k]));
      fc.uvs.push_back(std::move(p.uvs[k]));
    }
    *split += p.split;
  }
  for (uint32_t ci = 0; ci < fc.charts.charts.size(); ++ci)
    for (uint32_t f : fc.charts.charts[ci].faces)
      fc.charts.face_chart[fc.charts.charts[ci].mesh][f] = ci;
  return fc;
}

// Step 4 on every page: its charts baked into their cells (the same channels on each page).
std::vector<PageImages> bake_pages(const Scene& scene, const FlatCharts& fc,
                                   std::vector<Page>& pages, const AtlasOptions& o,
                                   const ChannelNeeds& need) {
  std::vector<PageImages> out;
  for (Page& pg : pages) {
    BakeResult baked;
    if (pages.size() == 1) {
      baked = bake_atlas(scene, fc.charts, fc.uvs, pg.layout, o.bake, need.bake);
    } else {
      const FlatCharts sub = page_charts(fc, pg);
      baked = bake_atlas(scene, sub.charts, sub.uvs, pg.layout, o.bake, need.bake);
    }
    pg.texel_chart = std::move(baked.texel_chart);
    PageImages images;
    images.atlas = std::move(baked.atlas);
    images.channels = {std::move(baked.normal), std::move(baked.orm), std::move(baked.emissive),
                       std::move(baked.sheen)};
    name_channels(images.channels);
    out.push_back(std::move(images));
  }
  return out;
}

// Stretch figures over textured charts (area-weighted mean and maximum).
void stretch_figures(const FlatCharts& fc, AtlasReport* rep) {
  double wsum = 0;
  for (size_t i = 0; i < fc.charts.charts.size(); ++i) {
    if (!fc.charts.charts[i].textured) continue;
    rep->mean_stretch_l2 += fc.uvs[i].stretch_l2 * fc.uvs[i].area_3d;
    wsum += fc.uvs[i].area_3d;
    rep->max_stretch_l2 = std::max(rep->max_stretch_l2, fc.uvs[i].stretch_l2);
  }
  if (wsum > 0) rep->mean_stretch_l2 /= wsum;
}

// How far the tangent frame glTF viewers generate when a mesh has no TANGENT (MikkTSpace: along
// dp/du per face, averaged) strays from the frame the normal maps are baked in (three.js's
// derivative frame: along ∇u): the area-weighted mean angle between dp/du and ∇u over the
// textured charts' faces, degrees. 0 for a conformal parameterization; the charts are flattened
// with low stretch, so this stays small and TANGENT is not written.
double tangent_deviation(const std::vector<MeshView>& views, const FlatCharts& fc) {
  double sum = 0, wsum = 0;
  for (size_t i = 0; i < fc.charts.charts.size(); ++i) {
    const Chart& c = fc.charts.charts[i];
    if (!c.textured || c.mesh >= views.size()) continue;
    const std::vector<Vec2>& uv = fc.uvs[i].corner_uv;
    for (size_t k = 0; k < c.faces.size() && 3 * k + 2 < uv.size(); ++k) {
      DVec3 p[3];
      for (int j = 0; j < 3; ++j) p[j] = to_dvec3(views[c.mesh].position(c.faces[k], j));
      const DVec3 e1 = sub(p[1], p[0]), e2 = sub(p[2], p[0]);
      const double u1 = uv[3 * k + 1].x - uv[3 * k].x, v1 = uv[3 * k + 1].y - uv[3 * k].y;
      const double u2 = uv[3 * k + 2].x - uv[3 * k].x, v2 = uv[3 * k + 2].y - uv[3 * k].y;
      const double det = u1 * v2 - u2 * v1;
      const double area = 0.5 * length(cross(e1, e2));
      const double a = dot(e1, e1), b = dot(e1, e2), d = dot(e2, e2), g = a * d - b * b;
      if (!(std::fabs(det) > 1e-20) || !(g > 1e-30) || !(area > 0)) continue;
      const DVec3 dpdu = mul(sub(mul(e1, v2), mul(e2, v1)), 1 / det);
      const double alpha = (d * u1 - b * u2) / g, beta = (a * u2 - b * u1) / g;
      const DVec3 grad = add(mul(e1, alpha), mul(e2, beta));
      const double l = length(dpdu) * length(grad);
      if (!(l > 0) || !std::isfinite(l)) continue;
      sum += area * std::acos(std::clamp(dot(dpdu, grad) / l, -1.0, 1.0));
      wsum += area;
    }
  }
  return wsum > 0 ? sum / wsum * 180 / 3.14159265358979323846 : 0;
}

// Steps 2–4 of build_atlas_core, from the flattened charts.
Result<Scene> build_from_charts(const Scene& scene, const std::vector<MeshView>& views,
                                const ChannelNeeds& need, const FlatCharts& fc,
                                const AtlasOptions& o, AtlasReport rep,
                                std::chrono::steady_clock::time_point start, AtlasReport* report) {
  rep.split = fc.split;
  // 2. Sizes by formula 2.
  Items items = size_charts(scene, views, fc, o);
  rep.target_texels = items.target_texels;
  rep.flat_colors = items.flat_colors;
  rep.charts = size_t(std::count_if(fc.charts.charts.begin(), fc.charts.charts.end(),
                                    [](const Chart& c) { return c.textured; }));
  // 3. Power-of-two-safe packing (§4.4), on as many pages as native density needs.
  auto planned = plan_pages(fc, items, o);
  if (!planned.ok()) return planned.status();
  std::vector<Page>& pages = *planned;
  rep.size = pages[0].packing.packed.size;
  rep.height = pages[0].packing.packed.height;
  rep.reference_texels = items.reference_texels;
  rep.utilization = pages[0].packing.utilization;
  rep.reuse_scale = items.reuse_scale;
  rep.min_density = 0;
  for (const Page& pg : pages)
    for (size_t k = 0; k < pg.items.rects.size(); ++k)
      if (pg.items.item_native[k]) {
        const double d = o.density * pg.items.reuse_scale *
                         std::pow(pg.packing.shrink * pg.packing.grow[k], 2.0);
        rep.min_density = rep.min_density > 0 ? std::min(rep.min_density, d) : d;
      }
  // 4. Bake every chart into its cell, page by page.
  const size_t chart_count = fc.charts.charts.size();
  std::vector<int32_t> chart_page(chart_count, 0);
  std::vector<uint32_t> local(chart_count, 0);
  rep.cell_pos.resize(chart_count);
  rep.cell_size.resize(chart_count);
  for (size_t pg = 0; pg < pages.size(); ++pg)
    for (uint32_t li = 0; li < pages[pg].charts.size(); ++li) {
      const uint32_t ci = pages[pg].charts[li];
      chart_page[ci] = int32_t(pg);
      local[ci] = li;
      const size_t k = pages[pg].items.chart_item[li];
      rep.cell_pos[ci] = pages[pg].packing.packed.placed[k];
      rep.cell_size[ci] = pages[pg].packing.packed.cells[k];
    }
  std::vector<PageImages> images = bake_pages(scene, fc, pages, o, need);
  for (const Page& pg : pages)
    rep.pages.push_back({pg.packing.packed.size, pg.packing.packed.height, pg.charts.size(),
                         pg.packing.utilization});
  rep.chart_page = chart_page;
  for (int32_t& c : pages[0].texel_chart)
    if (c >= 0) c = int32_t(pages[0].charts[size_t(c)]);
  rep.texel_chart = std::move(pages[0].texel_chart);
  stretch_figures(fc, &rep);
  rep.tangent_deviation_deg = tangent_deviation(views, fc);
  std::vector<std::vector<uint32_t>> face_slot(scene.meshes.size());
  std::vector<std::vector<int32_t>> face_page;
  for (size_t m = 0; m < scene.meshes.size(); ++m) face_slot[m].resize(views[m].faces.size());
  for (const Chart& c : fc.charts.charts)
    for (uint32_t k = 0; k < c.faces.size(); ++k) face_slot[c.mesh][c.faces[k]] = k;
  if (pages.size() > 1)
    for (size_t m = 0; m < scene.meshes.size(); ++m) {
      face_page.emplace_back(views[m].faces.size());
      for (uint32_t f = 0; f < views[m].faces.size(); ++f)
        face_page[m][f] = chart_page[fc.charts.face_chart[m][f]];
    }
  std::vector<std::function<Vec2(uint32_t, int)>> corner_uv;
  for (uint32_t m = 0; m < scene.meshes.size(); ++m)
    corner_uv.push_back([&, m](uint32_t f, int k) {
      const AtlasLayout& layout = pages[size_t(chart_page[fc.charts.face_chart[m][f]])].layout;
      return chart_corner_uv(fc, layout, local, face_slot, m, f, k);
    });
  Scene out = assemble(scene, views, corner_uv, std::move(images), face_page, need, {},
                       &rep.page_materials);
  rep.page_images = out.images.size() / pages.size();
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (report) *report = rep;
  return out;
}

// Warns of each material channel whose texture is not decoded (its factors stand in for it).
void warn_undecoded(const Scene& scene, Warnings* warnings) {
  for (const Material& m : scene.materials)
    for (auto [ref, what] : {std::pair{&m.normal, "normal"}, std::pair{&m.occlusion, "occlusion"},
                             std::pair{&m.metallic_roughness, "metallic-roughness"},
                             std::pair{&m.emissive, "emissive"}})
      if (ref->present() && (size_t(ref->image) >= scene.images.size() ||
                             !scene.images[size_t(ref->image)].decoded()))
        warn(warnings, "atlas: material '" + m.name + "': its " + what +
                           " texture is not decoded; its factors stand in for it");
}

// Step 0: the source's one texture already is an atlas (atlas/source_atlas.h): keep it and its
// uvs (no charts, no resampling); the further channels are images of its layout
// (source_atlas_channel).
Scene build_from_source_atlas(const Scene& scene, const std::vector<MeshView>& views,
                              const ChannelNeeds& need, const SourceAtlas& source, AtlasReport rep,
                              std::chrono::steady_clock::time_point start, AtlasReport* report) {
  rep.reused_source = true;
  Image atlas = source_atlas_image(scene, source);
  rep.size = atlas.width;
  rep.height = atlas.height;
  rep.reference_texels = referenced_pixels(scene);
  rep.utilization = 1;
  const uint32_t set = source.tex_coord;
  std::vector<std::function<Vec2(uint32_t, int)>> corner_uv;
  // Per primitive: its plain colour's block, or -1 (textured).
  std::vector<std::vector<int>> flat(views.size());
  for (size_t m = 0; m < views.size(); ++m)
    for (const Primitive& p : views[m].mesh.primitives)
      flat[m].push_back(flat_color_index(scene, source, p.material));
  rep.flat_colors = source.flat_colors.size();
  for (size_t m = 0; m < views.size(); ++m)
    corner_uv.push_back([&mv = views[m], &fl = flat[m], &src = source, set](uint32_t f, int k) {
      const uint32_t prim = mv.faces[f].primitive;
      if (fl[prim] >= 0) return src.flat_uv[size_t(fl[prim])];
      const std::vector<Vec2>& uv = mv.mesh.primitives[prim].uvs[set];
      const Vec2 cell = face_uv_cell(uv[mv.corner(f, 0)], uv[mv.corner(f, 1)], uv[mv.corner(f, 2)]);
      const Vec2 t = uv[mv.corner(f, k)];
      // The image's part of the atlas (the top rows when a half was appended below).
      return Vec2{(t.x - cell.x) * float(src.part_width) / float(src.width),
                  (t.y - cell.y) * float(src.part_height) / float(src.height)};
    });
  ChannelImages channels;
  const float es = need.bake.emissive_scale;
  if (need.bake.normal)
    channels.normal = source_atlas_channel(scene, source, AtlasChannel::kNormal, es);
  if (need.bake.orm)
    channels.orm =
        source_atlas_channel(scene, source, AtlasChannel::kOcclusionRoughnessMetallic, es);
  if (need.bake.emissive)
    channels.emissive = source_atlas_channel(scene, source, AtlasChannel::kEmissive, es);
  if (need.bake.sheen)
    channels.sheen = source_atlas_channel(scene, source, AtlasChannel::kSheen, es);
  name_channels(channels);
  // The source's texels as they are (its sides already powers of two): its sampler's
  // filtering within a mip level shows them as the original does; its wraps show across
  // the image's edges what the original shows there.
  const Image& src_image = scene.images[size_t(source.image)];
  AtlasSampling sampling;
  sampling.source_texels =
      src_image.width == source.part_width && src_image.height == source.part_height;
  sampling.wrap_s = source.wrap_s;
  sampling.wrap_t = source.wrap_t;
  std::vector<PageImages> pages(1);
  pages[0].atlas = std::move(atlas);
  pages[0].channels = std::move(channels);
  Scene out =
      assemble(scene, views, corner_uv, std::move(pages), {}, need, sampling, &rep.page_materials);
  rep.pages.push_back({rep.size, rep.height, 0, 1.0});
  rep.page_images = out.images.size();
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (report) *report = std::move(rep);
  return out;
}

// The atlas of a scene with no tiled material (see build_atlas).
Result<Scene> build_atlas_core(const Scene& input, const AtlasOptions& o, AtlasReport* report,
                               Warnings* warnings, AtlasMemo* memo) {
  auto start = std::chrono::steady_clock::now();
  AtlasReport rep;
  // Palette textures become plain colours (atlas/palette.h) where that leaves the scene one
  // real texture the atlas may keep as it is (atlas/source_atlas.h); elsewhere the charts bake
  // them as before.
  // The source atlas is looked for once, on the scene the atlas is made of.
  std::optional<Scene> plain;
  std::optional<SourceAtlas> reused;
  if (o.reuse_source_texture) {
    reused = find_source_atlas(input, o.max_size);
    if (!reused) plain = palette_as_plain_colors(input, &rep.palette_materials);
    if (plain) reused = find_source_atlas(*plain, o.max_size);
    if (plain && !reused) {
      plain.reset();
      rep.palette_materials = 0;
    }
  }
  const Scene& scene = plain ? *plain : input;
  if (!needs_atlas(scene)) {
    if (report) *report = rep;
    return scene;
  }
  rep.built = true;
  const ChannelNeeds need = channel_needs(scene);
  warn_undecoded(scene, warnings);
  std::vector<MeshView> views;
  for (const Mesh& m : scene.meshes) views.emplace_back(m);
  // 0. The source's one texture already is an atlas: keep it and its uvs (no resampling).
  if (reused)
    return build_from_source_atlas(scene, views, need, *reused, std::move(rep), start, report);
  // 1. Charts (Terrace et al. §4.2), flattened (§4.3).
  std::optional<FlatCharts> made;
  if (!memo || !memo->charts) {
    size_t split = 0;
    made = flatten_charts(scene, views, segment_charts(scene, o.charts), o, &split);
    made->split = split;
  }
  if (memo && made) memo->charts = std::move(made);
  return build_from_charts(scene, views, need, memo ? *memo->charts : *made, o, std::move(rep),
                           start, report);
}

}  // namespace

Result<Scene> build_atlas(const Scene& scene, const AtlasOptions& o, AtlasReport* report,
                          Warnings* warnings, AtlasMemo* memo) {
  std::vector<KeptReason> kept = find_kept_materials(scene, o.tiled_periods);
  if (!o.keep_unbakeable)
    for (KeptReason& k : kept)
      if (k != KeptReason::kTiled) k = KeptReason::kNone;
  // The source images the atlas replaces: those of the baked materials in use.
  std::vector<char> used(scene.materials.size(), 0);
  for (const Mesh& m : scene.meshes)
    for (const Primitive& p : m.primitives)
      if (p.material >= 0 && size_t(p.material) < used.size() && !p.indices.empty())
        used[size_t(p.material)] = 1;
  std::vector<char> baked(scene.images.size(), 0);
  for (size_t i = 0; i < scene.materials.size(); ++i)
    if (used[i] && kept[i] == KeptReason::kNone)
      for (const TextureRef* t : texture_refs(scene.materials[i]))
        if (t->present() && size_t(t->image) < baked.size()) baked[size_t(t->image)] = 1;
  auto baked_images = [&](AtlasReport& r, size_t atlas_images) {
    for (size_t i = 0; i < baked.size(); ++i)
      if (baked[i]) r.baked_images.push_back(int32_t(i));
    r.atlas_images = r.reused_source || !r.built ? 0 : atlas_images;
  };
  if (std::all_of(kept.begin(), kept.end(), [](KeptReason k) { return k == KeptReason::kNone; })) {
    auto out = build_atlas_core(scene, o, report, warnings, memo);
    if (out.ok() && report) {
      baked_images(*report, out->images.size());
      report->streamed_material = out->materials.empty() ? -1 : 0;
    }
    return out;
  }
  // Kept materials stay as they came, beside the atlas of the rest (atlas/kept.h).
  KeptSplit split = split_kept(scene, kept);
  AtlasReport rep;
  Scene out;
  out.source = scene.source;
  out.normalization_scale = scene.normalization_scale;
  const bool rest =
      std::any_of(split.rest.meshes.begin(), split.rest.meshes.end(), [](const Mesh& m) {
        return std::any_of(m.primitives.begin(), m.primitives.end(),
                           [](const Primitive& p) { return !p.indices.empty(); });
      });
  if (rest) {
    auto atlased = build_atlas_core(split.rest, o, &rep, warnings, memo);
    if (!atlased.ok()) return atlased.status();
    out = atlased.take();
  }
  const size_t atlas_images = rest ? out.images.size() : 0;
  append_scene(out, std::move(split.kept));
  out.lines = scene.lines;
  if (rest) baked_images(rep, atlas_images);
  rep.built = true;
  rep.kept_materials = split.kept_materials;
  for (size_t i = 0; i < kept.size(); ++i)
    if (used[i]) {
      rep.tiled_materials += kept[i] == KeptReason::kTiled;
      rep.layer_materials += kept[i] == KeptReason::kLayers;
      rep.texel_grid_materials += kept[i] == KeptReason::kTexelGrid;
    }
  // The atlas's materials come first; without a rest, the first kept one (its texture streams
  // where its sides allow, pipeline/convert.cpp).
  rep.streamed_material = out.materials.empty() ? -1 : 0;
  if (report) *report = std::move(rep);
  return out;
}

}  // namespace meshmux
