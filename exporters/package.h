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
//   12+J   the base .glb (offset and size in the table), then each chunk, in table order
// JSON table:
//   {"version": 1,
//    "base": {"offset": O, "size": S},                      // byte range of the base .glb
//    "meshes": [{"vertices": V, "faces": F,                  // full progressive mesh sizes
//                "base_vertices": v0, "base_faces": f0,      // what the base .glb holds
//                "bounds": [minx,miny,minz,maxx,maxy,maxz]}],  // position dequantization
//    "texture": {"width": W, "height": H} | null,           // full texture size
//    "chunks": [{"kind": "mesh", "offset": o, "size": s, "distortion": d,
//                "parts": [{"mesh": m, "vertex_begin": a, "vertex_end": b,
//                           "face_begin": c, "face_end": e,
//                           "vertex_bytes": n1, "index_bytes": n2}]},
//               {"kind": "texture", "offset": o, "size": s, "distortion": d,
//                "width": w, "height": h, "mime": "image/jpeg"}]}
// Offsets are absolute in the file. A mesh chunk's payload is, per part in order, the
// meshopt_encodeVertexBuffer bytes of its vertices [vertex_begin, vertex_end) then the
// meshopt_encodeIndexBuffer bytes of its faces [face_begin, face_end) (full-mesh corner indices;
// the client maps them through `parent`; the codec keeps the faces' order and winding but may
// rotate a face's corners). An empty vertex or face range is stored as zero bytes. A vertex is 20
// bytes: position as 3 uint16 over the mesh bounds + 1 uint16 zero, normal as 4 int8 (xyz·127, 0),
// uv as 2 uint16 (·65535), parent as uint32. A texture chunk is a complete JPEG or PNG of that
// level.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "scene/progressive.h"
#include "scene/scene.h"
#include "scene/texture_levels.h"

namespace meshmux {

constexpr uint32_t kPackageVersion = 1;
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
};

Result<std::vector<uint8_t>> write_package(const PackageInput& input);

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
struct PackagePart {
  uint32_t mesh = 0, vertex_begin = 0, vertex_end = 0, face_begin = 0, face_end = 0;
  uint64_t vertex_bytes = 0, index_bytes = 0;
};
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
};
struct Package {
  uint32_t version = 0;
  uint64_t base_offset = 0, base_size = 0;
  std::vector<PackageMesh> meshes;
  int texture_width = 0, texture_height = 0;
  std::vector<PackageChunk> chunks;
};

Result<Package> read_package(const std::vector<uint8_t>& bytes);

// A mesh chunk part decoded: packed vertices (kPackedVertexBytes each) and face indices.
struct DecodedPart {
  std::vector<uint8_t> vertices;
  std::vector<uint32_t> indices;
};
Result<DecodedPart> decode_part(const std::vector<uint8_t>& bytes, const Package& package,
                                const PackageChunk& chunk, size_t part);

}  // namespace meshmux
