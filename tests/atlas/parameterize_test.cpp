#include "atlas/parameterize.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>

#include "clean/clean.h"
#include "importers/import.h"
#include "test_util.h"

namespace meshmux {
namespace {

// One mesh, one primitive, a textured material (0) and a flat one (1).
Scene one_primitive(const Primitive& p) {
  Scene s;
  s.images.resize(1);
  Material tex;
  tex.base_color.image = 0;
  Material flat;
  flat.base_color_factor = {0, 1, 0, 1};
  s.materials = {tex, flat};
  Mesh m;
  m.primitives = {p};
  s.meshes.push_back(m);
  s.instances.push_back({0, Mat4::identity(), ""});
  return s;
}

Chart whole(const Scene& s, bool textured = true) {
  Chart c;
  c.mesh = 0;
  c.textured = textured;
  for (uint32_t f = 0; f < s.meshes[0].primitives[0].triangle_count(); ++f) c.faces.push_back(f);
  return c;
}

// A height field z = h(x, y) over an n×n grid on [-1, 1]², shared vertices, normal up.
template <class H>
Primitive height_field(int n, H h, int material = 0) {
  Primitive p;
  p.material = material;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      float x = -1 + 2.0f * i / n, y = -1 + 2.0f * j / n;
      // Jitter the interior so triangles are not all alike.
      if (i > 0 && i < n && j > 0 && j < n) x += 0.3f / n * std::sin(float(7 * i + 3 * j));
      p.positions.push_back({x, y, h(x, y)});
      p.normals.push_back({0, 0, 1});
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      uint32_t a = uint32_t(j * (n + 1) + i), b = a + 1, c = a + uint32_t(n) + 2,
               d = a + uint32_t(n) + 1;
      p.indices.insert(p.indices.end(), {a, b, c, a, c, d});
    }
  return p;
}

double uv_area(const Vec2* c) {
  return 0.5 * ((double(c[1].x) - c[0].x) * (double(c[2].y) - c[0].y) -
                (double(c[2].x) - c[0].x) * (double(c[1].y) - c[0].y));
}

// Checks what every textured result must satisfy: corners, min at 0, size = extent, uv area =
// 3D area, every face with the same (non-mirrored, glTF) orientation.
void expect_well_formed(const Chart& c, const ChartUv& uv) {
  ASSERT_EQ(uv.corner_uv.size(), c.faces.size() * 3);
  float min_u = INFINITY, min_v = INFINITY, max_u = -INFINITY, max_v = -INFINITY;
  double area = 0;
  size_t flipped = 0;
  for (size_t f = 0; f < c.faces.size(); ++f) {
    double a = uv_area(&uv.corner_uv[3 * f]);
    area += std::abs(a);
    flipped += a < 0 ? 0 : 1;
    for (int k = 0; k < 3; ++k) {
      Vec2 p = uv.corner_uv[3 * f + k];
      min_u = std::min(min_u, p.x), min_v = std::min(min_v, p.y);
      max_u = std::max(max_u, p.x), max_v = std::max(max_v, p.y);
    }
  }
  EXPECT_EQ(flipped, 0u);
  EXPECT_FLOAT_EQ(min_u, 0);
  EXPECT_FLOAT_EQ(min_v, 0);
  EXPECT_FLOAT_EQ(uv.size.x, max_u);
  EXPECT_FLOAT_EQ(uv.size.y, max_v);
  EXPECT_NEAR(area, uv.area_3d, 1e-4 * uv.area_3d);
}

// Every uv edge as long as its 3D edge (relative tolerance).
void expect_isometric(const Scene& s, const Chart& c, const ChartUv& uv, double tol) {
  const Primitive& p = s.meshes[0].primitives[0];
  for (size_t f = 0; f < c.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) {
      Vec3 a = p.positions[p.indices[3 * c.faces[f] + k]];
      Vec3 b = p.positions[p.indices[3 * c.faces[f] + (k + 1) % 3]];
      Vec2 u = uv.corner_uv[3 * f + k], w = uv.corner_uv[3 * f + (k + 1) % 3];
      double l3 = length(a - b), l2 = std::hypot(double(u.x) - w.x, double(u.y) - w.y);
      EXPECT_NEAR(l2, l3, tol * l3) << "face " << f << " edge " << k;
    }
}

TEST(Parameterize, PlanarChartIsIsometric) {
  Primitive p = height_field(10, [](float, float) { return 0.0f; });
  // Tilt the plane out of every axis plane.
  double q[4] = {0.3, 0.5, 0.1, 0.8};
  double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  Mat4 r = Mat4::rotation(q[0] / n, q[1] / n, q[2] / n, q[3] / n);
  for (Vec3& v : p.positions) v = r.transform_point(v);
  Scene s = one_primitive(p);
  Chart c = whole(s);
  ChartUv uv = parameterize_chart(s, c);
  expect_well_formed(c, uv);
  EXPECT_TRUE(uv.valid);
  EXPECT_NEAR(uv.area_3d, 4.0, 1e-4);
  EXPECT_NEAR(uv.stretch_l2, 1.0, 1e-3);
  EXPECT_NEAR(uv.stretch_linf, 1.0, 1e-2);
  expect_isometric(s, c, uv, 1e-3);
}

TEST(Parameterize, CurvedCapIsValidWithLowStretch) {
  // A spherical cap of half-angle ~60° over the unit disc... as a height field over the square.
  auto cap = [](float x, float y) { return std::sqrt(std::max(0.0f, 4.0f - x * x - y * y)); };
  Scene s = one_primitive(height_field(24, cap));
  Chart c = whole(s);
  ChartUv lscm_only = parameterize_chart(s, c, {0});
  ChartUv uv = parameterize_chart(s, c);
  expect_well_formed(c, uv);
  EXPECT_TRUE(uv.valid);
  EXPECT_TRUE(std::isfinite(uv.stretch_l2));
  EXPECT_GE(uv.stretch_l2, 1.0);
  EXPECT_LT(uv.stretch_l2, 1.5);
  EXPECT_GE(uv.stretch_linf, uv.stretch_l2 * 0.99);
  // The optimization lowers (never raises) the stretch of the conformal start.
  EXPECT_LE(uv.stretch_l2, lscm_only.stretch_l2 + 1e-9);
}

TEST(Parameterize, SteepHemisphereStaysUnflipped) {
  // A full hemisphere cut as a height field: faces near the rim are almost vertical.
  auto dome = [](float x, float y) {
    return std::sqrt(std::max(0.0f, 1.0f - 0.5f * (x * x + y * y)));
  };
  Scene s = one_primitive(height_field(32, dome));
  Chart c = whole(s);
  ChartUv uv = parameterize_chart(s, c);
  expect_well_formed(c, uv);
  EXPECT_TRUE(uv.valid);
  EXPECT_LT(uv.stretch_l2, 1.5);
}

TEST(Parameterize, SingleTriangleMapsIsometrically) {
  Primitive p;
  p.material = 0;
  p.positions = {{1, 2, 3}, {4, 2, 3}, {1, 2, 7}};  // a 3-4-5 right triangle, normal −y... any
  p.normals.assign(3, {0, -1, 0});
  p.indices = {0, 1, 2};
  Scene s = one_primitive(p);
  Chart c = whole(s);
  ChartUv uv = parameterize_chart(s, c);
  expect_well_formed(c, uv);
  EXPECT_TRUE(uv.valid);
  EXPECT_NEAR(uv.area_3d, 6.0, 1e-9);
  EXPECT_NEAR(uv.stretch_l2, 1.0, 1e-6);
  EXPECT_NEAR(uv.stretch_linf, 1.0, 1e-6);
  auto dist = [&](int i, int j) {
    Vec2 a = uv.corner_uv[size_t(i)], b = uv.corner_uv[size_t(j)];
    return std::hypot(a.x - b.x, a.y - b.y);
  };
  EXPECT_NEAR(dist(0, 1), 3, 1e-5);
  EXPECT_NEAR(dist(0, 2), 4, 1e-5);
  EXPECT_NEAR(dist(1, 2), 5, 1e-5);
}

TEST(Parameterize, FlatColourChartMapsToOnePoint) {
  Scene s = one_primitive(height_field(
      4, [](float x, float) { return x * x; }, 1));
  Chart c = whole(s, false);
  c.color = {0, 1, 0, 1};
  ChartUv uv = parameterize_chart(s, c);
  ASSERT_EQ(uv.corner_uv.size(), c.faces.size() * 3);
  for (Vec2 p : uv.corner_uv) EXPECT_EQ(p, (Vec2{0, 0}));
  EXPECT_EQ(uv.size, (Vec2{0, 0}));
  EXPECT_TRUE(uv.valid);
  EXPECT_GT(uv.area_3d, 4.0);
}

TEST(Parameterize, CornersOnOnePositionShareAUvWhateverTheirWedges) {
  // A quad whose diagonal vertices are duplicated with different input uvs (a seam).
  Primitive p;
  p.material = 0;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  p.normals.assign(6, {0, 0, 1});
  p.uvs = {{{0, 0}, {1, 0}, {1, 1}, {0.5f, 0.5f}, {0.2f, 0.9f}, {0, 1}}};
  p.indices = {0, 1, 2, 3, 4, 5};
  Scene s = one_primitive(p);
  Chart c = whole(s);
  ChartUv uv = parameterize_chart(s, c);
  expect_well_formed(c, uv);
  EXPECT_EQ(uv.corner_uv[0], uv.corner_uv[3]);
  EXPECT_EQ(uv.corner_uv[2], uv.corner_uv[4]);
  EXPECT_NEAR(uv.stretch_l2, 1.0, 1e-4);
  expect_isometric(s, c, uv, 1e-4);
}

TEST(Parameterize, UvIsNotMirroredSeenFromTheFront) {
  // A quad facing +z: seen from +z, x goes right and y goes up, so with glTF's v down the uv
  // image must have u growing with x and v growing with −y (up to a rotation): the signed
  // area in (u, v) is negative, as expect_well_formed checks, for this chart and for the same
  // chart wound the other way (then seen from −z).
  Primitive p;
  p.material = 0;
  p.positions = {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {0, 1, 0}};
  p.normals.assign(4, {0, 0, 1});
  p.indices = {0, 1, 2, 0, 2, 3};
  Scene s = one_primitive(p);
  Chart c = whole(s);
  ChartUv uv = parameterize_chart(s, c);
  expect_well_formed(c, uv);
  EXPECT_TRUE(uv.valid);
  p.indices = {0, 2, 1, 0, 3, 2};
  s = one_primitive(p);
  uv = parameterize_chart(s, c);
  expect_well_formed(c, uv);
  EXPECT_TRUE(uv.valid);
}

TEST(Parameterize, DisconnectedPiecesAreLaidSideBySide) {
  // Two unit quads far apart plus a triangle touching one of them at a single corner (a
  // bowtie): three pieces, each mapped on its own, none overlapping.
  Primitive p;
  p.material = 0;
  p.positions = {{0, 0, 0},    {1, 0, 0},   {1, 1, 0}, {0, 1, 0},  // quad in z = 0
                 {5, 0, 0},    {5, 1, 0},   {5, 1, 1}, {5, 0, 1},  // quad in x = 5
                 {2, 2, 0.5f}, {1, 2, 0.5f}};                      // triangle at corner 2
  p.normals.assign(p.positions.size(), {0, 0, 1});
  p.indices = {0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7, 2, 8, 9};
  Scene s = one_primitive(p);
  Chart c = whole(s);
  ChartUv uv = parameterize_chart(s, c);
  expect_well_formed(c, uv);
  EXPECT_TRUE(uv.valid);
  EXPECT_NEAR(uv.stretch_l2, 1.0, 1e-4);
  expect_isometric(s, c, uv, 1e-4);
}

TEST(Parameterize, OverlappingFlatteningIsReportedInvalid) {
  // A gently rising spiral ribbon of 1.5 turns: a height-field-like chart (every normal near
  // +z) whose flattening must overlap itself.
  Primitive p;
  p.material = 0;
  const int steps = 90;
  for (int i = 0; i <= steps; ++i) {
    double a = 3 * M_PI * i / steps, z = 0.05 * i / steps;
    for (double r : {1.0, 1.4}) {
      p.positions.push_back({float(r * std::cos(a)), float(r * std::sin(a)), float(z)});
      p.normals.push_back({0, 0, 1});
    }
  }
  for (uint32_t i = 0; i < steps; ++i) {
    uint32_t a = 2 * i, b = 2 * i + 1, c = 2 * i + 2, d = 2 * i + 3;
    p.indices.insert(p.indices.end(), {a, c, d, a, d, b});
  }
  Scene s = one_primitive(p);
  Chart c = whole(s);
  ChartUv uv = parameterize_chart(s, c);
  EXPECT_FALSE(uv.valid);
  EXPECT_TRUE(std::isfinite(uv.stretch_l2));
  // Invalid for the overlap alone: no face is flipped.
  for (size_t f = 0; f < c.faces.size(); ++f) EXPECT_LT(uv_area(&uv.corner_uv[3 * f]), 0) << f;
}

TEST(Parameterize, DuckChartsAreValidWithLowStretch) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  ImportOptions io;
  io.decode_images = false;
  auto in = import_scene(testing::shared_model("Duck-dae/duck.dae"), io, nullptr);
  ASSERT_TRUE(in.ok()) << in.status().message();
  Scene s = clean(*in, {});
  ChartSet cs = segment_charts(s);
  ASSERT_FALSE(cs.charts.empty());
  size_t invalid = 0;
  double sum = 0, worst = 0;
  for (const Chart& c : cs.charts) {
    ChartUv uv = parameterize_chart(s, c);
    ASSERT_EQ(uv.corner_uv.size(), c.faces.size() * 3);
    invalid += uv.valid ? 0 : 1;
    sum += uv.stretch_l2;
    worst = std::max(worst, uv.stretch_l2);
  }
  double mean = sum / double(cs.charts.size());
  EXPECT_EQ(invalid, 0u) << "of " << cs.charts.size() << " charts";
  EXPECT_LT(mean, 1.3) << "worst " << worst;
}

}  // namespace
}  // namespace meshmux
