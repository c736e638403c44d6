// The mesh stream's encoding (paper 002's shared vertex buffer made streamable; the byte layout
// is specified in exporters/package.h). The multiplexer costs each mesh layer with these
// encoders and hands the encoded parts on; the package writer lays those bytes out as they are,
// so every part is encoded exactly once per conversion.
#pragma once

#include <cstdint>
#include <vector>

#include "scene/progressive.h"
#include "scene/scene.h"

namespace meshmux {

constexpr int kPackedVertexBytes = 20;
// Vertices or faces per mesh the stream format allows; the package table carries it to the
// reader and the web client ("limits").
constexpr uint64_t kMaxStreamElements = uint64_t(1) << 28;

// One part of a mesh chunk: the vertices [vertex_begin, vertex_end) and faces
// [face_begin, face_end) of one mesh, with the byte sizes of its three pieces.
struct PackagePart {
  uint32_t mesh = 0, vertex_begin = 0, vertex_end = 0, face_begin = 0, face_end = 0;
  uint64_t vertex_bytes = 0, index_bytes = 0;
  uint32_t updates = 0;  // corner updates
  uint64_t update_bytes = 0;
};
// A part with its encoded pieces (vertices, new faces, corner updates, in payload order).
struct EncodedMeshPart {
  PackagePart part;
  std::vector<uint8_t> vertices, indices, updates;
  uint64_t bytes() const { return vertices.size() + indices.size() + updates.size(); }
};

// What the package table says of one mesh, and its base faces, encoded.
struct MeshStreamBase {
  uint32_t vertices = 0, faces = 0;            // the full progressive mesh
  uint32_t base_vertices = 0, base_faces = 0;  // what the base holds
  Bounds bounds;                               // position dequantization
  std::vector<uint8_t> base_indices;           // meshopt_encodeIndexBuffer of the base faces
};

// Encodes one progressive mesh's stream from a base level on, part by part, tracking what a
// client holds (each face's corner rotation as meshopt's index codec decodes it) so updates
// address the client's corners. Memory O(V + F); each part costs O(F received) to find the
// corners it moves. The constructor checks the mesh (counts within kMaxStreamElements, parents
// and indices in range); a failure shows in base_indices().
class MeshStreamEncoder {
 public:
  MeshStreamEncoder(const ProgressiveMesh& pm, const Bounds& bounds, uint32_t mesh,
                    size_t base_level);
  // The base's faces (meshopt_encodeIndexBuffer bytes); an error status if encoding failed.
  const Result<std::vector<uint8_t>>& base_indices() const { return base_; }
  // The part from the current level to `level` (≥ the current one); then `level` is current.
  Result<EncodedMeshPart> next(size_t level);
  size_t level() const { return level_; }

 private:
  const ProgressiveMesh& pm_;
  Bounds bounds_;
  uint32_t mesh_ = 0;
  size_t level_ = 0;
  std::vector<uint8_t> rotation_;  // per face received: decoded slot s holds corner (s + r) % 3
  Result<std::vector<uint8_t>> base_;
  Result<std::vector<uint8_t>> encode_faces(uint32_t face_begin, uint32_t face_end,
                                            uint32_t vertex_end);
};

// Parts encoded by every MeshStreamEncoder of this process so far (a counter for tests that
// check each part is encoded once per conversion). Thread-safe.
uint64_t mesh_parts_encoded();

// The packed vertices [begin, end) of `pm` (kPackedVertexBytes each, the layout in package.h)
// with positions quantized over `bounds`; what a mesh chunk's vertex bytes decode to. A clamped
// range: end is capped at the vertex count.
std::vector<uint8_t> pack_vertices(const ProgressiveMesh& pm, const Bounds& bounds, uint32_t begin,
                                   uint32_t end);
// The bounds the stream quantizes `pm`'s positions over: min/max of every finite position
// (all zero for a mesh without any).
Bounds package_bounds(const ProgressiveMesh& pm);

}  // namespace meshmux
