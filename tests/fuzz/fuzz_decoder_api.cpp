// libFuzzer target: the web client's decoder as its WebAssembly module is called
// (stream/decoder_api.h) on arbitrary bytes: capacities, a base of vertices and faces, then parts
// with their counts, each applied after mmx_begin_changes and its changes read out as the worker
// reads them (moved corners, new faces, float attributes, digest).
// Input: u32 capacity vertices, u32 capacity faces, u16 base vertices, u16 base corners, the
// base's 14 bytes per vertex (p, t as u16, n as i8) and 4 per corner, then records to the end:
// a part (u16 splits, u16 faces, u16 bytes and the bytes); u16 0xFFFF, u16 words and that many
// u32 words: a block table (mmx_set_blocks); u16 0xFFFE, u16 block, then a part of that block
// (mmx_apply_block_part).
#include <cstdint>
#include <cstring>
#include <vector>

#include "stream/decoder_api.h"

namespace {
struct Reader {
  const uint8_t* at;
  const uint8_t* end;
  template <class T>
  bool get(T& out) {
    if (size_t(end - at) < sizeof(T)) return false;
    std::memcpy(&out, at, sizeof(T));
    at += sizeof(T);
    return true;
  }
};
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  Reader in{data, data + size};
  uint32_t capacity_vertices = 0, capacity_faces = 0;
  uint16_t count = 0, corners = 0;
  if (!in.get(capacity_vertices) || !in.get(capacity_faces) || !in.get(count) || !in.get(corners))
    return 0;
  // Capacities bound what decoding may add; kept small so memory follows the input's size.
  MmxMesh* mesh = mmx_mesh_new(capacity_vertices % 65536, capacity_faces % 65536);
  if (!mesh) return 0;
  std::vector<uint16_t> p(3 * size_t(count)), t(2 * size_t(count));
  std::vector<int8_t> n(3 * size_t(count));
  std::vector<uint32_t> faces(corners);
  bool ok = true;
  for (auto& x : p) ok = ok && in.get(x);
  for (auto& x : t) ok = ok && in.get(x);
  for (auto& x : n) ok = ok && in.get(x);
  for (auto& x : faces) ok = ok && in.get(x);
  if (ok && mmx_set_base(mesh, p.data(), n.data(), t.data(), count) == 0 &&
      mmx_append_faces(mesh, faces.data(), corners) == 0) {
    uint16_t splits = 0, new_faces = 0, bytes = 0, block = 0, words = 0;
    while (in.get(splits)) {
      if (splits == 0xFFFF) {  // a block table
        if (!in.get(words)) break;
        std::vector<uint32_t> table;
        for (uint32_t w = 0, x = 0; w < words && in.get(x); ++w) table.push_back(x);
        if (mmx_set_blocks(mesh, table.data(), uint32_t(table.size())) != 0) break;
        continue;
      }
      const bool block_part = splits == 0xFFFE;
      if (block_part && (!in.get(block) || !in.get(splits))) break;
      if (!in.get(new_faces) || !in.get(bytes)) break;
      const size_t length = bytes < size_t(in.end - in.at) ? bytes : size_t(in.end - in.at);
      const uint32_t v0 = mmx_vertices(mesh), f0 = mmx_faces(mesh);
      mmx_begin_changes(mesh);
      if ((block_part ? mmx_apply_block_part(mesh, in.at, length, block, splits, new_faces)
                      : mmx_apply_part(mesh, in.at, length, splits, new_faces)) != 0)
        break;
      in.at += length;
      const uint32_t vn = mmx_vertices(mesh), nf = mmx_faces(mesh);
      std::vector<float> position(3 * size_t(vn - v0)), normal(position.size()),
          uv(2 * size_t(vn - v0));
      mmx_dequantize(mesh, v0, vn, position.data(), normal.data(), uv.data(), 0, 1, 2, 3, 0.5);
      uint64_t sum = 0;
      for (uint32_t i = 0; i < mmx_moved_count(mesh); ++i)
        sum += mmx_indices(mesh)[mmx_moved(mesh)[i]];
      for (uint32_t i = 3 * f0; i < 3 * nf; ++i) sum += mmx_indices(mesh)[i];
      (void)sum;
    }
  }
  (void)mmx_digest(mesh);
  mmx_mesh_free(mesh);
  return 0;
}
