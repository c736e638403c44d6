// Writing and reading the stream package (stream/format.h specifies it): the writer lays out
// bytes already encoded; the reader validates every offset, size and count before exposing
// anything, and decodes the base and the mesh parts into a client's state.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "scene/scene.h"
#include "scene/texture_levels.h"
#include "stream/format.h"
#include "stream/mesh_stream.h"

namespace meshmux {

// Everything the package holds, already encoded: the writer lays bytes out and encodes nothing.
struct PackageInput {
  std::vector<uint8_t> base_glb;  // the base, encoded (meshopt: vertex order kept; or whole)
  // The base is the whole model, Draco-coded (no mesh layers follow; see above).
  bool base_whole = false;
  std::vector<MeshStreamBase> meshes;  // per Scene mesh: counts, bounds, base faces
  // Per mesh layer, the encoded parts that take the meshes from the layer before to it
  // (layer 0, the base, has none): what the multiplexer costed (MultiplexResult::layer_parts).
  const std::vector<std::vector<EncodedMeshPart>>* mesh_layers = nullptr;
  // Per mesh layer, its chunk's payload: those parts' bytes in order (mesh_chunk_payload,
  // MultiplexResult::layer_chunks), as many entries as mesh_layers.
  const std::vector<std::vector<uint8_t>>* mesh_chunks = nullptr;
  // When not empty, the last mesh layer is the completion (stream/format.h "Completion"): these
  // meshes' full detail single-rate, their data concatenated in mesh_chunks' last entry, and no
  // parts in mesh_layers' last entry.
  std::vector<CompletionMesh> completion;
  // May be null for untextured scenes; the base .glb embeds level 0 (the smallest).
  const TextureLevels* textures = nullptr;
  std::vector<StreamStep> steps;  // in stream order; each mesh layer once
  double base_distortion = 0;     // expected distortion of the base alone
  // Further orders of the same steps (baselines). The stream order itself is written first
  // as "rate-distortion".
  std::vector<StreamOrder> orders;
  // How the distortion was measured: written to the table ("view") so the client frames and
  // shades as the multiplexer did.
  PackageView view{};
  // The grid's distortion per view (MultiplexResult::view_table), written as the table's
  // "view_table" when there is a choice to re-plan (mesh layers and texture levels).
  const ViewTable* view_table = nullptr;
};

Result<std::vector<uint8_t>> write_package(const PackageInput& input);

// The parsed package. Every offset, size and count is checked against the file and the table
// before anything is exposed; errors name the problem ("package: chunk 3: offset past the end").
// One map of a texture chunk: its channel, file type and absolute byte range.
struct PackageMap {
  std::string channel, mime;  // channel: empty for a kept image
  uint64_t offset = 0, size = 0;
  int32_t image = -1;         // a kept image: the base .glb image tagged meshmux_image = image
  int width = 0, height = 0;  // a kept image's size (a channel map's is the chunk's)
};
struct PackageChunk {
  StreamStep::Kind kind = StreamStep::kMesh;
  uint64_t offset = 0, size = 0;
  double distortion = 0;
  // Mesh chunks: the parts; the completion: per mesh its Draco bitstream, as mesh, vertex_end
  // (points), face_end (triangles) and bytes, the begins 0.
  std::vector<PackagePart> parts;
  int width = 0, height = 0;     // texture chunks
  std::vector<PackageMap> maps;  // texture chunks: base_color first
  std::vector<PackageMap> kept;  // texture chunks: kept images at this level, after the maps
};
struct PackageMesh {
  uint32_t vertices = 0, faces = 0, base_vertices = 0, base_faces = 0;
  float bounds[6] = {0, 0, 0, 0, 0, 0};
  double origin[3] = {0, 0, 0}, step = 1;  // the position grid (stream/quantize.h)
  std::vector<StreamBlock> blocks;         // a block hierarchy (version 17), else empty
};
struct PackageOrder {
  std::string name;
  std::vector<uint32_t> chunks;  // a permutation of chunk indices
  std::vector<double> distortion;
};
struct Package {
  uint32_t version = 0;
  PackageView view;
  uint64_t base_offset = 0, base_size = 0;  // the base as stored (absolute offset)
  bool base_deflated = false;               // stored zlib-deflated
  bool base_whole = false;                  // the base is the whole model (no mesh chunks)
  uint64_t base_glb_size = 0;               // the .glb's size once inflated
  double base_distortion = 0;
  std::vector<PackageMesh> meshes;
  int texture_width = 0, texture_height = 0;
  std::vector<PackageChunk> chunks;
  std::vector<PackageOrder> orders;  // orders[0] is the stored order
};

Result<Package> read_package(const std::vector<uint8_t>& bytes);

// The checks a part passes against the table (read_package's, again in decode_part): its ranges
// inside its mesh (at most kMaxStreamElements vertices and faces), its counts plausible for the
// bytes that carry them (stream/vsplit.h part_size_plausible). Errors name `where`.
Status check_part(const PackagePart& p, const std::vector<PackageMesh>& meshes,
                  const std::string& where);

// The base .glb of a package read from `bytes` (inflated when stored deflated).
Result<std::vector<uint8_t>> package_base_glb(const std::vector<uint8_t>& bytes,
                                              const Package& pkg);

// Applies part `part` of a mesh chunk to `mesh` (the state decode_base started for its mesh,
// with every earlier part applied; for a block part, with the blocks it depends on applied, in
// any order): checks the part against the table and the state, then decodes its vertex splits
// (stream/vsplit.h).
Status decode_part(const std::vector<uint8_t>& bytes, const Package& package,
                   const PackageChunk& chunk, size_t part, VsplitMesh& mesh);
// Mesh `mesh`'s client state after the base, from what the base .glb holds of it: its
// vertices' quantized attributes and its faces (its primitives' indices concatenated). Counts
// and indices are checked against the table.
Result<VsplitMesh> decode_base(const Package& package, size_t mesh,
                               const std::vector<QuantizedVertex>& base_vertices,
                               const std::vector<uint32_t>& base_faces);

}  // namespace meshmux
