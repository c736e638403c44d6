// The atlas stage: Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion of
// 3D models for interactive metaverses" §4.2 (charts), §4.3 (parameterization and formula 2
// sizing), §4.4 (power-of-two-safe packing and baking). This file orchestrates; the steps live in
// charts, parameterize, pack and bake.
#include "atlas/atlas.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <numeric>
#include <tuple>
#include <unordered_map>

#include "atlas/kept.h"
#include "atlas/palette.h"
#include "atlas/source_atlas.h"
#include "core/parallel.h"
#include "scene/dvec3.h"
#include "scene/position_key.h"

namespace meshmux {

namespace {

constexpr double kVertexColorTexelsPerVertex = 256;  // 16 × 16 texels of atlas per vertex

// The output's further channels: which are baked, and the factors shared when not.
struct ChannelNeeds {
  BakeChannels bake;          // baked channels (emissive_scale: the largest emissive component)
  Vec3 orm{1, 1, 1};          // shared occlusion-roughness-metallic factors (when not baked)
  Vec3 emissive{0, 0, 0};     // shared emissive factor (when not baked)
  Vec3 sheen{0, 0, 0};        // shared sheen colour factor (when not baked)
  float sheen_roughness = 0;  // sheen roughness: area-weighted over the sheen materials
};

// The images a bake produced, in Scene::images order after the base colour (index 0).
struct ChannelImages {
  Image normal, orm, emissive, sheen;  // empty when not baked
};

// One atlas page's images: the base colour and the baked channels (every page the same ones).
struct PageImages {
  Image atlas;
  ChannelImages channels;
};

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

// The pixels of the images the materials' base colours reference, each image once.
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

// Step 2, formula 2 sizing: A''_c = cbrt((L²_c/ΣL²)(A_c/ΣA)(A'_c/ΣA')) · T. A_c is the chart's
// area in the world (mean over the mesh's instances); A'_c its footprint in the source texture.
// The pack items: one per textured chart, one block per distinct flat colour.
struct Items {
  std::vector<size_t> chart_item;  // per chart: its item
  std::vector<PackRect> rects;     // per item (textured ones sized by pack_charts)
  std::vector<double> item_scale;  // per item: texels per chart-uv unit (0: a flat block)
  std::vector<size_t> item_chart;  // the chart whose uv rect the item holds (flat: first)
  std::vector<char> item_native;   // per item: sized from its own source texels (density)
  double reuse_scale = 1;          // density × this: the bytes bound where sources are reused
  double target_texels = 0;        // T
  double reference_texels = 0;     // the base-colour texels the materials reference, T for
                                   // vertex colours (reported)
  bool any_textured = false;
  size_t flat_colors = 0;
};
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
struct Packing {
  PackResult packed;
  int flat_block = 4;        // side of each flat colour's block, texels
  double shrink = 1;         // the factor f
  std::vector<double> grow;  // per item: the fill-the-cell factor
  int gutter = 0;            // texels around each textured chart
  double utilization = 0;    // packed texels / atlas texels
};
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

// One atlas page (docs/ARCHITECTURE.md "Atlas pages"): its charts (the scene's chart indices,
// ascending), their pack items (chart_item and item_chart indexing the page's charts), their
// packing and layout (indexed by the page's charts), and, once baked, which chart each of its
// texels holds (the page's chart indices).
struct Page {
  std::vector<uint32_t> charts;
  Items items;
  Packing packing;
  AtlasLayout layout;
  std::vector<int32_t> texel_chart;
};

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

// The charts, as FlatCharts, of one page (its charts in page order; face_chart left empty).
FlatCharts page_charts(const FlatCharts& fc, const Page& pg) {
  FlatCharts out;
  for (uint32_t ci : pg.charts) {
    out.charts.charts.push_back(fc.charts.charts[ci]);
    out.uvs.push_back(fc.uvs[ci]);
  }
  return out;
}

// The pages (Atlas pages, DESIGN.md "Atlas"): one page as packed when every chart fits one
// max_size² atlas at its size (or no chart has a native density to keep). Otherwise, rather
// than shrinking every chart, the items at their sizes (factor 1, flat blocks as at max_size)
// go, largest first, each to the first max_size² page with room (pack_cells_pages); each page
// is then packed on its own as a one-page atlas is (its smallest size that holds it).
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

// Step 5a: one material per group of source materials that agree on how alpha and back faces
// show (alpha mode with its cutoff, double-sidedness, unlit): every group samples the one atlas,
// so a model costs one draw call per group present (usually one).
// Glass (a transmission factor above 0) is a group of its own, one per set of glass
// parameters: light passing through is how the surface shows, so it is never folded into
// alpha, where a fully transmissive surface would vanish.
struct GroupKey {
  int alpha_mode = 0;
  float cutoff = 0.5f;
  bool double_sided = false, unlit = false;
  bool flat = false;  // Primitive::flat: shown flat-shaded, exported without normals
  float transmission = 0, ior = 1.5f, thickness = 0, attenuation_distance = 0;
  Vec3 attenuation_color{1, 1, 1};
  // The reflection's layers (clearcoat, specular, iridescence) likewise: factors per group.
  float clearcoat = 0, clearcoat_roughness = 0, specular = 1;
  Vec3 specular_color{1, 1, 1};
  float iridescence = 0, iridescence_ior = 1.3f, iridescence_thickness = 400;
  auto tied() const {
    return std::tie(transmission, alpha_mode, cutoff, double_sided, unlit, flat, ior, thickness,
                    attenuation_distance, attenuation_color.x, attenuation_color.y,
                    attenuation_color.z, clearcoat, clearcoat_roughness, specular, specular_color.x,
                    specular_color.y, specular_color.z, iridescence, iridescence_ior,
                    iridescence_thickness);
  }
  bool operator<(const GroupKey& o) const { return tied() < o.tied(); }
  bool operator==(const GroupKey& o) const { return !(*this < o) && !(o < *this); }
};
GroupKey group_key(const Scene& scene, const Primitive& p) {
  GroupKey k;
  k.flat = p.flat;
  int32_t material = p.material;
  if (material < 0 || size_t(material) >= scene.materials.size()) return k;  // glTF default
  const Material& m = scene.materials[size_t(material)];
  k.alpha_mode = int(m.alpha_mode);
  k.cutoff = m.alpha_mode == AlphaMode::kMask ? m.alpha_cutoff : 0.5f;
  k.double_sided = m.double_sided;
  k.unlit = m.unlit;
  if (m.transmissive() && !m.unlit) {
    k.transmission = m.transmission_factor;
    k.ior = m.ior;
    k.thickness = m.thickness_factor;
    k.attenuation_distance = m.attenuation_distance;
    k.attenuation_color = m.attenuation_color;
  }
  if (!m.unlit) {
    if (m.clearcoat_factor > 0) {
      k.clearcoat = m.clearcoat_factor;
      k.clearcoat_roughness = m.clearcoat_roughness_factor;
    }
    k.specular = m.specular_factor;
    k.specular_color = m.specular_color_factor;
    if (m.iridescence_factor > 0) {
      k.iridescence = m.iridescence_factor;
      k.iridescence_ior = m.iridescence_ior;
      k.iridescence_thickness = m.iridescence_thickness;
    }
  }
  return k;
}

// Indices into the output's images of the further channels (-1: not baked).
struct ChannelSlots {
  int32_t normal = -1, orm = -1, emissive = -1, sheen = -1;
};

// The minification filter of the group's atlas when the atlas's texels are the source's own
// (atlas/source_atlas.h, not resampled): the mipmapped one (NEAREST/LINEAR_MIPMAP_NEAREST/
// LINEAR, 9984–9987) that every base-colour texture the group's faces sample agrees on, an
// unspecified one counting as LINEAR_MIPMAP_LINEAR (what viewers then use); otherwise, or with
// no texture, LINEAR_MIPMAP_LINEAR. Minified, NEAREST within a level shows one texel's colour
// and its aliasing where LINEAR blends four: CesiumMan's NEAREST_MIPMAP_LINEAR stripes lost
// 10 dB unlit to the original when its own image and uvs were sampled LINEAR_MIPMAP_LINEAR.
// Resampled texels (charts, or an image whose sides were rounded up to powers of two) alias
// elsewhere, where trilinear filtering comes closer (BoxTexturedNonPowerOfTwo: −2 dB with
// NEAREST_MIPMAP_LINEAR), so the caller asks only for kept texels. Samplers without mipmaps
// never reach the atlas (atlas/kept.h).
int group_min_filter(const Scene& scene, const std::vector<MeshView>& views,
                     const std::vector<std::vector<int32_t>>& prim_group, int32_t group) {
  constexpr int kLinearMipmapLinear = 9987;
  int agreed = 0;
  for (size_t m = 0; m < views.size(); ++m)
    for (size_t pi = 0; pi < views[m].mesh.primitives.size(); ++pi) {
      const Primitive& p = views[m].mesh.primitives[pi];
      if (prim_group[m][pi] != group || p.indices.empty() || p.material < 0 ||
          size_t(p.material) >= scene.materials.size())
        continue;
      const TextureRef& t = scene.materials[size_t(p.material)].base_color;
      if (!t.present()) continue;
      const int f = t.sampler.min_filter == 0 ? kLinearMipmapLinear : t.sampler.min_filter;
      if (f < 9984 || f > 9987 || (agreed != 0 && f != agreed)) return kLinearMipmapLinear;
      agreed = f;
    }
  return agreed != 0 ? agreed : kLinearMipmapLinear;
}

// How the atlas is sampled: charts are clamped (each chart's gutter holds its edge); the
// source's image kept as the atlas (atlas/source_atlas.h) wraps as its sampler does.
struct AtlasSampling {
  bool source_texels = false;  // the atlas is the source's image, not resampled
  Wrap wrap_s = Wrap::kClampToEdge, wrap_t = Wrap::kClampToEdge;
};

// The group's material: the atlas's base colour; the baked channels' images (factors folded in,
// so the output's factors are 1), or the factors the sources share (metallic and roughness
// area-weighted over the group's faces, equal when they agree). Every channel is sampled
// with `sampling`'s wraps, LINEAR magnified, minified LINEAR_MIPMAP_LINEAR or, when
// source_texels, as group_min_filter says.
// `prim_group[m][p]`: the group of mesh m's primitive p, computed once by build_atlas.
Material merged_material(const Scene& scene, const std::vector<MeshView>& views,
                         const std::vector<std::vector<int32_t>>& prim_group, int32_t group,
                         const GroupKey& key, const ChannelNeeds& need, const ChannelSlots& slots,
                         const AtlasSampling& sampling) {
  Material mat;
  mat.name = "atlas";
  mat.base_color.image = 0;
  mat.base_color.sampler.wrap_s = sampling.wrap_s;
  mat.base_color.sampler.wrap_t = sampling.wrap_t;
  mat.base_color.sampler.mag_filter = 9729;  // LINEAR
  mat.base_color.sampler.min_filter =
      sampling.source_texels ? group_min_filter(scene, views, prim_group, group) : 9987;
  mat.metallic_factor = 0;
  mat.roughness_factor = 0;
  double area_total = 0;
  for (size_t m = 0; m < views.size(); ++m)
    for (uint32_t f = 0; f < views[m].faces.size(); ++f) {
      const MeshView& mv = views[m];
      if (prim_group[m][mv.faces[f].primitive] != group) continue;
      const Primitive& src = mv.mesh.primitives[mv.faces[f].primitive];
      Vec3 a = mv.position(f, 0), b = mv.position(f, 1), cc = mv.position(f, 2);
      double area = 0.5 * length(cross(b - a, cc - a));
      area_total += area;
      if (src.material >= 0) {
        const Material& sm = scene.materials[size_t(src.material)];
        mat.metallic_factor += float(area * sm.metallic_factor);
        mat.roughness_factor += float(area * sm.roughness_factor);
      } else {
        mat.metallic_factor += float(area * 1.0);
        mat.roughness_factor += float(area * 1.0);
      }
    }
  if (area_total > 0) {  // a mean of equal values may round past them: kept within [0, 1]
    mat.metallic_factor = std::clamp(float(mat.metallic_factor / area_total), 0.0f, 1.0f);
    mat.roughness_factor = std::clamp(float(mat.roughness_factor / area_total), 0.0f, 1.0f);
  } else {
    mat.metallic_factor = need.orm.z, mat.roughness_factor = need.orm.y;
  }
  auto channel = [&](TextureRef& ref, int32_t image) {
    ref.image = image;
    ref.sampler = mat.base_color.sampler;
  };
  if (slots.orm >= 0) {
    channel(mat.metallic_roughness, slots.orm);
    channel(mat.occlusion, slots.orm);
    mat.metallic_factor = mat.roughness_factor = 1;
  }
  mat.emissive_factor = need.emissive;
  if (slots.emissive >= 0) {
    channel(mat.emissive, slots.emissive);
    const float e = need.bake.emissive_scale;
    mat.emissive_factor = {e, e, e};
  }
  if (slots.normal >= 0) channel(mat.normal, slots.normal);
  mat.sheen_color_factor = need.sheen;
  mat.sheen_roughness_factor = need.sheen_roughness;
  if (slots.sheen >= 0) {
    channel(mat.sheen_color, slots.sheen);
    mat.sheen_color_factor = {1, 1, 1};
  }
  mat.alpha_mode = AlphaMode(key.alpha_mode);
  mat.alpha_cutoff = key.cutoff;
  mat.double_sided = key.double_sided;
  mat.unlit = key.unlit;
  mat.transmission_factor = key.transmission;
  mat.ior = key.ior;
  mat.thickness_factor = key.thickness;
  mat.attenuation_distance = key.attenuation_distance;
  mat.attenuation_color = key.attenuation_color;
  mat.clearcoat_factor = key.clearcoat;
  mat.clearcoat_roughness_factor = key.clearcoat_roughness;
  mat.specular_factor = key.specular;
  mat.specular_color_factor = key.specular_color;
  mat.iridescence_factor = key.iridescence;
  mat.iridescence_ior = key.iridescence_ior;
  mat.iridescence_thickness = key.iridescence_thickness;
  return mat;
}

// The atlas uv of a chart corner: the chart's parameterization placed by its page's layout (flat
// charts: the centre of their block). `face_slot[m][f]`: face f's index in its chart's list;
// `local[ci]`: chart ci's index in its page's layout.
Vec2 chart_corner_uv(const FlatCharts& fc, const AtlasLayout& layout,
                     const std::vector<uint32_t>& local,
                     const std::vector<std::vector<uint32_t>>& face_slot, uint32_t m, uint32_t f,
                     int k) {
  const uint32_t ci = fc.charts.face_chart[m][f];
  const uint32_t li = local[ci];
  if (layout.scale[li] == 0)
    return {float((layout.offset[li].x + layout.block[li] * 0.5) / layout.size),
            float((layout.offset[li].y + layout.block[li] * 0.5) / layout.rows())};
  Vec2 cu = fc.uvs[ci].corner_uv[3 * size_t(face_slot[m][f]) + size_t(k)];
  return {float((layout.offset[li].x + layout.scale[li] * cu.x) / layout.size),
          float((layout.offset[li].y + layout.scale[li] * cu.y) / layout.rows())};
}

// Step 5b: the faces of mesh m whose output material is `material` (face_material, per face)
// as one primitive into the atlas: every corner gets its chart's atlas uv, corners welded where
// position, normal and uv agree exactly.
// `corner_uv(f, k)`: the atlas uv of face f's corner k.
Mesh atlas_mesh(const MeshView& mv, const std::function<Vec2(uint32_t, int)>& corner_uv,
                const std::vector<int32_t>& face_material, int32_t material, const GroupKey& key) {
  Primitive prim;
  prim.material = material;
  prim.flat = key.flat;
  prim.uvs.resize(1);
  bool normals = std::all_of(mv.mesh.primitives.begin(), mv.mesh.primitives.end(),
                             [](const Primitive& p) { return !p.normals.empty(); });
  std::unordered_map<uint64_t, std::vector<uint32_t>> weld;
  for (uint32_t f = 0; f < mv.faces.size(); ++f) {
    if (face_material[f] != material) continue;
    const Primitive& src = mv.mesh.primitives[mv.faces[f].primitive];
    uint32_t tri[3];
    for (int k = 0; k < 3; ++k) {
      const Vec2 t = corner_uv(f, k);
      uint32_t v = mv.corner(f, k);
      Vec3 pos = src.positions[v];
      Vec3 nrm = normals ? src.normals[v] : Vec3{};
      uint32_t key[8] = {float_bits(pos.x), float_bits(pos.y), float_bits(pos.z), float_bits(nrm.x),
                         float_bits(nrm.y), float_bits(nrm.z), float_bits(t.x),   float_bits(t.y)};
      auto& bucket = weld[fnv1a(key, 8)];
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
  return mesh;
}

// The page suffix of an image's or material's name: none on page 0, " page N" (1-based) after.
std::string page_suffix(size_t page) {
  return page == 0 ? std::string() : " page " + std::to_string(page + 1);
}

// The output's materials: one per (page, group) with faces, pages first (page 0's are the
// scene's first materials), each sampling its page's images (`per_page` images a page, in the
// same order); `*material_of[p][g]` its index or -1, `*page_material[p]` page p's first.
std::vector<Material> page_materials(const std::vector<Material>& group_materials,
                                     const std::vector<std::vector<char>>& present, size_t per_page,
                                     std::vector<std::vector<int32_t>>* material_of,
                                     std::vector<int32_t>* page_material) {
  std::vector<Material> out;
  material_of->assign(present.size(), std::vector<int32_t>(group_materials.size(), -1));
  page_material->assign(present.size(), -1);
  for (size_t p = 0; p < present.size(); ++p)
    for (size_t g = 0; g < group_materials.size(); ++g) {
      if (!present[p][g]) continue;
      Material mat = group_materials[g];
      for (TextureRef* t : texture_refs(mat))
        if (t->present()) t->image += int32_t(p * per_page);
      mat.name += page_suffix(p);
      (*material_of)[p][g] = int32_t(out.size());
      if ((*page_material)[p] < 0) (*page_material)[p] = int32_t(out.size());
      out.push_back(std::move(mat));
    }
  return out;
}

// 5. The output scene: one primitive per mesh into the atlas, one material per group and page
// (docs/ARCHITECTURE.md "Atlas pages"), each page's images (decoded pixels only: the texture
// levels encode them once, JPEG when opaque, PNG with alpha, and model.glb embeds their top
// level). `corner_uv[m]` gives mesh m's atlas uvs (on its face's page); `face_page[m][f]` the
// page of mesh m's face f (empty: every face on page 0); `sampling`: how the materials sample
// the atlas (merged_material). `*page_material[p]`: page p's first material.
Scene assemble(const Scene& scene, const std::vector<MeshView>& views,
               const std::vector<std::function<Vec2(uint32_t, int)>>& corner_uv,
               std::vector<PageImages> pages, const std::vector<std::vector<int32_t>>& face_page,
               const ChannelNeeds& need, const AtlasSampling& sampling,
               std::vector<int32_t>* page_material) {
  Scene out;
  out.source = scene.source;
  out.normalization_scale = scene.normalization_scale;
  out.lines = scene.lines;
  // The groups present (primitives with faces), in key order (opaque first), and each
  // primitive's group, computed once.
  std::vector<GroupKey> groups;
  for (const Mesh& mesh : scene.meshes)
    for (const Primitive& p : mesh.primitives) {
      GroupKey k = group_key(scene, p);
      if (!p.indices.empty() && std::find(groups.begin(), groups.end(), k) == groups.end())
        groups.push_back(k);
    }
  std::sort(groups.begin(), groups.end());
  std::vector<std::vector<int32_t>> prim_group(scene.meshes.size());
  for (size_t m = 0; m < scene.meshes.size(); ++m)
    for (const Primitive& p : scene.meshes[m].primitives)
      prim_group[m].push_back(
          int32_t(std::find(groups.begin(), groups.end(), group_key(scene, p)) - groups.begin()));
  auto page_of = [&](size_t m, uint32_t f) {
    return face_page.empty() ? 0 : size_t(face_page[m][f]);
  };
  // The images, page by page: the base colour first, then the baked channels.
  ChannelSlots slots;
  size_t per_page = 0;
  for (size_t pg = 0; pg < pages.size(); ++pg) {
    pages[pg].atlas.name = "atlas" + page_suffix(pg);
    out.images.push_back(std::move(pages[pg].atlas));
    ChannelImages& channels = pages[pg].channels;
    for (auto [image, slot] :
         {std::pair{&channels.normal, &slots.normal}, std::pair{&channels.orm, &slots.orm},
          std::pair{&channels.emissive, &slots.emissive}, std::pair{&channels.sheen, &slots.sheen}})
      if (image->decoded()) {
        if (pg == 0) *slot = int32_t(out.images.size());
        image->name += page_suffix(pg);
        out.images.push_back(std::move(*image));
      }
    if (pg == 0) per_page = out.images.size();
  }
  // Which groups have faces on which page (one page: every group present).
  std::vector<std::vector<char>> present(std::max<size_t>(pages.size(), 1),
                                         std::vector<char>(groups.size(), face_page.empty()));
  for (size_t m = 0; m < views.size() && !face_page.empty(); ++m)
    for (uint32_t f = 0; f < views[m].faces.size(); ++f)
      present[page_of(m, f)][size_t(prim_group[m][views[m].faces[f].primitive])] = 1;
  std::vector<Material> group_materials;
  for (size_t g = 0; g < groups.size(); ++g)
    group_materials.push_back(
        merged_material(scene, views, prim_group, int32_t(g), groups[g], need, slots, sampling));
  std::vector<std::vector<int32_t>> material_of;
  out.materials = page_materials(group_materials, present, per_page, &material_of, page_material);
  std::vector<int32_t> material_group(out.materials.size(), 0);
  for (const std::vector<int32_t>& row : material_of)
    for (size_t g = 0; g < row.size(); ++g)
      if (row[g] >= 0) material_group[size_t(row[g])] = int32_t(g);
  // Each mesh splits into one mesh per material it has faces in (one primitive each, so the
  // stream can refine it); its instances place every part.
  std::vector<std::vector<uint32_t>> parts(scene.meshes.size());
  for (uint32_t m = 0; m < scene.meshes.size(); ++m) {
    std::vector<int32_t> face_material(views[m].faces.size());
    for (uint32_t f = 0; f < face_material.size(); ++f)
      face_material[f] =
          material_of[page_of(m, f)][size_t(prim_group[m][views[m].faces[f].primitive])];
    for (size_t i = 0; i < out.materials.size(); ++i) {
      Mesh mesh = atlas_mesh(views[m], corner_uv[m], face_material, int32_t(i),
                             groups[size_t(material_group[i])]);
      if (mesh.primitives[0].indices.empty()) continue;
      if (parts[m].size() > 0) mesh.name += " (" + std::to_string(parts[m].size() + 1) + ")";
      parts[m].push_back(uint32_t(out.meshes.size()));
      out.meshes.push_back(std::move(mesh));
    }
  }
  for (const Instance& inst : scene.instances) {
    if (inst.mesh >= parts.size()) continue;
    for (uint32_t part : parts[inst.mesh]) {
      Instance copy = inst;
      copy.mesh = part;
      out.instances.push_back(std::move(copy));
    }
  }
  return out;
}

}  // namespace

namespace {

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
  for (const Material& m : scene.materials)
    for (auto [ref, what] : {std::pair{&m.normal, "normal"}, std::pair{&m.occlusion, "occlusion"},
                             std::pair{&m.metallic_roughness, "metallic-roughness"},
                             std::pair{&m.emissive, "emissive"}})
      if (ref->present() && (size_t(ref->image) >= scene.images.size() ||
                             !scene.images[size_t(ref->image)].decoded()))
        warn(warnings, "atlas: material '" + m.name + "': its " + what +
                           " texture is not decoded; its factors stand in for it");
  std::vector<MeshView> views;
  for (const Mesh& m : scene.meshes) views.emplace_back(m);
  // 0. The source's one texture already is an atlas: keep it and its uvs (no resampling).
  if (const std::optional<SourceAtlas>& source = reused) {
    rep.reused_source = true;
    Image atlas = source_atlas_image(scene, *source);
    rep.size = atlas.width;
    rep.height = atlas.height;
    rep.reference_texels = referenced_pixels(scene);
    rep.utilization = 1;
    const uint32_t set = source->tex_coord;
    std::vector<std::function<Vec2(uint32_t, int)>> corner_uv;
    // Per primitive: its plain colour's block, or -1 (textured).
    std::vector<std::vector<int>> flat(views.size());
    for (size_t m = 0; m < views.size(); ++m)
      for (const Primitive& p : views[m].mesh.primitives)
        flat[m].push_back(flat_color_index(scene, *source, p.material));
    rep.flat_colors = source->flat_colors.size();
    for (size_t m = 0; m < views.size(); ++m)
      corner_uv.push_back([&mv = views[m], &fl = flat[m], &src = *source, set](uint32_t f, int k) {
        const uint32_t prim = mv.faces[f].primitive;
        if (fl[prim] >= 0) return src.flat_uv[size_t(fl[prim])];
        const std::vector<Vec2>& uv = mv.mesh.primitives[prim].uvs[set];
        const Vec2 cell =
            face_uv_cell(uv[mv.corner(f, 0)], uv[mv.corner(f, 1)], uv[mv.corner(f, 2)]);
        const Vec2 t = uv[mv.corner(f, k)];
        // The image's part of the atlas (the top rows when a half was appended below).
        return Vec2{(t.x - cell.x) * float(src.part_width) / float(src.width),
                    (t.y - cell.y) * float(src.part_height) / float(src.height)};
      });
    ChannelImages channels;
    const float es = need.bake.emissive_scale;
    if (need.bake.normal)
      channels.normal = source_atlas_channel(scene, *source, AtlasChannel::kNormal, es);
    if (need.bake.orm)
      channels.orm =
          source_atlas_channel(scene, *source, AtlasChannel::kOcclusionRoughnessMetallic, es);
    if (need.bake.emissive)
      channels.emissive = source_atlas_channel(scene, *source, AtlasChannel::kEmissive, es);
    if (need.bake.sheen)
      channels.sheen = source_atlas_channel(scene, *source, AtlasChannel::kSheen, es);
    name_channels(channels);
    // The source's texels as they are (its sides already powers of two): its sampler's
    // filtering within a mip level shows them as the original does; its wraps show across
    // the image's edges what the original shows there.
    const Image& src_image = scene.images[size_t(source->image)];
    AtlasSampling sampling;
    sampling.source_texels =
        src_image.width == source->part_width && src_image.height == source->part_height;
    sampling.wrap_s = source->wrap_s;
    sampling.wrap_t = source->wrap_t;
    std::vector<PageImages> pages(1);
    pages[0].atlas = std::move(atlas);
    pages[0].channels = std::move(channels);
    Scene out = assemble(scene, views, corner_uv, std::move(pages), {}, need, sampling,
                         &rep.page_materials);
    rep.pages.push_back({rep.size, rep.height, 0, 1.0});
    rep.page_images = out.images.size();
    rep.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (report) *report = std::move(rep);
    return out;
  }
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
  append_scene(out, split.kept);
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
