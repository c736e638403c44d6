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

}  // namespace
}  // namespace meshmux
