#include "exporters/split_primitive.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <tuple>
#include <vector>

#include "test_util.h"

namespace meshmux {
namespace {

// A sphere with every attribute model.glb carries (normals, a uv set, colours) and a material:
// what a big scan's primitive holds, at a size a test can afford.
Primitive coloured_sphere() {
  Primitive p = testing::uv_sphere(40, 80);  // 6,240 triangles
  for (const Vec3& v : p.positions) p.colors.push_back({v.x * 0.5f + 0.5f, 0.25f, 1.0f, 1.0f});
  p.material = 3;
  return p;
}

// One corner as everything it carries, so triangles compare across vertex numberings.
using Corner = std::tuple<float, float, float, float, float, float, float, float, float>;
std::vector<std::array<Corner, 3>> triangles_of(const Primitive& p) {
  std::vector<std::array<Corner, 3>> out;
  for (size_t t = 0; t < p.triangle_count(); ++t) {
    std::array<Corner, 3> tri;
    for (int c = 0; c < 3; ++c) {
      const uint32_t v = p.indices[3 * t + size_t(c)];
      tri[size_t(c)] = {p.positions[v].x, p.positions[v].y, p.positions[v].z,
                        p.normals[v].x,   p.uvs[0][v].x,    p.uvs[0][v].y,
                        p.colors[v].x,    p.colors[v].y,    p.colors[v].z};
    }
    out.push_back(tri);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The parts hold every triangle exactly once with the attributes of its own corners (a wrong
// remap would pair positions with other vertices' normals or uvs), the material and flags of
// the whole, nearly equal counts, and each part only the vertices its faces use.
TEST(SplitPrimitive, PartsHoldEveryTriangleOnceWithItsOwnAttributes) {
  const Primitive p = coloured_sphere();
  const std::vector<Primitive> parts = split_primitive(p, 1000);
  ASSERT_EQ(parts.size(), 7u);  // ceil(6240 / 1000)
  Primitive joined;
  joined.uvs.resize(1);
  for (const Primitive& q : parts) {
    EXPECT_EQ(q.material, 3);
    EXPECT_LE(q.triangle_count(), 1000u);
    EXPECT_GE(q.triangle_count(), 6240u / 7);
    std::vector<uint8_t> used(q.vertex_count(), 0);
    for (uint32_t v : q.indices) used[v] = 1;
    EXPECT_EQ(std::count(used.begin(), used.end(), 0), 0) << "a part carries an unused vertex";
    const uint32_t base = uint32_t(joined.positions.size());
    joined.positions.insert(joined.positions.end(), q.positions.begin(), q.positions.end());
    joined.normals.insert(joined.normals.end(), q.normals.begin(), q.normals.end());
    joined.uvs[0].insert(joined.uvs[0].end(), q.uvs[0].begin(), q.uvs[0].end());
    joined.colors.insert(joined.colors.end(), q.colors.begin(), q.colors.end());
    for (uint32_t v : q.indices) joined.indices.push_back(base + v);
  }
  EXPECT_EQ(triangles_of(joined), triangles_of(p));
}

// Parts are compact regions, so few vertices repeat on their borders: a split by face index
// (the source's order, shuffled in a scan) would repeat most of them.
TEST(SplitPrimitive, PartsAreCompactRegions) {
  const Primitive p = coloured_sphere();
  size_t vertices = 0;
  for (const Primitive& q : split_primitive(p, 1000)) vertices += q.vertex_count();
  EXPECT_LT(double(vertices), 1.25 * double(p.vertex_count()));
}

// Within the limit (or with no limit) the primitive comes back whole.
TEST(SplitPrimitive, SmallPrimitiveComesBackWhole) {
  const Primitive p = coloured_sphere();
  for (size_t limit : {size_t(0), size_t(6240), size_t(100000)}) {
    const std::vector<Primitive> parts = split_primitive(p, limit);
    ASSERT_EQ(parts.size(), 1u);
    EXPECT_EQ(parts[0].indices, p.indices);
    EXPECT_EQ(parts[0].positions.size(), p.positions.size());
  }
}

}  // namespace
}  // namespace meshmux
