// The atlas stage: paper 000 §4.2 (charts), §4.3 (parameterization and formula 2 sizing),
// §4.4 (power-of-two-safe packing and baking). This file orchestrates; the steps live in
// charts, parameterize, pack and bake.
#include "atlas/atlas.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <numeric>
#include <unordered_map>

#include "scene/position_key.h"

namespace meshmux {

namespace {

// Corner positions of a mesh face.
struct MeshView {
  const Mesh& mesh;
  std::vector<FaceRef> faces;
  explicit MeshView(const Mesh& m) : mesh(m), faces(mesh_faces(m)) {}
  uint32_t corner(uint32_t f, int k) const {
    const FaceRef& r = faces[f];
    return mesh.primitives[r.primitive].indices[3 * r.triangle + uint32_t(k)];
  }
  Vec3 position(uint32_t f, int k) const {
    return mesh.primitives[faces[f].primitive].positions[corner(f, k)];
  }
};

// Splits a chart's faces into edge-connected components (faces sharing two positions).
std::vector<std::vector<uint32_t>> components(const MeshView& mv,
                                              const std::vector<uint32_t>& faces) {
  std::unordered_map<uint64_t, std::vector<uint32_t>> by_edge;
  auto pos_key = [](Vec3 p) {
    return (uint64_t(float_bits(p.x)) * 0x9E3779B97F4A7C15ull) ^
           (uint64_t(float_bits(p.y)) * 0xC2B2AE3D27D4EB4Full) ^
           (uint64_t(float_bits(p.z)) * 0x165667B19E3779F9ull);
  };
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

// Σ over a chart's faces of their area in the source texture, in texels.
double source_texels(const Scene& scene, const MeshView& mv, const Chart& chart) {
  double sum = 0;
  for (uint32_t f : chart.faces) {
    const FaceRef& r = mv.faces[f];
    const Primitive& p = mv.mesh.primitives[r.primitive];
    if (p.material < 0) continue;
    const TextureRef& t = scene.materials[size_t(p.material)].base_color;
    if (!t.present() || t.tex_coord >= p.uvs.size()) continue;
    const Image& img = scene.images[size_t(t.image)];
    if (!img.decoded()) continue;
    Vec2 a = p.uvs[t.tex_coord][mv.corner(f, 0)], b = p.uvs[t.tex_coord][mv.corner(f, 1)],
         c = p.uvs[t.tex_coord][mv.corner(f, 2)];
    double area = 0.5 * std::abs(double(b.x - a.x) * (c.y - a.y) - double(c.x - a.x) * (b.y - a.y));
    area *= std::abs(double(t.transform.scale[0]) * t.transform.scale[1]);
    sum += area * img.width * img.height;
  }
  return sum;
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

}  // namespace

Result<Scene> build_atlas(const Scene& scene, const AtlasOptions& o, AtlasReport* report,
                          Warnings* warnings) {
  auto start = std::chrono::steady_clock::now();
  AtlasReport rep;
  if (!needs_atlas(scene)) {
    if (report) *report = rep;
    return scene;
  }
  rep.built = true;
  ChartSet seg = segment_charts(scene, o.charts);

  // Flatten textured charts (splitting the ones that will not flatten); flat charts pass.
  std::vector<MeshView> views;
  for (const Mesh& m : scene.meshes) views.emplace_back(m);
  ChartSet charts;
  std::vector<ChartUv> uvs;
  charts.face_chart.resize(scene.meshes.size());
  for (size_t m = 0; m < scene.meshes.size(); ++m)
    charts.face_chart[m].assign(views[m].faces.size(), 0);
  for (const Chart& c : seg.charts) {
    if (!c.textured) {
      charts.charts.push_back(c);
      uvs.push_back(parameterize_chart(scene, c, o.parameterize));
      continue;
    }
    flatten_chart(scene, views[c.mesh], c, o, charts.charts, uvs, &rep.split);
  }
  for (uint32_t ci = 0; ci < charts.charts.size(); ++ci)
    for (uint32_t f : charts.charts[ci].faces) charts.face_chart[charts.charts[ci].mesh][f] = ci;

  // Formula 2 sizing: A''_c = cbrt((L²_c/ΣL²)(A_c/ΣA)(A'_c/ΣA')) · T. A_c is the chart's area
  // in the world (mean over the mesh's instances); A'_c its footprint in the source texture.
  std::vector<double> inst_scale2(scene.meshes.size(), 0);
  std::vector<size_t> inst_count(scene.meshes.size(), 0);
  for (const Instance& inst : scene.instances) {
    inst_scale2[inst.mesh] += std::pow(std::abs(inst.world.det3()), 2.0 / 3.0);
    ++inst_count[inst.mesh];
  }
  for (size_t m = 0; m < scene.meshes.size(); ++m)
    inst_scale2[m] = inst_count[m] ? inst_scale2[m] / double(inst_count[m]) : 1.0;
  double sum_l2 = 0, sum_a = 0, sum_src = 0;
  std::vector<double> l2(charts.charts.size()), a3(charts.charts.size()), src(charts.charts.size());
  for (size_t i = 0; i < charts.charts.size(); ++i) {
    const Chart& c = charts.charts[i];
    if (!c.textured) continue;
    l2[i] = uvs[i].stretch_l2 * uvs[i].stretch_l2;
    a3[i] = uvs[i].area_3d * inst_scale2[c.mesh];
    src[i] = source_texels(scene, views[c.mesh], c);
    sum_l2 += l2[i], sum_a += a3[i], sum_src += src[i];
  }
  double max_t = double(o.max_size) * o.max_size;
  // "The total original texture area referenced by all triangles": Σ A'_c counts texels that
  // several charts reuse (mirrored halves, repeated decals) once per use, so it is also capped
  // by the pixels of the images the materials reference.
  double referenced_pixels = 0;
  {
    std::vector<char> seen(scene.images.size(), 0);
    for (const Material& mat : scene.materials)
      if (mat.base_color.present() && size_t(mat.base_color.image) < seen.size() &&
          !seen[size_t(mat.base_color.image)]) {
        seen[size_t(mat.base_color.image)] = 1;
        const Image& img = scene.images[size_t(mat.base_color.image)];
        referenced_pixels += double(img.width) * img.height;
      }
  }
  double T = sum_src > 0
                 ? std::min({sum_src, referenced_pixels > 0 ? referenced_pixels : sum_src, max_t})
                 : double(o.vertex_color_target) * o.vertex_color_target;
  rep.target_texels = T;

  // Flat colours share one block per distinct colour.
  std::map<std::array<uint32_t, 4>, size_t> flat_slot;
  std::vector<size_t> chart_item(charts.charts.size());
  std::vector<PackRect> rects;
  std::vector<double> item_scale;
  std::vector<size_t> item_chart;  // the chart whose uv rect the item holds (flat: first)
  for (size_t i = 0; i < charts.charts.size(); ++i) {
    const Chart& c = charts.charts[i];
    if (!c.textured) {
      std::array<uint32_t, 4> key{float_bits(c.color.x), float_bits(c.color.y),
                                  float_bits(c.color.z), float_bits(c.color.w)};
      auto [it, fresh] = flat_slot.emplace(key, rects.size());
      if (fresh) {
        int side =
            o.flat_block + 2 * std::max(0, o.bake.gutter);  // the block and its dilation rings
        rects.push_back({side, side});
        item_scale.push_back(0);
        item_chart.push_back(i);
      }
      chart_item[i] = it->second;
      continue;
    }
    double share =
        sum_src > 0
            ? std::cbrt((l2[i] / sum_l2) * (a3[i] / sum_a) * (src[i] > 0 ? src[i] / sum_src : 0.0))
            : std::sqrt((l2[i] / sum_l2) * (a3[i] / sum_a));
    if (!(share > 0))
      share =
          std::sqrt((l2[i] / sum_l2) * (a3[i] / sum_a));  // an untextured piece in a textured scene
    if (!std::isfinite(share) || !(share > 0)) share = 1e-6;  // degenerate input: a token size
    double texels = share * T;
    double uv_area = std::max(1e-30, uvs[i].area_3d);
    double scale = std::sqrt(texels / uv_area);
    item_scale.push_back(std::isfinite(scale) && scale > 0 ? scale : 1.0);
    item_chart.push_back(i);
    chart_item[i] = rects.size();
    rects.push_back({});
  }
  rep.flat_colors = flat_slot.size();
  rep.charts = charts.charts.size() - std::count_if(charts.charts.begin(), charts.charts.end(),
                                                    [](const Chart& c) { return !c.textured; });
  // Pack (paper 000 §4.4: "within a power of two of the target size"). The atlas side S is the
  // smallest power of two with S² ≥ T; one factor f scales every textured chart (keeping
  // formula 2's proportions) and is searched as large as still packs into S. If that costs more
  // than a quarter of the linear resolution (f < 0.75), the next size up is used instead.
  // Around each chart: the baker's dilation rings plus one texel for its conservative
  // rasterization (texel centres within half a texel of a triangle).
  int gutter = std::max(0, o.bake.gutter) + 1;
  auto rects_for = [&](double f) {
    for (size_t k = 0; k < rects.size(); ++k) {
      if (item_scale[k] == 0) continue;
      const ChartUv& u = uvs[item_chart[k]];
      double sc = item_scale[k] * f;
      auto texels = [&](double extent) {
        double t = std::ceil(extent * sc);
        return std::isfinite(t) ? int(std::clamp(t, 1.0, double(o.max_size))) : 1;
      };
      rects[k].w = texels(u.size.x) + 2 * gutter;
      rects[k].h = texels(u.size.y) + 2 * gutter;
    }
  };
  auto fits = [&](double f, int side) {
    rects_for(f);
    return pack_cells(rects, side, side).ok;
  };
  auto best_factor = [&](int side) {
    double lo = 0, hi = 1;
    while (fits(hi, side) && hi < 1024) lo = hi, hi *= 2;
    for (int it = 0; it < 24; ++it) {
      double mid = 0.5 * (lo + hi);
      if (fits(mid, side))
        lo = mid;
      else
        hi = mid;
    }
    return lo;
  };
  bool any_textured = sum_a > 0;
  double shrink = 1;
  int side = std::max(o.min_size, 1);
  if (!any_textured) {
    // A palette of flat colours: the smallest power of two that holds the blocks.
    side = 4;
    while (!fits(1, side) && side < o.max_size) side *= 2;
  } else {
    while (double(side) * side < T && side < o.max_size) side *= 2;
    shrink = best_factor(side);
  }
  if (any_textured && shrink < 0.75 && side < o.max_size) {
    side *= 2;
    shrink = best_factor(side);
  }
  if (!(shrink > 0))
    return Status::error("atlas: charts do not fit in " + std::to_string(side) + "²",
                         ErrorKind::kInternal);
  rects_for(shrink);
  PackResult packed = pack_cells(rects, side, side);
  if (!packed.ok) return Status::error("atlas: packing failed", ErrorKind::kInternal);
  rep.size = packed.size;
  // Each chart owns its cell (pack_cells): scale it up to fill the cell, for free resolution.
  std::vector<double> grow(rects.size(), 1.0);
  double used = 0;
  for (size_t k = 0; k < rects.size(); ++k) {
    if (item_scale[k] > 0) {
      double iw = rects[k].w - 2 * gutter, ih = rects[k].h - 2 * gutter;
      double cw = packed.cells[k].w - 2 * gutter, ch = packed.cells[k].h - 2 * gutter;
      const ChartUv& u = uvs[item_chart[k]];
      double s = item_scale[k] * shrink;
      // The chart's exact texel extent is size * s ≤ (iw, ih); grow until one side fills.
      double fx = u.size.x * s > 0 ? cw / std::max(u.size.x * s, 1e-9) : 1e30;
      double fy = u.size.y * s > 0 ? ch / std::max(u.size.y * s, 1e-9) : 1e30;
      grow[k] = std::max(1.0, std::min(fx, fy) * 0.999);
      if (!std::isfinite(grow[k]) || grow[k] > 1e6) grow[k] = 1.0;
      rects[k].w = std::min(packed.cells[k].w, int(std::ceil(u.size.x * s * grow[k])) + 2 * gutter);
      rects[k].h = std::min(packed.cells[k].h, int(std::ceil(u.size.y * s * grow[k])) + 2 * gutter);
      (void)iw, (void)ih;
    }
    used += double(rects[k].w) * rects[k].h;
  }
  rep.utilization = used / (double(packed.size) * packed.size);

  AtlasLayout layout;
  layout.size = packed.size;
  layout.offset.resize(charts.charts.size());
  layout.scale.resize(charts.charts.size());
  layout.block.resize(charts.charts.size());
  for (size_t i = 0; i < charts.charts.size(); ++i) {
    size_t k = chart_item[i];
    const PackPlacement& pl = packed.placed[k];
    if (item_scale[k] == 0) {
      int ring = std::max(0, o.bake.gutter);
      layout.offset[i] = {float(pl.x + ring), float(pl.y + ring)};
      layout.scale[i] = 0;
      layout.block[i] = o.flat_block;
    } else {
      layout.offset[i] = {float(pl.x + gutter), float(pl.y + gutter)};
      layout.scale[i] = item_scale[k] * shrink * grow[k];
      layout.block[i] = std::max(rects[k].w, rects[k].h);
    }
  }
  BakeResult baked = bake_atlas(scene, charts, uvs, layout, o.bake);
  rep.texel_chart = std::move(baked.texel_chart);
  for (size_t i = 0; i < charts.charts.size(); ++i) {
    rep.cell_pos.push_back(packed.placed[chart_item[i]]);
    rep.cell_size.push_back(packed.cells[chart_item[i]]);
  }

  // Stretch figures over textured charts.
  double wsum = 0;
  for (size_t i = 0; i < charts.charts.size(); ++i) {
    if (!charts.charts[i].textured) continue;
    rep.mean_stretch_l2 += uvs[i].stretch_l2 * uvs[i].area_3d;
    wsum += uvs[i].area_3d;
    rep.max_stretch_l2 = std::max(rep.max_stretch_l2, uvs[i].stretch_l2);
  }
  if (wsum > 0) rep.mean_stretch_l2 /= wsum;

  // The output scene: one primitive per mesh into the atlas, one material, one image.
  Scene out;
  out.source = scene.source;
  out.normalization_scale = scene.normalization_scale;
  out.instances = scene.instances;
  Material mat;
  mat.name = "atlas";
  mat.base_color.image = 0;
  mat.base_color.sampler.wrap_s = mat.base_color.sampler.wrap_t = Wrap::kClampToEdge;
  mat.base_color.sampler.mag_filter = 9729;  // LINEAR
  mat.base_color.sampler.min_filter = 9987;  // LINEAR_MIPMAP_LINEAR
  mat.metallic_factor = 0;
  mat.roughness_factor = 0;
  double area_total = 0;
  bool any_blend = false, any_mask = false, any_double = false, all_unlit = true, dropped = false;
  float cutoff = 1.0f;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const MeshView& mv = views[m];
    Primitive prim;
    prim.material = 0;
    prim.uvs.resize(1);
    bool normals = std::all_of(mv.mesh.primitives.begin(), mv.mesh.primitives.end(),
                               [](const Primitive& p) { return !p.normals.empty(); });
    std::unordered_map<uint64_t, std::vector<uint32_t>> weld;
    // Corner index within the chart's face list.
    std::vector<uint32_t> face_slot(mv.faces.size());
    for (uint32_t ci = 0; ci < charts.charts.size(); ++ci)
      if (charts.charts[ci].mesh == m)
        for (uint32_t k = 0; k < charts.charts[ci].faces.size(); ++k)
          face_slot[charts.charts[ci].faces[k]] = k;
    for (uint32_t f = 0; f < mv.faces.size(); ++f) {
      uint32_t ci = charts.face_chart[m][f];
      const Primitive& src = mv.mesh.primitives[mv.faces[f].primitive];
      if (src.material >= 0) {
        const Material& sm = scene.materials[size_t(src.material)];
        Vec3 a = mv.position(f, 0), b = mv.position(f, 1), cc = mv.position(f, 2);
        double area = 0.5 * length(cross(b - a, cc - a));
        area_total += area;
        mat.metallic_factor += float(area * sm.metallic_factor);
        mat.roughness_factor += float(area * sm.roughness_factor);
        any_blend |= sm.alpha_mode == AlphaMode::kBlend;
        if (sm.alpha_mode == AlphaMode::kMask)
          any_mask = true, cutoff = std::min(cutoff, sm.alpha_cutoff);
        any_double |= sm.double_sided;
        all_unlit &= sm.unlit;
        dropped |= sm.normal.present() || sm.occlusion.present() ||
                   sm.metallic_roughness.present() || sm.emissive.present();
      } else {
        all_unlit = false;
        Vec3 a = mv.position(f, 0), b = mv.position(f, 1), cc = mv.position(f, 2);
        double area = 0.5 * length(cross(b - a, cc - a));
        area_total += area;
        mat.metallic_factor += float(area * 1.0);
        mat.roughness_factor += float(area * 1.0);
      }
      uint32_t tri[3];
      for (int k = 0; k < 3; ++k) {
        Vec2 t;
        if (layout.scale[ci] == 0) {
          t = {float((layout.offset[ci].x + layout.block[ci] * 0.5) / layout.size),
               float((layout.offset[ci].y + layout.block[ci] * 0.5) / layout.size)};
        } else {
          Vec2 cu = uvs[ci].corner_uv[3 * size_t(face_slot[f]) + size_t(k)];
          t = {float((layout.offset[ci].x + layout.scale[ci] * cu.x) / layout.size),
               float((layout.offset[ci].y + layout.scale[ci] * cu.y) / layout.size)};
        }
        uint32_t v = mv.corner(f, k);
        Vec3 pos = src.positions[v];
        Vec3 nrm = normals ? src.normals[v] : Vec3{};
        uint32_t key[8] = {float_bits(pos.x), float_bits(pos.y), float_bits(pos.z),
                           float_bits(nrm.x), float_bits(nrm.y), float_bits(nrm.z),
                           float_bits(t.x),   float_bits(t.y)};
        uint64_t h = 1469598103934665603ull;
        for (uint32_t w : key) h = (h ^ w) * 1099511628211ull;
        auto& bucket = weld[h];
        uint32_t found = UINT32_MAX;
        for (uint32_t cand : bucket)
          if (prim.positions[cand] == pos && (!normals || prim.normals[cand] == nrm) &&
              prim.uvs[0][cand] == t)
            found = cand;
        if (found == UINT32_MAX) {
          found = uint32_t(prim.positions.size());
          prim.positions.push_back(pos);
          if (normals) prim.normals.push_back(nrm);
          prim.uvs[0].push_back(t);
          bucket.push_back(found);
        }
        tri[k] = found;
      }
      prim.indices.insert(prim.indices.end(), {tri[0], tri[1], tri[2]});
    }
    Mesh mesh;
    mesh.name = mv.mesh.name;
    mesh.primitives.push_back(std::move(prim));
    out.meshes.push_back(std::move(mesh));
  }
  if (area_total > 0) {
    mat.metallic_factor = float(mat.metallic_factor / area_total);
    mat.roughness_factor = float(mat.roughness_factor / area_total);
  } else {
    mat.metallic_factor = 0, mat.roughness_factor = 1;
  }
  mat.alpha_mode = any_blend ? AlphaMode::kBlend : any_mask ? AlphaMode::kMask : AlphaMode::kOpaque;
  mat.alpha_cutoff = any_mask ? cutoff : 0.5f;
  mat.double_sided = any_double;
  mat.unlit = all_unlit && !scene.materials.empty();
  if (dropped)
    warn(warnings,
         "atlas: normal, occlusion, metallic-roughness and emissive textures are not baked into "
         "the atlas; dropped");
  out.materials.push_back(mat);

  Image atlas = std::move(baked.atlas);
  atlas.name = "atlas";
  // Decoded pixels only: the texture levels (pipeline/convert) encode it once, JPEG when opaque,
  // PNG with alpha, and model.glb embeds their top level.
  out.images.push_back(std::move(atlas));
  rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (report) *report = rep;
  return out;
}

}  // namespace meshmux
