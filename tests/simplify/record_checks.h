// What the simplifier's tests share: a record built on a given number of threads, and two
// records compared as determinism asks (the same faces, parents, vertices and level errors).
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>

#include "simplify/simplify.h"

namespace meshmux::testing {

// Block levels forced on small test meshes: a mesh over 4,000 faces takes them, in blocks of 512
// positions (tens of blocks at the first level), until 2,000 faces are live.
inline SimplifyOptions small_block_options() {
  SimplifyOptions o;
  o.block_above = 4000;
  o.block_positions = 512;
  o.block_until = 2000;
  return o;
}

// The record of `s`'s first mesh, built with `o` on `threads` threads (MESHMUX_THREADS).
inline ProgressiveMesh record_on_threads(const Scene& s, const SimplifyOptions& o,
                                         const char* threads) {
  setenv("MESHMUX_THREADS", threads, 1);
  ProgressiveMesh pm = build_progressive(s, o).meshes[0];
  unsetenv("MESHMUX_THREADS");
  return pm;
}

// The same record: faces, parents, vertex count, every level's error and block.
inline void expect_same_record(const ProgressiveMesh& a, const ProgressiveMesh& b) {
  EXPECT_EQ(a.indices, b.indices);
  EXPECT_EQ(a.parent, b.parent);
  EXPECT_EQ(a.positions.size(), b.positions.size());
  ASSERT_EQ(a.levels.size(), b.levels.size());
  for (size_t i = 0; i < a.levels.size(); ++i) EXPECT_EQ(a.levels[i].error, b.levels[i].error);
  EXPECT_EQ(a.level_block, b.level_block);
  ASSERT_EQ(a.blocks.size(), b.blocks.size());
  for (size_t i = 0; i < a.blocks.size(); ++i) {
    EXPECT_EQ(a.blocks[i].level, b.blocks[i].level) << "block " << i;
    EXPECT_EQ(a.blocks[i].block, b.blocks[i].block) << "block " << i;
    EXPECT_EQ(a.blocks[i].error, b.blocks[i].error) << "block " << i;
  }
}

}  // namespace meshmux::testing
