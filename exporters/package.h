// The stream package (DESIGN.md "Package"; paper 002 for the mesh chunks, paper 004 for the
// order): one file holding a small header, a JSON chunk table, a base .glb any glTF viewer can
// open, then the chunks in multiplexed order. Any prefix that ends on a chunk boundary is
// displayable; a client fetches it with one HTTP range request or chunk by chunk.
//
// Layout (little-endian):
//   0   4  magic "MMXP"
//   4   4  uint32 version (kPackageVersion)
//   8   4  uint32 JSON length J (bytes, padded with spaces to a multiple of 4)
//   12  J  JSON table (UTF-8), see below
//   12+J   the base .glb, then each mesh's base indices, then each chunk, in table order
// JSON table:
//   {"version": 2,
//    "base": {"offset": O, "size": S, "distortion": d0},     // byte range of the base .glb
//    "meshes": [{"vertices": V, "faces": F,                  // full progressive mesh sizes
//                "base_vertices": v0, "base_faces": f0,      // what the base holds
//                "bounds": [minx,miny,minz,maxx,maxy,maxz],  // position dequantization
//                "base_indices": {"offset": o, "size": s}}], // the base's faces, see below
//    "texture": {"width": W, "height": H} | null,           // full texture size
//    "chunks": [{"kind": "mesh", "offset": o, "size": s, "distortion": d,
//                "parts": [{"mesh": m, "vertex_begin": a, "vertex_end": b,
//                           "face_begin": c, "face_end": e, "vertex_bytes": n1,
//                           "index_bytes": n2, "updates": u, "update_bytes": n3}]},
//               {"kind": "texture", "offset": o, "size": s, "distortion": d,
//                "width": w, "height": h, "mime": "image/jpeg"}],
//    "orders": [{"name": "rate-distortion", "chunks": [0, 1, ...], "distortion": [...]},
//               {"name": "mesh-first", ...}, ...]}                  // see below
// Offsets are absolute in the file.
//
// The mesh stream (paper 002's shared vertex buffer, made streamable). A client holds per mesh
// a vertex buffer that is only appended to and an index buffer of every face received so far,
// in the shared numbering valid at its current level (degenerate faces kept: they draw nothing
// and may open up later). The base's mesh m has exactly v0 vertices in stream order (the base
// .glb's mesh with extras {"meshmux_mesh": m}); its faces are "base_indices": the
// meshopt_encodeIndexBuffer bytes of the f0 faces [0, f0) mapped to that level (corners < v0).
// A mesh chunk's payload is, per part in order: the meshopt_encodeVertexBuffer bytes of the
// vertices [a, b) (n1), the meshopt_encodeIndexBuffer bytes of the new faces [c, e) mapped to
// level b (corners < b; n2), and the meshopt_encodeIndexSequence bytes (n3) of 2u uint32: u
// ascending corner positions p (3·face + slot in the client's index buffer, face < c) then u
// vertex values: index[p_i] = value_i moves the faces the new vertices split off onto them.
// The index codec keeps faces' order and winding but may rotate a face's corners; positions
// address the corners as the client decoded them. Empty pieces are stored as zero bytes. A
// vertex is 20 bytes: position as 3 uint16 over the mesh bounds + 1 uint16 zero, normal as 4
// int8 (xyz·127, 0), uv as 2 uint16 (·65535), parent as uint32 (paper 002's parentIndex, for
// geomorphs). A texture chunk is a complete JPEG or PNG of that level.
//
// Orders: chunks are stored in the first order's sequence ("rate-distortion", 0..n-1); every
// order is a permutation of the chunks that keeps the mesh chunks' relative order (texture
// chunks are whole images), with the expected distortion after each of its steps, so a client
// can replay a baseline from the same file.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "scene/progressive.h"
#include "scene/scene.h"
#include "scene/texture_levels.h"

namespace meshmux {

constexpr uint32_t kPackageVersion = 2;
constexpr int kPackedVertexBytes = 20;

// One step of the multiplexed order.
struct StreamStep {
  enum Kind { kMesh, kTexture } kind = kMesh;
  // kMesh: per Scene mesh the progressive level reached after this step (index into levels).
  std::vector<size_t> levels;
  // kTexture: the texture level (index into TextureLevels::levels).
  size_t texture_level = 0;
  double distortion = 0;  // expected distortion once this step is applied
};

struct PackageInput {
  const ProgressiveScene* scene = nullptr;  // the record (atlased: one primitive per mesh)
  std::vector<size_t> base_levels;          // per mesh: the level the base .glb holds
  std::vector<uint8_t> base_glb;  // that base, already encoded (no Draco: vertex order kept)
  const TextureLevels* textures = nullptr;  // may be null for untextured scenes
  size_t base_texture_level = 0;            // the level embedded in the base .glb
  std::vector<StreamStep> steps;            // in stream order
  double base_distortion = 0;               // expected distortion of the base alone
  // Further orders of the same steps (baselines), each a permutation of step indices keeping
  // the mesh steps' relative order, with the distortion after each step. The stream order
  // itself is written first as "rate-distortion".
  struct Order {
    std::string name;
    std::vector<uint32_t> steps;
    std::vector<double> distortion;
  };
  std::vector<Order> orders;
};

Result<std::vector<uint8_t>> write_package(const PackageInput& input);

// One part of a mesh chunk, encoded (the layout above).
struct PackagePart {
  uint32_t mesh = 0, vertex_begin = 0, vertex_end = 0, face_begin = 0, face_end = 0;
  uint64_t vertex_bytes = 0, index_bytes = 0;
  uint32_t updates = 0;  // corner updates
  uint64_t update_bytes = 0;
};
struct EncodedMeshPart {
  PackagePart part;
  std::vector<uint8_t> vertices, indices, updates;
  uint64_t bytes() const { return vertices.size() + indices.size() + updates.size(); }
};

// Encodes one progressive mesh's stream from a base level on, part by part, tracking what a
// client holds (each face's corner rotation as meshopt's index codec decodes it) so updates
// address the client's corners. Memory O(V + F); each part costs O(F received) to find the
// corners it moves.
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

// The packed vertices [begin, end) of `pm` (kPackedVertexBytes each, the layout above) with
// positions quantized over `bounds`; what a mesh chunk's vertex bytes decode to. A clamped
// range: end is capped at the vertex count. Shared with the multiplexer's byte estimates.
std::vector<uint8_t> pack_vertices(const ProgressiveMesh& pm, const Bounds& bounds, uint32_t begin,
                                   uint32_t end);
// The bounds a package quantizes `pm`'s positions over: min/max of every finite position
// (all zero for a mesh without any).
Bounds package_bounds(const ProgressiveMesh& pm);

// The parsed package. Every offset, size and count is checked against the file and the table
// before anything is exposed; errors name the problem ("package: chunk 3: offset past the end").
struct PackageChunk {
  StreamStep::Kind kind = StreamStep::kMesh;
  uint64_t offset = 0, size = 0;
  double distortion = 0;
  std::vector<PackagePart> parts;  // mesh chunks
  int width = 0, height = 0;       // texture chunks
  std::string mime;
};
struct PackageMesh {
  uint32_t vertices = 0, faces = 0, base_vertices = 0, base_faces = 0;
  float bounds[6] = {0, 0, 0, 0, 0, 0};
  uint64_t base_indices_offset = 0, base_indices_size = 0;
};
struct PackageOrder {
  std::string name;
  std::vector<uint32_t> chunks;  // a permutation of chunk indices
  std::vector<double> distortion;
};
struct Package {
  uint32_t version = 0;
  uint64_t base_offset = 0, base_size = 0;
  double base_distortion = 0;
  std::vector<PackageMesh> meshes;
  int texture_width = 0, texture_height = 0;
  std::vector<PackageChunk> chunks;
  std::vector<PackageOrder> orders;  // orders[0] is the stored order
};

Result<Package> read_package(const std::vector<uint8_t>& bytes);

// A mesh chunk part decoded: packed vertices (kPackedVertexBytes each), new face indices and
// corner updates (positions ascending, each < 3·face_begin; values < vertex_end).
struct DecodedPart {
  std::vector<uint8_t> vertices;
  std::vector<uint32_t> indices;
  std::vector<uint32_t> update_positions, update_values;
};
Result<DecodedPart> decode_part(const std::vector<uint8_t>& bytes, const Package& package,
                                const PackageChunk& chunk, size_t part);
// Mesh `mesh`'s base faces (3·base_faces corners, each < base_vertices).
Result<std::vector<uint32_t>> decode_base_indices(const std::vector<uint8_t>& bytes,
                                                  const Package& package, size_t mesh);

}  // namespace meshmux
