// The stream decoder's C API (stream/decoder_api.h), natively: what the web client's worker
// calls once it is compiled to WebAssembly. A client that mirrors the index buffer from the
// changes the API lists (new faces, plus the moved corners of earlier faces) must hold exactly
// the decoder's buffer, and the state's digest must be the encoder's; bad input is refused with
// a message, never decoded.
#include "stream/decoder_api.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "clean/clean.h"
#include "simplify/simplify.h"
#include "stream/mesh_stream.h"
#include "test_util.h"

namespace meshmux {
namespace {

std::string error_text() { return std::string(mmx_error(), mmx_error_length()); }

// A uv sphere's progressive mesh, streamed from its coarsest level (a seam and pole fans: splits
// move corners of faces received long before).
ProgressiveMesh sphere() {
  Scene s;
  Mesh m;
  m.primitives.push_back(testing::uv_sphere(32, 32, 1.5f));
  s.meshes.push_back(m);
  s.instances.push_back({0, Mat4::identity(), "sphere"});
  SimplifyOptions so;
  so.ship_whole_below = 0;
  so.ship_whole_fraction = 0;
  return build_progressive(clean(s, {}), so).meshes[0];
}

// The base of the encoder's simulated client, handed in as the web client hands it.
MmxMesh* open_base(const ProgressiveMesh& pm, const MeshStreamEncoder& encoder) {
  MmxMesh* mesh = mmx_mesh_new(uint32_t(pm.vertex_count()), uint32_t(pm.face_count()));
  const VsplitMesh& sim = encoder.client();
  std::vector<uint16_t> p, t;
  std::vector<int8_t> n;
  for (const QuantizedVertex& q : sim.vertices) {
    p.insert(p.end(), q.p, q.p + 3), n.insert(n.end(), q.n, q.n + 3),
        t.insert(t.end(), q.t, q.t + 2);
  }
  EXPECT_EQ(mmx_set_base(mesh, p.data(), n.data(), t.data(), sim.vertex_count()), 0);
  EXPECT_EQ(mmx_append_faces(mesh, sim.indices.data(), uint32_t(sim.indices.size())), 0);
  return mesh;
}

// Why it matters: the worker sends the page only each chunk's new faces and the corners of
// earlier faces its splits moved; a corner missed here would leave a stale index on the GPU.
TEST(DecoderApi, MirroredChangesEqualTheStateAndTheDigestTheEncoders) {
  ProgressiveMesh pm = sphere();
  MeshStreamEncoder encoder(pm, package_quantization(pm), 0, pm.base_level);
  ASSERT_TRUE(encoder.status().is_ok());
  MmxMesh* mesh = open_base(pm, encoder);
  std::vector<uint32_t> mirror(mmx_indices(mesh), mmx_indices(mesh) + 3 * mmx_faces(mesh));
  const size_t full = pm.levels.size() - 1;
  uint32_t moved_total = 0;
  for (int k = 1; k <= 3; ++k) {
    auto part = encoder.next(pm.base_level + (full - pm.base_level) * size_t(k) / 3);
    ASSERT_TRUE(part.ok());
    const PackagePart& pp = part->part;
    const uint32_t f0 = mmx_faces(mesh);
    mmx_begin_changes(mesh);
    ASSERT_EQ(mmx_apply_part(mesh, part->data.data(), part->data.size(),
                             pp.vertex_end - pp.vertex_begin, pp.face_end - pp.face_begin),
              0)
        << error_text();
    const uint32_t* indices = mmx_indices(mesh);
    for (uint32_t i = 0; i < mmx_moved_count(mesh); ++i) {
      ASSERT_LT(mmx_moved(mesh)[i], 3 * f0);
      mirror[mmx_moved(mesh)[i]] = indices[mmx_moved(mesh)[i]];
    }
    moved_total += mmx_moved_count(mesh);
    mirror.insert(mirror.end(), indices + 3 * f0, indices + 3 * mmx_faces(mesh));
    ASSERT_EQ(mirror, std::vector<uint32_t>(indices, indices + 3 * mmx_faces(mesh)))
        << "part " << k;
  }
  EXPECT_GT(moved_total, 0u);  // the case is exercised
  EXPECT_EQ(mmx_digest(mesh), state_digest(encoder.client()));
  EXPECT_EQ(mmx_solid(mesh), uint32_t(encoder.client().solid));
  // Attributes as the client draws them: grid integers, normals /127, uv /kUvMax.
  const QuantizedVertex& q = encoder.client().vertices.back();
  const uint32_t last = mmx_vertices(mesh) - 1;
  float position[3], normal[3], uv[2];
  mmx_dequantize(mesh, last, last + 1, position, normal, uv, 1, 0, 0, 0, 1);
  EXPECT_EQ(position[2], float(q.p[2]));
  EXPECT_EQ(normal[0], float(q.n[0] / 127.0));
  EXPECT_EQ(uv[1], float(q.t[1] / double(kUvMax)));
  mmx_dequantize(mesh, last, last + 1, position, normal, uv, 0, 1, 2, 3, 0.5);
  EXPECT_EQ(position[1], float(2 + q.p[1] * 0.5));
  mmx_mesh_free(mesh);
}

TEST(DecoderApi, BadInputIsRefusedWithAMessage) {
  EXPECT_EQ(mmx_mesh_new(uint32_t(kMaxStreamElements) + 1, 4), nullptr);
  EXPECT_NE(error_text().find("capacity"), std::string::npos);
  MmxMesh* mesh = mmx_mesh_new(4, 2);
  const uint16_t p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const int8_t n[9] = {0, 0, 127, 0, 0, 127, 0, 0, 127};
  const uint16_t t[6] = {};
  ASSERT_EQ(mmx_set_base(mesh, p, n, t, 3), 0);
  const uint32_t outside[3] = {0, 1, 3};
  EXPECT_EQ(mmx_append_faces(mesh, outside, 3), 1);
  EXPECT_EQ(error_text(), "base face 0 names vertex 3, only 3 are received");
  const uint32_t three[9] = {0, 1, 2, 0, 2, 1, 1, 2, 0};
  EXPECT_EQ(mmx_append_faces(mesh, three, 9), 1);
  EXPECT_EQ(error_text(), "3 faces exceed its capacity 2");
  const uint8_t bytes[4] = {1, 2, 3, 4};
  EXPECT_EQ(mmx_apply_part(mesh, bytes, 4, 1, 0), 1);
  EXPECT_EQ(error_text(), "4 bytes cannot hold 1 splits and 0 faces");
  mmx_mesh_free(mesh);
}

// A block table the client hands the module is checked as it is read (a box past the grid, a
// range past the capacity, a dependency on a later block, a table cut inside a block), and a
// block part needs a table that has its block: each refused with a message, nothing decoded.
TEST(DecoderApi, BlockTableIsCheckedAsRead) {
  MmxMesh* mesh = mmx_mesh_new(8, 8);
  const uint16_t p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const int8_t n[9] = {0, 0, 127, 0, 0, 127, 0, 0, 127};
  const uint16_t t[6] = {};
  ASSERT_EQ(mmx_set_base(mesh, p, n, t, 3), 0);
  const uint8_t bytes[8] = {};
  EXPECT_EQ(mmx_apply_block_part(mesh, bytes, 8, 0, 1, 2), 1);
  EXPECT_EQ(error_text(), "block 0 of 0 set");
  // Two blocks: the grid, vertices 3..5 and 5..8, the second depending on the first.
  std::vector<uint32_t> good = {0, 0, 0,     65535, 65535, 65535, 3, 5, 0, 0,
                                0, 0, 65535, 65535, 65535, 5,     8, 1, 0};
  ASSERT_EQ(mmx_set_blocks(mesh, good.data(), uint32_t(good.size())), 0) << error_text();
  std::vector<uint32_t> box = good;
  box[3] = 65536;
  EXPECT_EQ(mmx_set_blocks(mesh, box.data(), uint32_t(box.size())), 1);
  EXPECT_EQ(error_text(), "block 0: box past the grid");
  std::vector<uint32_t> range = good;
  range[16] = 9;
  EXPECT_EQ(mmx_set_blocks(mesh, range.data(), uint32_t(range.size())), 1);
  EXPECT_EQ(error_text(), "block 1: vertex range outside the mesh");
  std::vector<uint32_t> later = good;
  later[18] = 1;
  EXPECT_EQ(mmx_set_blocks(mesh, later.data(), uint32_t(later.size())), 1);
  EXPECT_EQ(error_text(), "block 1: dependency 1 is not an earlier block");
  EXPECT_EQ(mmx_set_blocks(mesh, good.data(), 12), 1);
  EXPECT_EQ(error_text(), "block 1: the table ends inside it");
  // The second block's part before the first: its ancestor's vertices are not held.
  ASSERT_EQ(mmx_set_blocks(mesh, good.data(), uint32_t(good.size())), 0);
  EXPECT_EQ(mmx_apply_block_part(mesh, bytes, 8, 1, 3, 0), 1);
  EXPECT_NE(error_text().find("block 1: vertex 3 of block 0 (a dependency) is not held"),
            std::string::npos)
      << error_text();
  EXPECT_EQ(mmx_vertices(mesh), 3u);
  mmx_mesh_free(mesh);
}

}  // namespace
}  // namespace meshmux
