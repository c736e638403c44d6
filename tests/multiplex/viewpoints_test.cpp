#include "multiplex/viewpoints.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <utility>

namespace meshmux {
namespace {

constexpr double kPi = 3.14159265358979323846;

// The counts the subdivision must give: V = 2 + F/2 with F = 4·4^layers.
TEST(Viewpoints, CountsPerLayer) {
  const size_t expected_v[] = {4, 10, 34, 130};
  for (int layers = 0; layers < 4; ++layers) {
    ViewingSphere s = viewing_sphere(layers);
    EXPECT_EQ(s.directions.size(), expected_v[layers]) << "layers " << layers;
    EXPECT_EQ(s.triangles.size(), size_t(4) << (2 * layers)) << "layers " << layers;
  }
}

TEST(Viewpoints, DirectionsAreUnit) {
  ViewingSphere s = viewing_sphere(3);
  for (Vec3 d : s.directions) EXPECT_NEAR(length(d), 1.0, 1e-6);
}

TEST(Viewpoints, TrianglesWindOutward) {
  for (int layers = 0; layers < 4; ++layers) {
    ViewingSphere s = viewing_sphere(layers);
    for (const auto& t : s.triangles) {
      Vec3 a = s.directions[t[0]], b = s.directions[t[1]], c = s.directions[t[2]];
      EXPECT_GT(dot(cross(b - a, c - a), a + b + c), 0.0f) << "layers " << layers;
    }
  }
}

// Closed, consistently oriented mesh: every undirected edge in exactly two triangles, and
// each directed edge once (the two neighbours traverse it in opposite directions).
TEST(Viewpoints, MeshIsClosed) {
  for (int layers = 0; layers < 4; ++layers) {
    ViewingSphere s = viewing_sphere(layers);
    std::map<std::pair<uint32_t, uint32_t>, int> undirected, directed;
    for (const auto& t : s.triangles) {
      for (int k = 0; k < 3; ++k) {
        uint32_t i = t[k], j = t[(k + 1) % 3];
        ASSERT_NE(i, j);
        ++undirected[{std::min(i, j), std::max(i, j)}];
        ++directed[{i, j}];
      }
    }
    for (const auto& [e, n] : undirected) EXPECT_EQ(n, 2) << "layers " << layers;
    for (const auto& [e, n] : directed) EXPECT_EQ(n, 1) << "layers " << layers;
    // Euler characteristic of a sphere.
    EXPECT_EQ(int(s.directions.size()) - int(undirected.size()) + int(s.triangles.size()), 2);
  }
}

TEST(Viewpoints, Deterministic) {
  ViewingSphere a = viewing_sphere(3), b = viewing_sphere(3);
  ASSERT_EQ(a.directions.size(), b.directions.size());
  for (size_t i = 0; i < a.directions.size(); ++i) EXPECT_EQ(a.directions[i], b.directions[i]);
  EXPECT_EQ(a.triangles, b.triangles);
  // Layers refine: the coarser layer's directions are a prefix of the finer one's.
  ViewingSphere c = viewing_sphere(2);
  for (size_t i = 0; i < c.directions.size(); ++i) EXPECT_EQ(c.directions[i], a.directions[i]);
}

// The camera sits on the ray from the bounds centre along d, and the bounding sphere's
// angular radius, on the image plane, is `fill` of the smaller viewport half-extent.
TEST(Viewpoints, CameraFramesBoundingSphere) {
  Bounds b;
  b.add(Vec3{-1, 2, 3});
  b.add(Vec3{3, 4, 5});
  const Vec3 centre = b.center();
  const double radius = 0.5 * b.diagonal();
  ViewOptions opt;
  opt.fov_y_degrees = 45;
  opt.fill = 0.8f;
  ViewingSphere s = viewing_sphere(2);
  for (float aspect : {1.0f, 16.0f / 9.0f, 0.5f}) {
    for (Vec3 d : s.directions) {
      Camera cam = camera_for(d, b, aspect, opt);
      EXPECT_EQ(cam.target, centre);
      Vec3 offset = cam.eye - centre;
      double distance = length(offset);
      // On the ray: the offset is parallel to d and points the same way.
      EXPECT_NEAR(dot(normalize(offset), d), 1.0, 1e-5);
      // Up is not parallel to the view direction.
      EXPECT_LT(std::fabs(dot(normalize(cam.up), d)), 0.995f);
      // Angle subtended by the sphere vs the intended fraction of the field of view.
      double half_angle = std::asin(radius / distance);
      double half_fov = opt.fov_y_degrees * kPi / 360.0;
      double fraction = std::tan(half_angle) / (std::tan(half_fov) * std::min(1.0f, aspect));
      EXPECT_NEAR(fraction / opt.fill, 1.0, 0.01) << "aspect " << aspect;
      // The whole sphere lies between near and far.
      EXPECT_LT(cam.near_plane, distance - radius);
      EXPECT_GT(cam.far_plane, distance + radius);
      EXPECT_GT(cam.near_plane, 0.0f);
    }
  }
}

TEST(Viewpoints, CameraUpAvoidsVerticalDirection) {
  Bounds b;
  b.add(Vec3{-1, -1, -1});
  b.add(Vec3{1, 1, 1});
  for (Vec3 d : {Vec3{0, 1, 0}, Vec3{0, -1, 0}}) {
    Camera cam = camera_for(d, b, 1.0f);
    EXPECT_EQ(cam.up, (Vec3{0, 0, 1}));
  }
  EXPECT_EQ(camera_for(Vec3{1, 0, 0}, b, 1.0f).up, (Vec3{0, 1, 0}));
}

TEST(Viewpoints, CameraForEmptyBoundsUsesUnitRadius) {
  Bounds empty;
  Camera cam = camera_for(Vec3{0, 0, 1}, empty, 1.0f);
  EXPECT_TRUE(std::isfinite(cam.eye.z));
  EXPECT_GT(cam.eye.z, 1.0f);
  EXPECT_EQ(cam.target, (Vec3{0, 0, 0}));
}

TEST(Viewpoints, LocateAtVertexGivesThatVertex) {
  ViewingSphere s = viewing_sphere(2);
  for (uint32_t v = 0; v < s.directions.size(); ++v) {
    auto [t, w] = locate_view(s, s.directions[v]);
    ASSERT_LT(t, s.triangles.size());
    const auto& tri = s.triangles[t];
    int slot = -1;
    for (int k = 0; k < 3; ++k)
      if (tri[k] == v) slot = k;
    ASSERT_GE(slot, 0) << "vertex " << v << " not in the located triangle";
    EXPECT_NEAR(w[slot], 1.0, 1e-5);
    EXPECT_NEAR(w[0] + w[1] + w[2], 1.0, 1e-6);
  }
}

TEST(Viewpoints, LocateAtCentroidGivesThirds) {
  ViewingSphere s = viewing_sphere(2);
  for (uint32_t t = 0; t < s.triangles.size(); ++t) {
    const auto& tri = s.triangles[t];
    Vec3 c = normalize(s.directions[tri[0]] + s.directions[tri[1]] + s.directions[tri[2]]);
    auto [found, w] = locate_view(s, c);
    EXPECT_EQ(found, t);
    for (float x : w) EXPECT_NEAR(x, 1.0 / 3, 1e-5);
  }
}

TEST(Viewpoints, LocateWeightsAreValidEverywhere) {
  ViewingSphere s = viewing_sphere(1);
  for (int i = 0; i < 200; ++i) {
    // A deterministic spread of directions (Fibonacci sphere).
    double z = 1 - (i + 0.5) * 2 / 200, r = std::sqrt(1 - z * z), phi = i * 2.399963229728653;
    Vec3 d{float(r * std::cos(phi)), float(r * std::sin(phi)), float(z)};
    auto [t, w] = locate_view(s, d);
    ASSERT_LT(t, s.triangles.size());
    for (float x : w) EXPECT_GE(x, 0.0f);
    EXPECT_NEAR(w[0] + w[1] + w[2], 1.0, 1e-5);
    // The weights reconstruct a point on the ray through d.
    const auto& tri = s.triangles[t];
    Vec3 p =
        s.directions[tri[0]] * w[0] + s.directions[tri[1]] * w[1] + s.directions[tri[2]] * w[2];
    EXPECT_NEAR(dot(normalize(p), d), 1.0, 1e-5);
  }
}

// Tables holding a linear function of direction (two entries: f(d) and g(d)). At a vertex the
// interpolation returns that vertex's table exactly; elsewhere it is close (the planar
// triangle lies inside the sphere, so linear functions are reproduced up to the scale
// between the ray's hit point and the unit direction).
TEST(Viewpoints, InterpolateTableLinearFunction) {
  ViewingSphere s = viewing_sphere(3);
  auto f = [](Vec3 d) { return 2.0 + 0.5 * d.x - 0.25 * d.y + 0.75 * d.z; };
  auto g = [](Vec3 d) { return -1.0 + 3.0 * d.x + d.y; };
  std::vector<std::vector<double>> tables;
  for (Vec3 d : s.directions) tables.push_back({f(d), g(d)});

  for (uint32_t v = 0; v < s.directions.size(); ++v) {
    auto out = interpolate_table(s, tables, s.directions[v]);
    ASSERT_EQ(out.size(), 2u);
    EXPECT_NEAR(out[0], tables[v][0], 1e-5);
    EXPECT_NEAR(out[1], tables[v][1], 1e-5);
  }
  for (int i = 0; i < 100; ++i) {
    double z = 1 - (i + 0.5) * 2 / 100, r = std::sqrt(1 - z * z), phi = i * 2.399963229728653;
    Vec3 d{float(r * std::cos(phi)), float(r * std::sin(phi)), float(z)};
    auto out = interpolate_table(s, tables, d);
    ASSERT_EQ(out.size(), 2u);
    // Error = (1 - |p|)·|k·d| for the hit point p of the ray on the triangle's plane; on
    // layer 3 every plane is more than 0.9 from the centre (|k_f| ≈ 0.94, |k_g| ≈ 3.16).
    EXPECT_NEAR(out[0], f(d), 0.1 * 0.94);
    EXPECT_NEAR(out[1], g(d), 0.1 * 3.17);
  }
  // Mismatched tables: nothing to blend.
  tables.pop_back();
  EXPECT_TRUE(interpolate_table(s, tables, Vec3{0, 0, 1}).empty());
}

}  // namespace
}  // namespace meshmux
