#include "atlas/atlas.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include "atlas/material_sample.h"
#include "clean/clean.h"
#include "image/color.h"
#include "image/texture_levels.h"
#include "importers/import.h"
#include "test_util.h"

namespace meshmux {
namespace {

struct Fidelity {
  double mean = 0, p99 = 0, max = 0;
  size_t samples = 0;
};

// Colour fidelity without a renderer: random surface points (area-weighted over the unique
// meshes), the colour the original material shows there vs the atlas colour at the mapped uv,
// both bilinear, compared with CIEDE2000 on RGB (alpha ignored).
Fidelity measure(const Scene& before, const Scene& after, size_t n, uint32_t seed) {
  struct Tri {
    uint32_t mesh, face;
    double cum;
  };
  std::vector<Tri> tris;
  std::vector<std::vector<FaceRef>> all_faces;
  double total = 0;
  for (uint32_t m = 0; m < before.meshes.size(); ++m) {
    all_faces.push_back(mesh_faces(before.meshes[m]));
    const auto& faces = all_faces.back();
    for (uint32_t f = 0; f < faces.size(); ++f) {
      const Primitive& p = before.meshes[m].primitives[faces[f].primitive];
      Vec3 a = p.positions[p.indices[3 * faces[f].triangle]],
           b = p.positions[p.indices[3 * faces[f].triangle + 1]],
           c = p.positions[p.indices[3 * faces[f].triangle + 2]];
      total += 0.5 * length(cross(b - a, c - a));
      tris.push_back({m, f, total});
    }
  }
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u01(0, 1);
  std::vector<double> de;
  de.reserve(n);
  for (size_t s = 0; s < n; ++s) {
    double pick = u01(rng) * total;
    auto it = std::lower_bound(tris.begin(), tris.end(), pick,
                               [](const Tri& t, double v) { return t.cum < v; });
    if (it == tris.end()) --it;
    double r1 = u01(rng), r2 = u01(rng);
    if (r1 + r2 > 1) r1 = 1 - r1, r2 = 1 - r2;
    double w[3] = {1 - r1 - r2, r1, r2};
    const FaceRef& fr = all_faces[it->mesh][it->face];
    const Primitive& p = before.meshes[it->mesh].primitives[fr.primitive];
    uint32_t v[3] = {p.indices[3 * fr.triangle], p.indices[3 * fr.triangle + 1],
                     p.indices[3 * fr.triangle + 2]};
    std::vector<Vec2> uvs(p.uvs.size());
    for (size_t k = 0; k < p.uvs.size(); ++k)
      for (int c = 0; c < 3; ++c)
        uvs[k].x += float(w[c] * p.uvs[k][v[c]].x), uvs[k].y += float(w[c] * p.uvs[k][v[c]].y);
    Vec4 col{1, 1, 1, 1};
    if (!p.colors.empty()) {
      col = {0, 0, 0, 0};
      for (int c = 0; c < 3; ++c) {
        col.x += float(w[c] * p.colors[v[c]].x), col.y += float(w[c] * p.colors[v[c]].y);
        col.z += float(w[c] * p.colors[v[c]].z), col.w += float(w[c] * p.colors[v[c]].w);
      }
    }
    Vec4 src = sample_base_color(before, p.material, uvs, col);
    const Primitive& q = after.meshes[it->mesh].primitives[0];
    uint32_t t[3] = {q.indices[3 * it->face], q.indices[3 * it->face + 1],
                     q.indices[3 * it->face + 2]};
    std::vector<Vec2> auv(1);
    for (int c = 0; c < 3; ++c)
      auv[0].x += float(w[c] * q.uvs[0][t[c]].x), auv[0].y += float(w[c] * q.uvs[0][t[c]].y);
    Vec4 dst = sample_base_color(after, q.material, auv, {1, 1, 1, 1});
    de.push_back(
        ciede2000(linear_rgb_to_lab(src.x, src.y, src.z), linear_rgb_to_lab(dst.x, dst.y, dst.z)));
  }
  std::sort(de.begin(), de.end());
  Fidelity f;
  f.samples = de.size();
  for (double d : de) f.mean += d;
  f.mean /= double(de.size());
  f.p99 = de[size_t(0.99 * double(de.size() - 1))];
  f.max = de.back();
  return f;
}

class AtlasSharedModel : public ::testing::TestWithParam<const char*> {};

// The atlas's targets: one material, one base-colour texture, one primitive per mesh; colour
// fidelity mean ΔE00 < 2 and 99th percentile < 10 over 100,000 surface points; the atlas figures
// and the texture levels' bytes are printed for the note.
TEST_P(AtlasSharedModel, OneMaterialOneTextureFaithfulColours) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  auto in = import_scene(testing::shared_model(GetParam()), {}, nullptr);
  ASSERT_TRUE(in.ok()) << in.status().message();
  Scene cleaned = clean(*in, {});
  AtlasReport rep;
  Warnings w;
  // The bake's fidelity, every texture baked (tiled ones included: SheenChair's fabrics would
  // otherwise keep their own materials, atlas/tiled.h, tested in tiled_test.cpp).
  AtlasOptions every;
  every.tiled_periods = 0;
  auto out = build_atlas(cleaned, every, &rep, &w);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_TRUE(rep.built);
  EXPECT_EQ(out->materials.size(), 1u);
  // The base colour, and one image per further channel the material samples.
  const Material& mat = out->materials[0];
  EXPECT_EQ(out->images.size(), 1u + mat.normal.present() + mat.metallic_roughness.present() +
                                    mat.emissive.present() + mat.sheen_color.present());
  EXPECT_EQ(mat.occlusion.image, mat.metallic_roughness.image);
  EXPECT_TRUE(out->materials[0].base_color.present());
  EXPECT_TRUE(validate(*out).is_ok()) << validate(*out).message();
  ASSERT_EQ(out->meshes.size(), cleaned.meshes.size());
  for (size_t m = 0; m < out->meshes.size(); ++m) {
    ASSERT_EQ(out->meshes[m].primitives.size(), 1u);
    size_t before = 0;
    for (const Primitive& p : cleaned.meshes[m].primitives) before += p.triangle_count();
    EXPECT_EQ(out->meshes[m].primitives[0].triangle_count(), before);
  }
  Fidelity f = measure(cleaned, *out, 100000, 12345);
  EXPECT_LT(f.mean, 2.0) << GetParam();
  EXPECT_LT(f.p99, 10.0) << GetParam();
  auto levels = make_texture_levels(out->images[0], {});
  ASSERT_TRUE(levels.ok()) << levels.status().message();
  std::string bytes;
  for (const TextureLevel& l : levels->levels)
    bytes += std::to_string(l.width) + ":" + std::to_string(l.encoded.size()) + " ";
  std::printf(
      "[ atlas ] %-42s %dx%d  used %.0f%%  charts %zu + %zu flat  split %zu  L2 mean %.3f max %.3f "
      " "
      "dE00 mean %.2f p99 %.2f max %.1f  levels %s %.2f s\n",
      GetParam(), rep.size, rep.size, 100 * rep.utilization, rep.charts, rep.flat_colors, rep.split,
      rep.mean_stretch_l2, rep.max_stretch_l2, f.mean, f.p99, f.max, bytes.c_str(), rep.seconds);
}

INSTANTIATE_TEST_SUITE_P(Shared, AtlasSharedModel,
                         ::testing::Values("Duck-dae/duck.dae",
                                           "CesiumMilkTruck-dae/CesiumMilkTruck.dae",
                                           "DamagedHelmet-glb/DamagedHelmet.glb",
                                           "Avocado-gltf/Avocado.gltf",
                                           "SheenChair-gltf/SheenChair.gltf", "Fox-glb/Fox.glb",
                                           "2CylinderEngine-glb/2CylinderEngine.glb",
                                           "BoxVertexColors-glb/BoxVertexColors.glb"),
                         [](const auto& info) { return testing::model_test_name(info.param); });

// 500 separate textured triangles (each its own chart, each needing a texel and its gutters) once
// failed with "atlas: charts do not fit in 128²" and exit 4. The atlas grows until they fit.
TEST(Atlas, ManySmallChartsGrowTheAtlasInsteadOfFailing) {
  Scene s;
  Image img;
  img.name = "tiny.png";
  img.width = img.height = 2;
  img.rgba = {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 255};
  s.images.push_back(img);
  Material m;
  m.base_color.image = 0;
  m.base_color.sampler.wrap_s = m.base_color.sampler.wrap_t = Wrap::kClampToEdge;
  s.materials.push_back(m);
  Primitive p;
  p.material = 0;
  p.uvs.resize(1);
  for (int i = 0; i < 500; ++i) {
    const float x = float(i % 25) * 3, y = float(i / 25) * 3;
    const uint32_t b = uint32_t(p.positions.size());
    p.positions.insert(p.positions.end(), {{x, y, 0}, {x + 1, y, 0}, {x, y + 1, 0}});
    p.normals.insert(p.normals.end(), 3, {0, 0, 1});
    p.uvs[0].insert(p.uvs[0].end(), {{0.1f, 0.1f}, {0.2f, 0.1f}, {0.1f, 0.2f}});
    p.indices.insert(p.indices.end(), {b, b + 1, b + 2});
  }
  // One face reaches beyond [0, 1] under a clamped sampler: the image cannot be kept as it is
  // (atlas/source_atlas), so the charts path runs.
  p.uvs[0][0] = {1.5f, 0.1f};
  Mesh mesh;
  mesh.primitives.push_back(p);
  s.meshes.push_back(mesh);
  s.instances.push_back({0, Mat4::identity(), ""});
  AtlasReport rep;
  auto out = build_atlas(clean(s, {}), {}, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  EXPECT_TRUE(rep.built);
  EXPECT_FALSE(rep.reused_source);
  EXPECT_GE(rep.charts, 400u);
  EXPECT_GE(rep.size, 256);
  EXPECT_TRUE(validate(*out).is_ok());
}

// A scene that needs no atlas (one material, no texture, no vertex colour) passes through.
TEST(Atlas, SingleUntexturedMaterialPassesThrough) {
  Scene s;
  Mesh m;
  Primitive p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  p.normals.assign(3, {0, 0, 1});
  p.indices = {0, 1, 2};
  p.material = 0;
  m.primitives.push_back(p);
  s.meshes.push_back(m);
  s.materials.emplace_back();
  s.instances.push_back({0, Mat4::identity(), ""});
  AtlasReport rep;
  auto out = build_atlas(s, {}, &rep, nullptr);
  ASSERT_TRUE(out.ok());
  EXPECT_FALSE(rep.built);
  EXPECT_TRUE(out->images.empty());
}

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// The point of Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion of 3D models
// for interactive metaverses" §4.4, checked texel by texel: no chart crosses a power-of-two
// boundary, and at every mip level at which a chart still spans a texel in both directions, each
// level-k texel that gathers any of its texels gathers no texel of another chart.
class AtlasMipLevels : public ::testing::TestWithParam<const char*> {};

TEST_P(AtlasMipLevels, ChartsNeverShareAMipTexel) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  auto in = import_scene(testing::shared_model(GetParam()), {}, nullptr);
  ASSERT_TRUE(in.ok());
  AtlasReport rep;
  AtlasOptions o;
  o.reuse_source_texture = false;  // the charts' layout is what is checked
  auto out = build_atlas(clean(*in, {}), o, &rep, nullptr);
  ASSERT_TRUE(out.ok() && rep.built);
  const int S = rep.size, H = rep.height;  // W × W or W × W/2
  ASSERT_TRUE(H == S || 2 * H == S) << S << "x" << H;
  ASSERT_EQ(rep.texel_chart.size(), size_t(S) * size_t(H));
  // Cells: aligned powers of two, inside the atlas, not crossing a power-of-two boundary.
  // Charts sharing a cell (one flat colour) form one group.
  std::map<std::pair<int, int>, int> group_of_cell;
  std::vector<int> group(rep.cell_pos.size());
  for (size_t c = 0; c < rep.cell_pos.size(); ++c) {
    const PackPlacement& p = rep.cell_pos[c];
    const PackRect& r = rep.cell_size[c];
    EXPECT_TRUE(respects_power_of_two(p.x, p.y, r.w, r.h)) << c;
    EXPECT_EQ(p.x % r.w, 0);
    EXPECT_EQ(p.y % r.h, 0);
    group[c] =
        group_of_cell.emplace(std::make_pair(p.x, p.y), int(group_of_cell.size())).first->second;
  }
  // Every texel's chart lies in that chart's cell.
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < S; ++x) {
      int32_t c = rep.texel_chart[size_t(y) * size_t(S) + size_t(x)];
      if (c < 0) continue;
      const PackPlacement& p = rep.cell_pos[size_t(c)];
      const PackRect& r = rep.cell_size[size_t(c)];
      ASSERT_TRUE(x >= p.x && x < p.x + r.w && y >= p.y && y < p.y + r.h)
          << "texel " << x << "," << y;
    }
  // Level by level: the groups gathered by each level-k texel.
  size_t checked = 0;
  for (int k = 1; (1 << k) <= H; ++k) {
    int b = 1 << k, n = S / b;
    std::vector<int> owner(size_t(n) * size_t(H / b), -1);  // -1 empty, -2 mixed
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < S; ++x) {
        int32_t c = rep.texel_chart[size_t(y) * size_t(S) + size_t(x)];
        if (c < 0) continue;
        int& o = owner[size_t(y / b) * size_t(n) + size_t(x / b)];
        int g = group[size_t(c)];
        o = o == -1 ? g : (o == g ? g : -2);
      }
    for (size_t c = 0; c < rep.cell_pos.size(); ++c) {
      const PackRect& r = rep.cell_size[c];
      if (b > std::min(r.w, r.h)) continue;  // the chart is under a texel here
      const PackPlacement& p = rep.cell_pos[c];
      for (int by = p.y / b; by < (p.y + r.h) / b; ++by)
        for (int bx = p.x / b; bx < (p.x + r.w) / b; ++bx) {
          ASSERT_NE(owner[size_t(by) * size_t(n) + size_t(bx)], -2)
              << "level " << k << " chart " << c;
          ++checked;
        }
    }
  }
  EXPECT_GT(checked, 0u);
}

INSTANTIATE_TEST_SUITE_P(Shared, AtlasMipLevels,
                         ::testing::Values("Duck-dae/duck.dae", "Fox-glb/Fox.glb",
                                           "DamagedHelmet-glb/DamagedHelmet.glb",
                                           "CesiumMilkTruck-dae/CesiumMilkTruck.dae"),
                         [](const auto& info) { return testing::model_test_name(info.param); });

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// Degenerate texture coordinates (every corner at one uv) and an image that is not decoded
// must not break sizing or packing: the atlas still builds and validates.
TEST(Atlas, DegenerateUvsAndUndecodedImagesStillBuild) {
  Scene s;
  Image img;
  img.name = "tiny";
  img.width = img.height = 2;
  img.rgba = {255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 255};
  s.images.push_back(img);
  Image broken;
  broken.name = "broken";  // not decoded
  s.images.push_back(broken);
  Material a, b;
  a.base_color.image = 0;
  b.base_color.image = 1;
  s.materials = {a, b};
  Mesh m;
  for (int k = 0; k < 2; ++k) {
    Primitive p;
    float x = float(k) * 2;
    p.positions = {{x, 0, 0}, {x + 1, 0, 0}, {x + 1, 1, 0}, {x, 1, 0}};
    p.normals.assign(4, {0, 0, 1});
    p.uvs = {std::vector<Vec2>(4, Vec2{0.5f, 0.5f})};  // every corner at one uv
    p.indices = {0, 1, 2, 0, 2, 3};
    p.material = k;
    m.primitives.push_back(p);
  }
  s.meshes.push_back(m);
  s.instances.push_back({0, Mat4::identity(), ""});
  Scene cleaned = clean(s, {});
  AtlasReport rep;
  auto out = build_atlas(cleaned, {}, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  EXPECT_TRUE(validate(*out).is_ok()) << validate(*out).message();
  EXPECT_EQ(out->materials.size(), 1u);
  EXPECT_GT(rep.size, 0);
}

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// Two quads side by side, each its own material: a plain colour and a translucent grey glass.
Scene glass_scene() {
  Scene s;
  Mesh mesh;
  for (int q = 0; q < 2; ++q) {
    Primitive p;
    float x = float(q) * 1.5f;
    p.positions = {{x, 0, 0}, {x + 1, 0, 0}, {x + 1, 1, 0}, {x, 1, 0}};
    p.normals.assign(4, Vec3{0, 0, 1});
    p.indices = {0, 1, 2, 0, 2, 3};
    p.material = q;
    mesh.primitives.push_back(p);
  }
  s.meshes.push_back(mesh);
  s.instances.push_back({0, Mat4::identity(), "quads"});
  Material red;
  red.name = "red";
  red.base_color_factor = {0.8f, 0.05f, 0.05f, 1};
  Material glass;
  glass.name = "glass";
  glass.base_color_factor = {0.15f, 0.15f, 0.15f, 0.3f};
  glass.alpha_mode = AlphaMode::kBlend;
  s.materials = {red, glass};
  return clean(s, {});
}

// A translucent colour keeps its RGB under its alpha. Grey glass (0.15, α 0.3) was once baked as
// (255, 255, 255, 77): every viewer then drew white glass.
TEST(Atlas, TranslucentColourKeepsItsRgbUnderAlpha) {
  Scene s = glass_scene();
  AtlasReport r;
  auto out = build_atlas(s, AtlasOptions{}, &r, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_EQ(out->images.size(), 1u);
  const Image& atlas = out->images[0];
  // The glass is its own part, with a BLEND material sampling the same atlas (one material per
  // alpha mode); sample the atlas at its centroid.
  ASSERT_EQ(out->meshes.size(), 2u);
  ASSERT_EQ(out->materials.size(), 2u);
  const Primitive* glass = nullptr;
  for (const Mesh& m : out->meshes)
    if (out->materials[size_t(m.primitives[0].material)].alpha_mode == AlphaMode::kBlend)
      glass = &m.primitives[0];
  ASSERT_TRUE(glass);
  const Primitive& p = *glass;
  ASSERT_EQ(p.indices.size(), 6u);
  Vec2 uv{0, 0};
  for (int k = 0; k < 6; ++k)
    uv.x += p.uvs[0][p.indices[k]].x / 6, uv.y += p.uvs[0][p.indices[k]].y / 6;
  int x = std::clamp(int(uv.x * float(atlas.width)), 0, atlas.width - 1);
  int y = std::clamp(int(uv.y * float(atlas.height)), 0, atlas.height - 1);
  const uint8_t* t = &atlas.rgba[(size_t(y) * size_t(atlas.width) + size_t(x)) * 4];
  uint8_t grey = linear_to_srgb(0.15f);  // 108
  EXPECT_NEAR(t[0], grey, 2);
  EXPECT_NEAR(t[1], grey, 2);
  EXPECT_NEAR(t[2], grey, 2);
  EXPECT_NEAR(t[3], 77, 1);
}

// Alpha and sidedness survive the atlas with the fewest draw calls: one material per (alpha mode
// with its cutoff, double-sided) present, all sampling the one atlas. Merging them (BLEND and
// double-sided for all) showed back faces of single-sided parts and blended opaque ones.
TEST(Atlas, OneMaterialPerAlphaModeAndSidedness) {
  Scene s = glass_scene();
  Material mask = s.materials[0];
  mask.name = "mask";
  mask.alpha_mode = AlphaMode::kMask;
  mask.alpha_cutoff = 0.25f;
  mask.double_sided = true;
  s.materials.push_back(mask);
  Mesh extra = s.meshes[0];
  for (Primitive& p : extra.primitives) p.material = 2;
  s.meshes.push_back(extra);
  s.instances.push_back({1, Mat4::translation(0, 3, 0), "masked"});
  s.instances.push_back({1, Mat4::translation(0, 6, 0), "masked again"});
  auto out = build_atlas(s, AtlasOptions{}, nullptr, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_EQ(out->materials.size(), 3u);
  EXPECT_EQ(out->images.size(), 1u);
  std::vector<AlphaMode> modes;
  for (const Material& m : out->materials) {
    EXPECT_EQ(m.base_color.image, 0);
    modes.push_back(m.alpha_mode);
  }
  EXPECT_EQ(modes,
            (std::vector<AlphaMode>{AlphaMode::kOpaque, AlphaMode::kMask, AlphaMode::kBlend}));
  EXPECT_FALSE(out->materials[0].double_sided);
  EXPECT_TRUE(out->materials[1].double_sided);
  EXPECT_FLOAT_EQ(out->materials[1].alpha_cutoff, 0.25f);
  // Every part is one primitive; the masked mesh keeps its two instances.
  size_t masked_instances = 0;
  for (const Mesh& m : out->meshes) EXPECT_EQ(m.primitives.size(), 1u);
  for (const Instance& inst : out->instances)
    masked_instances +=
        out->materials[size_t(out->meshes[inst.mesh].primitives[0].material)].alpha_mode ==
        AlphaMode::kMask;
  EXPECT_EQ(masked_instances, 2u);
  EXPECT_EQ(compute_stats(*out).scene_triangles, compute_stats(s).scene_triangles);
}

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// Two unit quads side by side, one per material, in one mesh.
Scene two_material_quads(const Material& a, const Material& b) {
  Scene s;
  Mesh mesh;
  for (int k = 0; k < 2; ++k) {
    Primitive p;
    const float x = float(k) * 1.5f;
    p.positions = {{x, 0, 0}, {x + 1, 0, 0}, {x + 1, 1, 0}, {x, 1, 0}};
    p.normals.assign(4, {0, 0, 1});
    p.uvs = {{{0, 0}, {1, 0}, {1, 1}, {0, 1}}};
    p.indices = {0, 1, 2, 0, 2, 3};
    p.material = k;
    mesh.primitives.push_back(p);
  }
  s.meshes.push_back(mesh);
  s.materials = {a, b};
  s.instances.push_back({0, Mat4::identity(), ""});
  return s;
}

// A metal part and a plastic part with no textures at all: one material cannot carry both as
// factors (the area-weighted mean made DamagedHelmet-like models half metal everywhere), so the
// channel is baked; the factors become 1 and the map carries the values.
TEST(AtlasChannels, DifferingMetalRoughnessFactorsBakeAMap) {
  Material metal, plastic;
  metal.base_color_factor = {0.8f, 0.8f, 0.8f, 1};
  metal.metallic_factor = 1, metal.roughness_factor = 0.2f;
  plastic.base_color_factor = {0.1f, 0.2f, 0.8f, 1};
  plastic.metallic_factor = 0, plastic.roughness_factor = 0.9f;
  AtlasReport rep;
  auto out = build_atlas(two_material_quads(metal, plastic), {}, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_EQ(out->materials.size(), 1u);
  const Material& m = out->materials[0];
  ASSERT_TRUE(m.metallic_roughness.present());
  EXPECT_EQ(m.occlusion.image, m.metallic_roughness.image);
  EXPECT_FALSE(m.normal.present());
  EXPECT_FALSE(m.emissive.present());
  EXPECT_EQ(m.metallic_factor, 1);
  EXPECT_EQ(m.roughness_factor, 1);
  ASSERT_EQ(out->images.size(), 2u);
  // Every face reads its own part's values through the atlas.
  const Image& orm = out->images[size_t(m.metallic_roughness.image)];
  ASSERT_TRUE(orm.decoded());
  const Primitive& p = out->meshes[0].primitives[0];
  for (size_t f = 0; f < p.indices.size(); f += 3) {
    Vec2 c{0, 0};
    float x = 0;
    for (int k = 0; k < 3; ++k) {
      c.x += p.uvs[0][p.indices[f + k]].x / 3;
      c.y += p.uvs[0][p.indices[f + k]].y / 3;
      x += p.positions[p.indices[f + k]].x / 3;
    }
    const Vec4 v = sample_image_data(orm, m.metallic_roughness.sampler, c);
    const bool is_metal = x < 1.25f;
    EXPECT_NEAR(v.z, is_metal ? 1.0 : 0.0, 1.5 / 255) << "face " << f / 3;
    EXPECT_NEAR(v.y, is_metal ? 0.2 : 0.9, 1.5 / 255) << "face " << f / 3;
    EXPECT_NEAR(v.x, 1.0, 1.5 / 255);
  }
}

// Materials that share their factors keep them as factors: no texture where none is needed
// (and the emissive factor, which the atlas used to drop, survives).
TEST(AtlasChannels, SharedFactorsStayFactors) {
  Material a, b;
  a.base_color_factor = {1, 0, 0, 1};
  b.base_color_factor = {0, 1, 0, 1};
  for (Material* m : {&a, &b}) {
    m->metallic_factor = 0.25f;
    m->roughness_factor = 0.5f;
    m->emissive_factor = {0.1f, 0.2f, 0.3f};
  }
  auto out = build_atlas(two_material_quads(a, b), {}, nullptr, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_EQ(out->images.size(), 1u);
  const Material& m = out->materials[0];
  EXPECT_FALSE(m.metallic_roughness.present());
  EXPECT_FALSE(m.emissive.present());
  EXPECT_FLOAT_EQ(m.metallic_factor, 0.25f);
  EXPECT_FLOAT_EQ(m.roughness_factor, 0.5f);
  EXPECT_EQ(m.emissive_factor, (Vec3{0.1f, 0.2f, 0.3f}));
}

// A single-texture model whose maps share its uvs (DamagedHelmet's layout) keeps every map
// texel for texel beside the kept base colour: no resampling of any channel.
TEST(AtlasChannels, KeptSourceTextureKeepsItsMapsTexelForTexel) {
  Scene s;
  auto noise = [](int seed) {
    Image img;
    img.width = img.height = 16;
    std::mt19937 engine{uint32_t(seed)};
    for (int i = 0; i < 16 * 16; ++i)
      for (int c = 0; c < 4; ++c) img.rgba.push_back(c == 3 ? 255 : uint8_t(engine() % 256));
    return img;
  };
  s.images = {noise(1), noise(2), noise(3)};
  Material m;
  m.base_color.image = 0;
  m.normal.image = 1;
  m.metallic_roughness.image = 2;
  s.materials.push_back(m);
  Mesh mesh;
  Primitive p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  p.normals.assign(4, {0, 0, 1});
  p.uvs = {{{0, 0}, {1, 0}, {1, 1}, {0, 1}}};
  p.indices = {0, 1, 2, 0, 2, 3};
  p.material = 0;
  mesh.primitives.push_back(p);
  s.meshes.push_back(mesh);
  s.instances.push_back({0, Mat4::identity(), ""});
  AtlasReport rep;
  auto out = build_atlas(s, {}, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  EXPECT_TRUE(rep.reused_source);
  const Material& o = out->materials[0];
  ASSERT_TRUE(o.normal.present());
  ASSERT_TRUE(o.metallic_roughness.present());
  const Image& nm = out->images[size_t(o.normal.image)];
  const Image& mr = out->images[size_t(o.metallic_roughness.image)];
  ASSERT_EQ(nm.width, 16);
  int normal_off = 0;
  for (size_t i = 0; i < nm.rgba.size(); i += 4) {
    // Normals are renormalized on the way (a map's texels are not always unit length).
    const double x = s.images[1].rgba[i] / 127.5 - 1, y = s.images[1].rgba[i + 1] / 127.5 - 1,
                 z = s.images[1].rgba[i + 2] / 127.5 - 1, l = std::sqrt(x * x + y * y + z * z);
    if (l < 0.05) continue;
    normal_off += std::abs(nm.rgba[i] - std::lround((x / l * 0.5 + 0.5) * 255)) > 1;
    EXPECT_EQ(mr.rgba[i + 1], s.images[2].rgba[i + 1]);  // roughness
    EXPECT_EQ(mr.rgba[i + 2], s.images[2].rgba[i + 2]);  // metallic
    EXPECT_EQ(mr.rgba[i], 255);                          // no occlusion map: 1
  }
  EXPECT_EQ(normal_off, 0);
}

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// Two quads, each sampling all of its own texture (256² and 128²), in one atlas.
Scene two_textured_quads(int first, int second) {
  Scene s;
  for (int side : {first, second}) {
    Image img;
    img.width = img.height = side;
    for (int i = 0; i < side * side; ++i)
      img.rgba.insert(img.rgba.end(), {uint8_t(i % 251), uint8_t(i % 13 * 19), 90, 255});
    s.images.push_back(img);
    Material m;
    m.base_color.image = int32_t(s.images.size() - 1);
    s.materials.push_back(m);
  }
  Mesh mesh;
  for (int k = 0; k < 2; ++k) {
    mesh.primitives.push_back(testing::unit_quad(2.0f * float(k), k));
  }
  s.meshes.push_back(mesh);
  s.instances.push_back({0, Mat4::identity(), ""});
  return s;
}

// Charts keep their sources' texel density. An earlier budget (no more atlas texels than the
// sources reference) held charts to ~63% of it once packed, and decals blurred (24.0 dB unlit).
// Here each quad spans at least its image's texels along both sides of the atlas, whatever its area
// in the world (the small texture is on a quad as large as the other's: formula 2 alone would give
// both the same texels).
TEST(AtlasDensity, ChartsKeepTheirSourcesDensity) {
  Scene s = two_textured_quads(256, 128);
  AtlasReport rep;
  auto out = build_atlas(s, {}, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_FALSE(rep.reused_source);
  EXPECT_GE(rep.min_density, 0.999);
  const Primitive& p = out->meshes[0].primitives[0];
  for (int k = 0; k < 2; ++k) {
    float lo_u = 1, hi_u = 0, lo_v = 1, hi_v = 0;
    for (size_t v = 0; v < p.positions.size(); ++v) {
      if ((p.positions[v].x > 1.5f) != (k == 1)) continue;
      lo_u = std::min(lo_u, p.uvs[0][v].x), hi_u = std::max(hi_u, p.uvs[0][v].x);
      lo_v = std::min(lo_v, p.uvs[0][v].y), hi_v = std::max(hi_v, p.uvs[0][v].y);
    }
    const double side = k == 0 ? 256 : 128;
    EXPECT_GE((hi_u - lo_u) * rep.size, side - 0.5) << "quad " << k;
    EXPECT_GE((hi_v - lo_v) * rep.height, side - 0.5) << "quad " << k;
  }
  const Image& atlas = out->images[0];
  EXPECT_EQ(atlas.width, rep.size);
  EXPECT_EQ(atlas.height, rep.height);
}

// Where charts reuse the same source texels (one 256² decal on six quads), each use would be a
// copy that costs its bytes again: the charts' own texels stay within 1.1× the distinct source
// texels, so the density drops to about 1.1 × distinct / referenced.
TEST(AtlasDensity, ReusedSourcesShareTheBound) {
  Scene s = two_textured_quads(256, 64);
  for (int k = 0; k < 5; ++k) {
    Primitive p = s.meshes[0].primitives[0];
    for (Vec3& v : p.positions) v.y += 2.0f * float(k + 1);
    s.meshes[0].primitives.push_back(p);
  }
  AtlasReport rep;
  auto out = build_atlas(s, {}, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  const double distinct = 256.0 * 256 + 64 * 64, referenced = 6 * 256.0 * 256 + 64 * 64;
  EXPECT_NEAR(rep.reuse_scale, 1.1 * distinct / referenced, 1e-6);
  const double density = AtlasOptions{}.density;
  EXPECT_LE(rep.min_density, density * rep.reuse_scale + 1e-6);
  EXPECT_GT(rep.min_density, 0.5 * density * rep.reuse_scale);
  EXPECT_LT(double(rep.size) * rep.height, referenced);
}

// The same density on every shared model the atlas resamples (the kept-source path holds the
// source image itself), unless the sources are reused (the bound above) or the largest atlas
// is full.
class AtlasBudgetShared : public ::testing::TestWithParam<const char*> {};
TEST_P(AtlasBudgetShared, ChartsKeepTheirSourcesDensity) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  auto in = import_scene(testing::shared_model(GetParam()), {}, nullptr);
  ASSERT_TRUE(in.ok()) << in.status().message();
  AtlasReport rep;
  AtlasOptions o;
  auto out = build_atlas(clean(*in, {}), o, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_TRUE(rep.built);
  if (rep.reused_source || rep.min_density == 0) GTEST_SKIP() << "no chart samples source texels";
  if (rep.size < o.max_size) {
    EXPECT_GE(rep.min_density, 0.999 * std::min(1.0, rep.reuse_scale))
        << rep.size << "x" << rep.height;
  }
}
// Normal maps are baked in the derivative frame three.js uses without TANGENT; viewers that
// generate MikkTSpace tangents instead follow dp/du. On the atlas's flattened charts the two stay
// within 2° on average, which is why no TANGENT is written.
TEST_P(AtlasBudgetShared, TangentFramesStayCloseToMikkTSpace) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  auto in = import_scene(testing::shared_model(GetParam()), {}, nullptr);
  ASSERT_TRUE(in.ok()) << in.status().message();
  AtlasReport rep;
  auto out = build_atlas(clean(*in, {}), {}, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  if (rep.reused_source) GTEST_SKIP() << "the source's uvs (and so its frame) are kept";
  EXPECT_LT(rep.tangent_deviation_deg, 2.0);
}

INSTANTIATE_TEST_SUITE_P(Shared, AtlasBudgetShared,
                         ::testing::Values("AlphaBlendModeTest-glb/AlphaBlendModeTest.glb",
                                           "TextureSettingsTest-glb/TextureSettingsTest.glb",
                                           "NegativeScaleTest-glb/NegativeScaleTest.glb",
                                           "VertexColorTest-glb/VertexColorTest.glb",
                                           "BoxVertexColors-glb/BoxVertexColors.glb",
                                           "SheenChair-gltf/SheenChair.gltf",
                                           "MultiUVTest-glb/MultiUVTest.glb",
                                           "DamagedHelmet-glb/DamagedHelmet.glb"),
                         [](const auto& info) { return testing::model_test_name(info.param); });

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// The stream's first picture is the atlas's smallest level (every other mip level, down to
// 128 px or less: a 1024-wide atlas shows at 64 px, 16 times smaller). A plain part's block
// must still hold its colour there; 4-texel blocks averaged with their neighbours and showed
// TextureSettingsTest's blue panel grey.
TEST(AtlasBudget, FlatColoursSurviveToTheSmallestLevel) {
  Scene s;
  Image img;
  img.width = img.height = 1024;
  for (int i = 0; i < 1024 * 1024; ++i)
    img.rgba.insert(img.rgba.end(), {uint8_t(i * 7 % 256), uint8_t(i / 1024 % 256), 40, 255});
  s.images.push_back(img);
  Material textured, red;
  textured.base_color.image = 0;
  red.base_color_factor = {1, 0, 0, 1};
  s.materials = {textured, red};
  Mesh mesh;
  for (int k = 0; k < 2; ++k) {
    mesh.primitives.push_back(testing::unit_quad(2.0f * float(k), k));
  }
  s.meshes.push_back(mesh);
  s.instances.push_back({0, Mat4::identity(), ""});
  AtlasOptions o;
  o.reuse_source_texture = false;
  AtlasReport rep;
  auto out = build_atlas(s, o, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_GE(rep.size, 1024);
  Image level = out->images[0];
  while (std::max(level.width, level.height) > rep.size / 16) level = downsample_half(level);
  // The red quad's faces (those at x ≥ 2) in the output mesh, read at their uv centre.
  const Primitive& p = out->meshes[0].primitives[0];
  int checked = 0;
  for (size_t f = 0; f < p.indices.size(); f += 3) {
    Vec2 c{0, 0};
    float x = 0;
    for (int k = 0; k < 3; ++k) {
      c.x += p.uvs[0][p.indices[f + k]].x / 3;
      c.y += p.uvs[0][p.indices[f + k]].y / 3;
      x += p.positions[p.indices[f + k]].x / 3;
    }
    if (x < 2) continue;
    // Within 3 sRGB levels of pure red (a 4-texel block there is half the noise's average).
    const Vec4 v = sample_image(level, out->materials[0].base_color.sampler, c);
    EXPECT_NEAR(v.x, 1.0, 0.05);
    EXPECT_NEAR(v.y, 0.0, 0.03);
    ++checked;
  }
  EXPECT_EQ(checked, 2);
}

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// KHR_materials_sheen (SheenChair's velvet): a velvet part and a wooden one. The sheen colour
// differs between them, so it is baked as its own channel; its roughness stays a factor.
// Glass beside an opaque part: the glass keeps its own material with its transmission, ior
// and volume (never alpha: a fully transmissive surface would vanish), sampling the same atlas.
TEST(Atlas, GlassIsAMaterialOfItsOwn) {
  Material opaque;
  opaque.name = "body";
  opaque.base_color_factor = {0.8f, 0.1f, 0.1f, 1};
  Material glass;
  glass.name = "glass";
  glass.base_color_factor = {0.9f, 0.9f, 1, 1};
  glass.transmission_factor = 1;
  glass.ior = 1.45f;
  glass.thickness_factor = 0.02f;
  glass.attenuation_distance = 0.5f;
  glass.attenuation_color = {0.8f, 0.9f, 1};
  Scene s = two_material_quads(opaque, glass);
  auto out = build_atlas(s, AtlasOptions{}, nullptr, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_EQ(out->materials.size(), 2u);
  const Material& a = out->materials[0];
  const Material& b = out->materials[1];
  EXPECT_FALSE(a.transmissive());
  EXPECT_FLOAT_EQ(b.transmission_factor, 1.0f);
  EXPECT_FLOAT_EQ(b.ior, 1.45f);
  EXPECT_FLOAT_EQ(b.thickness_factor, 0.02f);
  EXPECT_FLOAT_EQ(b.attenuation_distance, 0.5f);
  EXPECT_EQ(b.attenuation_color, (Vec3{0.8f, 0.9f, 1}));
  EXPECT_EQ(b.alpha_mode, AlphaMode::kOpaque);
  EXPECT_EQ(a.base_color.image, 0);
  EXPECT_EQ(b.base_color.image, 0);
  // Two glass parts that differ only in ior are two materials.
  Material other = glass;
  other.ior = 1.9f;
  auto two = build_atlas(two_material_quads(glass, other), AtlasOptions{}, nullptr, nullptr);
  ASSERT_TRUE(two.ok());
  EXPECT_EQ(two->materials.size(), 2u);
}

// A clear-coated part beside a plain one (car paint and tyre): the coat is a material of its
// own with its factors; the plain part has none.
TEST(Atlas, ClearcoatIsAMaterialOfItsOwn) {
  Material plain;
  plain.name = "tyre";
  Material coated;
  coated.name = "paint";
  coated.clearcoat_factor = 1;
  coated.clearcoat_roughness_factor = 0.05f;
  coated.specular_color_factor = {0.9f, 0.9f, 1};
  auto out = build_atlas(two_material_quads(plain, coated), AtlasOptions{}, nullptr, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_EQ(out->materials.size(), 2u);
  EXPECT_EQ(out->materials[0].clearcoat_factor, 0);
  EXPECT_EQ(out->materials[0].specular_color_factor, (Vec3{1, 1, 1}));
  EXPECT_FLOAT_EQ(out->materials[1].clearcoat_factor, 1);
  EXPECT_FLOAT_EQ(out->materials[1].clearcoat_roughness_factor, 0.05f);
  EXPECT_EQ(out->materials[1].specular_color_factor, (Vec3{0.9f, 0.9f, 1}));
}

TEST(AtlasChannels, SheenColourIsBakedWhereItDiffers) {
  Material velvet, wood;
  velvet.base_color_factor = {0.8f, 0.2f, 0.1f, 1};
  velvet.sheen_color_factor = {1, 0.329f, 0.1f};
  velvet.sheen_roughness_factor = 0.8f;
  wood.base_color_factor = {0.3f, 0.2f, 0.1f, 1};
  auto out = build_atlas(two_material_quads(velvet, wood), {}, nullptr, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  const Material& m = out->materials[0];
  ASSERT_TRUE(m.sheen_color.present());
  EXPECT_EQ(m.sheen_color_factor, (Vec3{1, 1, 1}));
  EXPECT_FLOAT_EQ(m.sheen_roughness_factor, 0.8f);
  const Image& sheen = out->images[size_t(m.sheen_color.image)];
  const Primitive& p = out->meshes[0].primitives[0];
  for (size_t f = 0; f < p.indices.size(); f += 3) {
    Vec2 c{0, 0};
    float x = 0;
    for (int k = 0; k < 3; ++k) {
      c.x += p.uvs[0][p.indices[f + k]].x / 3;
      c.y += p.uvs[0][p.indices[f + k]].y / 3;
      x += p.positions[p.indices[f + k]].x / 3;
    }
    const Vec4 v = sample_image(sheen, m.sheen_color.sampler, c);
    if (x < 1.25f) {
      EXPECT_NEAR(v.x, 1.0, 0.01);
      EXPECT_NEAR(v.y, 0.329, 0.01);
    } else {
      EXPECT_NEAR(v.x, 0.0, 0.01);
    }
  }
}

}  // namespace
}  // namespace meshmux
