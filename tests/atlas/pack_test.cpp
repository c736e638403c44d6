#include "atlas/pack.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>

namespace meshmux {
namespace {

// Deterministic on every platform: mt19937's output is specified, the reduction is ours.
std::vector<PackRect> random_rects(size_t count, uint32_t seed, int max_side) {
  std::mt19937 rng(seed);
  std::vector<PackRect> r(count);
  for (PackRect& x : r) {
    x.w = 1 + int(rng() % uint32_t(max_side));
    x.h = 1 + int(rng() % uint32_t(max_side));
  }
  return r;
}

bool overlap(const PackRect& a, const PackPlacement& pa, const PackRect& b,
             const PackPlacement& pb) {
  return pa.x < pb.x + b.w && pb.x < pa.x + a.w && pa.y < pb.y + b.h && pb.y < pa.y + a.h;
}

// Checks the packing's three properties; returns the number of violations.
int check(const std::vector<PackRect>& rects, const PackResult& r) {
  int bad = 0;
  for (size_t i = 0; i < rects.size(); ++i) {
    const PackRect& a = rects[i];
    const PackPlacement& p = r.placed[i];
    if (!respects_power_of_two(p.x, p.y, a.w, a.h)) {
      ADD_FAILURE() << "rect " << i << " (" << a.w << "x" << a.h << " at " << p.x << "," << p.y
                    << ") crosses a power-of-two boundary";
      ++bad;
    }
    if (p.x < 0 || p.y < 0 || p.x + a.w > r.size || p.y + a.h > r.size) {
      ADD_FAILURE() << "rect " << i << " outside the " << r.size << " atlas";
      ++bad;
    }
    for (size_t j = 0; j < i; ++j)
      if (overlap(a, p, rects[j], r.placed[j])) {
        ADD_FAILURE() << "rects " << j << " and " << i << " overlap";
        ++bad;
      }
  }
  return bad;
}

TEST(Pack, PowerOfTwoPredicate) {
  EXPECT_TRUE(respects_power_of_two(0, 0, 100, 100));
  EXPECT_TRUE(respects_power_of_two(128, 256, 100, 100));
  EXPECT_TRUE(respects_power_of_two(28, 0, 100, 100));   // 28..127 stays in cell 0
  EXPECT_FALSE(respects_power_of_two(29, 0, 100, 100));  // 29..128 crosses 128
  EXPECT_FALSE(respects_power_of_two(0, 50, 100, 100));
  EXPECT_FALSE(respects_power_of_two(60, 0, 5, 5));    // cell 8: 60..64 crosses 64
  EXPECT_TRUE(respects_power_of_two(56, 0, 8, 1));     // exactly one 8-cell
  EXPECT_FALSE(respects_power_of_two(100, 0, 64, 2));  // 64-cells: 100..163 crosses 128
}

TEST(Pack, RandomSetsRespectBoundariesStayInsideAndDoNotOverlap) {
  const size_t counts[] = {1, 2, 3, 7, 20, 50, 100, 200, 350, 500};
  uint32_t seed = 1;
  for (size_t count : counts)
    for (int rep = 0; rep < 3; ++rep, ++seed) {
      std::vector<PackRect> rects = random_rects(count, seed, 300);
      PackResult r = pack_charts(rects, 1, 1 << 14);
      ASSERT_TRUE(r.ok) << count << " rects, seed " << seed;
      ASSERT_EQ(r.placed.size(), rects.size());
      EXPECT_EQ(r.size & (r.size - 1), 0) << "not a power of two: " << r.size;
      EXPECT_EQ(check(rects, r), 0) << count << " rects, seed " << seed;
      double area = 0;
      for (const PackRect& x : rects) area += double(x.w) * x.h;
      EXPECT_NEAR(r.utilization, area / (double(r.size) * r.size), 1e-12);
      // The smallest power of two that could hold the rectangles at all (area and longest side),
      // for comparison.
      int bound = 1, longest = 0;
      for (const PackRect& x : rects) longest = std::max({longest, x.w, x.h});
      while (double(bound) * bound < area || bound < longest) bound *= 2;
      std::printf(
          "[ pack     ] %3zu rects (seed %2u): atlas %5d (lower bound %5d), utilization %.3f\n",
          count, seed, r.size, bound, r.utilization);
      RecordProperty("utilization_" + std::to_string(count) + "_" + std::to_string(seed),
                     std::to_string(r.utilization));
    }
}

// Many small rectangles with the same cell size must share cells rather than take one each:
// 128 rectangles of 3x2 (cell 4) fit two to a 4x4 cell in 32², where one cell each needs 64².
TEST(Pack, SmallRectanglesShareCells) {
  std::vector<PackRect> rects(128, PackRect{3, 2});
  PackResult r = pack_charts(rects, 1, 1024);
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(check(rects, r), 0);
  EXPECT_EQ(r.size, 32);
}

TEST(Pack, Single100IsPackedIn128) {
  PackResult r = pack_charts({{100, 100}}, 1, 4096);
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.size, 128);
  ASSERT_EQ(r.placed.size(), 1u);
  EXPECT_TRUE(respects_power_of_two(r.placed[0].x, r.placed[0].y, 100, 100));
  EXPECT_NEAR(r.utilization, 10000.0 / (128 * 128), 1e-12);
}

TEST(Pack, MinSizeIsHonoured) {
  PackResult r = pack_charts({{3, 2}}, 64, 4096);
  ASSERT_TRUE(r.ok);
  EXPECT_EQ(r.size, 64);
}

TEST(Pack, TooMuchFailsAtMaxSize) {
  PackResult r = pack_charts(std::vector<PackRect>(5, PackRect{100, 100}), 1, 128);
  EXPECT_FALSE(r.ok);
  PackResult big = pack_charts({{300, 10}}, 1, 256);
  EXPECT_FALSE(big.ok);
}

TEST(Pack, EmptyInputFitsTheMinimum) {
  PackResult r = pack_charts({}, 16, 4096);
  EXPECT_TRUE(r.ok);
  EXPECT_EQ(r.size, 16);
  EXPECT_EQ(r.utilization, 0);
}

TEST(Pack, Deterministic) {
  std::vector<PackRect> rects = random_rects(300, 77, 300);
  PackResult a = pack_charts(rects, 1, 1 << 14);
  PackResult b = pack_charts(rects, 1, 1 << 14);
  ASSERT_TRUE(a.ok);
  EXPECT_EQ(a.size, b.size);
  for (size_t i = 0; i < rects.size(); ++i) {
    EXPECT_EQ(a.placed[i].x, b.placed[i].x);
    EXPECT_EQ(a.placed[i].y, b.placed[i].y);
  }
}

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// Exclusive cells: every rectangle sits at the corner of an aligned power-of-two cell of its
// own (sides next_pow2 of its own), cells never overlap, all inside the atlas.
TEST(PackCells, EveryRectangleOwnsAnAlignedPowerOfTwoCell) {
  std::vector<PackRect> rects;
  uint64_t state = 42;
  for (int i = 0; i < 300; ++i) {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    int w = 1 + int((state >> 33) % 200), h = 1 + int((state >> 17) % 120);
    rects.push_back({w, h});
  }
  PackResult r = pack_cells(rects, 64, 4096);
  ASSERT_TRUE(r.ok);
  ASSERT_EQ(r.cells.size(), rects.size());
  for (size_t i = 0; i < rects.size(); ++i) {
    const PackRect& c = r.cells[i];
    EXPECT_EQ(c.w & (c.w - 1), 0);
    EXPECT_EQ(c.h & (c.h - 1), 0);
    EXPECT_GE(c.w, rects[i].w);
    EXPECT_GE(c.h, rects[i].h);
    EXPECT_EQ(r.placed[i].x % c.w, 0);
    EXPECT_EQ(r.placed[i].y % c.h, 0);
    EXPECT_LE(r.placed[i].x + c.w, r.size);
    EXPECT_LE(r.placed[i].y + c.h, r.size);
    for (size_t j = 0; j < i; ++j) {
      const PackRect& d = r.cells[j];
      bool apart = r.placed[i].x + c.w <= r.placed[j].x || r.placed[j].x + d.w <= r.placed[i].x ||
                   r.placed[i].y + c.h <= r.placed[j].y || r.placed[j].y + d.h <= r.placed[i].y;
      ASSERT_TRUE(apart) << i << " overlaps " << j;
    }
  }
  std::printf("[ pack_cells ] 300 rects: %dx%d, utilization %.2f\n", r.size, r.size, r.utilization);
}

}  // namespace
}  // namespace meshmux
