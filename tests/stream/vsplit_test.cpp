// Compact vertex splits (stream/vsplit.h, encoder in stream/mesh_stream.cpp): what the
// decoder rebuilds from the bytes is exactly the state the encoder simulated, and that state
// draws the progressive mesh's levels; the coding is compact; damaged parts fail cleanly.
#include "stream/vsplit.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <optional>
#include <random>

#include "clean/clean.h"
#include "importers/import.h"
#include "simplify/simplify.h"
#include "stream/mesh_stream.h"
#include "test_util.h"

namespace meshmux {
namespace {

// A progressive mesh of a uv sphere (its seam duplicates vertices, its poles are fans: the
// cases a split must code beyond the manifold interior), streamed from its coarsest level.
ProgressiveMesh sphere_record() {
  Scene s;
  Mesh m;
  m.primitives.push_back(testing::uv_sphere(48, 48, 2.0f, Vec3{1, -3, 0.5f}));
  s.meshes.push_back(m);
  s.instances.push_back({0, Mat4::identity(), "sphere"});
  SimplifyOptions so;
  so.ship_whole_below = 0;
  so.ship_whole_fraction = 0;
  ProgressiveScene ps = build_progressive(clean(s, {}), so);
  return ps.meshes[0];
}

using Triangle = std::array<uint32_t, 3>;
// The non-degenerate faces of a client state, sorted.
std::vector<Triangle> drawn(const VsplitMesh& m) { return testing::sorted_faces(m.indices); }
// The progressive mesh's level `level` in stream numbering (`rank`: pm vertex → stream vertex).
std::vector<Triangle> level_faces(const ProgressiveMesh& pm, size_t level,
                                  const std::vector<uint32_t>& order) {
  std::vector<uint32_t> rank(pm.vertex_count(), UINT32_MAX);
  for (uint32_t i = 0; i < order.size(); ++i) rank[order[i]] = i;
  const ProgressiveLevel& l = pm.levels[level];
  std::vector<Triangle> out;
  for (uint32_t f = 0; f < l.face_end; ++f) {
    uint32_t r[3];
    for (int k = 0; k < 3; ++k) {
      uint32_t v = pm.indices[size_t(f) * 3 + size_t(k)];
      while (v >= l.vertex_end) v = pm.parent[v];
      r[k] = rank[v];
    }
    if (r[0] != r[1] && r[1] != r[2] && r[0] != r[2])
      out.push_back(testing::canonical_face(r[0], r[1], r[2]));
  }
  std::sort(out.begin(), out.end());
  return out;
}

// Encodes `pm` from its base level to the full mesh in `parts` parts, decoding each part into
// a client state built from the base as the package reader would; checks after every part.
struct RoundTrip {
  std::vector<std::vector<uint8_t>> parts;
  uint64_t bytes = 0, new_faces = 0, twins = 0;
};
RoundTrip round_trip(const ProgressiveMesh& pm, int parts) {
  RoundTrip out;
  PositionQuantization q = package_quantization(pm);
  MeshStreamEncoder encoder(pm, q, 0, pm.base_level);
  EXPECT_TRUE(encoder.status().is_ok()) << encoder.status().message();
  const ProgressiveLevel& base = pm.levels[pm.base_level];
  VsplitMesh client;
  client.reset(uint32_t(pm.vertex_count()), uint32_t(pm.face_count()));
  // A flat-shaded mesh's stream carries no normals: every vertex holds +Z.
  auto expected = [&](uint32_t v) {
    QuantizedVertex x = quantize_vertex(pm, q, encoder.stream_order()[v]);
    if (!stream_carries_normals(pm)) x.n[0] = 0, x.n[1] = 0, x.n[2] = 127;
    return x;
  };
  for (uint32_t v = 0; v < base.vertex_end; ++v) client.add_vertex(expected(v));
  const VsplitMesh& sim = encoder.client();
  for (size_t i = 0; i < sim.indices.size(); i += 3)
    client.add_face(sim.indices[i], sim.indices[i + 1], sim.indices[i + 2]);
  size_t full = pm.levels.size() - 1;
  for (int k = 1; k <= parts; ++k) {
    size_t level = pm.base_level + (full - pm.base_level) * size_t(k) / size_t(parts);
    auto part = encoder.next(level);
    EXPECT_TRUE(part.ok()) << part.status().message();
    if (!part.ok()) return out;
    const PackagePart& p = part->part;
    Status s = decode_vsplit_part(client, part->data.data(), part->data.size(),
                                  p.vertex_end - p.vertex_begin, p.face_end - p.face_begin);
    EXPECT_TRUE(s.is_ok()) << "part " << k << ": " << s.message();
    EXPECT_EQ(client.indices, sim.indices) << "part " << k;
    EXPECT_TRUE(client.vertices == sim.vertices) << "part " << k;
    EXPECT_EQ(client.solid, sim.solid);
    EXPECT_EQ(state_digest(client), state_digest(sim));
    EXPECT_EQ(drawn(client), level_faces(pm, level, encoder.stream_order())) << "part " << k;
    out.bytes += part->data.size();
    out.new_faces += p.face_end - p.face_begin;
    out.twins += part->twins;
    out.parts.push_back(part->data);
  }
  // Every vertex carries its own quantized attributes.
  for (uint32_t i = 0; i < client.vertex_count(); ++i)
    EXPECT_TRUE(client.vertices[i] == expected(i)) << i;
  return out;
}

// The decoder rebuilds the encoder's client state bit for bit, and each part's end draws exactly
// the progressive mesh's level there (seams and pole fans included).
TEST(Vsplit, DecoderRebuildsEveryLevelOfASphere) {
  ProgressiveMesh pm = sphere_record();
  ASSERT_LT(pm.base_level + 10, pm.levels.size());
  RoundTrip r = round_trip(pm, 4);
  EXPECT_EQ(r.parts.size(), 4u);
  // The sphere's uv seam splits in pairs: the second of each takes its position from its twin
  // (and the decoder rebuilt those positions above).
  EXPECT_GT(r.twins, 10u);
}

// A single split per part (the smallest batches) decodes as well as large ones.
TEST(Vsplit, OneLevelPerPartDecodes) {
  ProgressiveMesh pm = sphere_record();
  size_t n = std::min<size_t>(40, pm.levels.size() - 1 - pm.base_level);
  pm.levels.resize(pm.base_level + n + 1);
  round_trip(pm, int(n));
}

// The multiplexer plans a part on another thread while the part before is coded: a plan made
// before the part ahead of it is coded (and adopted only after that) gives the same bytes as
// next() part by part. Why it matters: a plan that read the encoder's state as the coding
// changes it, or numbered its splits into the stream order early, would code other splits.
TEST(Vsplit, PlansMadeAheadCodeTheSameParts) {
  const ProgressiveMesh pm = sphere_record();
  const PositionQuantization q = package_quantization(pm);
  const size_t full = pm.levels.size() - 1, parts = 6;
  std::vector<size_t> levels;
  for (size_t k = 1; k <= parts; ++k)
    levels.push_back(pm.base_level + (full - pm.base_level) * k / parts);
  MeshStreamEncoder one(pm, q, 0, pm.base_level), ahead(pm, q, 0, pm.base_level);
  auto plan = ahead.prepare(levels[0]);
  ASSERT_TRUE(plan.ok());
  ahead.adopt(*plan);
  for (size_t k = 0; k < parts; ++k) {
    // The next plan first, as the multiplexer's thread would make it, then this part's coding.
    std::optional<Result<MeshStreamEncoder::PartPlan>> next_plan;
    if (k + 1 < parts) {
      next_plan.emplace(ahead.prepare(levels[k + 1]));
      ASSERT_TRUE(next_plan->ok());
    }
    auto coded = ahead.encode(plan.take());
    auto expected = one.next(levels[k]);
    ASSERT_TRUE(coded.ok() && expected.ok()) << k;
    EXPECT_EQ(coded->data, expected->data) << "part " << k;
    EXPECT_EQ(state_digest(ahead.client()), state_digest(one.client())) << "part " << k;
    if (next_plan) {
      plan = std::move(*next_plan);
      ahead.adopt(*plan);
    }
  }
  EXPECT_EQ(ahead.stream_order(), one.stream_order());
}

// The coding is compact: a smooth sphere's refinements cost well under what the old stream paid
// (147 bits per triangle): here under 40 bits per new triangle, attributes included.
TEST(Vsplit, SphereRefinementsCostFewBitsPerTriangle) {
  ProgressiveMesh pm = sphere_record();
  RoundTrip r = round_trip(pm, 3);
  ASSERT_GT(r.new_faces, 1000u);
  double bits = 8.0 * double(r.bytes) / double(r.new_faces);
  std::printf("sphere: %llu new faces in %llu bytes: %.1f bits per triangle\n",
              (unsigned long long)r.new_faces, (unsigned long long)r.bytes, bits);
  EXPECT_LT(bits, 40.0);
}

// Damaged parts are refused or decode to something bounded; never a crash or a hang.
TEST(Vsplit, DamagedPartsFailCleanly) {
  ProgressiveMesh pm = sphere_record();
  PositionQuantization q = package_quantization(pm);
  MeshStreamEncoder encoder(pm, q, 0, pm.base_level);
  auto part = encoder.next(pm.levels.size() - 1);
  ASSERT_TRUE(part.ok());
  const PackagePart& p = part->part;
  auto fresh = [&] {
    VsplitMesh m;
    m.reset(uint32_t(pm.vertex_count()), uint32_t(pm.face_count()));
    const ProgressiveLevel& base = pm.levels[pm.base_level];
    MeshStreamEncoder start(pm, q, 0, pm.base_level);
    for (uint32_t v = 0; v < base.vertex_end; ++v)
      m.add_vertex(quantize_vertex(pm, q, start.stream_order()[v]));
    auto faces = start.client().indices;
    for (size_t i = 0; i < faces.size(); i += 3) m.add_face(faces[i], faces[i + 1], faces[i + 2]);
    return m;
  };
  uint32_t nv = p.vertex_end - p.vertex_begin, nf = p.face_end - p.face_begin;
  {
    VsplitMesh m = fresh();
    ASSERT_TRUE(decode_vsplit_part(m, part->data.data(), part->data.size(), nv, nf).is_ok());
  }
  {  // truncated
    VsplitMesh m = fresh();
    Status s = decode_vsplit_part(m, part->data.data(), part->data.size() / 2, nv, nf);
    EXPECT_FALSE(s.is_ok());
    EXPECT_NE(s.message().find("end early"), std::string::npos) << s.message();
  }
  {  // a byte left over
    std::vector<uint8_t> longer = part->data;
    longer.push_back(0);
    VsplitMesh m = fresh();
    Status s = decode_vsplit_part(m, longer.data(), longer.size(), nv, nf);
    EXPECT_FALSE(s.is_ok());
    EXPECT_NE(s.message().find("left over"), std::string::npos) << s.message();
  }
  {  // counts that disagree with the data
    VsplitMesh m = fresh();
    EXPECT_FALSE(decode_vsplit_part(m, part->data.data(), part->data.size(), nv + 1, nf).is_ok());
    VsplitMesh m2 = fresh();
    EXPECT_FALSE(decode_vsplit_part(m2, part->data.data(), part->data.size(), nv, nf - 1).is_ok());
  }
  {  // a few bytes cannot stand for millions of splits (a hostile table)
    std::vector<uint8_t> few(16);
    VsplitMesh m;
    m.reset(1u << 24, 1u << 25);
    m.add_vertex(QuantizedVertex{});
    Status s = decode_vsplit_part(m, few.data(), few.size(), 1u << 23, 1u << 24);
    EXPECT_FALSE(s.is_ok());
    EXPECT_NE(s.message().find("cannot hold"), std::string::npos) << s.message();
    EXPECT_EQ(m.vertex_count(), 1u);
  }
  // Random streams: every outcome is a clean error or a bounded state.
  std::mt19937 rng(7);
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<uint8_t> plain(size_t(rng() % 4096));
    for (auto& b : plain) b = uint8_t(rng() % (trial % 2 ? 4 : 256));
    VsplitMesh m = fresh();
    Status s = decode_vsplit_part(m, plain.data(), plain.size(), nv, nf);
    EXPECT_LE(m.vertex_count(), pm.vertex_count());
    EXPECT_LE(m.face_count(), pm.face_count());
    for (uint32_t i : m.indices) ASSERT_LT(i, m.vertex_count());
    (void)s;
  }
}

// The shared scan (69k triangles): bits per triangle of its refinements, for the record.
// A mesh whose sources are all flat-shaded (no normals, glTF 3.7.2.1) streams no normals: its
// viewers derive face normals, so normals would be bytes no one looks at. The same record
// marked smooth costs more, and both round-trip exactly.
TEST(Vsplit, FlatShadedMeshStreamsNoNormals) {
  ProgressiveMesh pm = sphere_record();
  ASSERT_TRUE(stream_carries_normals(pm));
  RoundTrip smooth = round_trip(pm, 2);
  pm.primitive_flat.assign(std::max<size_t>(pm.primitive_flat.size(), 1), 1);
  ASSERT_FALSE(stream_carries_normals(pm));
  RoundTrip flat = round_trip(pm, 2);
  ASSERT_EQ(flat.parts.size(), 2u);
  EXPECT_LT(double(flat.bytes), 0.9 * double(smooth.bytes));
  // One smooth primitive among flat ones keeps the normals.
  pm.primitive_flat.push_back(0);
  EXPECT_TRUE(stream_carries_normals(pm));
}

// Where a part's bits go (EncodedMeshPart::field_bits, report.json "mesh_stream_bits"): the
// fields add up to the part's bytes less the coder's flush, and each field is charged what it
// codes: a flat-shaded mesh's normals cost nothing, a smooth one's do; positions cost most.
TEST(Vsplit, FieldBitsAddUpToThePartsBytes) {
  ProgressiveMesh pm = sphere_record();
  for (bool flat : {false, true}) {
    if (flat) pm.primitive_flat.assign(std::max<size_t>(pm.primitive_flat.size(), 1), 1);
    MeshStreamEncoder encoder(pm, package_quantization(pm), 0, pm.base_level);
    ASSERT_TRUE(encoder.status().is_ok());
    auto part = encoder.next(pm.levels.size() - 1);
    ASSERT_TRUE(part.ok()) << part.status().message();
    const auto& f = part->field_bits;
    double sum = 0;
    for (double b : f) sum += b;
    const double coded = 8.0 * double(part->bytes());
    EXPECT_LE(sum, coded + 16) << (flat ? "flat" : "smooth");
    EXPECT_GE(sum, coded - 8.0 * (kRangeCoderFlushBytes + 2)) << (flat ? "flat" : "smooth");
    EXPECT_EQ(f[size_t(StreamField::kNormal)] == 0, flat);
    EXPECT_GT(f[size_t(StreamField::kParent)], 0);
    EXPECT_GT(f[size_t(StreamField::kConnectivity)], 0);
    for (size_t k = 0; k < kStreamFields; ++k)
      EXPECT_LE(f[k], f[size_t(StreamField::kPosition)]) << kStreamFieldNames[k];
  }
}

TEST(Vsplit, SharedBunnyRoundTrips) {
  std::string path = testing::shared_model("StanfordBunny-glb/bunny.glb");
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  Warnings w;
  auto scene = import_scene(path, {}, &w);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  SimplifyOptions so;
  ProgressiveScene ps = build_progressive(clean(*scene, {}), so);
  ASSERT_FALSE(ps.meshes.empty());
  RoundTrip r = round_trip(ps.meshes[0], 4);
  double bits = 8.0 * double(r.bytes) / double(std::max<uint64_t>(1, r.new_faces));
  std::printf("bunny: %llu new faces in %llu bytes: %.1f bits per triangle\n",
              (unsigned long long)r.new_faces, (unsigned long long)r.bytes, bits);
}

}  // namespace
}  // namespace meshmux
