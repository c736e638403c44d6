// The block hierarchy's DAG (simplify/block_dag.h): a record built through the block levels is
// a DAG of blocks, and any dependency-closed set of blocks, applied in any order the
// dependencies allow, gives one client state. The tests lower the size threshold so that a
// bumpy sphere of ~36k triangles (a rough, scan-like surface, closed, with a uv seam) takes the
// block path in several levels of many blocks.
#include "simplify/block_dag.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <set>
#include <tuple>

#include "clean/clean.h"
#include "simplify/lod.h"
#include "simplify/record_checks.h"
#include "simplify/simplify.h"
#include "test_util.h"

namespace meshmux {
namespace {

using testing::uv_sphere;

// Blocks of 512 positions (record_checks.h): tens of blocks at the first level.
SimplifyOptions block_options() { return testing::small_block_options(); }

// A scan-like bumpy sphere (test_util.h), cleaned.
Scene bumpy_sphere() { return clean(testing::bumpy_sphere(96, 192), {}); }

// A record with its DAG, and per level the neighbourhood its splits read in the record's own
// order (every level applied in turn): BlockReplay::signature.
struct Hierarchy {
  ProgressiveMesh pm;
  BlockDag dag;
  std::vector<uint64_t> signatures;
};

void complete(Hierarchy& h) {
  Result<BlockDag> r = block_dag(h.pm);
  EXPECT_TRUE(r.ok()) << r.status().message();
  if (r.ok()) h.dag = *r;
  h.signatures.assign(h.pm.levels.size(), 0);
  BlockReplay replay(h.pm);
  replay.signatures = true;
  for (size_t l = 1; l < h.pm.levels.size(); ++l) {
    EXPECT_TRUE(replay.apply_level(l).is_ok());
    h.signatures[l] = replay.signature;
  }
}

// The record as built.
const Hierarchy& recorded() {
  static const Hierarchy h = [] {
    Hierarchy out{build_progressive(bumpy_sphere(), block_options()).meshes[0], {}, {}};
    complete(out);
    return out;
  }();
  return h;
}
const ProgressiveMesh& record() { return recorded().pm; }
const BlockDag& dag() { return recorded().dag; }

// The record renumbered block by block (order_by_blocks).
const Hierarchy& ordered() {
  static const Hierarchy h = [] {
    Hierarchy out{record(), {}, {}};
    EXPECT_TRUE(order_by_blocks(out.pm).is_ok());
    complete(out);
    return out;
  }();
  return h;
}

// A random dependency-closed set of blocks (the root always; another block with probability
// one half once all its dependencies are in) and a random order of it that respects them.
std::vector<uint16_t> closed_subset_order(const Hierarchy& h, std::mt19937& rng, double keep) {
  const BlockDag& d = h.dag;
  const size_t n = d.nodes.size();
  std::vector<int> state(n, 0);  // 0 undecided, 1 in, 2 out
  std::vector<uint16_t> order;
  bool progress = true;
  while (progress) {
    progress = false;
    std::vector<uint16_t> ready;
    for (size_t b = 0; b < n; ++b) {
      if (state[b] != 0) continue;
      bool deps_in = true, dep_out = false;
      for (uint16_t y : d.nodes[b].deps) deps_in &= state[y] == 1, dep_out |= state[y] == 2;
      if (dep_out) state[b] = 2, progress = true;
      if (deps_in) ready.push_back(uint16_t(b));
    }
    std::shuffle(ready.begin(), ready.end(), rng);
    for (uint16_t b : ready) {
      const bool in = h.pm.blocks[b].level == h.pm.blocks[0].level ||  // the root (its pieces)
                      std::bernoulli_distribution(keep)(rng);
      state[b] = in ? 1 : 2;
      if (in) order.push_back(b);
      progress = true;
      break;  // one at a time: the next choice sees it
    }
  }
  return order;
}

// Applies the blocks in `order`, each block's levels in record order; with `check`, each level's
// splits must read what they read in the record's order.
Status apply_blocks(BlockReplay& replay, const std::vector<uint16_t>& order,
                    const Hierarchy& h = recorded(), bool check = false) {
  const ProgressiveMesh& pm = h.pm;
  replay.signatures = check;
  for (uint16_t b : order)
    for (size_t r = 1; r < pm.levels.size(); ++r) {
      if (pm.level_block[r - 1] != b) continue;
      if (Status s = replay.apply_level(r); !s) return s;
      if (check && replay.signature != h.signatures[r])
        return Status::error("level " + std::to_string(r) + " (block " + std::to_string(b) +
                                 ") read another neighbourhood than in the record's order",
                             ErrorKind::kInternal);
    }
  return Status::ok();
}

// Another order of the same set that respects the dependencies: repeatedly the ready block of
// the highest id (the first order took them at random).
std::vector<uint16_t> other_order(const std::vector<uint16_t>& order,
                                  const Hierarchy& h = recorded()) {
  const BlockDag& d = h.dag;
  std::set<uint16_t> left(order.begin(), order.end()), done;
  std::vector<uint16_t> out;
  while (!left.empty()) {
    for (auto it = left.rbegin(); it != left.rend(); ++it) {
      bool ready = true;
      for (uint16_t y : d.nodes[*it].deps) ready &= done.count(y) > 0;
      if (!ready) continue;
      out.push_back(*it), done.insert(*it), left.erase(*it);
      break;
    }
  }
  return out;
}

// The record took the block path: many blocks over several levels, every level's collapse in a
// block, the root coarsest.
TEST(BlockDag, RecordCarriesTheBlockOfEveryLevel) {
  const ProgressiveMesh& pm = record();
  ASSERT_GT(pm.blocks.size(), 16u);
  ASSERT_EQ(pm.level_block.size() + 1, pm.levels.size());
  std::set<uint16_t> levels;
  for (const ProgressiveBlock& b : pm.blocks) levels.insert(b.level);
  EXPECT_GE(levels.size(), 3u);  // two block levels at least, and the root's
  for (size_t b = 1; b < pm.blocks.size(); ++b) EXPECT_LT(pm.blocks[b].level, pm.blocks[0].level);
  for (uint16_t b : pm.level_block) ASSERT_LT(b, pm.blocks.size());
  // The root's collapses are the coarsest: the record's first levels.
  EXPECT_EQ(pm.level_block.front(), 0u);
}

// A mesh under the threshold keeps no hierarchy (its record is today's single chain).
TEST(BlockDag, MeshUnderTheThresholdHasNoBlocks) {
  SimplifyOptions o = block_options();
  o.block_above = 1000000;
  const ProgressiveMesh pm = build_progressive(bumpy_sphere(), o).meshes[0];
  EXPECT_TRUE(pm.blocks.empty());
  EXPECT_TRUE(pm.level_block.empty());
  EXPECT_FALSE(block_dag(pm).ok());
}

// The dependencies point to coarser blocks only; blocks of one level never depend on each
// other (their locked borders keep them apart); every block reaches the root.
TEST(BlockDag, DependenciesGoToCoarserLevelsAndReachTheRoot) {
  const ProgressiveMesh& pm = record();
  const BlockDag& d = dag();
  ASSERT_EQ(d.nodes.size(), pm.blocks.size());
  EXPECT_TRUE(d.nodes[0].deps.empty());
  size_t with_deps = 0;
  for (size_t b = 1; b < d.nodes.size(); ++b) {
    if (d.nodes[b].levels == 0) continue;
    ++with_deps;
    ASSERT_FALSE(d.nodes[b].deps.empty()) << "block " << b;
    for (uint16_t y : d.nodes[b].deps)
      EXPECT_GT(pm.blocks[y].level, pm.blocks[b].level) << "block " << b << " on " << y;
    // Reaches the root through its dependencies.
    std::vector<uint16_t> stack = {uint16_t(b)};
    std::set<uint16_t> seen;
    while (!stack.empty()) {
      const uint16_t x = stack.back();
      stack.pop_back();
      if (!seen.insert(x).second) continue;
      for (uint16_t y : d.nodes[x].deps) stack.push_back(y);
    }
    EXPECT_TRUE(seen.count(0)) << "block " << b;
    // A finite box around its vertices.
    EXPECT_LE(d.nodes[b].box_min.x, d.nodes[b].box_max.x);
    EXPECT_TRUE(std::isfinite(d.nodes[b].box_max.z));
  }
  EXPECT_GT(with_deps, 16u);
}

// Undirected position edges of the appeared faces, with how many faces use each.
std::map<std::tuple<float, float, float, float, float, float>, int> edges(
    const BlockReplay& replay, const ProgressiveMesh& pm) {
  std::map<std::tuple<float, float, float, float, float, float>, int> m;
  for (uint32_t f = 0; f < pm.face_count(); ++f) {
    if (!replay.appeared(f)) continue;
    const auto c = replay.corners(f);
    for (int e = 0; e < 3; ++e) {
      Vec3 a = pm.positions[c[e]], b = pm.positions[c[(e + 1) % 3]];
      if (std::make_tuple(b.x, b.y, b.z) < std::make_tuple(a.x, a.y, a.z)) std::swap(a, b);
      ++m[{a.x, a.y, a.z, b.x, b.y, b.z}];
    }
  }
  return m;
}

// The property the client's view-dependent refinement rests on: in a dependency-closed set of
// blocks applied in two different orders, every split reads the neighbourhood it read in the
// record's own order (what its coding refers to), both give the same state (every face's
// corners, every vertex's corner list in the same order), that state is the record's parent
// mapping (the faces not yet appeared are degenerate under it), and the surface stays closed.
void expect_one_state_whatever_the_order(const Hierarchy& h) {
  const ProgressiveMesh& pm = h.pm;
  ASSERT_FALSE(h.dag.nodes.empty());
  std::mt19937 rng(7);
  for (double keep : {0.8, 0.9, 0.95, 0.97, 0.99}) {
    const std::vector<uint16_t> first = closed_subset_order(h, rng, keep),
                                second = other_order(first, h);
    ASSERT_EQ(first.size(), second.size());
    BlockReplay a(pm), b(pm);
    const Status sa = apply_blocks(a, first, h, true), sb = apply_blocks(b, second, h, true);
    ASSERT_TRUE(sa.is_ok()) << sa.message();
    ASSERT_TRUE(sb.is_ok()) << sb.message();
    size_t appeared = 0;
    for (uint32_t f = 0; f < pm.face_count(); ++f) {
      ASSERT_EQ(a.appeared(f), b.appeared(f)) << "face " << f;
      if (!a.appeared(f)) {
        const uint32_t x = a.mapped(pm.indices[3 * f]), y = a.mapped(pm.indices[3 * f + 1]),
                       z = a.mapped(pm.indices[3 * f + 2]);
        ASSERT_TRUE(x == y || y == z || x == z) << "face " << f << " not appeared yet whole";
        continue;
      }
      ++appeared;
      ASSERT_EQ(a.corners(f), b.corners(f)) << "face " << f;
      for (int k = 0; k < 3; ++k) ASSERT_EQ(a.corners(f)[k], a.mapped(pm.indices[3 * f + k]));
    }
    for (uint32_t v = 0; v < pm.vertex_count(); ++v) {
      ASSERT_EQ(a.present(v), b.present(v)) << "vertex " << v;
      if (!a.present(v)) continue;
      ASSERT_EQ(a.corner_list(v), b.corner_list(v)) << "vertex " << v;
    }
    for (const auto& [edge, faces] : edges(a, pm)) ASSERT_EQ(faces, 2) << "keep " << keep;
    EXPECT_GT(appeared, 0u);
  }
}
TEST(BlockDag, ClosedSetsGiveOneStateWhateverTheOrder) {
  expect_one_state_whatever_the_order(recorded());
}

// Every block applied (in a dependency order other than the record's) gives the full mesh.
TEST(BlockDag, AllBlocksInAnotherOrderGiveTheFullMesh) {
  const ProgressiveMesh& pm = record();
  std::vector<uint16_t> all;
  for (size_t b = 0; b < pm.blocks.size(); ++b) all.push_back(uint16_t(b));
  BlockReplay replay(pm);
  ASSERT_TRUE(apply_blocks(replay, other_order(all)).is_ok());
  for (uint32_t f = 0; f < pm.face_count(); ++f) {
    ASSERT_TRUE(replay.appeared(f));
    for (int k = 0; k < 3; ++k) ASSERT_EQ(replay.corners(f)[k], pm.indices[3 * f + k]);
  }
}

// A block applied without a dependency that made one of its parents is refused by the replay
// (the dependencies are not decoration: they carry the parents).
TEST(BlockDag, BlockWithoutItsParentsDependencyIsRefused) {
  const ProgressiveMesh& pm = record();
  const BlockDag& d = dag();
  // A block with a vertex whose parent another non-root block made.
  std::vector<uint16_t> block_of_vertex(pm.vertex_count(), 0);
  for (size_t r = 1; r < pm.levels.size(); ++r)
    for (uint32_t v = pm.levels[r - 1].vertex_end; v < pm.levels[r].vertex_end; ++v)
      block_of_vertex[v] = pm.level_block[r - 1];
  for (size_t x = 1; x < d.nodes.size(); ++x) {
    for (uint32_t v = 0; v < pm.vertex_count(); ++v) {
      const uint16_t y = block_of_vertex[pm.parent[v]];
      if (block_of_vertex[v] != x || y == 0 || y == x) continue;
      // Apply the root and every block x depends on but y (and what depends on y), then x.
      std::vector<uint16_t> order = {0};
      BlockReplay replay(pm);
      ASSERT_TRUE(apply_blocks(replay, order).is_ok());
      const Status s = apply_blocks(replay, {uint16_t(x)});
      EXPECT_FALSE(s.is_ok()) << "block " << x << " applied without block " << y;
      EXPECT_NE(s.message().find("is not present"), std::string::npos) << s.message();
      return;
    }
  }
  FAIL() << "no block splits from a vertex another block made";
}

// Each block becomes one run of levels (a chunk of the stream is then one range of vertices and
// faces), the root's first and in place, the base where it was.
TEST(BlockOrder, EveryBlockIsOneRunOfLevels) {
  const ProgressiveMesh &pm = record(), &o = ordered().pm;
  ASSERT_EQ(o.level_block.size(), pm.level_block.size());
  std::set<uint16_t> closed;
  for (size_t i = 0; i < o.level_block.size(); ++i) {
    const uint16_t b = o.level_block[i];
    if (i > 0 && o.level_block[i - 1] != b) closed.insert(o.level_block[i - 1]);
    ASSERT_FALSE(closed.count(b)) << "block " << b << " comes back at level " << i + 1;
  }
  // The same blocks (by level and index in it) with the same levels, renumbered in run order;
  // the root (the top level) in pieces of growing triangles, each at least 1,024 on.
  const uint16_t top = pm.blocks[0].level;
  std::map<std::pair<uint16_t, uint32_t>, size_t> before, after;
  for (uint16_t b : pm.level_block)
    ++before[{pm.blocks[b].level, pm.blocks[b].level == top ? 0 : pm.blocks[b].block}];
  for (uint16_t b : o.level_block)
    ++after[{o.blocks[b].level, o.blocks[b].level == top ? 0 : o.blocks[b].block}];
  EXPECT_EQ(before, after);
  size_t pieces = 0;
  while (pieces < o.blocks.size() && o.blocks[pieces].level == top) ++pieces;
  EXPECT_GE(pieces, 3u);
  for (size_t k = pieces; k < o.blocks.size(); ++k) EXPECT_LT(o.blocks[k].level, top);
  for (size_t i = 1; i < o.level_block.size(); ++i)
    ASSERT_LE(o.level_block[i - 1], o.level_block[i]) << "level " << i + 1;
  EXPECT_EQ(o.level_block.front(), 0u);
  EXPECT_EQ(o.base_level, pm.base_level);
  for (size_t r = 0; r <= pm.base_level; ++r)
    EXPECT_EQ(o.levels[r].vertex_end, pm.levels[r].vertex_end) << "level " << r;
}

// Sorted position triples of a record's faces at full detail.
std::vector<std::array<float, 9>> full_faces(const ProgressiveMesh& pm) {
  std::vector<std::array<float, 9>> out;
  for (size_t f = 0; f < pm.face_count(); ++f) {
    std::array<float, 9> t{};
    for (int k = 0; k < 3; ++k) {
      const Vec3 p = pm.positions[pm.indices[3 * f + size_t(k)]];
      t[3 * k] = p.x, t[3 * k + 1] = p.y, t[3 * k + 2] = p.z;
    }
    out.push_back(t);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The same progressive mesh renumbered: parents before children, the full mesh the same faces,
// every prefix level closed and manifold with the triangles it promises, errors never rising
// with detail.
TEST(BlockOrder, OrderedRecordIsAValidProgressiveMesh) {
  const ProgressiveMesh &pm = record(), &o = ordered().pm;
  for (uint32_t v = 0; v < o.vertex_count(); ++v) ASSERT_LE(o.parent[v], v) << "vertex " << v;
  EXPECT_EQ(full_faces(o), full_faces(pm));
  for (size_t l = 1; l < o.levels.size(); ++l)
    ASSERT_LE(o.levels[l].error, o.levels[l - 1].error) << "level " << l;
  EXPECT_EQ(o.levels.back().error, 0.0f);
  const size_t n = o.levels.size();
  for (size_t k = 0; k <= 16; ++k) {
    const size_t l = k * (n - 1) / 16;
    const Mesh level = extract_level(o, l);
    EXPECT_EQ(level.primitives[0].indices.size() / 3, o.levels[l].triangles) << "level " << l;
    std::map<std::tuple<float, float, float, float, float, float>, int> edges;
    const Primitive& p = level.primitives[0];
    for (size_t t = 0; t < p.indices.size(); t += 3)
      for (int e = 0; e < 3; ++e) {
        Vec3 a = p.positions[p.indices[t + size_t(e)]],
             b = p.positions[p.indices[t + (size_t(e) + 1) % 3]];
        if (std::make_tuple(b.x, b.y, b.z) < std::make_tuple(a.x, a.y, a.z)) std::swap(a, b);
        ++edges[{a.x, a.y, a.z, b.x, b.y, b.z}];
      }
    for (const auto& [edge, faces] : edges) ASSERT_EQ(faces, 2) << "level " << l;
  }
}

// The renumbered record is a block hierarchy as the recorded one is: the same blocks with the
// same vertices and faces, and closed sets giving one state whatever the order. (Its
// dependencies may differ where a face's readers gave way in another order, both sound.)
TEST(BlockOrder, OrderedRecordGivesOneStateWhateverTheOrder) {
  const ProgressiveMesh &pm = record(), &o = ordered().pm;
  const BlockDag &a = dag(), &b = ordered().dag;
  // Every block but the root's pieces as it was; the pieces together the root.
  const uint16_t top = pm.blocks[0].level;
  std::map<std::pair<uint16_t, uint32_t>, std::pair<uint32_t, uint32_t>> sizes, got;
  for (size_t x = 0; x < a.nodes.size(); ++x)
    if (a.nodes[x].levels)
      sizes[{pm.blocks[x].level, pm.blocks[x].level == top ? 0 : pm.blocks[x].block}] = {
          a.nodes[x].vertices, a.nodes[x].faces};
  for (size_t x = 0; x < b.nodes.size(); ++x) {
    auto& g = got[{o.blocks[x].level, o.blocks[x].level == top ? 0 : o.blocks[x].block}];
    g.first += b.nodes[x].vertices, g.second += b.nodes[x].faces;
    for (uint16_t d : b.nodes[x].deps) EXPECT_LT(d, x) << "block " << x;  // earlier blocks only
    if (x == 0 || o.blocks[x].level != top) continue;  // a root piece follows the one before
    EXPECT_EQ(b.nodes[x].deps, std::vector<uint16_t>{uint16_t(x - 1)}) << "block " << x;
  }
  EXPECT_EQ(got, sizes);
  expect_one_state_whatever_the_order(ordered());
}

// A record without a hierarchy, or whose levels name a block it does not have, is refused.
TEST(BlockOrder, RecordWithoutFittingBlocksIsRefused) {
  ProgressiveMesh pm = record();
  pm.level_block.pop_back();
  const Status s = order_by_blocks(pm);
  EXPECT_NE(s.message().find("no block hierarchy"), std::string::npos) << s.message();
  pm = record();
  pm.level_block[pm.level_block.size() / 2] = uint16_t(pm.blocks.size());
  EXPECT_NE(order_by_blocks(pm).message().find("does not exist"), std::string::npos);
}

}  // namespace
}  // namespace meshmux
