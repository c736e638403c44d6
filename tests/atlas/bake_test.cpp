#include "atlas/bake.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "atlas/material_sample.h"
#include "atlas/tangent_frame.h"

namespace meshmux {
namespace {

using Rgba = std::array<uint8_t, 4>;

Rgba texel(const Image& img, int x, int y) {
  const uint8_t* p = &img.rgba[(size_t(y) * size_t(img.width) + size_t(x)) * 4];
  return {p[0], p[1], p[2], p[3]};
}

int chart_at(const BakeResult& r, int x, int y) {
  return r.texel_chart[size_t(y) * size_t(r.atlas.width) + size_t(x)];
}

// Unit quad in the xy plane, uv set 0 covering [0, 1]², two faces: (0 1 2), (0 2 3).
Primitive quad(int32_t material) {
  Primitive p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  p.normals.assign(4, {0, 0, 1});
  p.uvs = {{{0, 0}, {1, 0}, {1, 1}, {0, 1}}};
  p.indices = {0, 1, 2, 0, 2, 3};
  p.material = material;
  return p;
}

Scene scene_with(const Image& img) {
  Scene s;
  s.images.push_back(img);
  Material m;
  m.base_color.image = 0;
  m.base_color.sampler.wrap_s = m.base_color.sampler.wrap_t = Wrap::kClampToEdge;
  s.materials.push_back(m);
  Mesh mesh;
  mesh.primitives.push_back(quad(0));
  s.meshes.push_back(mesh);
  s.instances.push_back({0, Mat4::identity(), ""});
  return s;
}

// A 4x4 checker of two colours.
const Rgba kDark{200, 30, 40, 255}, kLight{20, 180, 90, 255};
Image checker() {
  Image img;
  img.name = "checker";
  img.width = img.height = 4;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      const Rgba& c = (x + y) % 2 ? kLight : kDark;
      img.rgba.insert(img.rgba.end(), c.begin(), c.end());
    }
  return img;
}

// The quad's chart with chart uv = uv × side (so one chart-uv unit is one texel at scale 1).
Chart quad_chart() {
  Chart c;
  c.mesh = 0;
  c.faces = {0, 1};
  return c;
}
ChartUv quad_uv(float side) {
  ChartUv u;
  const Vec2 q[4] = {{0, 0}, {side, 0}, {side, side}, {0, side}};
  u.corner_uv = {q[0], q[1], q[2], q[0], q[2], q[3]};
  u.size = {side, side};
  return u;
}

Chart flat_chart(Vec4 color) {
  Chart c = quad_chart();
  c.textured = false;
  c.color = color;
  return c;
}

void add_chart(ChartSet& cs, std::vector<ChartUv>& uvs, AtlasLayout& layout, const Chart& c,
               const ChartUv& u, Vec2 offset, double scale, int block) {
  cs.charts.push_back(c);
  uvs.push_back(u);
  layout.offset.push_back(offset);
  layout.scale.push_back(scale);
  layout.block.push_back(block);
}

// A layout `size` wide holding the checker quad's chart (at `quad_at`, scaled, in a block) and a
// flat chart of one colour (at `flat_at`, in a block).
struct QuadAndFlat {
  ChartSet cs;
  std::vector<ChartUv> uvs;
  AtlasLayout layout;
};
QuadAndFlat quad_and_flat(int size, Vec2 quad_at, double scale, int quad_block, Vec4 flat,
                          Vec2 flat_at, int flat_block) {
  QuadAndFlat c;
  c.layout.size = size;
  add_chart(c.cs, c.uvs, c.layout, quad_chart(), quad_uv(4), quad_at, scale, quad_block);
  add_chart(c.cs, c.uvs, c.layout, flat_chart(flat), ChartUv{}, flat_at, 0.0, flat_block);
  return c;
}

TEST(Bake, TexturedQuadReproducesTheCheckerTexels) {
  Scene s = scene_with(checker());
  ChartSet cs;
  std::vector<ChartUv> uvs;
  AtlasLayout layout;
  layout.size = 8;
  add_chart(cs, uvs, layout, quad_chart(), quad_uv(4), {2, 2}, 1.0, 6);
  BakeOptions o;
  o.gutter = 0;
  BakeResult r = bake_atlas(s, cs, uvs, layout, o);
  ASSERT_EQ(r.atlas.width, 8);
  ASSERT_EQ(r.atlas.height, 8);
  ASSERT_EQ(r.atlas.rgba.size(), 8u * 8u * 4u);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      Rgba want = (x + y) % 2 ? kLight : kDark;
      Rgba got = texel(r.atlas, 2 + x, 2 + y);
      for (int k = 0; k < 4; ++k) EXPECT_NEAR(got[size_t(k)], want[size_t(k)], 1) << x << "," << y;
      EXPECT_EQ(chart_at(r, 2 + x, 2 + y), 0);
    }
  EXPECT_FALSE(r.has_alpha);
}

// A 2x scale: each source texel becomes 2x2 atlas texels.
TEST(Bake, ScaleMapsOneSourceTexelToSeveralAtlasTexels) {
  Scene s = scene_with(checker());
  ChartSet cs;
  std::vector<ChartUv> uvs;
  AtlasLayout layout;
  layout.size = 16;
  add_chart(cs, uvs, layout, quad_chart(), quad_uv(4), {0, 0}, 2.0, 8);
  BakeOptions o;
  o.gutter = 0;
  BakeResult r = bake_atlas(s, cs, uvs, layout, o);
  // Atlas texel centres fall a quarter source texel from a source texel centre: the bilinear blend
  // weighs that texel (and its same-coloured diagonal) 5/8, the other colour 3/8.
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      Rgba want = (x + y) % 2 ? kLight : kDark;
      Rgba other = (x + y) % 2 ? kDark : kLight;
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          Rgba got = texel(r.atlas, 2 * x + dx, 2 * y + dy);
          // Green separates the two colours: in linear light nearer to `want` than to `other`.
          float g = srgb_to_linear(got[1]);
          EXPECT_LT(std::fabs(g - srgb_to_linear(want[1])), std::fabs(g - srgb_to_linear(other[1])))
              << x << "," << y;
        }
    }
}

TEST(Bake, FlatChartFillsItsBlock) {
  Scene s = scene_with(checker());
  ChartSet cs;
  std::vector<ChartUv> uvs;
  AtlasLayout layout;
  layout.size = 16;
  const Vec4 color{0.5f, 0.25f, 1.0f, 1.0f};
  add_chart(cs, uvs, layout, flat_chart(color), ChartUv{}, {4, 8}, 0.0, 4);
  BakeOptions o;
  o.gutter = 0;
  BakeResult r = bake_atlas(s, cs, uvs, layout, o);
  const Rgba want{linear_to_srgb(0.5f), linear_to_srgb(0.25f), 255, 255};
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      bool inside = x >= 4 && x < 8 && y >= 8 && y < 12;
      EXPECT_EQ(chart_at(r, x, y), inside ? 0 : -1) << x << "," << y;
      if (inside) {
        EXPECT_EQ(texel(r.atlas, x, y), want) << x << "," << y;
      }
    }
}

// Texels are covered in bands of rows on every core: a textured chart 400 texels tall and a flat
// chart whose block straddles a band's edge must still own every texel of their rows (a row lost
// or doubled at a band's edge would show as a seam across the atlas).
TEST(Bake, ChartsAcrossRowBandsOwnEveryRow) {
  Scene s = scene_with(checker());
  QuadAndFlat c =
      quad_and_flat(512, {20, 50}, 100.0, 400, {0.5f, 0.25f, 1.0f, 1.0f}, {440, 100}, 64);
  BakeOptions o;
  o.gutter = 0;
  BakeResult r = bake_atlas(s, c.cs, c.uvs, c.layout, o);
  ASSERT_EQ(r.atlas.height, 512);
  for (int y = 0; y < 512; ++y)
    for (int x = 0; x < 512; ++x) {
      // A texel whose centre is within half a texel of a face is the face's: one ring around
      // the quad [20, 420] × [50, 450], its corners cut.
      const double dx = std::max({20.0 - (x + 0.5), 0.0, x + 0.5 - 420.0});
      const double dy = std::max({50.0 - (y + 0.5), 0.0, y + 0.5 - 450.0});
      const int want = std::hypot(dx, dy) <= 0.5                      ? 0
                       : (x >= 440 && x < 504 && y >= 100 && y < 164) ? 1
                                                                      : -1;
      ASSERT_EQ(chart_at(r, x, y), want) << x << "," << y;
    }
}

// Two flat charts 3 texels apart with 2 gutter rings: the gap fills from both sides, and every
// gutter texel has exactly the colour of the chart it is assigned to.
TEST(Bake, GutterTexelsTakeOnlyTheirOwnChartsIdAndColour) {
  Scene s = scene_with(checker());
  ChartSet cs;
  std::vector<ChartUv> uvs;
  AtlasLayout layout;
  layout.size = 16;
  const Vec4 red{1, 0, 0, 1}, blue{0, 0, 1, 1};
  add_chart(cs, uvs, layout, flat_chart(red), ChartUv{}, {2, 4}, 0.0, 4);   // x 2..5
  add_chart(cs, uvs, layout, flat_chart(blue), ChartUv{}, {9, 4}, 0.0, 4);  // x 9..12
  BakeOptions o;
  o.gutter = 2;
  BakeResult r = bake_atlas(s, cs, uvs, layout, o);
  const Rgba kRed{255, 0, 0, 255}, kBlue{0, 0, 255, 255};
  int gutter_texels[2] = {0, 0};
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      int c = chart_at(r, x, y);
      if (c == 0) {
        EXPECT_EQ(texel(r.atlas, x, y), kRed) << x << "," << y;
      } else if (c == 1) {
        EXPECT_EQ(texel(r.atlas, x, y), kBlue) << x << "," << y;
      }
      bool in0 = x >= 2 && x < 6 && y >= 4 && y < 8, in1 = x >= 9 && x < 13 && y >= 4 && y < 8;
      if (c >= 0 && !in0 && !in1) ++gutter_texels[c];
    }
  EXPECT_GT(gutter_texels[0], 0);
  EXPECT_GT(gutter_texels[1], 0);
  // The gap columns 6, 7, 8: 6 is red's first ring, 8 blue's, 7 is contested in ring 2.
  for (int y = 4; y < 8; ++y) {
    EXPECT_EQ(chart_at(r, 6, y), 0);
    EXPECT_EQ(chart_at(r, 8, y), 1);
    EXPECT_GE(chart_at(r, 7, y), 0);
  }
  // Two rings and no further: (0, y) is 2 from red's block, (14, y) 2 from blue's, (15, y) 3.
  EXPECT_EQ(chart_at(r, 0, 5), 0);
  EXPECT_EQ(chart_at(r, 14, 5), 1);
  EXPECT_EQ(chart_at(r, 15, 5), -1);
  EXPECT_EQ(chart_at(r, 5, 11), -1);
  EXPECT_EQ(chart_at(r, 5, 1), -1);
}

// Distance from p to triangle abc (0 inside), for the coverage test below.
double distance_to_triangle(const Vec2 v[3], double px, double py) {
  auto cross = [](double ax, double ay, double bx, double by) { return ax * by - ay * bx; };
  double d0 = cross(v[1].x - v[0].x, v[1].y - v[0].y, px - v[0].x, py - v[0].y);
  double d1 = cross(v[2].x - v[1].x, v[2].y - v[1].y, px - v[1].x, py - v[1].y);
  double d2 = cross(v[0].x - v[2].x, v[0].y - v[2].y, px - v[2].x, py - v[2].y);
  if ((d0 >= 0 && d1 >= 0 && d2 >= 0) || (d0 <= 0 && d1 <= 0 && d2 <= 0)) return 0;
  double best = 1e30;
  for (int e = 0; e < 3; ++e) {
    const Vec2 a = v[e], b = v[(e + 1) % 3];
    double dx = b.x - a.x, dy = b.y - a.y;
    double t = std::clamp(((px - a.x) * dx + (py - a.y) * dy) / (dx * dx + dy * dy), 0.0, 1.0);
    best = std::min(best, std::hypot(a.x + t * dx - px, a.y + t * dy - py));
  }
  return best;
}

// One slanted triangle: without gutters exactly the texels whose centre is inside or within half
// a texel are marked; one gutter ring adds exactly their 8-neighbours.
TEST(Bake, TexelChartMarksOnlyCoveredAndGutterTexels) {
  Scene s = scene_with(checker());
  Chart c;
  c.mesh = 0;
  c.faces = {0};
  ChartUv u;
  const Vec2 tri[3] = {{0.3f, 0.7f}, {9.6f, 2.2f}, {4.1f, 8.9f}};
  u.corner_uv = {tri[0], tri[1], tri[2]};
  ChartSet cs;
  std::vector<ChartUv> uvs;
  AtlasLayout layout;
  layout.size = 16;
  add_chart(cs, uvs, layout, c, u, {3, 4}, 1.0, 12);
  BakeOptions o;
  o.gutter = 0;
  BakeResult r0 = bake_atlas(s, cs, uvs, layout, o);
  o.gutter = 1;
  BakeResult r1 = bake_atlas(s, cs, uvs, layout, o);
  const Vec2 atlas_tri[3] = {
      {tri[0].x + 3, tri[0].y + 4}, {tri[1].x + 3, tri[1].y + 4}, {tri[2].x + 3, tri[2].y + 4}};
  int covered = 0;
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      double d = distance_to_triangle(atlas_tri, x + 0.5, y + 0.5);
      if (d < 0.5 - 1e-6) {
        EXPECT_EQ(chart_at(r0, x, y), 0) << x << "," << y;
      } else if (d > 0.5 + 1e-6) {
        EXPECT_EQ(chart_at(r0, x, y), -1) << x << "," << y;
      }
      covered += chart_at(r0, x, y) == 0;
      bool near = false;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          int nx = x + dx, ny = y + dy;
          if (nx >= 0 && ny >= 0 && nx < 16 && ny < 16 && chart_at(r0, nx, ny) == 0) near = true;
        }
      EXPECT_EQ(chart_at(r1, x, y), near ? 0 : -1) << x << "," << y;
    }
  EXPECT_GT(covered, 20);
}

// A triangle thinner than a texel still gets texels.
TEST(Bake, ThinTrianglesStillGetTexels) {
  Scene s = scene_with(checker());
  Chart c;
  c.mesh = 0;
  c.faces = {0};
  ChartUv u;
  u.corner_uv = {{0.1f, 0.2f}, {10.0f, 0.3f}, {5.0f, 0.45f}};  // 0.25 texel tall at most
  ChartSet cs;
  std::vector<ChartUv> uvs;
  AtlasLayout layout;
  layout.size = 16;
  add_chart(cs, uvs, layout, c, u, {2, 5}, 1.0, 12);
  BakeOptions o;
  o.gutter = 0;
  BakeResult r = bake_atlas(s, cs, uvs, layout, o);
  for (int x = 3; x < 12; ++x) EXPECT_EQ(chart_at(r, x, 5), 0) << x;
}

// A chart smaller than a texel whose faces come no nearer than kMargin to any texel centre
// still gets a texel of its own colour. The atlas sizes a chart from the source texels it
// samples, so a sphere that samples a 1x1 texture (TextureEncodingTest's "Texture" column) is a
// fraction of a texel; before, such a chart baked nothing and showed whatever colour the fill
// around it brought from neighbouring charts (its spheres rendered in patches of other colours).
TEST(Bake, ChartSmallerThanATexelStillGetsItsColour) {
  const Rgba kRed{230, 20, 20, 255};
  Image one;
  one.name = "one texel";
  one.width = one.height = 1;
  one.rgba.assign(kRed.begin(), kRed.end());
  Scene s = scene_with(one);
  ChartSet cs;
  std::vector<ChartUv> uvs;
  AtlasLayout layout;
  layout.size = 16;
  // Chart 0: the quad at 0.1 texel per side, its corner at the texel corner (3, 3): the nearest
  // texel centre (3.5, 3.5) is 0.57 texel away. Chart 1: a green block beside it.
  add_chart(cs, uvs, layout, quad_chart(), quad_uv(1), {3, 3}, 0.1, 4);
  add_chart(cs, uvs, layout, flat_chart({0, 1, 0, 1}), quad_uv(1), {8, 0}, 0, 8);
  BakeOptions o;
  o.gutter = 0;
  BakeResult r = bake_atlas(s, cs, uvs, layout, o);
  EXPECT_EQ(chart_at(r, 3, 3), 0);
  const Rgba got = texel(r.atlas, 3, 3);
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(got[size_t(k)], kRed[size_t(k)], 1) << k;
}

// Empty texels take the charts' colour AND alpha: transparent black there would be averaged
// into every chart edge at the coarse mip levels a model is seen at (AlphaBlendModeTest went
// from 27.8 to 32.3 dB unlit in the fidelity harness when this was fixed).
TEST(Bake, TranslucentSourceSetsHasAlphaAndFillsEmptyTexelsWithChartColourAndAlpha) {
  Image img;
  img.name = "half";
  img.width = img.height = 1;
  img.rgba = {255, 255, 255, 128};
  Scene s = scene_with(img);
  ChartSet cs;
  std::vector<ChartUv> uvs;
  AtlasLayout layout;
  layout.size = 16;
  add_chart(cs, uvs, layout, quad_chart(), quad_uv(4), {2, 2}, 1.0, 6);
  BakeResult r = bake_atlas(s, cs, uvs, layout, {});
  EXPECT_TRUE(r.has_alpha);
  EXPECT_EQ(texel(r.atlas, 3, 3)[3], 128);
  EXPECT_EQ(texel(r.atlas, 15, 15), (Rgba{255, 255, 255, 128}));
  EXPECT_EQ(chart_at(r, 15, 15), -1);  // filled, but no chart's
}

TEST(Bake, OpaqueSourceFillsEmptyTexelsOpaqueWithNearbyColour) {
  Scene s = scene_with(checker());
  ChartSet cs;
  std::vector<ChartUv> uvs;
  AtlasLayout layout;
  layout.size = 16;
  add_chart(cs, uvs, layout, flat_chart({0, 1, 0, 1}), ChartUv{}, {0, 0}, 0.0, 4);
  BakeResult r = bake_atlas(s, cs, uvs, layout, {});
  EXPECT_FALSE(r.has_alpha);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x)
      EXPECT_EQ(texel(r.atlas, x, y), (Rgba{0, 255, 0, 255})) << x << "," << y;
  EXPECT_EQ(chart_at(r, 15, 15), -1);  // filled, but no chart's
}

// Supersampling averages samples across the texel: a texel spanning a black|white|white|black
// strip reads white at its centre but grey (linear ½) over its area.
TEST(Bake, SupersampleAveragesOverTheTexel) {
  Image img;
  img.name = "strip";
  img.width = 4;
  img.height = 1;
  img.rgba = {0, 0, 0, 255, 255, 255, 255, 255, 255, 255, 255, 255, 0, 0, 0, 255};
  Scene s = scene_with(img);
  ChartSet cs;
  std::vector<ChartUv> uvs;
  AtlasLayout layout;
  layout.size = 4;
  add_chart(cs, uvs, layout, quad_chart(), quad_uv(1), {1, 1}, 1.0, 1);
  BakeOptions o;
  o.gutter = 0;
  o.supersample = 1;
  EXPECT_EQ(texel(bake_atlas(s, cs, uvs, layout, o).atlas, 1, 1)[0], 255);
  o.supersample = 2;
  EXPECT_EQ(texel(bake_atlas(s, cs, uvs, layout, o).atlas, 1, 1)[0], linear_to_srgb(0.5f));
}

TEST(Bake, Deterministic) {
  Scene s = scene_with(checker());
  QuadAndFlat c = quad_and_flat(32, {1.5f, 2.25f}, 2.5, 12, {0.3f, 0.6f, 0.9f, 1}, {16, 16}, 8);
  BakeResult a = bake_atlas(s, c.cs, c.uvs, c.layout, {});
  BakeResult b = bake_atlas(s, c.cs, c.uvs, c.layout, {});
  EXPECT_EQ(a.atlas.rgba, b.atlas.rgba);
  EXPECT_EQ(a.texel_chart, b.texel_chart);
}

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

Image solid(int side, Rgba c) {
  Image img;
  img.width = img.height = side;
  for (int i = 0; i < side * side; ++i) img.rgba.insert(img.rgba.end(), c.begin(), c.end());
  return img;
}

// Occlusion, roughness and metallic come from two source images and three factors and must
// land packed as glTF packs them (R occlusion with its strength, G roughness, B metallic), so a
// three.js MeshStandardMaterial reading the atlas shades as it shaded the source.
TEST(BakeChannels, OcclusionRoughnessMetallicPackedWithFactorsFolded) {
  Scene s = scene_with(checker());
  s.images.push_back(solid(4, {0, 128, 255, 255}));  // metallic-roughness: G 128, B 255
  s.images.push_back(solid(4, {100, 0, 0, 255}));    // occlusion: R 100
  Material& m = s.materials[0];
  m.metallic_roughness.image = 1;
  m.occlusion.image = 2;
  m.occlusion.scale = 0.5f;  // strength
  m.roughness_factor = 0.5f;
  m.metallic_factor = 0.8f;
  ChartSet cs;
  std::vector<ChartUv> uvs;
  AtlasLayout layout;
  layout.size = 8;
  add_chart(cs, uvs, layout, quad_chart(), quad_uv(4), {2, 2}, 1.0, 6);
  BakeChannels ch;
  ch.orm = true;
  BakeResult r = bake_atlas(s, cs, uvs, layout, BakeOptions{}, ch);
  ASSERT_EQ(r.orm.width, 8);
  EXPECT_TRUE(r.normal.rgba.empty());
  EXPECT_TRUE(r.emissive.rgba.empty());
  const double occlusion = 1 + 0.5 * (100 / 255.0 - 1);
  for (int y = 2; y < 6; ++y)
    for (int x = 2; x < 6; ++x) {
      Rgba t = texel(r.orm, x, y);
      EXPECT_NEAR(t[0], occlusion * 255, 1);
      EXPECT_NEAR(t[1], 0.5 * 128, 1);
      EXPECT_NEAR(t[2], 0.8 * 255, 1);
      EXPECT_EQ(t[3], 255);
    }
}

// Emissive radiance beyond 1 (KHR_materials_emissive_strength) is stored divided by the scale
// the output's emissiveFactor carries.
TEST(BakeChannels, EmissiveDividedByItsScale) {
  Scene s = scene_with(checker());
  s.materials[0].emissive_factor = {2, 1, 0};
  ChartSet cs;
  std::vector<ChartUv> uvs;
  AtlasLayout layout;
  layout.size = 8;
  add_chart(cs, uvs, layout, quad_chart(), quad_uv(4), {2, 2}, 1.0, 6);
  BakeChannels ch;
  ch.emissive = true;
  ch.emissive_scale = 2;
  BakeResult r = bake_atlas(s, cs, uvs, layout, BakeOptions{}, ch);
  ASSERT_EQ(r.emissive.width, 8);
  Rgba t = texel(r.emissive, 3, 3);
  EXPECT_EQ(t[0], 255);
  EXPECT_EQ(t[1], linear_to_srgb(0.5f));
  EXPECT_EQ(t[2], 0);
}

// The point of re-expressing normal maps: the source's uvs run rotated against the atlas's, so
// copying its texels would tilt every bump the wrong way. The baked map, read in the frame a
// viewer derives from the atlas uvs, must shade with the normal the source shaded with.
TEST(BakeChannels, NormalMapShadesAsTheSourceInTheAtlasFrame) {
  Scene s = scene_with(checker());
  // Source uvs rotated a quarter turn: u = y, v = 1 − x.
  s.meshes[0].primitives[0].uvs = {{{0, 1}, {0, 0}, {1, 0}, {1, 1}}};
  const DVec3 m_src = normalize(DVec3{0.4, -0.3, 0.85});
  auto byte = [](double v) { return uint8_t(std::lround((v * 0.5 + 0.5) * 255)); };
  s.images.push_back(solid(4, {byte(m_src.x), byte(m_src.y), byte(m_src.z), 255}));
  s.materials[0].normal.image = 1;
  ChartSet cs;
  std::vector<ChartUv> uvs;
  AtlasLayout layout;
  layout.size = 8;
  add_chart(cs, uvs, layout, quad_chart(), quad_uv(4), {2, 2}, 1.0, 6);
  BakeChannels ch;
  ch.normal = true;
  BakeResult r = bake_atlas(s, cs, uvs, layout, BakeOptions{}, ch);
  ASSERT_EQ(r.normal.width, 8);
  // Both faces' frames: edges e1 = p1 − p0, e2 = p2 − p0 of face (0 1 2); the quad is planar
  // and its uv maps are affine, so face (0 2 3) has the same frames.
  const DVec3 e1{1, 0, 0}, e2{1, 1, 0}, n{0, 0, 1};
  const TangentFrame source = derivative_frame(e1, e2, {0, -1}, {1, -1}, n);
  const TangentFrame atlas = derivative_frame(e1, e2, {4, 0}, {4, 4}, n);
  const DVec3 want = apply_normal_map(source, m_src);
  EXPECT_GT(std::acos(dot(want, apply_normal_map(atlas, m_src))) * 180 / M_PI, 20)
      << "the test needs frames that differ";
  for (int y = 2; y < 6; ++y)
    for (int x = 2; x < 6; ++x) {
      Rgba t = texel(r.normal, x, y);
      const DVec3 m{t[0] / 127.5 - 1, t[1] / 127.5 - 1, t[2] / 127.5 - 1};
      const double deg =
          std::acos(std::clamp(dot(want, apply_normal_map(atlas, m)), -1.0, 1.0)) * 180 / M_PI;
      EXPECT_LT(deg, 1.0) << x << "," << y;
    }
}

// Flat charts (a plain material) carry their factors into every channel, and a flat normal.
TEST(BakeChannels, FlatChartsCarryTheirFactors) {
  Scene s = scene_with(checker());
  ChartSet cs;
  std::vector<ChartUv> uvs;
  AtlasLayout layout;
  layout.size = 8;
  Chart c = flat_chart({1, 0, 0, 1});
  c.orm = {1, 0.25f, 0.75f};
  c.emissive = {0, 1, 0};
  add_chart(cs, uvs, layout, c, quad_uv(4), {0, 0}, 0.0, 4);
  BakeChannels ch;
  ch.normal = ch.orm = ch.emissive = true;
  BakeResult r = bake_atlas(s, cs, uvs, layout, BakeOptions{}, ch);
  Rgba o = texel(r.orm, 1, 1), e = texel(r.emissive, 1, 1), nm = texel(r.normal, 1, 1);
  EXPECT_EQ(o[0], 255);
  EXPECT_NEAR(o[1], 64, 1);
  EXPECT_NEAR(o[2], 191, 1);
  EXPECT_EQ(e[1], 255);
  EXPECT_EQ(e[0], 0);
  EXPECT_EQ(nm[0], 128);
  EXPECT_EQ(nm[1], 128);
  EXPECT_EQ(nm[2], 255);
}

}  // namespace
}  // namespace meshmux
