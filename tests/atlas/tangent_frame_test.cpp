#include "atlas/tangent_frame.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace meshmux {
namespace {

double angle_deg(DVec3 a, DVec3 b) {
  const double c = dot(normalize(a), normalize(b));
  return std::acos(std::clamp(c, -1.0, 1.0)) * 180 / M_PI;
}

// three.js's getTangentFrame written out from screen-space derivatives: q0, q1 the position's
// derivatives along screen x and y, st0, st1 the uv's. The frame our bake uses must be this one
// for any screen basis that sees the triangle from the front.
TangentFrame three_frame(DVec3 q0, DVec3 q1, Vec2 st0, Vec2 st1, DVec3 n) {
  const DVec3 q1perp = cross(q1, n), q0perp = cross(n, q0);
  const DVec3 t = add(mul(q1perp, st0.x), mul(q0perp, st1.x));
  const DVec3 b = add(mul(q1perp, st0.y), mul(q0perp, st1.y));
  const double det = std::max(dot(t, t), dot(b, b));
  const double s = det == 0 ? 0 : 1 / std::sqrt(det);
  return {mul(t, s), mul(b, s), n};
}

// The simplest case pins the conventions: u along +x, v along +y, seen from +z.
TEST(TangentFrame, AlignedTriangleGivesTheUvAxes) {
  const TangentFrame f = derivative_frame({1, 0, 0}, {0, 1, 0}, {1, 0}, {0, 1}, {0, 0, 1});
  EXPECT_NEAR(f.t.x, 1, 1e-12);
  EXPECT_NEAR(f.b.y, 1, 1e-12);
  // glTF's +y points up the image (against +v), so a map value tilted to +y leans to −y.
  const DVec3 n = apply_normal_map(f, {0, 0.5, 1});
  EXPECT_LT(n.y, 0);
  EXPECT_NEAR(length(n), 1, 1e-12);
}

// Mirrored uvs (u running along −x) flip T: the mirrored half of a model reads its map mirrored.
TEST(TangentFrame, MirroredUvsFlipTheTangent) {
  const TangentFrame f = derivative_frame({1, 0, 0}, {0, 1, 0}, {-1, 0}, {0, 1}, {0, 0, 1});
  EXPECT_NEAR(f.t.x, -1, 1e-12);
  EXPECT_NEAR(f.b.y, 1, 1e-12);
}

// The frame from the triangle's edges equals three.js's from screen derivatives, whatever
// front-facing screen basis the rasterizer has (random triangles, uvs, normals and bases).
TEST(TangentFrame, MatchesThreeJsForAnyFrontFacingScreenBasis) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 200; ++trial) {
    const DVec3 e1{u(rng), u(rng), u(rng)}, e2{u(rng), u(rng), u(rng)};
    const Vec2 d1{float(u(rng)), float(u(rng))}, d2{float(u(rng)), float(u(rng))};
    const DVec3 nf = normalize(cross(e1, e2));
    const DVec3 n = normalize(add(nf, DVec3{0.2 * u(rng), 0.2 * u(rng), 0.2 * u(rng)}));
    // Screen derivatives: q0 = a e1 + b e2, q1 = c e1 + d e2 with ad − bc > 0 (front-facing).
    double a = u(rng), b = u(rng), c = u(rng), d = u(rng);
    if (a * d - b * c < 0) std::swap(a, c), std::swap(b, d);
    if (std::fabs(a * d - b * c) < 1e-3) continue;
    const DVec3 q0 = add(mul(e1, a), mul(e2, b)), q1 = add(mul(e1, c), mul(e2, d));
    const Vec2 st0{float(a * d1.x + b * d2.x), float(a * d1.y + b * d2.y)};
    const Vec2 st1{float(c * d1.x + d * d2.x), float(c * d1.y + d * d2.y)};
    const TangentFrame ours = derivative_frame(e1, e2, d1, d2, n);
    const TangentFrame theirs = three_frame(q0, q1, st0, st1, n);
    const DVec3 m = normalize(DVec3{u(rng), u(rng), 1.5});
    EXPECT_LT(angle_deg(apply_normal_map(ours, m), apply_normal_map(theirs, m)), 1e-3)
        << "trial " << trial;
  }
}

// Encoding is the inverse of shading: the map value the bake stores gives back the normal.
TEST(TangentFrame, EncodeInvertsApply) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 200; ++trial) {
    const DVec3 e1{u(rng), u(rng), u(rng)}, e2{u(rng), u(rng), u(rng)};
    const Vec2 d1{float(u(rng)), float(u(rng))}, d2{float(u(rng)), float(u(rng))};
    const DVec3 n = normalize(cross(e1, e2));
    const TangentFrame f = derivative_frame(e1, e2, d1, d2, n);
    if (length(cross(f.t, f.b)) < 0.05) continue;  // nearly degenerate uvs
    const DVec3 target = normalize(add(n, DVec3{0.4 * u(rng), 0.4 * u(rng), 0.4 * u(rng)}));
    const DVec3 m = encode_normal_map(f, target);
    EXPECT_NEAR(length(m), 1, 1e-9);
    EXPECT_LT(angle_deg(apply_normal_map(f, m), target), 1e-6) << "trial " << trial;
  }
}

// Degenerate uvs leave no frame: the flat map value, which shades with N.
TEST(TangentFrame, DegenerateUvsEncodeFlat) {
  const TangentFrame f = derivative_frame({1, 0, 0}, {0, 1, 0}, {0, 0}, {0, 0}, {0, 0, 1});
  const DVec3 m = encode_normal_map(f, normalize(DVec3{0.3, 0, 1}));
  EXPECT_EQ(m.x, 0);
  EXPECT_EQ(m.y, 0);
  EXPECT_EQ(m.z, 1);
}

}  // namespace
}  // namespace meshmux
