#include "simplify/simplify.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include "clean/clean.h"
#include "importers/import.h"
#include "simplify/lod.h"
#include "simplify/record_checks.h"
#include "test_util.h"

namespace meshmux {
namespace {

using testing::expect_same_record;
using testing::record_on_threads;
using testing::uv_sphere;

// A cube whose faces are n×n grids with one normal per face (flat shading): every edge and
// corner vertex is split per face, so welding on attributes alone leaves no interior to
// collapse across.
Primitive flat_cube(int n) {
  Primitive p;
  const Vec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (const Vec3& nn : axes) {
    Vec3 u = std::abs(nn.y) > 0.5f ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    Vec3 v = cross(nn, u);
    uint32_t base = uint32_t(p.positions.size());
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        float a = -1 + 2 * float(i) / float(n), b = -1 + 2 * float(j) / float(n);
        p.positions.push_back(nn + u * a + v * b);
        p.normals.push_back(nn);
      }
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        uint32_t a = base + uint32_t(j * (n + 1) + i), b = a + 1, c = a + uint32_t(n + 1),
                 d = c + 1;
        p.indices.insert(p.indices.end(), {a, b, d, a, d, c});
      }
  }
  // Orient faces outward.
  for (size_t t = 0; t < p.indices.size(); t += 3) {
    Vec3 A = p.positions[p.indices[t]], B = p.positions[p.indices[t + 1]],
         C = p.positions[p.indices[t + 2]];
    if (dot(cross(B - A, C - A), p.normals[p.indices[t]]) < 0)
      std::swap(p.indices[t + 1], p.indices[t + 2]);
  }
  return p;
}

Scene scene_of(const Primitive& p, std::vector<Mat4> transforms = {Mat4::identity()}) {
  Scene s;
  Mesh m;
  m.primitives.push_back(p);
  s.meshes.push_back(m);
  for (size_t i = 0; i < transforms.size(); ++i)
    s.instances.push_back({0, transforms[i], "instance-" + std::to_string(i)});
  return clean(s, {});
}

// Position-level undirected edges with how many faces use them.
std::map<std::pair<Vec3, Vec3>, int,
         bool (*)(const std::pair<Vec3, Vec3>&, const std::pair<Vec3, Vec3>&)>
edge_counts(const Mesh& mesh) {
  auto less = [](const std::pair<Vec3, Vec3>& a, const std::pair<Vec3, Vec3>& b) {
    auto t = [](const std::pair<Vec3, Vec3>& e) {
      return std::make_tuple(e.first.x, e.first.y, e.first.z, e.second.x, e.second.y, e.second.z);
    };
    return t(a) < t(b);
  };
  std::map<std::pair<Vec3, Vec3>, int,
           bool (*)(const std::pair<Vec3, Vec3>&, const std::pair<Vec3, Vec3>&)>
      m(less);
  auto vless = [](Vec3 a, Vec3 b) {
    return std::make_tuple(a.x, a.y, a.z) < std::make_tuple(b.x, b.y, b.z);
  };
  for (const Primitive& p : mesh.primitives)
    for (size_t t = 0; t < p.indices.size(); t += 3)
      for (int e = 0; e < 3; ++e) {
        Vec3 a = p.positions[p.indices[t + e]], b = p.positions[p.indices[t + (e + 1) % 3]];
        if (vless(b, a)) std::swap(a, b);
        ++m[{a, b}];
      }
  return m;
}

std::vector<size_t> sample_levels(const ProgressiveMesh& pm) {
  std::vector<size_t> out;
  size_t n = pm.levels.size();
  for (size_t k = 0; k < 25; ++k) out.push_back(k * (n - 1) / 24);
  return out;
}

// Every extracted level is a valid mesh with exactly the triangle count the record promises,
// and only uses its vertex prefix.
TEST(Simplify, EveryLevelIsValidWithPromisedCounts) {
  Scene s = scene_of(uv_sphere(24, 32));
  ProgressiveScene ps = build_progressive(s, {});
  const ProgressiveMesh& pm = ps.meshes[0];
  ASSERT_GT(pm.levels.size(), 100u);
  EXPECT_EQ(pm.levels.back().triangles, compute_stats(s).unique_triangles);
  for (size_t l : sample_levels(pm)) {
    std::vector<uint32_t> idx = level_indices(pm, l);
    EXPECT_EQ(idx.size() / 3, pm.levels[l].triangles) << "level " << l;
    for (uint32_t v : idx) ASSERT_LT(v, pm.levels[l].vertex_end) << "level " << l;
    Scene one;
    one.meshes.push_back(extract_level(pm, l));
    one.instances.push_back({0, Mat4::identity(), ""});
    EXPECT_TRUE(validate(one).is_ok()) << validate(one).message();
    EXPECT_EQ(compute_stats(one).unique_triangles, pm.levels[l].triangles);
  }
}

// The layout of Hoppe, "Octaviewer: spherically parameterized progressive meshes": level k's
// vertices are a prefix of level k+1's; parents come earlier; errors never rise with detail.
TEST(Simplify, LevelsArePrefixesWithEarlierParents) {
  Scene s = scene_of(uv_sphere(16, 24));
  ProgressiveScene ps = build_progressive(s, {});
  const ProgressiveMesh& pm = ps.meshes[0];
  for (size_t l = 1; l < pm.levels.size(); ++l) {
    EXPECT_GE(pm.levels[l].vertex_end, pm.levels[l - 1].vertex_end);
    EXPECT_GE(pm.levels[l].face_end, pm.levels[l - 1].face_end);
    EXPECT_LE(pm.levels[l].error, pm.levels[l - 1].error);
  }
  uint32_t base = pm.levels[0].vertex_end;
  for (uint32_t v = 0; v < pm.vertex_count(); ++v) {
    if (v < base)
      EXPECT_EQ(pm.parent[v], v);
    else
      EXPECT_LT(pm.parent[v], v);
  }
  EXPECT_EQ(pm.levels.back().error, 0.0f);
}

// No crack at any level: a closed sphere with a uv seam never shows a boundary edge.
// Every sampled level of a closed primitive's record has each edge in exactly two faces.
void expect_closed_at_every_level(const Primitive& closed) {
  ProgressiveScene ps = build_progressive(scene_of(closed), {});
  const ProgressiveMesh& pm = ps.meshes[0];
  for (size_t l : sample_levels(pm)) {
    for (const auto& [edge, count] : edge_counts(extract_level(pm, l)))
      ASSERT_EQ(count, 2) << "level " << l << " of " << pm.levels.size() << " has an open edge";
  }
}

TEST(Simplify, SeamsNeverCrack) { expect_closed_at_every_level(uv_sphere(20, 28)); }

// The same where more wedges meet at one position than the simplifier compares one by one (its
// classes are looked up by value past 32): the poles of a sphere of 48 segments have 48 wedges
// each, one per u.
TEST(Simplify, SeamsNeverCrackWhereManyWedgesMeet) {
  expect_closed_at_every_level(uv_sphere(12, 48));
}

// An open grid keeps exactly its own border at every level: no new boundary edges, and the
// border does not move inward (boundary vertices slide along it only).
TEST(Simplify, OpenBoundaryGetsNoNewBorderEdges) {
  Primitive grid;
  const int n = 20;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      grid.positions.push_back(
          {float(i), 0.3f * std::sin(float(i) * 0.5f) * std::cos(float(j) * 0.4f), float(j)});
      grid.normals.push_back({0, 1, 0});
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      uint32_t a = uint32_t(j * (n + 1) + i), b = a + 1, c = a + uint32_t(n + 1), d = c + 1;
      grid.indices.insert(grid.indices.end(), {a, c, b, b, c, d});
    }
  Scene s = scene_of(grid);
  ProgressiveScene ps = build_progressive(s, {});
  const ProgressiveMesh& pm = ps.meshes[0];
  Bounds full = mesh_bounds(s.meshes[0]);
  for (size_t l : sample_levels(pm)) {
    Mesh m = extract_level(pm, l);
    for (const auto& [edge, count] : edge_counts(m)) {
      ASSERT_LE(count, 2);
      if (count == 1) {
        // A border edge lies on the grid's rim.
        for (Vec3 v : {edge.first, edge.second})
          EXPECT_TRUE(v.x == full.min.x || v.x == full.max.x || v.z == full.min.z ||
                      v.z == full.max.z)
              << "level " << l;
      }
    }
  }
}

// Azim, Cheslack-Postava and Levis, "Instance-aware simplification of 3D polygonal meshes",
// equation 5: with identity transforms it is the plain quadric; with k identical instances it is k
// times it; with a transform it measures distance in the placed space.
TEST(Simplify, InstanceQuadricWithIdentityEqualsPlainQuadric) {
  Vec3 a{0, 0, 0}, b{2, 0, 0}, c{0, 2, 0};  // plane z = 0, area 2
  auto one = instance_face_quadric(a, b, c, {Mat4::identity()});
  // Plain plane quadric: area · (0,0,1,0)(0,0,1,0)ᵀ.
  std::array<double, 16> plain{};
  plain[10] = 2.0;
  for (int i = 0; i < 16; ++i) EXPECT_DOUBLE_EQ(one[size_t(i)], plain[size_t(i)]) << i;
  auto two = instance_face_quadric(a, b, c, {Mat4::identity(), Mat4::identity()});
  for (int i = 0; i < 16; ++i) EXPECT_DOUBLE_EQ(two[size_t(i)], 2 * plain[size_t(i)]) << i;
  // Placed at z = 5 and scaled 3x: a mesh-space point at z = 1 maps to z = 8, 3 from the
  // placed plane z = 5 whose area is 18: vᵀQv = 18 · 3².
  auto placed = instance_face_quadric(a, b, c, {Mat4::translation(0, 0, 5) * Mat4::scale(3, 3, 3)});
  double v[4] = {0.3, -0.7, 1, 1}, e = 0;
  for (int r = 0; r < 4; ++r)
    for (int k = 0; k < 4; ++k) e += v[r] * placed[size_t(r * 4 + k)] * v[k];
  EXPECT_NEAR(e, 18.0 * 9.0, 1e-9);
}

// Azim et al. equation 4 for a general affine placement (non-uniform scale and shear): the
// simplifier's factorized form must equal Tᵀ Q(T·face) T computed the long way.
TEST(Simplify, InstanceQuadricMatchesBruteForceForShear) {
  Vec3 a{0.1f, 0.2f, 0.3f}, b{1.5f, -0.4f, 0.2f}, c{0.3f, 1.1f, 0.9f};
  Mat4 M = Mat4::translation(2, -1, 4) * Mat4::scale(1, 3, 0.5);
  M.at(0, 1) = 0.7;                // shear
  Mat4 N = Mat4::scale(-2, 1, 1);  // a mirror
  auto fast = instance_face_quadric(a, b, c, {M, N});
  std::array<double, 16> brute{};
  for (const Mat4& T : {M, N}) {
    Vec3 A = T.transform_point(a), B = T.transform_point(b), C = T.transform_point(c);
    double e1[3] = {double(B.x) - A.x, double(B.y) - A.y, double(B.z) - A.z};
    double e2[3] = {double(C.x) - A.x, double(C.y) - A.y, double(C.z) - A.z};
    double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                   e1[0] * e2[1] - e1[1] * e2[0]};
    double len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    double p[4] = {n[0] / len, n[1] / len, n[2] / len, 0};
    p[3] = -(p[0] * A.x + p[1] * A.y + p[2] * A.z);
    double area = 0.5 * len, Q[4][4], R[4][4] = {};
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) Q[i][j] = area * p[i] * p[j];
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j)
        for (int k = 0; k < 4; ++k)
          for (int l = 0; l < 4; ++l) R[i][j] += T.at(k, i) * Q[k][l] * T.at(l, j);
    for (int i = 0; i < 16; ++i) brute[size_t(i)] += R[i / 4][i % 4];
  }
  // The corners went through float on the brute-force side: compare relatively.
  for (int i = 0; i < 16; ++i)
    EXPECT_NEAR(fast[size_t(i)], brute[size_t(i)], 1e-5 * (1 + std::abs(brute[size_t(i)]))) << i;
}

// The smallest closed mesh: 4 triangles, outward-facing.
Primitive tetrahedron() {
  Primitive tet;
  tet.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  tet.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  return tet;
}

// A submesh never vanishes: a 4-triangle tetrahedron instanced 500 times keeps at least one
// triangle per submesh at its coarsest, and a tiny target thins instances instead.
TEST(Simplify, SubmeshNeverVanishesAndThinningScalesUp) {
  const Primitive tet = tetrahedron();
  std::vector<Mat4> places;
  for (int i = 0; i < 500; ++i)
    places.push_back(Mat4::translation((i % 25) * 3.0, 0, (i / 25) * 3.0));
  Scene s = scene_of(tet, places);
  ProgressiveScene ps = build_progressive(s, {});
  EXPECT_FALSE(ps.flattened);
  EXPECT_GE(ps.meshes[0].levels[0].triangles, 1u);
  LodSelection sel = select_triangles(ps, 400);  // less than one triangle per instance
  EXPECT_LE(selection_triangles(ps, sel), 400u);
  EXPECT_GE(sel.instances[0], 1u);
  EXPECT_LT(sel.instances[0], 500u);
  Scene out = materialize(ps, sel);
  ASSERT_EQ(out.instances.size(), sel.instances[0]);
  // Kept instances are scaled up by sqrt(n/m) to preserve the total area.
  double expected = std::sqrt(500.0 / double(sel.instances[0]));
  EXPECT_NEAR(std::cbrt(out.instances[0].world.det3()), expected, 1e-6);
  // Thinned instances return in a fixed refinement order: a larger budget keeps a superset.
  LodSelection more = select_triangles(ps, 800);
  Scene out2 = materialize(ps, more);
  ASSERT_GT(out2.instances.size(), out.instances.size());
  std::set<std::string> kept2;
  for (const Instance& i : out2.instances) kept2.insert(i.name);
  for (const Instance& i : out.instances) EXPECT_TRUE(kept2.count(i.name)) << i.name;
}

// The multiplexer frames its views by selection_bounds, which reads the record instead of making
// the scene (the full detail of a 20M-triangle scan is 640 MB): it must give the box of what
// materialize draws, at the full detail, at a coarse level, and with thinned instances (scaled
// up about their centres, so the box grows past the instances' own).
TEST(Simplify, SelectionBoundsAreTheMaterializedScenesBox) {
  const Primitive tet = tetrahedron();
  std::vector<Mat4> places;
  for (int i = 0; i < 60; ++i)
    places.push_back(Mat4::translation((i % 8) * 3.0, 0.5 * (i % 3), (i / 8) * 3.0));
  Scene s = scene_of(tet, places);
  Mesh sphere;
  sphere.primitives.push_back(testing::uv_sphere(24, 16));  // a second submesh, refined
  s.meshes.push_back(sphere);
  s.instances.push_back({1, Mat4::translation(-4, 2, 1) * Mat4::scale(2, 1, 3), "sphere"});
  ProgressiveScene ps = build_progressive(s, {});
  for (const LodSelection& sel : {select_full(ps), select_base(ps), select_triangles(ps, 40)}) {
    const Bounds want = scene_bounds(materialize(ps, sel, false, false));
    const Bounds got = selection_bounds(ps, sel);
    ASSERT_FALSE(want.empty());
    EXPECT_EQ(got.min, want.min);
    EXPECT_EQ(got.max, want.max);
  }
  EXPECT_LT(select_triangles(ps, 40).instances[0], 60u);  // the thinned case was among them
}

// The three level lookups of the record: by vertex count, triangle budget and error.
TEST(Simplify, LevelLookupsByVerticesTrianglesAndError) {
  Scene s = scene_of(uv_sphere(16, 24));
  ProgressiveScene ps = build_progressive(s, {});
  const ProgressiveMesh& pm = ps.meshes[0];
  size_t mid = pm.levels.size() / 2;
  const ProgressiveLevel& m = pm.levels[mid];
  EXPECT_EQ(level_for_vertices(pm, m.vertex_end), mid);
  EXPECT_LE(pm.levels[level_for_vertices(pm, m.vertex_end - 1)].vertex_end, m.vertex_end - 1);
  size_t lt = level_for_triangles(pm, m.triangles);
  EXPECT_LE(pm.levels[lt].triangles, m.triangles);
  if (lt + 1 < pm.levels.size()) {
    EXPECT_GT(pm.levels[lt + 1].triangles, m.triangles);
  }
  size_t le = level_for_error(pm, m.error);
  EXPECT_LE(pm.levels[le].error, m.error);
  EXPECT_LE(le, mid);
  if (le > 0) {
    EXPECT_GT(pm.levels[le - 1].error, m.error);
  }
  EXPECT_EQ(level_for_error(pm, 0.0f), pm.levels.size() - 1);
}

// Fewer than 1.75 instances per submesh: flatten and simplify as one mesh (Azim et al. §4).
TEST(Simplify, FewInstancesPerSubmeshTakeTheFlattenPath) {
  Scene s;
  Primitive tri;
  tri.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  tri.indices = {0, 1, 2};
  for (int m = 0; m < 2; ++m) {
    Mesh mesh;
    mesh.primitives.push_back(tri);
    s.meshes.push_back(mesh);
  }
  s.instances = {{0, Mat4::identity(), ""},
                 {0, Mat4::translation(2, 0, 0), ""},
                 {1, Mat4::translation(4, 0, 0), ""}};
  SimplifyReport r;
  ProgressiveScene ps = build_progressive(clean(s, {}), {}, &r);
  EXPECT_NEAR(r.instances_per_submesh, 1.5, 1e-12);
  EXPECT_TRUE(ps.flattened);
  EXPECT_EQ(ps.scene.meshes.size(), 1u);
  EXPECT_EQ(ps.scene.instances.size(), 1u);
  EXPECT_EQ(compute_stats(materialize(ps, select_full(ps))).scene_triangles, 3u);
  // Two instances per submesh (≥ 1.75) keep instancing.
  s.instances.push_back({1, Mat4::translation(6, 0, 0), ""});
  EXPECT_FALSE(build_progressive(clean(s, {}), {}).flattened);
}

// Flat-shaded input (a normal per face) simplifies like smooth input: the subdivided cube
// reaches 20% of its triangles.
TEST(Simplify, FlatShadedCubeReaches20Percent) {
  Scene s = scene_of(flat_cube(8));
  uint64_t full = compute_stats(s).scene_triangles;  // 6 * 8 * 8 * 2 = 768
  ProgressiveScene ps = build_progressive(s, {});
  LodSelection sel = select_triangles(ps, full / 5);
  Scene out = materialize(ps, sel);
  EXPECT_LE(compute_stats(out).scene_triangles, full / 5);
  EXPECT_GT(compute_stats(out).scene_triangles, 0u);
  // Still a cube: the bounds survive (corners are kept by the quadrics).
  Bounds b = scene_bounds(out);
  EXPECT_NEAR(b.min.x, -1, 1e-6);
  EXPECT_NEAR(b.max.y, 1, 1e-6);
}

// Faceted geometry (every triangle its own three vertices, as flat-shaded game levels come):
// each collapse removes two faces whose far corners' vertices then serve no face, and those
// used to stay in the base's vertex prefix. A faceted 58k-triangle level's base held 45.6k
// vertices for 3,964 triangles (its stream base 4x its Draco twin's bytes). Now at the
// coarsest and the base level every vertex of the prefix is used by a face of that level, and
// every level still only uses its prefix.
TEST(Simplify, FacetedBasePrefixHoldsOnlyUsedVertices) {
  Primitive p;
  const int n = 24;
  uint32_t seed = 7;
  auto height = [&]() {
    seed = seed * 1664525u + 1013904223u;
    return 0.3f * float(seed >> 8) / float(1u << 24);
  };
  std::vector<float> h((n + 1) * (n + 1));
  for (float& v : h) v = height();
  auto at = [&](int i, int j) {
    return Vec3{float(i) / n, h[size_t(j * (n + 1) + i)], float(j) / n};
  };
  auto tri = [&](Vec3 a, Vec3 b, Vec3 c) {
    const Vec3 nn = normalize(cross(b - a, c - a));
    for (Vec3 q : {a, b, c}) {
      p.indices.push_back(uint32_t(p.positions.size()));
      p.positions.push_back(q);
      p.normals.push_back(nn);
    }
  };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      tri(at(i, j), at(i, j + 1), at(i + 1, j + 1));
      tri(at(i, j), at(i + 1, j + 1), at(i + 1, j));
    }
  Scene s = scene_of(p);
  ProgressiveScene ps = build_progressive(s, {});
  const ProgressiveMesh& pm = ps.meshes[0];
  ASSERT_GT(pm.levels.size(), 200u);
  for (size_t l : {size_t(0), pm.base_level}) {
    std::vector<uint32_t> idx = level_indices(pm, l);
    std::vector<char> used(pm.levels[l].vertex_end, 0);
    for (uint32_t v : idx) {
      ASSERT_LT(v, pm.levels[l].vertex_end) << "level " << l;
      used[v] = 1;
    }
    EXPECT_EQ(size_t(std::count(used.begin(), used.end(), 0)), 0u)
        << "level " << l << ": " << pm.levels[l].vertex_end << " vertices for "
        << pm.levels[l].triangles << " triangles";
  }
  for (size_t l : sample_levels(pm))
    for (uint32_t v : level_indices(pm, l)) ASSERT_LT(v, pm.levels[l].vertex_end) << l;
  for (uint32_t v = pm.levels[0].vertex_end; v < pm.vertex_count(); ++v) ASSERT_LT(pm.parent[v], v);
}

// A real flat-shaded CAD model (split normals at every crease) reaches 20% too, keeping its
// instancing.
TEST(Simplify, CylinderEngineReaches20PercentKeepingInstances) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  auto in =
      import_scene(testing::shared_model("2CylinderEngine-glb/2CylinderEngine.glb"), {}, nullptr);
  ASSERT_TRUE(in.ok());
  Scene s = clean(*in, {});
  uint64_t full = compute_stats(s).scene_triangles;
  ProgressiveScene ps = build_progressive(s, {});
  EXPECT_FALSE(ps.flattened);
  Scene out = materialize(ps, select_triangles(ps, full / 5));
  SceneStats st = compute_stats(out);
  EXPECT_LE(st.scene_triangles, full / 5);
  EXPECT_GE(st.scene_triangles, full / 5 * 9 / 10);
  EXPECT_EQ(st.instances, 67u);
  EXPECT_EQ(st.meshes, 29u);
}

// The same scene gives the same record.
TEST(Simplify, IsDeterministic) {
  Scene s = scene_of(uv_sphere(12, 16));
  ProgressiveMesh a = build_progressive(s, {}).meshes[0], b = build_progressive(s, {}).meshes[0];
  EXPECT_EQ(a.indices, b.indices);
  EXPECT_EQ(a.parent, b.parent);
  ASSERT_EQ(a.levels.size(), b.levels.size());
  for (size_t i = 0; i < a.levels.size(); ++i) EXPECT_EQ(a.levels[i].error, b.levels[i].error);
}

// The collapse loop costs on every core; the record must not depend on how many there are
// (determinism whatever the thread count). The sphere is large enough (16k triangles) for the
// first passes to re-cost thousands of positions in several chunks on several threads.
TEST(Simplify, RecordIsTheSameWhateverTheThreadCount) {
  const Scene s = scene_of(uv_sphere(64, 128));
  expect_same_record(record_on_threads(s, {}, "1"), record_on_threads(s, {}, "3"));
}

// A scan's vertices and triangles come in no spatial order; the simplifier puts its working
// copy in spatial order first. The input's order must not change what the record is: the same
// input shuffled gives levels of the same triangle counts with errors within a few percent (the
// order decides only ties and the rounding of sums), and every vertex keeps its own source
// attributes (a wrong mapping back from the working order would pair positions with other
// vertices' normals).
TEST(Simplify, InputOrderDoesNotChangeTheRecord) {
  Primitive p = uv_sphere(40, 80);
  Primitive shuffled = p;
  std::vector<uint32_t> perm(p.positions.size());
  for (uint32_t i = 0; i < perm.size(); ++i) perm[i] = i;
  std::mt19937 rng(7);
  std::shuffle(perm.begin(), perm.end(), rng);
  for (uint32_t i = 0; i < perm.size(); ++i) {
    shuffled.positions[perm[i]] = p.positions[i];
    shuffled.normals[perm[i]] = p.normals[i];
    for (size_t s = 0; s < p.uvs.size(); ++s) shuffled.uvs[s][perm[i]] = p.uvs[s][i];
  }
  std::vector<std::array<uint32_t, 3>> tris;
  for (size_t t = 0; t < p.indices.size(); t += 3)
    tris.push_back({perm[p.indices[t]], perm[p.indices[t + 1]], perm[p.indices[t + 2]]});
  std::shuffle(tris.begin(), tris.end(), rng);
  shuffled.indices.clear();
  for (const auto& t : tris) shuffled.indices.insert(shuffled.indices.end(), t.begin(), t.end());
  ProgressiveMesh a = build_progressive(scene_of(p), {}).meshes[0];
  ProgressiveMesh b = build_progressive(scene_of(shuffled), {}).meshes[0];
  ASSERT_EQ(a.face_count(), b.face_count());
  // The level at 20% of the triangles, and the coarsest.
  for (double share : {0.2, 0.0}) {
    auto at = [&](const ProgressiveMesh& pm) {
      size_t i = 0;
      while (i + 1 < pm.levels.size() && pm.levels[i].triangles < share * pm.face_count()) ++i;
      return pm.levels[i];
    };
    ProgressiveLevel la = at(a), lb = at(b);
    EXPECT_NEAR(double(la.triangles), double(lb.triangles), 0.01 * double(a.face_count()) + 2);
    EXPECT_NEAR(la.error, lb.error, 0.05 * la.error + 1e-7) << "share " << share;
  }
  // Each vertex's normal is its own position's (a unit sphere about the origin).
  for (size_t v = 0; v < b.positions.size(); ++v)
    ASSERT_GT(dot(b.normals[v], normalize(b.positions[v])), 0.999f) << "vertex " << v;
}

// Small models ship whole: the base level is the full mesh (Terrace, Cheslack-Postava, Levis and
// Freedman, "Unsupervised conversion of 3D models for interactive metaverses" §4.5).
TEST(Simplify, SmallModelsShipWhole) {
  Scene s = scene_of(uv_sphere(12, 16));
  ProgressiveScene ps = build_progressive(s, {});
  EXPECT_EQ(ps.meshes[0].base_level, ps.meshes[0].levels.size() - 1);
}

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// The record holds the only copy of the geometry it was made from: ps.scene keeps materials,
// instances and names for materialize(), its primitives no vertex data (at millions of
// triangles a second copy would cost as much as the record), and the full level is still
// the input.
TEST(Simplify, RecordKeepsTheOnlyCopyOfTheGeometry) {
  Scene s;
  Mesh mesh;
  mesh.name = "ball";
  mesh.primitives.push_back(testing::uv_sphere(12, 16));
  mesh.primitives[0].material = 0;
  s.meshes.push_back(mesh);
  s.materials.push_back(Material{});
  for (int i = 0; i < 3; ++i) s.instances.push_back({0, Mat4::translation(2.0 * i, 0, 0), ""});
  Scene cleaned = clean(s, {});
  ProgressiveScene ps = build_progressive(cleaned, {});
  ASSERT_EQ(ps.scene.meshes.size(), 1u);
  EXPECT_EQ(ps.scene.meshes[0].name, "ball");
  ASSERT_EQ(ps.scene.meshes[0].primitives.size(), 1u);
  EXPECT_TRUE(ps.scene.meshes[0].primitives[0].positions.empty());
  EXPECT_TRUE(ps.scene.meshes[0].primitives[0].indices.empty());
  EXPECT_EQ(ps.scene.meshes[0].primitives[0].material, 0);
  EXPECT_EQ(ps.scene.instances.size(), 3u);
  Scene full = materialize(ps, select_full(ps));
  EXPECT_EQ(compute_stats(full).scene_triangles, compute_stats(cleaned).scene_triangles);
  EXPECT_EQ(full.meshes[0].name, "ball");
}

// Every shared model (CAD with slivers, scans with holes, seams, instancing, skins): the
// record builds, every sampled level is a valid mesh with the promised triangle count, and the
// full level is the cleaned input.
class SimplifySharedModel : public ::testing::TestWithParam<const char*> {};

TEST_P(SimplifySharedModel, RecordIsValidAtEveryLevel) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  auto in = import_scene(testing::shared_model(GetParam()), {}, nullptr);
  ASSERT_TRUE(in.ok()) << in.status().message();
  Scene cleaned = clean(*in, {});
  ProgressiveScene ps = build_progressive(cleaned, {});
  EXPECT_EQ(compute_stats(materialize(ps, select_full(ps))).scene_triangles,
            compute_stats(cleaned).scene_triangles);
  for (const ProgressiveMesh& pm : ps.meshes) {
    ASSERT_FALSE(pm.levels.empty());
    EXPECT_LE(pm.base_level, pm.levels.size() - 1);
    for (size_t l : sample_levels(pm)) {
      Scene one;
      one.materials = ps.scene.materials;
      one.images = ps.scene.images;
      one.meshes.push_back(extract_level(pm, l));
      one.instances.push_back({0, Mat4::identity(), ""});
      ASSERT_TRUE(validate(one).is_ok()) << validate(one).message();
      ASSERT_EQ(compute_stats(one).unique_triangles, pm.levels[l].triangles) << "level " << l;
    }
  }
  Scene base = materialize(ps, select_base(ps));
  EXPECT_TRUE(validate(base).is_ok());
  EXPECT_GT(compute_stats(base).scene_triangles, 0u);
}

INSTANTIATE_TEST_SUITE_P(
    Shared, SimplifySharedModel,
    ::testing::Values("2CylinderEngine-dae/2CylinderEngine.dae", "Avocado-gltf/Avocado.gltf",
                      "BoxVertexColors-glb/BoxVertexColors.glb",
                      "CesiumMilkTruck-dae/CesiumMilkTruck.dae",
                      "ConcavePolygon-dae/ConcavePolygon.dae",
                      "DamagedHelmet-glb/DamagedHelmet.glb", "Duck-dae/duck.dae", "Fox-glb/Fox.glb",
                      "SheenChair-gltf/SheenChair.gltf",
                      "SimpleInstancing-gltf/SimpleInstancing.gltf", "StanfordBunny-glb/bunny.glb",
                      "TeapotInstanceNodes-dae/teapot_instancenodes.DAE"),
    [](const auto& info) { return testing::model_test_name(info.param); });

}  // namespace
}  // namespace meshmux
