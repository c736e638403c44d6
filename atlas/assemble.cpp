// The atlas stage's output scene: material groups, one material per group and page, meshes into
// the atlas (see assemble.h; Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised
// conversion of 3D models for interactive metaverses" §4.2–4.4).
#include "atlas/assemble.h"

#include <algorithm>
#include <string>
#include <tuple>
#include <unordered_map>

#include "scene/position_key.h"

namespace meshmux {

namespace {

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

// The group's material: the atlas's base colour; the baked channels' images (factors folded in,
// so the output's factors are 1), or the factors the sources share (metallic and roughness
// area-weighted over the group's faces, equal when they agree). Every channel is sampled
// with `sampling`'s wraps, LINEAR magnified, minified LINEAR_MIPMAP_LINEAR or, when
// source_texels, as group_min_filter says.
// `prim_group[m][p]`: the group of mesh m's primitive p, computed once by assemble.
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

}  // namespace

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

}  // namespace meshmux
