#include "scene/scene.h"

#include <gtest/gtest.h>

namespace meshmux {
namespace {

// A unit quad as two triangles: the smallest mesh that exercises stats and bounds.
Mesh quad() {
  Mesh m;
  Primitive p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  p.indices = {0, 1, 2, 0, 2, 3};
  m.primitives.push_back(p);
  return m;
}

// Stats must count a shared mesh once for unique triangles and once per instance for scene
// triangles; that is the whole point of keeping instancing.
TEST(SceneStats, CountsSharedMeshOncePerInstance) {
  Scene s;
  s.meshes.push_back(quad());
  for (int i = 0; i < 5; ++i) s.instances.push_back({0, Mat4::translation(i, 0, 0), ""});
  SceneStats st = compute_stats(s);
  EXPECT_EQ(st.meshes, 1u);
  EXPECT_EQ(st.instances, 5u);
  EXPECT_EQ(st.unique_triangles, 2u);
  EXPECT_EQ(st.scene_triangles, 10u);
  EXPECT_EQ(st.draw_calls, 1u);  // 5 >= kMinGpuInstances: one instanced draw
}

// Fewer instances than the GPU-instancing threshold cost one draw each.
TEST(SceneStats, FewInstancesCostOneDrawEach) {
  Scene s;
  s.meshes.push_back(quad());
  s.instances.push_back({0, Mat4::identity(), ""});
  s.instances.push_back({0, Mat4::translation(2, 0, 0), ""});
  EXPECT_EQ(compute_stats(s).draw_calls, 2u);
}

// Bounds are taken in world space through each instance's transform.
TEST(SceneBounds, UsesInstanceTransforms) {
  Scene s;
  s.meshes.push_back(quad());
  s.instances.push_back({0, Mat4::translation(10, 0, 0), ""});
  s.instances.push_back({0, Mat4::scale(2, 2, 2), ""});
  Bounds b = scene_bounds(s);
  EXPECT_FLOAT_EQ(b.min.x, 0);
  EXPECT_FLOAT_EQ(b.max.x, 11);
  EXPECT_FLOAT_EQ(b.max.y, 2);
}

// Validation must catch the out-of-range index a hostile file could carry.
TEST(SceneValidate, RejectsIndexOutOfRange) {
  Scene s;
  s.meshes.push_back(quad());
  s.meshes[0].primitives[0].indices[4] = 9;
  s.instances.push_back({0, Mat4::identity(), ""});
  Status st = validate(s, "test");
  ASSERT_FALSE(st.is_ok());
  EXPECT_NE(st.message().find("mesh 0 primitive 0: index 9 out of range (4 vertices)"),
            std::string::npos)
      << st.message();
}

TEST(SceneValidate, RejectsAttributeCountMismatch) {
  Scene s;
  s.meshes.push_back(quad());
  s.meshes[0].primitives[0].normals = {{0, 0, 1}};
  EXPECT_FALSE(validate(s).is_ok());
}

TEST(SceneValidate, AcceptsWellFormedScene) {
  Scene s;
  s.meshes.push_back(quad());
  s.instances.push_back({0, Mat4::identity(), ""});
  EXPECT_TRUE(validate(s).is_ok());
}

// decompose_trs must reproduce the matrix it came from, including a mirror (negative det),
// and must refuse shear, which EXT_mesh_gpu_instancing cannot express.
TEST(MathDecompose, RoundTripsTrsAndRefusesShear) {
  double t[3] = {1, 2, 3}, q[4] = {0.2, -0.3, 0.1, 0}, s[3] = {2, -0.5, 3};
  double n = std::sqrt(0.04 + 0.09 + 0.01 + 0.5 * 0.5);
  q[3] = 0.5;
  for (double& c : q) c /= n;
  Mat4 m = Mat4::trs(t, q, s);
  double t2[3], q2[4], s2[3];
  ASSERT_TRUE(decompose_trs(m, t2, q2, s2));
  Mat4 m2 = Mat4::trs(t2, q2, s2);
  for (int i = 0; i < 16; ++i) EXPECT_NEAR(m.m[size_t(i)], m2.m[size_t(i)], 1e-9) << i;
  Mat4 shear;
  shear.at(0, 1) = 0.5;
  EXPECT_FALSE(decompose_trs(shear, t2, q2, s2));
}

TEST(MathInverse, InverseTimesMatrixIsIdentity) {
  double t[3] = {1, -2, 3}, q[4] = {0, 0.7071067811865476, 0, 0.7071067811865476}, s[3] = {2, 3, 4};
  Mat4 m = Mat4::trs(t, q, s);
  EXPECT_TRUE((m.inverse() * m).is_identity(1e-12));
}

// Normals of rotated instances used to point the wrong way once flattened (the adjugate, ∝ the
// inverse, was applied instead of the inverse transpose: Rᵀ for a rotation R). A normal must turn
// with its surface: rotating the plane x = 0 by 90° about z gives the plane y = 0.
TEST(MathTransformNormal, RotationTurnsNormalsWithTheSurface) {
  const double h = std::sqrt(0.5);
  Mat4 r = Mat4::rotation(0, 0, h, h);  // 90° about +z: x → y
  Vec3 n = r.transform_normal({1, 0, 0});
  EXPECT_NEAR(n.x, 0, 1e-6);
  EXPECT_NEAR(n.y, 1, 1e-6);
  EXPECT_NEAR(n.z, 0, 1e-6);
  // A general rotation: the transformed normal equals the rotated vector.
  double q[4] = {0.2, -0.3, 0.1, 0.5}, t[3] = {0, 0, 0}, one[3] = {1, 1, 1};
  double l = std::sqrt(0.04 + 0.09 + 0.01 + 0.25);
  for (double& c : q) c /= l;
  Mat4 g = Mat4::trs(t, q, one);
  Vec3 v = normalize(Vec3{0.3f, -0.8f, 0.5f});
  Vec3 a = g.transform_normal(v), b = g.transform_vector(v);
  EXPECT_NEAR(a.x, b.x, 1e-6);
  EXPECT_NEAR(a.y, b.y, 1e-6);
  EXPECT_NEAR(a.z, b.z, 1e-6);
}

// Under a non-uniform scale with rotation the normal stays perpendicular to the transformed
// surface: for the plane spanned by e1, e2 with normal e1 × e2, M n ∥ (M e1) × (M e2).
TEST(MathTransformNormal, StaysPerpendicularUnderNonUniformScaleAndMirror) {
  double q[4] = {0.1, 0.4, -0.2, 0.8}, t[3] = {5, 6, 7}, s[3] = {2, -0.5, 3};
  double l = std::sqrt(0.01 + 0.16 + 0.04 + 0.64);
  for (double& c : q) c /= l;
  Mat4 m = Mat4::trs(t, q, s);
  Vec3 e1 = normalize(Vec3{1, 2, 0.5f}), e2 = normalize(Vec3{-0.3f, 0.4f, 1});
  Vec3 n = m.transform_normal(normalize(cross(e1, e2)));
  Vec3 expect = normalize(cross(m.transform_vector(e1), m.transform_vector(e2)));
  // A mirror (det < 0) swaps the winding, so the surface's front normal is −(M e1 × M e2).
  if (m.det3() < 0) expect = expect * -1.0f;
  EXPECT_NEAR(n.x, expect.x, 1e-5);
  EXPECT_NEAR(n.y, expect.y, 1e-5);
  EXPECT_NEAR(n.z, expect.z, 1e-5);
}

}  // namespace
}  // namespace meshmux
