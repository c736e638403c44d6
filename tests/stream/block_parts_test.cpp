// Block parts (stream/vsplit.h decode_vsplit_block_part, MeshStreamEncoder::set_block_parts):
// a block-built record, ordered by blocks, coded one part per block with fresh contexts; a
// client that applies any dependency-closed set of blocks, in any order the dependencies allow,
// decodes every part and holds exactly the state the record gives for that set. The record is
// a scan-like bumpy sphere forced into ~120 blocks over several levels (simplify/block_dag.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <random>
#include <set>

#include "clean/clean.h"
#include "simplify/block_dag.h"
#include "simplify/record_checks.h"
#include "simplify/simplify.h"
#include "stream/mesh_stream.h"
#include "stream/vsplit.h"
#include "test_util.h"

namespace meshmux {
namespace {

// The record, its DAG, the encoder's base state, and the parts with the block of each.
struct Coded {
  ProgressiveMesh pm;
  BlockDag dag;
  VsplitMesh base, full;       // the client at the base, and once every part is applied
  std::vector<uint32_t> rank;  // per record vertex: its stream number
  std::vector<EncodedMeshPart> parts;
  std::vector<uint16_t> part_block;
  uint64_t chained_bytes = 0;  // the same parts with contexts carried over (today's coding)
  // What a client's table holds: the blocks with the parts' ranges, the base's vertices.
  std::vector<StreamBlock> blocks;
  uint32_t base_vertices = 0;
  uint64_t escaped = 0;            // block parts' parents sent by stream number
  double parent_bits = 0;          // the block parts' parents
  double chained_parent_bits = 0;  // the same splits' parents chained (stream numbers)
};

// The table's blocks (the encoder's stream_blocks) with each part's range as its block's.
std::vector<StreamBlock> table_blocks(const MeshStreamEncoder& enc,
                                      const std::vector<EncodedMeshPart>& parts) {
  std::vector<StreamBlock> blocks = enc.stream_blocks();
  for (const EncodedMeshPart& e : parts) {
    if (e.part.block < 0 || size_t(e.part.block) >= blocks.size()) continue;
    StreamBlock& b = blocks[size_t(e.part.block)];
    b.vertex_begin = e.part.vertex_begin, b.vertex_end = e.part.vertex_end;
    b.face_begin = e.part.face_begin, b.face_end = e.part.face_end;
  }
  return blocks;
}

// The parts of `pm` from its base, one per block run; block parts or chained contexts.
std::vector<EncodedMeshPart> encode_parts(const ProgressiveMesh& pm, bool block_parts,
                                          std::vector<uint16_t>* part_block, VsplitMesh* base,
                                          VsplitMesh* full, std::vector<uint32_t>* rank,
                                          Coded* table = nullptr) {
  MeshStreamEncoder enc(pm, package_quantization(pm), 0, pm.base_level);
  EXPECT_TRUE(enc.status().is_ok()) << enc.status().message();
  enc.set_block_parts(block_parts);
  if (base) *base = enc.client();
  std::vector<EncodedMeshPart> parts;
  for (size_t r = pm.base_level + 1; r < pm.levels.size(); ++r) {
    const uint16_t b = pm.level_block[r - 1];
    if (r + 1 < pm.levels.size() && pm.level_block[r] == b) continue;  // the run goes on
    Result<EncodedMeshPart> part = enc.next(r);
    EXPECT_TRUE(part.ok()) << part.status().message();
    if (!part.ok()) break;
    parts.push_back(part.take());
    if (part_block) part_block->push_back(b);
  }
  if (full) *full = enc.client();
  if (table) {
    table->blocks = table_blocks(enc, parts);
    table->base_vertices = pm.levels[pm.base_level].vertex_end;
    table->escaped = enc.escaped_parents();
  }
  if (rank) {
    rank->assign(pm.vertex_count(), 0);
    for (uint32_t s = 0; s < enc.stream_order().size(); ++s) (*rank)[enc.stream_order()[s]] = s;
  }
  return parts;
}

const Coded& coded() {
  static const Coded c = [] {
    const SimplifyOptions o = testing::small_block_options();
    Coded out;
    ProgressiveScene ps = build_progressive(clean(testing::bumpy_sphere(96, 192), {}), o);
    EXPECT_TRUE(order_block_records(ps).is_ok());  // as the converter orders it
    out.pm = std::move(ps.meshes[0]);
    Result<BlockDag> dag = block_dag(out.pm);  // of the record as the converter orders it
    EXPECT_TRUE(dag.ok()) << dag.status().message();
    if (!dag.ok()) return out;
    out.dag = *dag;
    out.parts = encode_parts(out.pm, true, &out.part_block, &out.base, &out.full, &out.rank, &out);
    for (const EncodedMeshPart& p : out.parts)
      out.parent_bits += p.field_bits[size_t(StreamField::kParent)];
    for (const EncodedMeshPart& p :
         encode_parts(out.pm, false, nullptr, nullptr, nullptr, nullptr)) {
      out.chained_bytes += p.bytes();
      out.chained_parent_bits += p.field_bits[size_t(StreamField::kParent)];
    }
    return out;
  }();
  return c;
}

// A random dependency-closed set of blocks holding the root's pieces, in a random order that
// respects the dependencies.
std::vector<uint16_t> closed_set(std::mt19937& rng, double keep) {
  const BlockDag& d = coded().dag;
  std::vector<int> state(d.nodes.size(), 0);  // 0 undecided, 1 in, 2 out
  std::vector<uint16_t> order;
  for (bool progress = true; progress;) {
    progress = false;
    std::vector<uint16_t> ready;
    for (size_t b = 0; b < d.nodes.size(); ++b) {
      if (state[b] != 0) continue;
      bool in = true, out = false;
      for (uint16_t y : d.nodes[b].deps) in &= state[y] == 1, out |= state[y] == 2;
      if (out) state[b] = 2, progress = true;
      if (in) ready.push_back(uint16_t(b));
    }
    if (ready.empty()) break;
    const uint16_t b = ready[std::uniform_int_distribution<size_t>(0, ready.size() - 1)(rng)];
    const bool root = coded().pm.blocks[b].level == coded().pm.blocks[0].level;  // its pieces
    state[b] = root || std::bernoulli_distribution(keep)(rng) ? 1 : 2;
    if (state[b] == 1) order.push_back(b);
    progress = true;
  }
  return order;
}

// The client: the base, then each block's parts decoded in `order`.
Result<VsplitMesh> decode_blocks(const std::vector<uint16_t>& order) {
  const Coded& c = coded();
  VsplitMesh m = c.base;
  for (uint16_t b : order)
    for (size_t i = 0; i < c.parts.size(); ++i) {
      if (c.part_block[i] != b) continue;
      const PackagePart& p = c.parts[i].part;
      const std::vector<uint8_t>& d = c.parts[i].data;
      if (Status s =
              decode_vsplit_block_part(m, d.data(), d.size(), c.blocks, c.base_vertices, b,
                                       p.vertex_end - p.vertex_begin, p.face_end - p.face_begin);
          !s)
        return s.with_prefix("block " + std::to_string(b));
    }
  return m;
}

// What the record says a client holding `blocks` draws: the base's faces and those of the
// blocks' levels, each corner at its nearest held ancestor, in stream numbers; sorted, each face
// turned to start at its smallest corner.
std::vector<std::array<uint32_t, 3>> expected_faces(const std::set<uint16_t>& blocks) {
  const Coded& c = coded();
  const ProgressiveMesh& pm = c.pm;
  std::vector<uint8_t> held(pm.vertex_count(), 0), shown(pm.face_count(), 0);
  const ProgressiveLevel& base = pm.levels[pm.base_level];
  for (uint32_t v = 0; v < base.vertex_end; ++v) held[v] = 1;
  for (uint32_t f = 0; f < base.face_end; ++f) shown[f] = 1;
  for (size_t i = 0; i < c.parts.size(); ++i) {
    if (!blocks.count(c.part_block[i])) continue;
    const PackagePart& p = c.parts[i].part;
    for (uint32_t s = p.vertex_begin; s < p.vertex_end; ++s) held[s] = 1;  // a part's record and
    for (uint32_t f = p.face_begin; f < p.face_end; ++f) shown[f] = 1;     // stream ranges agree
  }
  std::vector<uint32_t> indices;
  for (uint32_t f = 0; f < pm.face_count(); ++f) {
    if (!shown[f]) continue;
    for (int k = 0; k < 3; ++k) {
      uint32_t v = pm.indices[3 * size_t(f) + size_t(k)];
      while (!held[v]) v = pm.parent[v];
      indices.push_back(c.rank[v]);
    }
  }
  return testing::sorted_faces(indices);
}

// Every part decodes on the base in stream order to exactly the encoder's state (the block
// parts are a valid stream), and fresh contexts cost little against carried ones.
TEST(BlockParts, StreamOrderDecodesToTheEncodersState) {
  const Coded& c = coded();
  ASSERT_GT(c.parts.size(), 16u);
  std::vector<uint16_t> all;
  for (uint16_t b : c.part_block)
    if (all.empty() || all.back() != b) all.push_back(b);
  Result<VsplitMesh> m = decode_blocks(all);
  ASSERT_TRUE(m.ok()) << m.status().message();
  EXPECT_EQ(state_digest(*m), state_digest(c.full));
  uint64_t bytes = 0;
  for (const EncodedMeshPart& p : c.parts) bytes += p.bytes();
  EXPECT_LE(double(bytes), 1.10 * double(c.chained_bytes))
      << bytes << " bytes in block parts, " << c.chained_bytes << " chained";
}

// A block part's parents are coded as indices into its block's candidates (the vertices of its
// ancestors inside its box): where stream numbers made a part's parents jump over the ancestors'
// vertices outside the block (a 4M-triangle scan's parents took 1.76× the chain's bits), they
// cost no more than the chain's (here ~18% less: a block's list is denser than the whole mesh's),
// and every parent lies in its block's box (no escape).
TEST(BlockParts, ParentsCostNoMoreThanTheChainsDo) {
  const Coded& c = coded();
  EXPECT_EQ(c.escaped, 0u);
  EXPECT_LE(c.parent_bits, c.chained_parent_bits)
      << c.parent_bits << " bits of block parts' parents, " << c.chained_parent_bits << " chained";
}

// A parent outside its block's box (a box that does not bound what the block touches: here every
// box shrunk to its corner) is sent by stream number after the escape index, and the stream
// still decodes to the encoder's state.
TEST(BlockParts, ParentsOutsideTheBoxAreSentByNumber) {
  ProgressiveMesh pm = coded().pm;
  for (ProgressiveBlock& b : pm.blocks) b.box_max = b.box_min;
  Coded shrunk;
  std::vector<EncodedMeshPart> parts =
      encode_parts(pm, true, &shrunk.part_block, &shrunk.base, &shrunk.full, nullptr, &shrunk);
  ASSERT_FALSE(parts.empty());
  EXPECT_GT(shrunk.escaped, 0u);
  VsplitMesh m = shrunk.base;
  for (size_t i = 0; i < parts.size(); ++i) {
    const PackagePart& p = parts[i].part;
    Status s = decode_vsplit_block_part(m, parts[i].data.data(), parts[i].data.size(),
                                        shrunk.blocks, shrunk.base_vertices, shrunk.part_block[i],
                                        p.vertex_end - p.vertex_begin, p.face_end - p.face_begin);
    ASSERT_TRUE(s.is_ok()) << "part " << i << ": " << s.message();
  }
  EXPECT_EQ(state_digest(m), state_digest(shrunk.full));
}

// The property a client's view-dependent refinement rests on: any dependency-closed set of
// blocks, applied in a random order the dependencies allow, decodes (every split finds what
// its coding names) to the vertices the encoder coded at their stream numbers and exactly the
// faces the record gives for that set.
TEST(BlockParts, ClosedSetsInAnyOrderDecodeToTheRecordsState) {
  const Coded& c = coded();
  std::mt19937 rng(11);
  for (double keep : {0.5, 0.8, 0.9, 0.95, 1.0}) {
    const std::vector<uint16_t> order = closed_set(rng, keep);
    Result<VsplitMesh> m = decode_blocks(order);
    ASSERT_TRUE(m.ok()) << "keep " << keep << ": " << m.status().message();
    size_t held = 0;
    for (uint32_t v = 0; v < m->vertex_count(); ++v) {
      if (!m->has_vertex(v)) continue;
      ++held;
      ASSERT_TRUE(m->vertices[v] == c.full.vertices[v]) << "vertex " << v;
    }
    EXPECT_EQ(testing::sorted_faces(m->indices),
              expected_faces(std::set<uint16_t>(order.begin(), order.end())))
        << "keep " << keep << ", " << order.size() << " blocks";
    EXPECT_GT(held, c.base.vertex_count());
  }
}

// A block whose dependency is missing is refused by name, not decoded into a wrong state.
TEST(BlockParts, BlockWithoutItsDependencyIsRefused) {
  const Coded& c = coded();
  for (size_t x = 1; x < c.dag.nodes.size(); ++x) {
    const std::vector<uint16_t>& deps = c.dag.nodes[x].deps;
    if (deps.size() != 1 || deps[0] == 0) continue;
    // The root, then x without its one dependency.
    Result<VsplitMesh> m = decode_blocks({0, uint16_t(x)});
    ASSERT_FALSE(m.ok()) << "block " << x << " decoded without block " << deps[0];
    EXPECT_NE(m.status().message().find("block " + std::to_string(x)), std::string::npos)
        << m.status().message();
    return;
  }
  GTEST_SKIP() << "no block with a single non-root dependency";
}

// A part decoded twice is refused (its vertices are held already).
TEST(BlockParts, PartAppliedTwiceIsRefused) {
  Result<VsplitMesh> m = decode_blocks({0, 0});
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.status().message().find("held already"), std::string::npos) << m.status().message();
}

// A layer's chunk is made from its parts as each part's bytes are let go (the multiplexer's
// take_chunk_payload, so the chunk never sits beside all of them): the same bytes as the copy,
// parts large and small (whole pages of a big one handed back), and the parts left empty.
TEST(BlockParts, ChunkTakenFromItsPartsHasTheirBytes) {
  std::vector<EncodedMeshPart> parts(3);
  std::mt19937 rng(7);
  const size_t sizes[3] = {300000, 17, 70000};
  for (size_t i = 0; i < 3; ++i) {
    parts[i].data.resize(sizes[i]);
    for (uint8_t& b : parts[i].data) b = uint8_t(rng());
  }
  const std::vector<uint8_t> copied = mesh_chunk_payload(parts);
  EXPECT_EQ(copied.size(), 300000u + 17u + 70000u);
  EXPECT_EQ(take_chunk_payload(parts), copied);
  for (const EncodedMeshPart& p : parts) EXPECT_TRUE(p.data.empty());
}

}  // namespace
}  // namespace meshmux
