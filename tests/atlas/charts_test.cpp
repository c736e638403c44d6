#include "atlas/charts.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "clean/clean.h"
#include "importers/import.h"
#include "test_util.h"

namespace meshmux {
namespace {

// Appends a triangle, wound so its normal points away from `inside`.
void add_tri(Primitive& p, Vec3 a, Vec3 b, Vec3 c, Vec3 inside) {
  Vec3 n = cross(b - a, c - a);
  if (dot(n, (a + b + c) * (1.0f / 3) - inside) < 0) std::swap(b, c);
  uint32_t base = uint32_t(p.positions.size());
  for (Vec3 v : {a, b, c}) {
    p.positions.push_back(v);
    p.normals.push_back(normalize(cross(b - a, c - a)));
  }
  p.indices.insert(p.indices.end(), {base, base + 1, base + 2});
}

// A scene with one textured material (0), one flat red (1), one flat blue (2), one more flat
// red (3, same colour as 1).
Scene scene_with(std::vector<Primitive> prims) {
  Scene s;
  s.images.resize(1);
  s.images[0].name = "tex";
  Material tex;
  tex.base_color.image = 0;
  Material red, blue;
  red.base_color_factor = {1, 0, 0, 1};
  blue.base_color_factor = {0, 0, 1, 1};
  s.materials = {tex, red, blue, red};
  Mesh m;
  m.primitives = std::move(prims);
  s.meshes.push_back(m);
  s.instances.push_back({0, Mat4::identity(), ""});
  return s;
}

// n×n quads over [0,w]×[0,h] in the z = 0 plane, normal +z; quads with (i + j) in `select`
// parity go to this primitive (all when parity < 0).
Primitive grid(int n, float w, float h, int material, int parity = -1) {
  Primitive p;
  p.material = material;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      if (parity >= 0 && (i < n / 2 ? 0 : 1) != parity) continue;
      Vec3 a{w * i / n, h * j / n, 0}, b{w * (i + 1) / n, h * j / n, 0};
      Vec3 c{w * (i + 1) / n, h * (j + 1) / n, 0}, d{w * i / n, h * (j + 1) / n, 0};
      add_tri(p, a, b, c, {0, 0, -1});
      add_tri(p, a, c, d, {0, 0, -1});
    }
  return p;
}

Primitive cube(int material) {
  Primitive p;
  p.material = material;
  Vec3 o{0.5f, 0.5f, 0.5f};
  auto corner = [](int i) { return Vec3{float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1)}; };
  // Each face: four corners with one coordinate fixed.
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      std::vector<Vec3> q;
      for (int i = 0; i < 8; ++i)
        if (((i >> axis) & 1) == side) q.push_back(corner(i));
      // q[0], q[1], q[3], q[2] go round the face.
      add_tri(p, q[0], q[1], q[3], o);
      add_tri(p, q[0], q[3], q[2], o);
    }
  return p;
}

Vec3 sphere_point(int i, int j, int rings, int segments, float r) {
  double th = M_PI * i / rings, ph = 2 * M_PI * (j % segments) / segments;
  if (i == 0 || i == rings) ph = 0;  // the poles: one position
  return {float(r * std::sin(th) * std::cos(ph)), float(r * std::cos(th)),
          float(r * std::sin(th) * std::sin(ph))};
}

Primitive uv_sphere(int rings, int segments, float r, int material) {
  Primitive p;
  p.material = material;
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      Vec3 a = sphere_point(i, j, rings, segments, r),
           b = sphere_point(i, j + 1, rings, segments, r);
      Vec3 c = sphere_point(i + 1, j + 1, rings, segments, r),
           d = sphere_point(i + 1, j, rings, segments, r);
      if (i > 0) add_tri(p, a, b, c, {0, 0, 0});
      if (i < rings - 1) add_tri(p, a, c, d, {0, 0, 0});
    }
  return p;
}

Vec3 face_normal(const Scene& s, uint32_t mesh, uint32_t face) {
  FaceRef f = mesh_faces(s.meshes[mesh])[face];
  const Primitive& p = s.meshes[mesh].primitives[f.primitive];
  Vec3 a = p.positions[p.indices[3 * f.triangle]], b = p.positions[p.indices[3 * f.triangle + 1]],
       c = p.positions[p.indices[3 * f.triangle + 2]];
  return normalize(cross(b - a, c - a));
}

// Every face in exactly one chart; face_chart agrees with the charts' face lists.
void expect_consistent(const Scene& s, const ChartSet& cs) {
  ASSERT_EQ(cs.face_chart.size(), s.meshes.size());
  std::vector<std::vector<int>> seen(s.meshes.size());
  for (size_t m = 0; m < s.meshes.size(); ++m) seen[m].assign(mesh_faces(s.meshes[m]).size(), 0);
  for (uint32_t c = 0; c < cs.charts.size(); ++c) {
    const Chart& ch = cs.charts[c];
    ASSERT_LT(ch.mesh, s.meshes.size());
    ASSERT_FALSE(ch.faces.empty());
    EXPECT_TRUE(std::is_sorted(ch.faces.begin(), ch.faces.end()));
    for (uint32_t f : ch.faces) {
      ASSERT_LT(f, seen[ch.mesh].size());
      ++seen[ch.mesh][f];
      EXPECT_EQ(cs.face_chart[ch.mesh][f], c);
    }
  }
  for (const auto& v : seen)
    for (int n : v) EXPECT_EQ(n, 1);
}

TEST(Charts, MeshFacesNumberTrianglesOverPrimitivesInOrder) {
  Mesh m;
  m.primitives = {grid(1, 1, 1, 0), grid(2, 1, 1, 0)};  // 2 and 8 triangles
  std::vector<FaceRef> f = mesh_faces(m);
  ASSERT_EQ(f.size(), 10u);
  EXPECT_EQ(f[0].primitive, 0u);
  EXPECT_EQ(f[1].triangle, 1u);
  EXPECT_EQ(f[2].primitive, 1u);
  EXPECT_EQ(f[2].triangle, 0u);
  EXPECT_EQ(f[9].primitive, 1u);
  EXPECT_EQ(f[9].triangle, 7u);
}

TEST(Charts, SubdividedPlaneIsOneChart) {
  // Corner vertices are not shared in the input (every triangle has its own): adjacency goes by
  // position.
  for (float h : {1.0f, 3.0f}) {
    Scene s = scene_with({grid(12, 1, h, 0)});
    ChartSet cs = segment_charts(s);
    expect_consistent(s, cs);
    ASSERT_EQ(cs.charts.size(), 1u) << "height " << h;
    EXPECT_TRUE(cs.charts[0].textured);
    EXPECT_EQ(cs.charts[0].faces.size(), 288u);
  }
}

TEST(Charts, CubeIsSixChartsOfTwoFaces) {
  Scene s = clean(scene_with({cube(0)}), {});
  ChartSet cs = segment_charts(s);
  expect_consistent(s, cs);
  ASSERT_EQ(cs.charts.size(), 6u);
  for (const Chart& c : cs.charts) {
    ASSERT_EQ(c.faces.size(), 2u);
    EXPECT_GT(dot(face_normal(s, 0, c.faces[0]), face_normal(s, 0, c.faces[1])), 0.999f);
  }
}

TEST(Charts, TexturedAndFlatNeverShareAChart) {
  // Left half textured, right half flat red: one plane, two charts.
  Scene s = scene_with({grid(8, 1, 1, 0, 0), grid(8, 1, 1, 1, 1)});
  ChartSet cs = segment_charts(s);
  expect_consistent(s, cs);
  ASSERT_EQ(cs.charts.size(), 2u);
  std::vector<FaceRef> refs = mesh_faces(s.meshes[0]);
  for (const Chart& c : cs.charts) {
    uint32_t prim = refs[c.faces[0]].primitive;
    for (uint32_t f : c.faces) EXPECT_EQ(refs[f].primitive, prim);
    EXPECT_EQ(c.textured, prim == 0);
  }
  const Chart& flat = cs.charts[cs.charts[0].textured ? 1 : 0];
  EXPECT_EQ(flat.color, (Vec4{1, 0, 0, 1}));
}

TEST(Charts, FlatColoursMergeOnlyWhenIdentical) {
  // Red | blue: two charts. Red | red from another material with the same colour: one.
  {
    Scene s = scene_with({grid(8, 1, 1, 1, 0), grid(8, 1, 1, 2, 1)});
    ChartSet cs = segment_charts(s);
    expect_consistent(s, cs);
    ASSERT_EQ(cs.charts.size(), 2u);
    std::set<float> reds;
    for (const Chart& c : cs.charts) {
      EXPECT_FALSE(c.textured);
      reds.insert(c.color.x);
    }
    EXPECT_EQ(reds.size(), 2u);
  }
  {
    Scene s = scene_with({grid(8, 1, 1, 1, 0), grid(8, 1, 1, 3, 1)});
    ChartSet cs = segment_charts(s);
    ASSERT_EQ(cs.charts.size(), 1u);
    EXPECT_FALSE(cs.charts[0].textured);
    EXPECT_EQ(cs.charts[0].color, (Vec4{1, 0, 0, 1}));
  }
}

// A mesh of flat colours only (a CAD assembly) is not segmented: its faces go to palette blocks by
// colour, so it gets one chart per colour, even for pieces that do not touch (charting a 7-colour
// assembly once took most of a conversion's atlas time).
TEST(Charts, FlatOnlyMeshIsOneChartPerColour) {
  Primitive far_red = grid(4, 1, 1, 1);
  for (Vec3& p : far_red.positions) p.x += 10;  // a second red piece, apart from the first
  Scene s = scene_with({grid(4, 1, 1, 1), grid(4, 1, 1, 2), far_red, grid(4, 1, 1, 3)});
  ChartSet cs = segment_charts(s);
  expect_consistent(s, cs);
  ASSERT_EQ(cs.charts.size(), 2u);
  EXPECT_EQ(cs.charts[0].color, (Vec4{1, 0, 0, 1}));  // first face first
  EXPECT_EQ(cs.charts[1].color, (Vec4{0, 0, 1, 1}));
  EXPECT_EQ(cs.charts[0].faces.size(), 3u * 32u);  // three red grids of 32 triangles
  EXPECT_EQ(cs.charts[1].faces.size(), 32u);
}

TEST(Charts, VertexColoursDecideTexturedOrFlat) {
  // Constant vertex colour × factor: flat. Varying vertex colours: textured.
  Primitive constant = grid(4, 1, 1, 1);
  constant.colors.assign(constant.positions.size(), Vec4{0.5f, 1, 1, 0.5f});
  Scene s = scene_with({constant});
  ChartSet cs = segment_charts(s);
  ASSERT_EQ(cs.charts.size(), 1u);
  EXPECT_FALSE(cs.charts[0].textured);
  EXPECT_EQ(cs.charts[0].color, (Vec4{0.5f, 0, 0, 0.5f}));

  Primitive varying = grid(4, 1, 1, -1);
  varying.colors.assign(varying.positions.size(), Vec4{1, 1, 1, 1});
  varying.colors[5] = {0, 1, 0, 1};
  s = scene_with({varying});
  cs = segment_charts(s);
  ASSERT_EQ(cs.charts.size(), 1u);
  EXPECT_TRUE(cs.charts[0].textured);

  // No material, no colours: flat white.
  s = scene_with({grid(4, 1, 1, -1)});
  cs = segment_charts(s);
  ASSERT_EQ(cs.charts.size(), 1u);
  EXPECT_FALSE(cs.charts[0].textured);
  EXPECT_EQ(cs.charts[0].color, (Vec4{1, 1, 1, 1}));
}

TEST(Charts, BackToBackTwinsStayApart) {
  // A double-sided sheet: the front grid and the same grid wound the other way, in one
  // primitive and in the same material (clean keeps both).
  Primitive p = grid(4, 1, 1, 0);
  Primitive back = grid(4, 1, 1, 0);
  for (size_t t = 0; t < back.indices.size(); t += 3)
    std::swap(back.indices[t + 1], back.indices[t + 2]);
  uint32_t base = uint32_t(p.positions.size());
  p.positions.insert(p.positions.end(), back.positions.begin(), back.positions.end());
  for (Vec3 n : back.normals) p.normals.push_back(n * -1.0f);
  for (uint32_t i : back.indices) p.indices.push_back(base + i);
  Scene s = clean(scene_with({p}), {});
  ASSERT_EQ(s.meshes[0].primitives[0].triangle_count(), 64u);
  ChartSet cs = segment_charts(s);
  expect_consistent(s, cs);
  EXPECT_EQ(cs.charts.size(), 2u);
  // No chart holds two faces over the same three positions.
  const Primitive& q = s.meshes[0].primitives[0];
  for (const Chart& c : cs.charts) {
    std::set<std::vector<uint32_t>> keys;
    for (uint32_t f : c.faces) {
      std::vector<uint32_t> k;
      for (int i = 0; i < 3; ++i) {
        Vec3 v = q.positions[q.indices[3 * f + i]];
        k.push_back(uint32_t(std::lround(v.x * 100) * 10000 + std::lround(v.y * 100)));
      }
      std::sort(k.begin(), k.end());
      EXPECT_TRUE(keys.insert(k).second) << "face " << f << " shares a chart with its twin";
    }
  }
}

TEST(Charts, SphereBecomesSeveralFlattenableCharts) {
  Scene s = scene_with({uv_sphere(24, 48, 1, 0)});
  ChartSet cs = segment_charts(s);
  expect_consistent(s, cs);
  EXPECT_GE(cs.charts.size(), 3u);
  EXPECT_LE(cs.charts.size(), 40u);
  for (const Chart& c : cs.charts) {
    // Every face within ~90° of the chart's area-weighted mean normal (the guard keeps charts
    // height fields over their plane).
    Vec3 mean{0, 0, 0};
    for (uint32_t f : c.faces) mean = mean + face_normal(s, 0, f);
    mean = normalize(mean);
    for (uint32_t f : c.faces) EXPECT_GT(dot(face_normal(s, 0, f), mean), 0.0f);
  }
}

TEST(Charts, DeterministicAndScaleIndependent) {
  Scene s = scene_with({uv_sphere(16, 32, 1, 0), cube(1)});
  ChartSet a = segment_charts(s), b = segment_charts(s);
  ASSERT_EQ(a.charts.size(), b.charts.size());
  for (size_t i = 0; i < a.charts.size(); ++i) EXPECT_EQ(a.charts[i].faces, b.charts[i].faces);
  EXPECT_EQ(a.face_chart, b.face_chart);
  // The same model in millimetres: the same charts (the scale is a power of two, so every
  // position scales exactly).
  Scene big = s;
  for (Primitive& p : big.meshes[0].primitives)
    for (Vec3& v : p.positions) v = v * 1024.0f;
  ChartSet c = segment_charts(big);
  EXPECT_EQ(a.face_chart, c.face_chart);
}

TEST(Charts, ChartsNeverSpanMeshesAndRespectMaxFaces) {
  Scene s = scene_with({grid(6, 1, 1, 0)});
  s.meshes.push_back(s.meshes[0]);  // the same plane as a second mesh
  ChartSet cs = segment_charts(s);
  expect_consistent(s, cs);
  ASSERT_EQ(cs.charts.size(), 2u);
  EXPECT_EQ(cs.charts[0].mesh, 0u);
  EXPECT_EQ(cs.charts[1].mesh, 1u);

  ChartOptions o;
  o.max_faces = 10;
  cs = segment_charts(s, o);
  expect_consistent(s, cs);
  EXPECT_GE(cs.charts.size(), 2u * 72 / 10);
  for (const Chart& c : cs.charts) EXPECT_LE(c.faces.size(), 10u);
}

TEST(Charts, StopRatioControlsCurvedMergingButFlatMergesAreFree) {
  // stop_ratio 0: formula 1 says stop at the first merge. Flat, compact merges are exempt (the
  // safeguard), so a plane still becomes one chart, but a sphere stays in small pieces.
  ChartOptions stop_at_once;
  stop_at_once.stop_ratio = 0;
  Scene plane = scene_with({grid(8, 1, 1, 0)});
  EXPECT_EQ(segment_charts(plane, stop_at_once).charts.size(), 1u);

  Scene sphere = scene_with({uv_sphere(16, 32, 1, 0)});
  size_t faces = mesh_faces(sphere.meshes[0]).size();
  size_t eager = segment_charts(sphere, stop_at_once).charts.size();
  size_t normal = segment_charts(sphere).charts.size();
  EXPECT_GT(eager, faces / 4);
  EXPECT_LT(normal, faces / 50);
}

TEST(Charts, SharedModelsSegmentIntoFlattenableCharts) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  ImportOptions io;
  io.decode_images = false;
  auto in = import_scene(testing::shared_model("Duck-dae/duck.dae"), io, nullptr);
  ASSERT_TRUE(in.ok()) << in.status().message();
  Scene s = clean(*in, {});
  ChartSet cs = segment_charts(s);
  expect_consistent(s, cs);
  size_t faces = mesh_faces(s.meshes[0]).size();
  // Neither one chart per face nor one for the whole duck.
  EXPECT_GT(cs.charts.size(), 8u);
  EXPECT_LT(cs.charts.size(), faces / 20);
  for (const Chart& c : cs.charts) EXPECT_TRUE(c.textured);
}

}  // namespace
}  // namespace meshmux
