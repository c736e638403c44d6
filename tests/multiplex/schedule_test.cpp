#include "multiplex/schedule.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

namespace meshmux {
namespace {

// A synthetic distortion surface: separable decay in mesh and texture detail plus an
// interaction term, with uneven layer sizes — the shape rendered grids have.
RdGrid synthetic(int m, int n) {
  RdGrid g;
  for (int i = 0; i < m; ++i) g.mesh_bytes.push_back(uint64_t(1000 + 700 * ((i * 7) % 5)));
  for (int j = 0; j < n; ++j) g.texture_bytes.push_back(uint64_t(500 << std::min(j, 6)));
  g.distortion = [m, n](int i, int j) {
    double a = double(m - 1 - i) / double(m - 1), b = double(n - 1 - j) / double(n - 1);
    return 10 * a * a + 6 * b + 3 * a * b;
  };
  return g;
}

// Brute-force greedy: evaluates every cell up front, then walks the same rule.
RdPath brute_force(const RdGrid& g) {
  int m = int(g.mesh_bytes.size()), n = int(g.texture_bytes.size());
  std::vector<double> d(size_t(m) * size_t(n));
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < n; ++j) d[size_t(i * n + j)] = g.distortion(i, j);
  auto bytes = [&](int i, int j) {
    uint64_t b = 0;
    for (int k = 0; k <= i; ++k) b += g.mesh_bytes[size_t(k)];
    for (int k = 0; k <= j; ++k) b += g.texture_bytes[size_t(k)];
    return b;
  };
  RdPath p;
  int i = 0, j = 0;
  p.cells.push_back({0, 0});
  while (i < m - 1 || j < n - 1) {
    double gm = i < m - 1 ? (d[size_t(i * n + j)] - d[size_t((i + 1) * n + j)]) /
                                double(bytes(i + 1, j) - bytes(i, j) + 1)
                          : -INFINITY;
    double gt = j < n - 1 ? (d[size_t(i * n + j)] - d[size_t(i * n + j + 1)]) /
                                double(bytes(i, j + 1) - bytes(i, j) + 1)
                          : -INFINITY;
    if (gm >= gt)
      ++i;
    else
      ++j;
    p.cells.push_back({i, j});
  }
  return p;
}

TEST(Schedule, SteepestDescentEqualsBruteForceGreedy) {
  RdGrid g = synthetic(9, 7);
  RdCache cache(g);
  RdPath p = steepest_descent(cache);
  EXPECT_EQ(p.cells, brute_force(g).cells);
}

// The path only adds bytes, starts at (0,0) and ends at (m−1, n−1), one layer per step.
TEST(Schedule, PathIsMonotoneAndComplete) {
  RdGrid g = synthetic(12, 6);
  RdCache cache(g);
  for (RdPath p :
       {steepest_descent(cache), mesh_first(cache), texture_first(cache), constant_ratio(cache)}) {
    ASSERT_EQ(p.cells.front(), std::make_pair(0, 0));
    ASSERT_EQ(p.cells.back(), std::make_pair(11, 5));
    ASSERT_EQ(p.cells.size(), size_t(12 + 6 - 1));
    for (size_t k = 1; k < p.cells.size(); ++k) {
      EXPECT_GT(p.bytes[k], p.bytes[k - 1]);
      int di = p.cells[k].first - p.cells[k - 1].first,
          dj = p.cells[k].second - p.cells[k - 1].second;
      EXPECT_EQ(di + dj, 1);
      EXPECT_GE(di, 0);
      EXPECT_GE(dj, 0);
    }
  }
}

// Lazy evaluation: the descent looks at the cells it visits and their two forward neighbours
// only, far fewer than the whole grid.
TEST(Schedule, LazyEvaluationTouchesFewCells) {
  RdGrid g = synthetic(20, 10);
  RdCache cache(g);
  steepest_descent(cache);
  EXPECT_LE(cache.evaluated(), size_t(2 * (20 + 10)));
  EXPECT_LT(cache.evaluated(), size_t(20 * 10) / 3);
  std::printf("[ lazy ] evaluated %zu of %d cells\n", cache.evaluated(), 20 * 10);
}

// On a surface where one axis is plainly cheaper per byte, the descent's area is no larger than any
// baseline's (the point of Yang, Shen and Kuo, "Progressive coding of 3D textured graphic model via
// joint mesh-texture optimization").
TEST(Schedule, DescentAreaIsNoWorseThanBaselines) {
  RdGrid g = synthetic(10, 6);
  RdCache cache(g);
  double rd = area_under(steepest_descent(cache));
  EXPECT_LE(rd, area_under(mesh_first(cache)));
  EXPECT_LE(rd, area_under(texture_first(cache)));
  EXPECT_LE(rd, area_under(constant_ratio(cache)));
}

TEST(Schedule, AreaUnderIsTrapezoidal) {
  RdPath p;
  p.bytes = {0, 10, 30};
  p.distortion = {4, 2, 0};
  EXPECT_DOUBLE_EQ(area_under(p), 0.5 * (4 + 2) * 10 + 0.5 * (2 + 0) * 20);
}

}  // namespace
}  // namespace meshmux
