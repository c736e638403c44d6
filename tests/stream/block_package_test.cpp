// A package whose mesh is a block hierarchy (stream/format.h "Blocks", version 17): written
// from a block-built record (a scan-like bumpy sphere forced into ~120 blocks), read back with
// its blocks' dependencies, boxes and ranges; its parts decode in stored order to the encoder's
// state and, block by block, in any order the dependencies allow; damaged tables (a dependency
// cycle, a missing block, a box that is not a number, a block sent before its dependency) are
// refused naming the block.
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <nlohmann/json.hpp>
#include <random>
#include <set>

#include "clean/clean.h"
#include "multiplex/stream_plan.h"
#include "simplify/block_dag.h"
#include "simplify/lod.h"
#include "simplify/record_checks.h"
#include "simplify/simplify.h"
#include "stream/deflate.h"
#include "stream/mesh_stream.h"
#include "stream/package.h"
#include "test_util.h"

namespace meshmux {
namespace {

struct Fixture {
  ProgressiveScene ps;
  PackageInput input;
  std::vector<std::vector<EncodedMeshPart>> layers;  // per mesh layer (0: the base)
  std::vector<std::vector<uint8_t>> chunks;
  std::vector<QuantizedVertex> base_vertices;  // as the base .glb holds them
  std::vector<uint32_t> base_faces;            // as a client decodes them
  uint32_t full_digest = 0;                    // the encoder's state after every part
  std::vector<uint8_t> package;
};

const Fixture& fixture() {
  static Fixture* f = [] {
    auto* f = new Fixture;
    const SimplifyOptions so = testing::small_block_options();
    f->ps = build_progressive(clean(testing::bumpy_sphere(96, 192), {}), so);
    EXPECT_TRUE(order_block_records(f->ps).is_ok());  // as the converter orders it
    const ProgressiveMesh& pm = f->ps.meshes[0];
    const size_t base = pm.base_level;
    MeshStreamEncoder encoder(pm, package_quantization(pm), 0, base);
    MeshStreamBase head;
    head.vertices = uint32_t(pm.vertex_count()), head.faces = uint32_t(pm.face_count());
    head.base_vertices = pm.levels[base].vertex_end, head.base_faces = pm.levels[base].face_end;
    head.bounds = package_bounds(pm);
    head.quantization = package_quantization(pm);
    head.base_primitive_faces = encoder.base_faces();
    head.base_order = encoder.stream_order();
    head.blocks = encoder.stream_blocks();
    f->base_faces = encoder.client().indices;
    for (uint32_t v : head.base_order)
      f->base_vertices.push_back(quantize_vertex(pm, head.quantization, v));
    f->input.meshes = {head};
    f->input.base_glb = std::vector<uint8_t>(20, 0);  // not read here
    f->layers.resize(1), f->chunks.resize(1);
    // Four mesh chunks, each a few whole blocks: the multiplexer's layers cut at block ends.
    std::vector<size_t> ends;  // the levels ending a block run
    for (size_t r = base + 1; r < pm.levels.size(); ++r)
      if (r + 1 == pm.levels.size() || pm.level_block[r] != pm.level_block[r - 1])
        ends.push_back(r);
    for (size_t c = 0; c < 4; ++c) {
      std::vector<EncodedMeshPart> parts;
      for (size_t i = c * ends.size() / 4; i < (c + 1) * ends.size() / 4; ++i) {
        Result<EncodedMeshPart> part = encoder.next(ends[i]);
        EXPECT_TRUE(part.ok()) << part.status().message();
        if (part.ok()) parts.push_back(part.take());
      }
      f->chunks.push_back(mesh_chunk_payload(parts));
      f->layers.push_back(std::move(parts));
      StreamStep st;
      st.kind = StreamStep::kMesh, st.mesh_layer = c + 1, st.distortion = 3.0 - double(c);
      f->input.steps.push_back(st);
    }
    f->full_digest = state_digest(encoder.client());
    f->input.mesh_layers = &f->layers, f->input.mesh_chunks = &f->chunks;
    f->input.base_distortion = 4;
    f->input.view = package_view(MultiplexOptions{});
    Result<std::vector<uint8_t>> bytes = write_package(f->input);
    EXPECT_TRUE(bytes.ok()) << bytes.status().message();
    if (bytes.ok()) f->package = bytes.take();
    return f;
  }();
  return *f;
}

// Where each block's part is: (chunk, part).
std::vector<std::pair<size_t, size_t>> part_of_block(const Package& pkg) {
  std::vector<std::pair<size_t, size_t>> at(pkg.meshes[0].blocks.size(), {SIZE_MAX, 0});
  for (size_t c = 0; c < pkg.chunks.size(); ++c)
    for (size_t p = 0; p < pkg.chunks[c].parts.size(); ++p)
      at[size_t(pkg.chunks[c].parts[p].block)] = {c, p};
  return at;
}

Result<VsplitMesh> base_state(const Package& pkg) {
  return decode_base(pkg, 0, fixture().base_vertices, fixture().base_faces);
}

// The table says what the record's hierarchy is: version 17, every block with its
// dependencies (earlier blocks), box and contiguous ranges, every part naming its block.
TEST(BlockPackage, TableCarriesTheHierarchy) {
  const Fixture& f = fixture();
  Result<Package> pkg = read_package(f.package);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  EXPECT_EQ(pkg->version, kBlockPackageVersion);
  const ProgressiveMesh& pm = f.ps.meshes[0];
  const std::vector<StreamBlock>& blocks = pkg->meshes[0].blocks;
  ASSERT_EQ(blocks.size(), pm.blocks.size());
  ASSERT_GT(blocks.size(), 16u);
  size_t with_deps = 0;
  for (size_t k = 0; k < blocks.size(); ++k) {
    EXPECT_EQ(blocks[k].deps,
              std::vector<uint32_t>(pm.blocks[k].deps.begin(), pm.blocks[k].deps.end()));
    EXPECT_EQ(blocks[k].level, pm.blocks[k].level);
    with_deps += !blocks[k].deps.empty();
    EXPECT_LE(blocks[k].box[0], blocks[k].box[3]);
    EXPECT_LE(blocks[k].box[3], 16383);
  }
  EXPECT_EQ(with_deps, blocks.size() - 1);  // all but the root
  size_t parts = 0;
  for (const PackageChunk& c : pkg->chunks)
    for (const PackagePart& p : c.parts) {
      ASSERT_GE(p.block, 0);
      EXPECT_EQ(p.vertex_begin, blocks[size_t(p.block)].vertex_begin);
      ++parts;
    }
  EXPECT_EQ(parts, blocks.size());
}

// Played in stored order, the parts give the encoder's state.
TEST(BlockPackage, StoredOrderDecodesToTheEncodersState) {
  const Fixture& f = fixture();
  Result<Package> pkg = read_package(f.package);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  Result<VsplitMesh> m = base_state(*pkg);
  ASSERT_TRUE(m.ok()) << m.status().message();
  for (const PackageChunk& c : pkg->chunks)
    for (size_t p = 0; p < c.parts.size(); ++p) {
      Status s = decode_part(f.package, *pkg, c, p, *m);
      ASSERT_TRUE(s.is_ok()) << s.message();
    }
  EXPECT_EQ(state_digest(*m), f.full_digest);
}

// A client refining by view takes blocks out of stored order: any dependency-closed set, in any
// order its dependencies allow, decodes from the package; two orders of one set give the same
// vertices and faces.
TEST(BlockPackage, ClosedSetsDecodeInAnyOrder) {
  const Fixture& f = fixture();
  Result<Package> pkg = read_package(f.package);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  const std::vector<StreamBlock>& blocks = pkg->meshes[0].blocks;
  const auto at = part_of_block(*pkg);
  std::mt19937 rng(5);
  for (double keep : {0.5, 0.8, 0.95}) {
    // A random closed set: each block of the finer half of the levels dropped with probability
    // 1 - keep, and every block depending on a dropped one; then a random order of it that the
    // dependencies allow.
    std::vector<int> state(blocks.size(), 1);  // 1 in, 2 out
    for (uint32_t k = 0; k < blocks.size(); ++k) {
      for (uint32_t d : blocks[k].deps)
        if (state[d] == 2) state[k] = 2;
      if (2 * blocks[k].level < blocks[0].level && !std::bernoulli_distribution(keep)(rng))
        state[k] = 2;
    }
    std::vector<uint32_t> order;
    std::vector<uint8_t> done(blocks.size(), 0);
    for (bool progress = true; progress;) {
      progress = false;
      std::vector<uint32_t> ready;
      for (uint32_t k = 0; k < blocks.size(); ++k) {
        if (state[k] != 1 || done[k]) continue;
        bool deps_done = true;
        for (uint32_t d : blocks[k].deps) deps_done &= done[d] != 0;
        if (deps_done) ready.push_back(k);
      }
      if (ready.empty()) break;
      const uint32_t k = ready[std::uniform_int_distribution<size_t>(0, ready.size() - 1)(rng)];
      done[k] = 1, order.push_back(k), progress = true;
    }
    std::vector<uint32_t> sorted = order;
    std::sort(sorted.begin(), sorted.end());  // ascending: another order the deps allow
    VsplitMesh states[2];
    for (int o = 0; o < 2; ++o) {
      Result<VsplitMesh> m = base_state(*pkg);
      ASSERT_TRUE(m.ok());
      for (uint32_t k : o == 0 ? order : sorted) {
        const PackageChunk& c = pkg->chunks[at[k].first];
        Status s = decode_part(f.package, *pkg, c, at[k].second, *m);
        ASSERT_TRUE(s.is_ok()) << "keep " << keep << ": " << s.message();
      }
      states[o] = m.take();
    }
    ASSERT_EQ(states[0].vertex_count(), states[1].vertex_count());
    for (uint32_t v = 0; v < states[0].vertex_count(); ++v) {
      ASSERT_EQ(states[0].has_vertex(v), states[1].has_vertex(v));
      if (!states[0].has_vertex(v)) continue;
      ASSERT_TRUE(states[0].vertices[v] == states[1].vertices[v]) << "vertex " << v;
    }
    EXPECT_EQ(testing::sorted_faces(states[0].indices), testing::sorted_faces(states[1].indices));
    EXPECT_LT(order.size(), blocks.size()) << "keep " << keep << ": every block taken";
    EXPECT_GT(order.size(), blocks.size() / 4) << "keep " << keep;
  }
}

// A block applied without one of its dependencies is refused by decode_part, naming both.
TEST(BlockPackage, BlockWithoutItsDependencyIsRefused) {
  const Fixture& f = fixture();
  Result<Package> pkg = read_package(f.package);
  ASSERT_TRUE(pkg.ok());
  const auto at = part_of_block(*pkg);
  const std::vector<StreamBlock>& blocks = pkg->meshes[0].blocks;
  const uint32_t k = uint32_t(blocks.size() - 1);  // a finest block
  ASSERT_FALSE(blocks[k].deps.empty());
  Result<VsplitMesh> m = base_state(*pkg);
  ASSERT_TRUE(m.ok());
  Status s = decode_part(f.package, *pkg, pkg->chunks[at[k].first], at[k].second, *m);
  ASSERT_FALSE(s.is_ok());
  EXPECT_NE(s.message().find("block " + std::to_string(k) + " needs block"), std::string::npos)
      << s.message();
}

// The table as JSON (inflated) and a package with it replaced.
nlohmann::json table_of(const std::vector<uint8_t>& package) {
  const uint32_t size = uint32_t(package[8]) | uint32_t(package[9]) << 8 |
                        uint32_t(package[10]) << 16 | uint32_t(package[11]) << 24;
  Result<std::vector<uint8_t>> text = inflate_bytes(package.data() + 12, size, 1u << 26);
  return text.ok() ? nlohmann::json::parse(text->begin(), text->end()) : nlohmann::json();
}
// The table with the block index's lists put in it (stream/format.h "Block index": a table
// that holds them itself, without "index", reads the same), so that a case edits them there.
nlohmann::json merged_table_of(const std::vector<uint8_t>& package) {
  nlohmann::json j = table_of(package);
  if (!j.is_object() || !j.contains("index")) return j;
  const uint32_t size = uint32_t(package[8]) | uint32_t(package[9]) << 8 |
                        uint32_t(package[10]) << 16 | uint32_t(package[11]) << 24;
  const size_t at = 12 + size + j["index"]["offset"].get<size_t>();
  Result<std::vector<uint8_t>> text =
      inflate_bytes(package.data() + at, j["index"]["size"].get<size_t>(), 1u << 26);
  if (!text.ok()) return nlohmann::json();
  const nlohmann::json index = nlohmann::json::parse(text->begin(), text->end());
  for (size_t i = 0; i < j["meshes"].size(); ++i)
    if (!index["blocks"][i].is_null()) j["meshes"][i]["blocks"] = index["blocks"][i];
  size_t next = 0;
  for (auto& c : j["chunks"])
    if (c["kind"] == "mesh") c["parts"] = index["parts"][next++];
  j.erase("index");
  return j;
}
std::vector<uint8_t> with_table(const std::vector<uint8_t>& package, const nlohmann::json& j) {
  const std::string s = j.dump();
  const std::vector<uint8_t> text = deflate_bytes(std::vector<uint8_t>(s.begin(), s.end()));
  const uint32_t old = uint32_t(package[8]) | uint32_t(package[9]) << 8 |
                       uint32_t(package[10]) << 16 | uint32_t(package[11]) << 24;
  std::vector<uint8_t> out(package.begin(), package.begin() + 8);
  for (int i = 0; i < 4; ++i) out.push_back(uint8_t(text.size() >> (8 * i)));
  out.insert(out.end(), text.begin(), text.end());
  out.insert(out.end(), package.begin() + 12 + long(old), package.end());
  return out;
}

// The block lists and the parts wait after the base (stream/format.h "Block index"): the table
// the first picture needs holds the blocks' count and no part, the index begins where the base
// ends and the chunks where it ends, and the reader gives back what the writer was given.
TEST(BlockPackage, BlockListsComeAfterTheBase) {
  const Fixture& f = fixture();
  const nlohmann::json table = table_of(f.package);
  ASSERT_TRUE(table.is_object());
  ASSERT_TRUE(table.contains("index"));
  EXPECT_EQ(table["index"]["offset"], table["base"]["size"]);
  EXPECT_EQ(table["meshes"][0]["blocks"], f.input.meshes[0].blocks.size());
  for (const auto& c : table["chunks"]) EXPECT_FALSE(c.contains("parts"));
  EXPECT_EQ(table["chunks"][0]["offset"].get<uint64_t>(),
            table["index"]["offset"].get<uint64_t>() + table["index"]["size"].get<uint64_t>());
  Result<Package> pkg = read_package(f.package);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  ASSERT_EQ(pkg->meshes[0].blocks.size(), f.input.meshes[0].blocks.size());
  for (size_t k = 0; k < pkg->meshes[0].blocks.size(); ++k)
    EXPECT_EQ(pkg->meshes[0].blocks[k].deps, f.input.meshes[0].blocks[k].deps) << "block " << k;
  size_t parts = 0;
  for (const PackageChunk& c : pkg->chunks) parts += c.parts.size();
  EXPECT_GT(parts, 16u);
  // The index is only the bytes after the base: its lists in the table read the same.
  Result<Package> inline_lists = read_package(with_table(f.package, merged_table_of(f.package)));
  ASSERT_TRUE(inline_lists.ok()) << inline_lists.status().message();
  EXPECT_EQ(inline_lists->meshes[0].blocks.size(), pkg->meshes[0].blocks.size());
}

// A damaged block index is refused by name: bytes that do not inflate, a range that does not
// follow the base, a count that differs from its list.
TEST(BlockPackage, DamagedIndexIsRefusedByName) {
  const Fixture& f = fixture();
  const nlohmann::json table = table_of(f.package);
  ASSERT_TRUE(table.is_object() && table.contains("index"));
  const uint32_t size = uint32_t(f.package[8]) | uint32_t(f.package[9]) << 8 |
                        uint32_t(f.package[10]) << 16 | uint32_t(f.package[11]) << 24;
  std::vector<uint8_t> garbled = f.package;
  const size_t at = 12 + size + table["index"]["offset"].get<size_t>();
  for (size_t i = 2; i < 10; ++i) garbled[at + i] ^= 0x5a;
  Result<Package> pkg = read_package(garbled);
  ASSERT_FALSE(pkg.ok());
  EXPECT_NE(pkg.status().message().find("index"), std::string::npos) << pkg.status().message();
  nlohmann::json moved = table;
  moved["index"]["offset"] = 1;
  pkg = read_package(with_table(f.package, moved));
  ASSERT_FALSE(pkg.ok());
  EXPECT_NE(pkg.status().message().find("not right after the base"), std::string::npos)
      << pkg.status().message();
  nlohmann::json recount = table;
  recount["meshes"][0]["blocks"] = table["meshes"][0]["blocks"].get<size_t>() + 1;
  pkg = read_package(with_table(f.package, recount));
  ASSERT_FALSE(pkg.ok());
  EXPECT_NE(pkg.status().message().find("count and the index's list differ"), std::string::npos)
      << pkg.status().message();
}

// Damaged tables are refused by name: the reader checks the DAG before anything is used.
TEST(BlockPackage, DamagedHierarchiesAreRefusedByName) {
  const Fixture& f = fixture();
  const nlohmann::json table = merged_table_of(f.package);
  ASSERT_TRUE(table.is_object());
  ASSERT_TRUE(read_package(with_table(f.package, table)).ok());  // the rewrite itself is sound
  const size_t n = table["meshes"][0]["blocks"].size(), k = n / 2;
  struct Case {
    std::string what, expect;
    std::function<void(nlohmann::json&)> edit;
  };
  const std::vector<Case> cases = {
      {"a dependency cycle",
       "block " + std::to_string(k) + ": depends on block " + std::to_string(n - 1) +
           ", not an earlier one (a dependency cycle)",
       [&](nlohmann::json& j) { j["meshes"][0]["blocks"][k][3] = {n - 1}; }},
      {"a block on itself", "not an earlier one",
       [&](nlohmann::json& j) { j["meshes"][0]["blocks"][k][3] = {k}; }},
      {"a missing block",
       "block " + std::to_string(k) + ": depends on block " + std::to_string(n) +
           ", which is missing",
       [&](nlohmann::json& j) {
         j["meshes"][0]["blocks"][k][3] = {0, n};
       }},
      {"a box of NaN (null in JSON)", "block " + std::to_string(k) + ": box is not 6 integers",
       [&](nlohmann::json& j) { j["meshes"][0]["blocks"][k][2][2] = nullptr; }},
      {"an infinite error", "block " + std::to_string(k) + ": error",
       [&](nlohmann::json& j) { j["meshes"][0]["blocks"][k][1] = "inf"; }},
      {"a part ending before its block begins", "ends at vertex 0, face 0, before it begins",
       [&](nlohmann::json& j) {
         for (auto& c : j["chunks"])
           for (auto& p : c["parts"])
             if (p[4].get<size_t>() == k) p[1] = 0, p[2] = 0;
       }},
      {"blocks in a version 15 package", "\"blocks\" in a version 15 package",
       [&](nlohmann::json& j) { j["version"] = 15; }},
  };
  for (const Case& c : cases) {
    nlohmann::json j = table;
    c.edit(j);
    std::vector<uint8_t> bytes = with_table(f.package, j);
    if (c.what.find("version 15") != std::string::npos) bytes[4] = 15;
    Result<Package> pkg = read_package(bytes);
    ASSERT_FALSE(pkg.ok()) << c.what << " was accepted";
    EXPECT_NE(pkg.status().message().find(c.expect), std::string::npos)
        << c.what << ": " << pkg.status().message();
  }
  // A block's part stored before one of its dependencies' parts.
  nlohmann::json j = table;
  auto& chunks = j["chunks"];
  std::swap(chunks[0]["parts"][0], chunks[0]["parts"][1]);
  Result<Package> pkg = read_package(with_table(f.package, j));
  ASSERT_FALSE(pkg.ok());
  EXPECT_NE(pkg.status().message().find("which it depends on"), std::string::npos)
      << pkg.status().message();
}

}  // namespace
}  // namespace meshmux
