// The stream package (DESIGN.md "Package"; paper 002 for the mesh chunks, paper 004 for the
// order): one file holding a small header, a JSON chunk table, a base .glb any glTF viewer can
// open, then the chunks in multiplexed order. Any prefix that ends on a chunk boundary is
// displayable; a client fetches it with one HTTP range request or chunk by chunk.
//
// Layout (little-endian):
//   0   4  magic "MMXP"
//   4   4  uint32 version (kPackageVersion)
//   8   4  uint32 table length J (bytes)
//   12  J  the JSON table (UTF-8), zlib-deflated (browsers: DecompressionStream("deflate"))
//   12+J   the data: the base .glb (deflated when "deflated"), then each chunk, in table order
// JSON table:
//   {"version": 11,
//    "view": {"fov_y_degrees": 45, "fill": 0.8,              // how the distortion was measured:
//             "direction": [x, y, z], "clip_margin": 1.5,    // framing, default view direction,
//             "ambient": a, "diffuse": d,                    // near/far at distance ∓
//             margin·radius, "light_direction": [x, y, z],                  // shading (light in
//             view space "light_follows_camera": true,                  // when it follows the
//             "shading": "lambert" | "physical", "environment": e,      // physical: uniform
//             "light_intensity": i},                                    // environment radiance e,
//                                                                       // light intensity i
//             camera)
//    "limits": {"max_elements": 2^28, "max_texture_side": 65536, "max_json_depth": 32},
//    "base": {"offset": O, "size": S, "deflated": z,          // byte range of the base as
//             "glb_size": G, "distortion": d0,                // stored; the .glb's own size
//             "whole": true},                                 // optional, see below
//    "meshes": [{"vertices": V, "faces": F,                  // full progressive mesh sizes
//                "base_vertices": v0, "base_faces": f0,      // what the base holds
//                "bounds": [minx,miny,minz,maxx,maxy,maxz],  // of every position, mesh units
//                                                            // (floats, shortest decimals)
//                "quantization": {"origin": [x,y,z], "step": s}}],  // the position grid
//    "texture": {"width": W, "height": H} | null,           // full texture size
//    "chunks": [{"kind": "mesh", "offset": o, "size": s, "distortion": d,
//                "parts": [[m, b, e, n], ...]},  // mesh m to vertex b and face e in n coded
//                                                  // bytes (summing to the chunk's size),
//                                                  // from where m stands (its base, then the
//                                                  // parts before in file order): vertex a, face c
//               {"kind": "texture", "offset": o, "size": s, "distortion": d,
//                "width": w, "height": h,                  // every map's size
//                "maps": [{"channel": "base_color", "mime": "image/jpeg", "size": n}, ...]}],
//                   // the payload is the maps' files in this order; base_color comes first,
//                   // then any of kTextureChannels (issue 5/8's physically based maps)
//    "orders": [{"name": "rate-distortion", "chunks": [0, 1, ...], "distortion": [...]},
//               {"name": "mesh-first", ...}, ...]}                  // see below
// Offsets count from the data start (12 + J).
//
// The mesh stream (paper 002's shared vertex buffer, made streamable). A client holds per mesh
// a vertex buffer that is only appended to and an index buffer of every face received so far.
// A base that is the whole model ("whole": every mesh ships whole, no mesh chunk follows: the
// stream is texture levels only) keeps no vertex order, so it is coded as model.glb is (Draco,
// KHR_draco_mesh_compression, its meshes tagged with extras {"meshmux_mesh": m}); a client
// draws its objects as they are. Otherwise the base's mesh m has exactly v0 vertices in stream
// order (the base .glb's mesh with extras
// {"meshmux_mesh": m}, EXT_meshopt_compression + KHR_mesh_quantization: positions as integers
// on the grid, q = round((x - origin) / step), the nodes' transforms dequantizing; normals as
// normalized bytes; uv as normalized shorts, see scene/quantize.h); its f0 faces are the
// concatenation of that mesh's primitives' indices in primitive order, as decoded (meshopt's
// index codec may rotate a face's corners; the client keeps them so). A mesh chunk's payload
// is its parts' bytes in order, n bytes each; each part is the range-coded compact vertex splits
// taking the mesh from vertex a to b and face c to e (multiplex/vsplit.h; the splits' order is the
// stream's vertex order, so stream vertex i need not be the progressive mesh's vertex i). A texture
// chunk is the complete JPEG or PNG files of that level's maps, one per channel.
//
// Orders: chunks are stored in the first order's sequence ("rate-distortion", 0..n-1); every
// order is a permutation of the chunks that keeps the mesh chunks' relative order (texture
// chunks are whole images), with the expected distortion after each of its steps, so a client
// can replay a baseline from the same file.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "multiplex/mesh_stream.h"
#include "multiplex/render.h"
#include "multiplex/stream_plan.h"
#include "multiplex/viewpoints.h"
#include "scene/scene.h"
#include "scene/texture_levels.h"

namespace meshmux {

// 13: a part is one adaptive range-coded stream (multiplex/range_coder.h; 12: ten byte streams,
// the chunk's parts deflated together); flat-shaded meshes carry no normals since 12.
constexpr uint32_t kPackageVersion = 13;
constexpr uint64_t kMaxTableBytes = uint64_t(64) << 20;  // the JSON table, inflated
constexpr uint64_t kMaxBaseBytes = uint64_t(1) << 31;    // the base .glb, inflated
constexpr size_t kPackageHeaderBytes = 12;
constexpr uint64_t kMaxTextureSide = 65536;  // pixels, either side of a texture level
constexpr int kMaxJsonDepth = 32;            // bracket nesting of the JSON table
// The material channels a texture step's maps may stand for (glTF metal-roughness).
constexpr const char* kBaseColorChannel = "base_color";
inline bool is_texture_channel(const std::string& c) {
  return c == kBaseColorChannel || c == "normal" || c == "occlusion_roughness_metallic" ||
         c == "emissive" || c == "sheen_color";
}

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
  const TextureLevels* textures = nullptr;  // may be null for untextured scenes
  size_t base_texture_level = 0;            // the level embedded in the base .glb
  std::vector<StreamStep> steps;            // in stream order; each mesh layer once
  double base_distortion = 0;               // expected distortion of the base alone
  // Further orders of the same steps (baselines). The stream order itself is written first
  // as "rate-distortion".
  std::vector<StreamOrder> orders;
  // How the distortion was measured: written to the table ("view") so the client frames and
  // shades as the multiplexer did.
  ViewOptions view{};
  RenderOptions shading{};
  // The grid's distortion per view (MultiplexResult::view_table), written as the table's
  // "view_table" when there is a choice to re-plan (mesh layers and texture levels; issue 7/8).
  const ViewTable* view_table = nullptr;
};

Result<std::vector<uint8_t>> write_package(const PackageInput& input);

// The parsed package. Every offset, size and count is checked against the file and the table
// before anything is exposed; errors name the problem ("package: chunk 3: offset past the end").
// One map of a texture chunk: its channel, file type and absolute byte range.
struct PackageMap {
  std::string channel, mime;
  uint64_t offset = 0, size = 0;
};
struct PackageChunk {
  StreamStep::Kind kind = StreamStep::kMesh;
  uint64_t offset = 0, size = 0;
  double distortion = 0;
  std::vector<PackagePart> parts;  // mesh chunks
  int width = 0, height = 0;       // texture chunks
  std::vector<PackageMap> maps;    // texture chunks: base_color first
};
struct PackageMesh {
  uint32_t vertices = 0, faces = 0, base_vertices = 0, base_faces = 0;
  float bounds[6] = {0, 0, 0, 0, 0, 0};
  double origin[3] = {0, 0, 0}, step = 1;  // the position grid (scene/quantize.h)
};
struct PackageOrder {
  std::string name;
  std::vector<uint32_t> chunks;  // a permutation of chunk indices
  std::vector<double> distortion;
};
// The view and shading the distortion was measured with (the table's "view").
struct PackageView {
  double fov_y_degrees = 0, fill = 0, clip_margin = 0;
  double direction[3] = {0, 0, 0};
  double ambient = 0, diffuse = 0;
  double light_direction[3] = {0, 0, 0};
  bool light_follows_camera = true;
  bool physical = false;       // "shading": "physical" (else "lambert", also when absent)
  double environment = 0;      // physical: uniform environment radiance
  double light_intensity = 0;  // physical: the directional light's intensity
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

// The base .glb of a package read from `bytes` (inflated when stored deflated).
Result<std::vector<uint8_t>> package_base_glb(const std::vector<uint8_t>& bytes,
                                              const Package& pkg);

// Applies part `part` of a mesh chunk to `mesh` (the state decode_base started for its mesh,
// with every earlier part applied): checks the part against the table and the state, then
// decodes its vertex splits (multiplex/vsplit.h).
Status decode_part(const std::vector<uint8_t>& bytes, const Package& package,
                   const PackageChunk& chunk, size_t part, VsplitMesh& mesh);
// Mesh `mesh`'s client state after the base, from what the base .glb holds of it: its
// vertices' quantized attributes and its faces (its primitives' indices concatenated). Counts
// and indices are checked against the table.
Result<VsplitMesh> decode_base(const Package& package, size_t mesh,
                               const std::vector<QuantizedVertex>& base_vertices,
                               const std::vector<uint32_t>& base_faces);

}  // namespace meshmux
