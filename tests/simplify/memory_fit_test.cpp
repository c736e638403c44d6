// fit_simplify_to_memory: the block build's parameters under a memory cap.
#include "simplify/memory_fit.h"

#include <gtest/gtest.h>

namespace meshmux {
namespace {

// The default cap (2 GB, or more for bigger inputs) leaves the defaults as they are: outputs
// under it stay byte for byte what they were.
TEST(MemoryFit, DefaultCapChangesNothing) {
  const SimplifyOptions d;
  const SimplifyOptions o = fit_simplify_to_memory(d, 2048);
  EXPECT_EQ(o.block_above, d.block_above);
  EXPECT_EQ(o.block_positions, d.block_positions);
  EXPECT_EQ(o.block_until, d.block_until);
}

// A 200 MB cap: meshes over 200k faces take blocks (half the cap at 500 bytes a face), the
// block levels go down to 200k faces, and a block holds 25k positions (a quarter of the cap
// over two blocks at 1000 bytes a position); a tiny cap, never below 1024 positions.
TEST(MemoryFit, SmallCapMakesBlocksSoonerAndSmaller) {
  const SimplifyOptions o = fit_simplify_to_memory(SimplifyOptions{}, 200);
  EXPECT_EQ(o.block_above, 200000u);
  EXPECT_EQ(o.block_until, 200000u);
  EXPECT_EQ(o.block_positions, 25000u);
  EXPECT_EQ(fit_simplify_to_memory(SimplifyOptions{}, 4).block_positions, 1024u);
}

// A cap never raises a parameter set lower by hand, and no cap (0) changes nothing.
TEST(MemoryFit, NeverRaises) {
  SimplifyOptions small;
  small.block_above = 4000, small.block_positions = 512, small.block_until = 2000;
  for (uint64_t mb : {0ull, 64ull, 100000ull}) {
    const SimplifyOptions o = fit_simplify_to_memory(small, mb);
    EXPECT_EQ(o.block_above, 4000u) << mb;
    EXPECT_EQ(o.block_positions, 512u) << mb;
    EXPECT_EQ(o.block_until, 2000u) << mb;
  }
}

}  // namespace
}  // namespace meshmux
