// batch/world.h: where a batch places its packages, on a grid or as a layout file says.
#include "batch/world.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/file_io.h"
#include "test_util.h"

namespace meshmux {
namespace {

using testing::TempDir;

WorldPackage package(const std::string& name, std::array<double, 6> bounds, uint64_t bytes = 1000) {
  return {name, name + "/model.mmxp", bounds, bytes};
}

// A point through a column-major affine matrix.
std::array<double, 3> apply(const std::array<double, 16>& m, double x, double y, double z) {
  return {m[0] * x + m[4] * y + m[8] * z + m[12], m[1] * x + m[5] * y + m[9] * z + m[13],
          m[2] * x + m[6] * y + m[10] * z + m[14]};
}

// Uploads come in every size (a 20-unit building beside a 0.2-unit duck): the grid scales each
// to a unit diagonal, stands it on y = 0 and gives each its own cell, so none hides another.
TEST(World, GridGivesEachModelAUnitCellOnTheGround) {
  std::vector<WorldPackage> packages;
  for (int i = 0; i < 5; ++i) {
    const double s = std::pow(10.0, i - 2);  // 0.01 to 100 units
    packages.push_back(package("m" + std::to_string(i), {10 * s, 5 * s, -s, 12 * s, 6 * s, s}));
  }
  World w = grid_world(packages);
  ASSERT_EQ(w.placements.size(), 5u);
  std::vector<std::array<double, 6>> placed;
  for (const WorldPlacement& p : w.placements) {
    const auto& b = w.packages[p.package].bounds;
    const auto lo = apply(p.matrix, b[0], b[1], b[2]), hi = apply(p.matrix, b[3], b[4], b[5]);
    const double d =
        std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                  (hi[2] - lo[2]) * (hi[2] - lo[2]));
    EXPECT_NEAR(d, 1.0, 1e-9);
    EXPECT_NEAR(lo[1], 0.0, 1e-9);  // standing on the ground
    placed.push_back({lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]});
  }
  for (size_t i = 0; i < placed.size(); ++i)
    for (size_t j = i + 1; j < placed.size(); ++j) {
      const bool apart = placed[i][3] < placed[j][0] || placed[j][3] < placed[i][0] ||
                         placed[i][5] < placed[j][2] || placed[j][5] < placed[i][2];
      EXPECT_TRUE(apart) << i << " overlaps " << j;
    }
}

// A layout places named models (one twice, by translation, scale and rotation, or by matrix);
// a name no model has is reported, not silently dropped; mixing a matrix with a translation is
// refused as ambiguous.
TEST(World, LayoutPlacesNamedModelsAndReportsUnknownNames) {
  TempDir dir;
  const std::string path = dir.file("layout.json");
  ASSERT_TRUE(
      write_file_atomic(
          path,
          std::string("{\"placements\": ["
                      "{\"name\": \"Duck\", \"translation\": [10, 0, 0], \"scale\": 2, "
                      "\"rotation_y_degrees\": 90},"
                      "{\"name\": \"Duck\", \"matrix\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,5,0,1]},"
                      "{\"name\": \"Ghost\"}]}"))
          .is_ok());
  auto layout = read_layout(path);
  ASSERT_TRUE(layout.ok()) << layout.status().message();
  ASSERT_EQ(layout->size(), 3u);
  // Scale 2, a quarter turn about y (x → −z), then 10 along x.
  const auto p = apply((*layout)[0].matrix, 1, 0, 0);
  EXPECT_NEAR(p[0], 10, 1e-12);
  EXPECT_NEAR(p[1], 0, 1e-12);
  EXPECT_NEAR(p[2], -2, 1e-12);
  std::vector<std::string> missing;
  World w = apply_layout({package("Duck", {0, 0, 0, 1, 1, 1}), package("Fox", {0, 0, 0, 1, 1, 1})},
                         *layout, &missing);
  ASSERT_EQ(w.placements.size(), 2u);
  EXPECT_EQ(w.placements[0].package, 0u);
  EXPECT_EQ(w.placements[1].matrix[13], 5);
  EXPECT_EQ(missing, std::vector<std::string>{"Ghost"});
  ASSERT_TRUE(
      write_file_atomic(path, std::string("{\"placements\": [{\"name\": \"Duck\", "
                                          "\"matrix\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1], "
                                          "\"translation\": [1, 2, 3]}]}"))
          .is_ok());
  auto both = read_layout(path);
  ASSERT_FALSE(both.ok());
  EXPECT_NE(both.status().message().find("layout.json: placements[0] gives a matrix and"),
            std::string::npos)
      << both.status().message();
  auto none = read_layout(dir.file("nothing.json"));
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.status().message().find("nothing.json"), std::string::npos);
}

}  // namespace
}  // namespace meshmux
