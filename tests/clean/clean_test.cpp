#include "clean/clean.h"

#include <gtest/gtest.h>

#include <cmath>

namespace meshmux {
namespace {

Scene one_primitive(const Primitive& p, size_t instances = 1) {
  Scene s;
  Mesh m;
  m.primitives.push_back(p);
  s.meshes.push_back(m);
  for (size_t i = 0; i < instances; ++i)
    s.instances.push_back({0, Mat4::translation(double(i) * 3, 0, 0), ""});
  return s;
}

// A quad stored as COLLADA importers deliver it: every corner its own vertex. Welding must
// bring it to 4 shared vertices.
TEST(Clean, WeldsVerticesWhoseAttributesAllAgree) {
  Primitive p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  p.normals.assign(6, {0, 0, 1});
  p.indices = {0, 1, 2, 3, 4, 5};
  CleanReport r;
  Scene out = clean(one_primitive(p), {}, &r);
  const Primitive& q = out.meshes[0].primitives[0];
  EXPECT_EQ(q.vertex_count(), 4u);
  EXPECT_EQ(q.triangle_count(), 2u);
  EXPECT_EQ(r.vertices_in, 6u);
  EXPECT_EQ(r.vertices_out, 4u);
}

// Welding compares bits with −0 folded into +0 (an exporter's −0 is the same point); the
// vertices come out in the order the triangles first reach them, which the record's
// determinism rests on.
TEST(Clean, WeldsNegativeZeroAndKeepsFirstOccurrenceOrder) {
  Primitive p;
  p.positions = {{1, 0, 0}, {-0.0f, 0, 0}, {0, 1, 0}, {0, 0, 0}, {1, 0, 0}, {0, 1, -0.0f}};
  p.normals.assign(6, {0, 0, 1});
  p.indices = {0, 2, 1, 4, 5, 3};
  Scene out = clean(one_primitive(p), {});
  const Primitive& q = out.meshes[0].primitives[0];
  ASSERT_EQ(q.vertex_count(), 3u);
  EXPECT_EQ(q.positions[0], (Vec3{1, 0, 0}));
  EXPECT_EQ(q.positions[1], (Vec3{0, 1, 0}));
  EXPECT_EQ(q.positions[2], (Vec3{0, 0, 0}));
  // The second triangle is the first one again: a duplicate after welding.
  EXPECT_EQ(q.triangle_count(), 1u);
  EXPECT_EQ(q.indices, (std::vector<uint32_t>{0, 1, 2}));
}

// Vertices at one position but with different uvs are a texture seam: they must stay apart.
TEST(Clean, KeepsSeamVerticesWithDifferentUvs) {
  Primitive p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  p.normals.assign(6, {0, 0, 1});
  p.uvs = {{{0, 0}, {1, 0}, {1, 1}, {0.5f, 0}, {1, 1}, {0, 1}}};
  p.indices = {0, 1, 2, 3, 4, 5};
  Scene out = clean(one_primitive(p), {});
  EXPECT_EQ(out.meshes[0].primitives[0].vertex_count(), 5u);
}

// Degenerate triangles (repeated corner, coincident positions, zero area) go; the count is
// reported so round-trip checks can account for them.
TEST(Clean, RemovesDegenerateTriangles) {
  Primitive p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}, {1, 0, 0}};
  p.normals.assign(5, {0, 0, 1});
  p.indices = {0, 1, 2,   // good
               0, 0, 1,   // repeated index
               0, 1, 3,   // collinear: zero area
               1, 4, 2};  // vertices 1 and 4 coincide
  CleanReport r;
  Scene out = clean(one_primitive(p), {}, &r);
  EXPECT_EQ(out.meshes[0].primitives[0].triangle_count(), 1u);
  EXPECT_EQ(r.degenerate_removed, 3u);
}

// A repeated triangle in any rotation is a duplicate; the back-to-back twin (reversed
// winding) is real two-sided geometry and stays.
TEST(Clean, RemovesDuplicatesButKeepsBackToBackTwins) {
  Primitive p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  p.indices = {0, 1, 2, 1, 2, 0, 0, 2, 1};
  CleanReport r;
  Scene out = clean(one_primitive(p), {}, &r);
  EXPECT_EQ(r.duplicates_removed, 1u);
  EXPECT_EQ(out.meshes[0].primitives[0].triangle_count(), 2u);
}

TEST(Clean, RemovesUnreferencedVertices) {
  Primitive p;
  p.positions = {{9, 9, 9}, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {7, 7, 7}};
  p.normals.assign(5, {0, 0, 1});
  p.indices = {1, 2, 3};
  Scene out = clean(one_primitive(p), {});
  const Primitive& q = out.meshes[0].primitives[0];
  EXPECT_EQ(q.vertex_count(), 3u);
  EXPECT_EQ(q.positions[0], (Vec3{0, 0, 0}));
}

// A cube without normals: the 90° edges exceed the 60° crease, so each corner splits into
// three vertices with axis-aligned (flat) normals — 24 vertices.
TEST(Clean, GeneratedNormalsKeepHardEdgesAboveCrease) {
  Primitive p;
  for (int i = 0; i < 8; ++i)
    p.positions.push_back({float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1)});
  p.indices = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4,
               2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5};
  CleanReport r;
  Scene out = clean(one_primitive(p), {}, &r);
  const Primitive& q = out.meshes[0].primitives[0];
  EXPECT_EQ(r.primitives_with_generated_normals, 1u);
  ASSERT_EQ(q.normals.size(), q.positions.size());
  EXPECT_EQ(q.vertex_count(), 24u);
  for (size_t t = 0; t < q.triangle_count(); ++t) {
    Vec3 a = q.positions[q.indices[3 * t]], b = q.positions[q.indices[3 * t + 1]],
         c = q.positions[q.indices[3 * t + 2]];
    Vec3 fn = normalize(cross(b - a, c - a));
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(dot(q.normals[q.indices[3 * t + k]], fn), 1.0f, 1e-5);
  }
}

// A finely tessellated cylinder side: neighbouring faces differ by 15°, under the crease, so
// normals are smooth (radial), and seam-duplicated vertices still get the same normal.
TEST(Clean, GeneratedNormalsAreSmoothBelowCrease) {
  Primitive p;
  const int n = 24;
  for (int s = 0; s <= n; ++s)
    for (int h = 0; h < 2; ++h) {
      float a = 2 * float(M_PI) * float(s) / n;
      p.positions.push_back({std::cos(a), float(h), std::sin(a)});
    }
  for (int s = 0; s < n; ++s) {
    uint32_t a = uint32_t(2 * s), b = a + 1, c = a + 2, d = a + 3;
    p.indices.insert(p.indices.end(), {a, b, c, c, b, d});
  }
  Scene out = clean(one_primitive(p), {});
  const Primitive& q = out.meshes[0].primitives[0];
  for (size_t v = 0; v < q.vertex_count(); ++v) {
    Vec3 radial = normalize(Vec3{q.positions[v].x, 0, q.positions[v].z});
    EXPECT_GT(std::abs(dot(q.normals[v], radial)), 0.99f) << v;
  }
}

// Broken normals (zero length) are replaced, not passed to the exporter (the validator would
// reject them).
TEST(Clean, ReplacesZeroNormals) {
  Primitive p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  p.normals = {{0, 0, 1}, {0, 0, 0}, {0, 0, 1}};
  p.indices = {0, 1, 2};
  Scene out = clean(one_primitive(p), {});
  for (Vec3 n : out.meshes[0].primitives[0].normals) EXPECT_NEAR(length(n), 1.0f, 1e-6);
}

// Zero normals on a degenerate (zero-area) triangle, as exporters write them, must not cost the
// primitive its authored normals: those triangles are removed anyway. Once they did, and the
// generated normals (60° crease) smoothed a table's 45° bevels that its file shades flat (lit
// 26 dB against three.js). Here two faces meet at 45° with flat normals of their own, beside a
// degenerate triangle whose corners have zero normals: the faces keep their flat normals.
TEST(Clean, ZeroNormalsOnDegenerateTrianglesKeepTheAuthoredNormals) {
  const Vec3 up{0, 0, 1}, bevel = normalize(Vec3{1, 0, 1});
  Primitive p;
  p.positions = {{0, 0, 0}, {1, 0, 0},  {0, 1, 0},   // flat face, normal +z
                 {1, 0, 0}, {2, 0, -1}, {1, 1, 0},   // bevel face at 45°, below x = 1
                 {3, 3, 3}, {3, 3, 3},  {4, 4, 4}};  // degenerate, zero normals
  p.normals = {up, up, up, bevel, bevel, bevel, {}, {}, {}};
  p.indices = {0, 1, 2, 3, 4, 5, 6, 7, 8};
  CleanReport r;
  Scene out = clean(one_primitive(p), {}, &r);
  const Primitive& q = out.meshes[0].primitives[0];
  EXPECT_EQ(r.degenerate_removed, 1u);
  EXPECT_EQ(r.primitives_with_generated_normals, 0u);
  ASSERT_EQ(q.triangle_count(), 2u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_NEAR(dot(q.normals[q.indices[size_t(k)]], up), 1.0f, 1e-6f) << k;
    EXPECT_NEAR(dot(q.normals[q.indices[size_t(3 + k)]], bevel), 1.0f, 1e-6f) << k;
  }
}

// Cleaning works on the shared mesh: instances survive untouched, and a mesh left empty is
// dropped with its instances.
TEST(Clean, KeepsInstancesAndDropsEmptiedMeshes) {
  Primitive good;
  good.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  good.indices = {0, 1, 2};
  Primitive bad;
  bad.positions = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
  bad.indices = {0, 1, 2};
  Scene s = one_primitive(good, 5);
  Mesh m;
  m.primitives.push_back(bad);
  s.meshes.push_back(m);
  s.instances.push_back({1, Mat4::identity(), "empty"});
  CleanReport r;
  Scene out = clean(s, {}, &r);
  EXPECT_EQ(out.meshes.size(), 1u);
  EXPECT_EQ(out.instances.size(), 5u);
  EXPECT_EQ(r.meshes_dropped, 1u);
}

// The normalization scale maps the scene's bounding-box diagonal to 1 (Terrace, Cheslack-Postava,
// Levis and Freedman, "Unsupervised conversion of 3D models for interactive metaverses" §4.1),
// without touching positions.
TEST(Clean, ComputesNormalizationScale) {
  Primitive p;
  p.positions = {{0, 0, 0}, {3, 0, 0}, {0, 4, 0}};
  p.indices = {0, 1, 2};
  Scene out = clean(one_primitive(p), {});
  EXPECT_NEAR(out.normalization_scale, 1.0 / 5.0, 1e-7);
  EXPECT_EQ(out.meshes[0].primitives[0].positions[1], (Vec3{3, 0, 0}));
}

// Same input, same output: determinism down to the vertex order.
TEST(Clean, IsDeterministic) {
  Primitive p;
  for (int i = 0; i < 8; ++i)
    p.positions.push_back({float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1)});
  p.indices = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4};
  Scene a = clean(one_primitive(p), {}), b = clean(one_primitive(p), {});
  const Primitive &x = a.meshes[0].primitives[0], &y = b.meshes[0].primitives[0];
  EXPECT_EQ(x.indices, y.indices);
  ASSERT_EQ(x.vertex_count(), y.vertex_count());
  for (size_t v = 0; v < x.vertex_count(); ++v) {
    EXPECT_EQ(x.positions[v], y.positions[v]);
    EXPECT_EQ(x.normals[v], y.normals[v]);
  }
}

// A triangle soup of 180k corners (every triangle its own three vertices, as COLLADA and STL
// deliver scans) is welded on every core: the shared grid vertices in the order the triangles
// first reach them, duplicate triangles gone whatever their rotation, as one serial scan makes
// them.
TEST(Clean, LargeSoupWeldsInFirstOccurrenceOrder) {
  const int g = 100;  // g × g cells, two triangles each
  Primitive p;
  auto corner = [&](int x, int y) {
    p.positions.push_back({float(x), float(y), float((x * 7 + y * 3) % 5) * 0.1f});
    p.normals.push_back({0, 0, 1});
    p.indices.push_back(uint32_t(p.indices.size()));
  };
  for (int y = 0; y < g; ++y)
    for (int x = 0; x < g; ++x) {
      corner(x, y), corner(x + 1, y), corner(x + 1, y + 1);
      corner(x, y), corner(x + 1, y + 1), corner(x, y + 1);
    }
  // Every tenth cell's first triangle again, rotated: a duplicate.
  for (int c = 0; c < g * g; c += 10) {
    const int x = c % g, y = c / g;
    corner(x + 1, y + 1), corner(x, y), corner(x + 1, y);
  }
  CleanReport r;
  const Scene out = clean(one_primitive(p), {}, &r);
  const Primitive& q = out.meshes[0].primitives[0];
  EXPECT_EQ(q.vertex_count(), size_t((g + 1) * (g + 1)));
  EXPECT_EQ(q.triangle_count(), size_t(2 * g * g));
  EXPECT_EQ(r.duplicates_removed, size_t(g * g / 10));
  // First-occurrence order: the first cell brings (0,0), (1,0), (1,1), then (0,1); the second
  // cell (2,0) and (2,1).
  ASSERT_GE(q.positions.size(), 6u);
  EXPECT_EQ(q.positions[3].x, 0.0f);
  EXPECT_EQ(q.positions[3].y, 1.0f);
  EXPECT_EQ(q.positions[4].x, 2.0f);
  EXPECT_EQ(q.positions[5].y, 1.0f);
  for (size_t i = 0; i < q.indices.size(); i += 3) {
    const Vec3 a = q.positions[q.indices[i]], b = q.positions[q.indices[i + 1]];
    ASSERT_FALSE(a == b) << "triangle " << i / 3;
  }
}

}  // namespace
}  // namespace meshmux
