#include "clean/flatten.h"

#include <gtest/gtest.h>

namespace meshmux {
namespace {

// Two placements of one triangle, one of them mirrored: flattening keeps every triangle,
// places it in world space, and flips the mirrored copy's winding so it still faces out.
TEST(Flatten, ExpandsInstancesAndKeepsMirroredFacesFront) {
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
  s.instances.push_back({0, Mat4::translation(5, 0, 0), "a"});
  s.instances.push_back({0, Mat4::scale(-1, 1, 1), "mirrored"});
  Scene f = flatten(s);
  ASSERT_EQ(f.meshes.size(), 1u);
  ASSERT_EQ(f.instances.size(), 1u);
  EXPECT_TRUE(f.instances[0].world.is_identity());
  const Primitive& q = f.meshes[0].primitives[0];
  ASSERT_EQ(q.triangle_count(), 2u);
  EXPECT_EQ(q.positions[1], (Vec3{6, 0, 0}));
  // Geometric normal of each flattened triangle agrees with its (transformed) vertex normal.
  for (size_t t = 0; t < 2; ++t) {
    Vec3 a = q.positions[q.indices[3 * t]], b = q.positions[q.indices[3 * t + 1]],
         c = q.positions[q.indices[3 * t + 2]];
    EXPECT_GT(dot(cross(b - a, c - a), q.normals[q.indices[3 * t]]), 0.0f) << t;
  }
  EXPECT_EQ(f.materials.size(), 1u);
}

}  // namespace
}  // namespace meshmux
