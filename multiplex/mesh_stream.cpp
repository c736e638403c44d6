// Mesh stream encoding (multiplex/mesh_stream.h; paper 002's shared vertex buffer made
// streamable, DESIGN.md "Package"). Per part: the new vertices as 20-byte packed vertices
// through meshopt_encodeVertexBuffer, the new faces mapped to the part's level through
// meshopt_encodeIndexBuffer, and the corner updates (faces held before the part whose corners
// the new vertices take over; paper 002's parent mapping evaluated here, where every parent is
// known, instead of on the client, which lacks the parents of vertices yet to come) through
// meshopt_encodeIndexSequence. The encoder decodes its own faces to learn how the codec rotated
// each one, so updates name the corner slots the client really holds. An empty piece is stored
// as zero bytes (no codec header).
#include "multiplex/mesh_stream.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>

namespace meshmux {

namespace {

std::atomic<uint64_t> g_parts_encoded{0};

uint16_t quantize16(float x, float lo, float extent) {
  float t = extent > 0 ? (x - lo) / extent : 0;
  if (!(t >= 0)) t = 0;  // also NaN
  if (t > 1) t = 1;
  return uint16_t(std::lround(t * 65535));
}
int8_t quantize8(float x) {
  if (std::isnan(x)) return 0;
  return int8_t(std::lround(std::clamp(x * 127, -127.0f, 127.0f)));
}

uint32_t map_to(const ProgressiveMesh& pm, uint32_t v, uint32_t k) {
  while (v >= k) v = pm.parent[v];
  return v;
}

Status internal(uint32_t mesh, const std::string& what) {
  return Status::error("package: mesh " + std::to_string(mesh) + ": " + what, ErrorKind::kInternal);
}

// The encoder's own checks on a progressive mesh: what the package reader will demand.
Status check_mesh(const ProgressiveMesh& pm, uint32_t m) {
  if (pm.vertex_count() > kMaxStreamElements || pm.face_count() > kMaxStreamElements)
    return internal(m, "more than 2^28 vertices or faces");
  if (pm.parent.size() != pm.vertex_count())
    return internal(m, "parent count differs from the vertex count");
  if (pm.indices.size() % 3) return internal(m, "index count is not a multiple of 3");
  if (pm.levels.empty()) return internal(m, "no levels");
  for (uint32_t i : pm.indices)
    if (i >= pm.vertex_count()) return internal(m, "index " + std::to_string(i) + " out of range");
  for (size_t l = 0; l < pm.levels.size(); ++l)
    if (pm.levels[l].vertex_end > pm.vertex_count() || pm.levels[l].face_end > pm.face_count())
      return internal(m, "level " + std::to_string(l) + " past the mesh's vertices or faces");
  return Status::ok();
}

}  // namespace

uint64_t mesh_parts_encoded() { return g_parts_encoded.load(); }

MeshStreamEncoder::MeshStreamEncoder(const ProgressiveMesh& pm, const Bounds& bounds, uint32_t mesh,
                                     size_t base_level)
    : pm_(pm), bounds_(bounds), mesh_(mesh), level_(base_level), base_(std::vector<uint8_t>{}) {
  if (Status s = check_mesh(pm, mesh); !s) {
    base_ = s;
    return;
  }
  if (base_level >= pm.levels.size()) {
    base_ = internal(mesh, "base level out of range");
    return;
  }
  const ProgressiveLevel& b = pm.levels[base_level];
  base_ = encode_faces(0, b.face_end, b.vertex_end);
}

// Encodes faces [face_begin, face_end) mapped to the level with `vertex_end` vertices, decodes
// them back and records each face's rotation (any rotation the decoded corners match: when
// several do, the corners are equal and every choice is the same triangle once they split).
Result<std::vector<uint8_t>> MeshStreamEncoder::encode_faces(uint32_t face_begin, uint32_t face_end,
                                                             uint32_t vertex_end) {
  std::vector<uint8_t> out;
  size_t count = size_t(face_end - face_begin) * 3;
  if (count == 0) return out;
  std::vector<uint32_t> mapped(count);
  for (size_t i = 0; i < count; ++i)
    mapped[i] = map_to(pm_, pm_.indices[size_t(face_begin) * 3 + i], vertex_end);
  out.resize(meshopt_encodeIndexBufferBound(count, std::max<size_t>(vertex_end, 1)));
  size_t size = meshopt_encodeIndexBuffer(out.data(), out.size(), mapped.data(), count);
  if (size == 0) return internal(mesh_, "index encoding failed");
  out.resize(size);
  std::vector<uint32_t> decoded(count);
  if (meshopt_decodeIndexBuffer(decoded.data(), count, sizeof(uint32_t), out.data(), size) != 0)
    return internal(mesh_, "index data does not decode");
  rotation_.resize(face_end, 0);
  for (size_t f = 0; f < count / 3; ++f) {
    const uint32_t *d = &decoded[f * 3], *e = &mapped[f * 3];
    int r = 0;
    while (r < 3 && !(d[0] == e[r] && d[1] == e[(r + 1) % 3] && d[2] == e[(r + 2) % 3])) ++r;
    if (r == 3) return internal(mesh_, "index codec changed a face");
    rotation_[face_begin + f] = uint8_t(r);
  }
  return out;
}

Result<EncodedMeshPart> MeshStreamEncoder::next(size_t level) {
  if (!base_.ok()) return base_.status();
  if (level >= pm_.levels.size() || level < level_)
    return internal(mesh_, "level " + std::to_string(level) + " out of order");
  const ProgressiveLevel &from = pm_.levels[level_], &to = pm_.levels[level];
  if (to.vertex_end < from.vertex_end || to.face_end < from.face_end)
    return internal(mesh_, "levels shrink");
  EncodedMeshPart e;
  e.part.mesh = mesh_;
  e.part.vertex_begin = from.vertex_end, e.part.vertex_end = to.vertex_end;
  e.part.face_begin = from.face_end, e.part.face_end = to.face_end;
  size_t n = size_t(to.vertex_end - from.vertex_end);
  if (n > 0) {
    std::vector<uint8_t> packed = pack_vertices(pm_, bounds_, from.vertex_end, to.vertex_end);
    e.vertices.resize(meshopt_encodeVertexBufferBound(n, kPackedVertexBytes));
    size_t size = meshopt_encodeVertexBuffer(e.vertices.data(), e.vertices.size(), packed.data(), n,
                                             kPackedVertexBytes);
    if (size == 0) return internal(mesh_, "vertex encoding failed");
    e.vertices.resize(size);
  }
  // Corners of the faces already held that the new vertices take over.
  std::vector<std::pair<uint32_t, uint32_t>> moves;
  if (n > 0) {
    for (uint32_t f = 0; f < from.face_end; ++f)
      for (uint32_t t = 0; t < 3; ++t) {
        uint32_t w = pm_.indices[size_t(f) * 3 + t];
        if (w < from.vertex_end) continue;
        uint32_t was = map_to(pm_, w, from.vertex_end), now = map_to(pm_, w, to.vertex_end);
        if (was == now) continue;
        uint32_t slot = (t + 3 - rotation_[f]) % 3;
        moves.push_back({f * 3 + slot, now});
      }
    std::sort(moves.begin(), moves.end());
  }
  if (!moves.empty()) {
    std::vector<uint32_t> seq(moves.size() * 2);
    for (size_t i = 0; i < moves.size(); ++i)
      seq[i] = moves[i].first, seq[moves.size() + i] = moves[i].second;
    size_t top = std::max<size_t>(size_t(from.face_end) * 3, to.vertex_end);
    e.updates.resize(meshopt_encodeIndexSequenceBound(seq.size(), top));
    size_t size =
        meshopt_encodeIndexSequence(e.updates.data(), e.updates.size(), seq.data(), seq.size());
    if (size == 0) return internal(mesh_, "update encoding failed");
    e.updates.resize(size);
  }
  auto faces = encode_faces(from.face_end, to.face_end, to.vertex_end);
  if (!faces.ok()) return faces.status();
  e.indices = faces.take();
  e.part.vertex_bytes = e.vertices.size(), e.part.index_bytes = e.indices.size();
  e.part.updates = uint32_t(moves.size()), e.part.update_bytes = e.updates.size();
  level_ = level;
  ++g_parts_encoded;
  return e;
}

Bounds package_bounds(const ProgressiveMesh& pm) {
  Bounds b;
  for (Vec3 p : pm.positions)
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) b.add(p);
  if (b.empty()) b.min = b.max = Vec3{0, 0, 0};
  return b;
}

std::vector<uint8_t> pack_vertices(const ProgressiveMesh& pm, const Bounds& box, uint32_t begin,
                                   uint32_t end) {
  end = uint32_t(std::min<size_t>(end, pm.vertex_count()));
  begin = std::min(begin, end);
  std::vector<uint8_t> out(size_t(end - begin) * kPackedVertexBytes, 0);
  Vec3 ext = box.max - box.min;
  auto put16 = [](uint8_t* p, uint16_t v) { p[0] = uint8_t(v), p[1] = uint8_t(v >> 8); };
  for (uint32_t v = begin; v < end; ++v) {
    uint8_t* q = &out[size_t(v - begin) * kPackedVertexBytes];
    Vec3 p = pm.positions[v];
    put16(q + 0, quantize16(p.x, box.min.x, ext.x));
    put16(q + 2, quantize16(p.y, box.min.y, ext.y));
    put16(q + 4, quantize16(p.z, box.min.z, ext.z));  // q[6..7] stay 0
    Vec3 n = v < pm.normals.size() ? pm.normals[v] : Vec3{0, 0, 1};
    q[8] = uint8_t(quantize8(n.x)), q[9] = uint8_t(quantize8(n.y)),
    q[10] = uint8_t(quantize8(n.z));  // q[11] = 0
    Vec2 t = !pm.uvs.empty() && v < pm.uvs[0].size() ? pm.uvs[0][v] : Vec2{};
    put16(q + 12, quantize16(t.x, 0, 1));
    put16(q + 14, quantize16(t.y, 0, 1));
    uint32_t parent = v < pm.parent.size() ? pm.parent[v] : v;
    for (int i = 0; i < 4; ++i) q[16 + i] = uint8_t(parent >> (8 * i));
  }
  return out;
}

}  // namespace meshmux
