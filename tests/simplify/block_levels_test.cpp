// The block hierarchy of big meshes (simplify/block_levels.cpp): levels of blocks simplified on
// every core with locked borders, then the whole-unit loop. The tests lower the size threshold
// so that a sphere of 16k triangles takes the block path in several levels of many blocks.
#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <tuple>

#include "clean/clean.h"
#include "simplify/lod.h"
#include "simplify/record_checks.h"
#include "simplify/simplify.h"
#include "test_util.h"

namespace meshmux {
namespace {

using testing::expect_same_record;
using testing::record_on_threads;
using testing::uv_sphere;

// Blocks of 512 positions (record_checks.h): tens of blocks at the first level.
SimplifyOptions block_options() { return testing::small_block_options(); }

Scene sphere_scene() {
  Scene s;
  Mesh m;
  m.primitives.push_back(uv_sphere(64, 128));  // a uv seam and two poles
  s.meshes.push_back(m);
  s.instances.push_back({0, Mat4::identity(), "sphere"});
  return clean(s, {});
}

// Undirected position edges of a level with how many faces use each.
std::map<std::tuple<float, float, float, float, float, float>, int> edges_of(const Mesh& mesh) {
  std::map<std::tuple<float, float, float, float, float, float>, int> m;
  for (const Primitive& p : mesh.primitives)
    for (size_t t = 0; t < p.indices.size(); t += 3)
      for (int e = 0; e < 3; ++e) {
        Vec3 a = p.positions[p.indices[t + e]], b = p.positions[p.indices[t + (e + 1) % 3]];
        if (std::make_tuple(b.x, b.y, b.z) < std::make_tuple(a.x, a.y, a.z)) std::swap(a, b);
        ++m[{a.x, a.y, a.z, b.x, b.y, b.z}];
      }
  return m;
}

// The block path runs several levels and its record is a valid progressive mesh: every level
// closed (no crack where blocks met, no seam opened), manifold, with the triangle count it
// promises; errors never rise with detail; the full level is the whole input.
TEST(BlockLevels, RecordIsClosedAndValidAtEveryLevel) {
  const Scene s = sphere_scene();
  SimplifyReport report;
  const ProgressiveMesh pm = build_progressive(s, block_options(), &report).meshes[0];
  EXPECT_GE(report.block_levels, 2u);
  EXPECT_EQ(pm.levels.back().triangles, compute_stats(s).unique_triangles);
  EXPECT_LT(pm.levels.front().triangles, 100u);
  for (size_t l = 1; l < pm.levels.size(); ++l)
    ASSERT_LE(pm.levels[l].error, pm.levels[l - 1].error) << "level " << l;
  const size_t n = pm.levels.size();
  for (size_t k = 0; k <= 16; ++k) {
    const size_t l = k * (n - 1) / 16;
    const Mesh level = extract_level(pm, l);
    EXPECT_EQ(level.primitives[0].indices.size() / 3, pm.levels[l].triangles) << "level " << l;
    for (const auto& [edge, faces] : edges_of(level))
      ASSERT_EQ(faces, 2) << "level " << l << " of " << n << ": an edge with " << faces << " faces";
  }
}

// Blocks run on every core; the record must not depend on how many there are.
TEST(BlockLevels, RecordIsTheSameWhateverTheThreadCount) {
  const Scene s = sphere_scene();
  expect_same_record(record_on_threads(s, block_options(), "1"),
                     record_on_threads(s, block_options(), "3"));
}

// A level's merge hands back the pages of the blocks' lists it has read (a page at a time here,
// where the default is every 64 KB of a block's collapses): it must never read one again, or the
// record would take zeros for wedges and faces. The same record as with every list held whole.
// Blocks of 4,096 positions on a sphere of 64k triangles: lists of several pages each.
TEST(BlockLevels, MergeHandingPagesBackGivesTheSameRecord) {
  Scene big;
  Mesh m;
  m.primitives.push_back(uv_sphere(128, 256));
  big.meshes.push_back(m);
  big.instances.push_back({0, Mat4::identity(), "sphere"});
  const Scene s = clean(big, {});
  SimplifyOptions every_page = block_options(), held = block_options();
  every_page.block_positions = held.block_positions = 4096;
  every_page.merge_release_bytes = 4096;
  held.merge_release_bytes = 0;
  expect_same_record(build_progressive(s, every_page).meshes[0],
                     build_progressive(s, held).meshes[0]);
}

// The spilled quadrics are read back and placed into the mapped rest block by block on every
// core (each block fills its own slots): one thread or three, the same record.
TEST(BlockLevels, SpilledQuadricsPlacedOnEveryCoreGiveTheSameRecord) {
  const Scene s = sphere_scene();
  testing::TempDir dir;
  SimplifyOptions spilled = block_options();
  spilled.spill_dir = dir.path();
  expect_same_record(record_on_threads(s, spilled, "1"), record_on_threads(s, spilled, "3"));
}

// The first level's quadrics may wait in a file (SimplifyOptions::spill_dir) instead of memory,
// and the rest's live in pages mapped from another one through its levels, dropped from memory
// block by block, then copied in for the last loop: what comes back is what went out, so the
// record is the same, and the files leave no trace.
TEST(BlockLevels, SpilledQuadricsGiveTheSameRecord) {
  const Scene s = sphere_scene();
  testing::TempDir dir;
  SimplifyOptions spilled = block_options();
  spilled.spill_dir = dir.path();
  SimplifyReport report;
  const ProgressiveMesh a = build_progressive(s, block_options()).meshes[0];
  const ProgressiveMesh b = build_progressive(s, spilled, &report).meshes[0];
  EXPECT_GT(report.spilled_bytes, 100000u);  // the quadrics of ~8k positions and wedges
  EXPECT_GT(report.mapped_bytes, 50000u);    // the rest's, mapped through its levels
  expect_same_record(a, b);
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

// Locked borders cost little: at a quarter and a sixteenth of the triangles the block path's
// geometric error stays within half again of the whole-unit loop's on the same sphere (a
// level's error is the largest collapse error not undone, in diagonals).
TEST(BlockLevels, ErrorStaysNearTheWholeUnitLoop) {
  const Scene s = sphere_scene();
  const ProgressiveMesh blocks = build_progressive(s, block_options()).meshes[0];
  const ProgressiveMesh whole = build_progressive(s, {}).meshes[0];
  const uint32_t full = whole.levels.back().triangles;
  for (uint32_t share : {4u, 16u}) {
    const float e_blocks = blocks.levels[level_for_triangles(blocks, full / share)].error;
    const float e_whole = whole.levels[level_for_triangles(whole, full / share)].error;
    EXPECT_GT(e_whole, 0.0f);
    EXPECT_LE(e_blocks, 1.5f * e_whole) << "1/" << share << " of the triangles";
  }
}

}  // namespace
}  // namespace meshmux
