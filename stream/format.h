// The stream package format, in one place: the spec in prose, the version, the limits, the
// channel names and the step types every stage that makes or reads a package shares. Papers:
// H. Hoppe, "Octaviewer: spherically parameterized progressive meshes" (the shared vertex
// buffer of the mesh chunks); S. Yang, M. Shen, C.-C. J. Kuo, "Progressive coding of 3D
// textured graphic model via joint mesh-texture optimization" (the order).
//
// A package is one file holding a small header, a JSON chunk table, a base .glb any glTF viewer
// can open, then the chunks in multiplexed order. Any prefix that ends on a chunk boundary is
// displayable; a client fetches it with one HTTP range request or chunk by chunk.
//
// Layout (little-endian):
//   0   4  magic "MMXP"
//   4   4  uint32 version (kPackageVersion)
//   8   4  uint32 table length J (bytes)
//   12  J  the JSON table (UTF-8), zlib-deflated (browsers: DecompressionStream("deflate"))
//   12+J   the data: the base .glb (deflated when "deflated"), the block index (a package with
//          blocks, see "Block index"), then each chunk, in table order
// JSON table (keys in the order written; letters stand for values):
// clang-format off
//   {"version": 14,                                  // kPackageVersion
//    "view": {                                       // how the distortion was measured:
//      "fov_y_degrees": 45, "fill": 0.8,             //   framing (the bounding sphere fills
//      "direction": [x, y, z],                       //   `fill` of the view), the default
//      "clip_margin": 1.5,                           //   view direction, near/far at distance
//                                                    //   ∓ margin·radius;
//      "ambient": a, "diffuse": d,                   //   shading (the light in view space
//      "light_direction": [x, y, z],                 //   when it follows the camera);
//      "light_follows_camera": true,
//      "shading": "lambert" | "physical",            //   absent: "lambert";
//      "environment": e, "light_intensity": i,       //   physical: uniform environment
//                                                    //   radiance e, the light's intensity i;
//      "display": [w, h],                            //   the display the order was made for
//                                                    //   (device pixels; optional)
//      "metric": "mse" | "ciede2000"},               //   what every distortion is: the mean
//                                                    //   squared error per RGB channel over
//                                                    //   the covered pixels, or their mean
//                                                    //   CIEDE2000 (absent: "ciede2000")
//    "limits": {"max_elements": 268435456,           // 2^28
//               "max_texture_side": 65536, "max_json_depth": 32},
//    "base": {"offset": O, "size": S,                // byte range of the base as stored
//             "deflated": z,                         // true: zlib-deflated
//             "glb_size": G,                         // the .glb's own size
//             "distortion": d0,                      // expected distortion of the base alone
//             "whole": true},                        // optional, see below
//    "index": {"offset": o, "size": s},              // version 17 only: see "Block index"
//    "meshes": [{"vertices": V, "faces": F,          // full progressive mesh sizes
//                "base_vertices": v0, "base_faces": f0,            // what the base holds
//                "bounds": [minx, miny, minz, maxx, maxy, maxz],   // of every position, mesh
//                                                                  // units (floats, shortest
//                                                                  // decimals)
//                "quantization": {"origin": [x, y, z], "step": s}, // the position grid
//                "blocks": K                                       // optional (version 17): the
//                                                                  // count; the list
//                                                                  // [[l, e, [x0, y0, z0, x1, y1,
//                                                                  // z1], [k, ...]], ...] is in
//                                                                  // the index, see "Blocks"
//               }, ...],
//    "texture": {"width": W, "height": H} | null,    // full texture size
//    "chunks": [
//      {"kind": "mesh", "offset": o, "size": s, "distortion": d,
//       "parts": [[m, b, e, n], ...]},               // see "Parts" below ([m, b, e, n, k]: a
//                                                    // block's, see "Blocks"); version 17: in
//                                                    // the index
//      {"kind": "complete", "offset": o, "size": s, "distortion": d,
//       "meshes": [[m, v, f, n], ...]},              // see "Completion" below
//      {"kind": "texture", "offset": o, "size": s, "distortion": d,
//       "width": w, "height": h,                     // every map's size
//       "maps": [{"channel": "base_color", "mime": "image/jpeg", "size": n}, ...],
//       "kept": [{"image": k, "width": w, "height": h, "mime": "image/jpeg", "size": n},
//                ...]},                              // optional, see "Kept" below
//      ...],
//    "orders": [{"name": "rate-distortion", "chunks": [0, 1, ...], "distortion": [...]},
//               {"name": "mesh-first", ...}, ...],   // see "Orders" below
//    "view_table": {...}}                            // optional, see "View table" below
// clang-format on
// Offsets count from the data start (12 + J). A chunk's "distortion" is the expected distortion
// once it is applied (after the chunks before it in the stored order).
// Parts: [m, b, e, n] takes mesh m to vertex b and face e in n coded bytes (the parts' bytes sum
// to the chunk's size), from where m stands (its base, then the parts before in file order):
// vertex a, face c.
// Blocks (version 17; a mesh whose record is a block hierarchy, simplify/block_dag.h: big meshes
// built as spatial blocks simplified with locked borders, after Ponchio and Dellepiane's Nexus):
// the mesh's refinements are one part per block. Block k is [l, e, box, deps]: its level l in
// the hierarchy (0 the finest; the root's pieces, the first blocks, the coarsest), the largest
// geometric error e its refinement removes (units of the scene's bounding diagonal), the bounds
// of what it refines on the mesh's position grid (integers: minimum floored, maximum ceiled),
// and the blocks it depends on. Its part [m, b, e, n, k] takes the mesh's vertices a..b-1 and
// faces c..e-1, where a and c are where block k - 1 ends (block 0: the base's counts); a block
// that no part names sends nothing (it ends where it begins: wholly in the base), and the last
// block ends at the mesh's counts. A client may apply block k's part once the blocks in its deps
// are applied (each an earlier block: the list order is a topological order, so no cycle can
// be written), whatever other blocks it holds: its vertices take their stream numbers a..b-1
// (stream/vsplit.h decode_vsplit_block_part: fresh contexts, vertices placed, not appended, each
// parent an index into the block's candidates: the base's vertices and its ancestors' in its
// box, block_parent_candidates; so a client needs every block's range and box before it
// decodes a part). In
// stored order the parts come in block order, so a client playing the chunks in order applies
// them as a chain. A package holds version 17 only when a mesh has blocks (15 otherwise, byte
// for byte as before). A completion may end a block mesh's parts, as it ends a chain's (where
// the parts would pass the package's bound): the blocks after it are sent by no part, and the
// last block sent need not end at the mesh's counts. Readers check: deps strictly ascending
// integers below the block's own index (a dependency on itself or a later block: a cycle; past
// the list: a missing block), the box's integers within 16 bits and min ≤ max, the error finite
// and ≥ 0, each block in at most one part, the parts' ends not decreasing in block order and
// the last block ending at the mesh's counts (without a completion), and every part after the
// parts of the blocks it depends on.
// Block index (version 17: exactly when a mesh has blocks): what a client needs of the blocks
// before it applies a refinement, not before its first picture, so it comes after the base
// (a 4M-triangle scan's 145 blocks and their parts were 4.7 of the table's 5.6 KB, and the first
// picture waited for them). "index" gives its range, which begins where the base ends; the
// chunks begin where it ends. It is a zlib-deflated JSON object {"blocks": [list | null, ...],
// "parts": [[part, ...], ...]}: per mesh (in table order) its block list (null for a mesh
// without blocks; a list exactly when the table's mesh has "blocks", of that count), and per mesh
// chunk (in stored order) its "parts". A reader puts each where a table without an index holds
// it and reads the table as one; the table's mesh chunks then carry no "parts". (A version 17
// table without "index" that holds the lists itself reads the same; the writer always writes
// the index.)
// Completion (optional, at most one, after every mesh chunk in every order): the full mesh sent
// single-rate where the vertex splits' tail would cost more (the package's bound, or a tail
// dearer than the full mesh). [m, v, f, n]: mesh m's full detail as a Draco bitstream of n
// bytes (the payload holds them in this order, summing to the chunk's size) that decodes to v
// points and f triangles, positions in the mesh's grid integers as the base's (so the base's
// node transforms dequantize them), normals (when the stream carries them) and uv (when the
// mesh has them) as Draco's generic attributes. A client replaces mesh m's vertex and index
// buffers with it; no split follows. Each m once; a mesh not listed is full already.
// Maps: a texture chunk's payload is the maps' files in this order; base_color comes first, then
// any other of the channels below (physically based maps), each once.
// Kept (optional): after the maps' files, the images of materials kept beside the atlas at this
// level's scale, each replacing the base .glb's image tagged extras {"meshmux_image": k} wherever
// a material samples it (sampler, uv set, transform unchanged); each k once per chunk.
//
// View table (optional; written only when there are at least two mesh layers and two texture
// layers, so a client has an order to re-plan): the distortion of every cell of the grid (mesh
// layers received × texture levels received) from each view of the viewing sphere, for a client
// that re-plans the order for its own camera (ViewTable below; Yang, Shen and Kuo §3).
// clang-format off
//   "view_table": {"directions": [[x, y, z], ...],  // unit, from the model's centre to each view
//                  "triangles": [[i, j, k], ...],   // the viewing mesh: indices into directions
//                  "mesh_layers": M,                // mesh chunks + 1 (layer 0: the base)
//                  "texture_layers": T,             // texture chunks + 1 (level 0: the base's)
//                  "distortion": [[d, ...] | null, ...],  // M × T cells, one d per direction
//                  "texture_widths": [w, ...]}      // optional: T widths, level 0's (the base's) first
// clang-format on
// Cells are row-major: cell i × T + j is the state after i mesh chunks and j texture chunks (the
// k-th mesh chunk of the stored order is mesh layer k + 1, the k-th texture chunk texture level
// k + 1); null where the cell was not measured. Directions and values are floats' shortest
// decimals. The web reader (viewers/web/package_reader.js) accepts a missing or null table, else
// requires M and T to equal the mesh and texture chunks + 1, 1 to 4096 directions of 3 finite
// numbers, triangles of 3 integer indices below the directions' count, and exactly M × T cells,
// each null or one finite number per direction, and texture_widths (when present) T integers
// from 1 to the texture side limit, not decreasing. The C++ reader (package_read.cpp) skips it.
//
// The mesh stream (Hoppe's shared vertex buffer, made streamable). A client holds per mesh
// a vertex buffer that is only appended to and an index buffer of every face received so far.
// A base that is the whole model ("whole": every mesh ships whole, no mesh chunk follows: the
// stream is texture levels only) keeps no vertex order, so it is coded as model.glb is (Draco,
// KHR_draco_mesh_compression, its meshes tagged with extras {"meshmux_mesh": m}); a client
// draws its objects as they are. Otherwise the base's mesh m has exactly v0 vertices in stream
// order (the base .glb's mesh with extras
// {"meshmux_mesh": m}, EXT_meshopt_compression + KHR_mesh_quantization: positions as integers
// on the grid, q = round((x - origin) / step), the nodes' transforms dequantizing; normals as
// normalized bytes; uv as normalized shorts, see stream/quantize.h); its f0 faces are the
// concatenation of that mesh's primitives' indices in primitive order, as decoded (meshopt's
// index codec may rotate a face's corners; the client keeps them so). A mesh chunk's payload
// is its parts' bytes in order, n bytes each; each part is the range-coded compact vertex splits
// taking the mesh from vertex a to b and face c to e (stream/vsplit.h; the splits' order is the
// stream's vertex order, so stream vertex i need not be the progressive mesh's vertex i). A texture
// chunk is the complete JPEG, PNG or KTX2 files of that level's maps (is_map_mime: with KTX2
// levels the base .glb's images are KTX2 too, behind KHR_texture_basisu), one per channel, then its
// kept images (image/kept_levels.h: the base carries each at the base level's scale, a level only
// where the size changes, the finest level as the image came).
//
// Orders: chunks are stored in the first order's sequence ("rate-distortion", 0..n-1); every
// order is a permutation of the chunks that keeps the mesh chunks' relative order (texture
// chunks are whole images), with the expected distortion after each of its steps, so a client
// can replay a baseline from the same file.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "scene/math.h"

namespace meshmux {

// 15: a "complete" chunk may end the mesh chunks (the full mesh single-rate); 14: texture
// chunks may carry "kept" images (and the base .glb tags its images); 13: a part
// is one adaptive range-coded stream (stream/range_coder.h; 12: ten byte streams,
// the chunk's parts deflated together); flat-shaded meshes carry no normals since 12. The web
// client reads exactly this version (PACKAGE_VERSION of viewers/web/stream_format.js, which the
// build generates from this header: scripts/format_constants.mjs).
constexpr uint32_t kPackageVersion = 15;
// 17: a mesh may be a block hierarchy ("blocks", parts naming their block); written only then.
// (16 coded a block part's parents by stream number; its packages are not read.)
constexpr uint32_t kBlockPackageVersion = 17;
constexpr size_t kPackageHeaderBytes = 12;               // magic, version, table length
constexpr uint64_t kMaxTableBytes = uint64_t(64) << 20;  // the JSON table, inflated
constexpr uint64_t kMaxBaseBytes = uint64_t(1) << 31;    // the base .glb, inflated
constexpr uint64_t kMaxTextureSide = 65536;              // pixels, either side of a texture level
constexpr int kMaxJsonDepth = 32;                        // bracket nesting of the JSON table
constexpr uint64_t kMaxKeptImages = 65536;               // a kept map's "image" is below this
// Vertices or faces per mesh the stream format allows; the package table carries it to the
// reader and the web client ("limits").
constexpr uint64_t kMaxStreamElements = uint64_t(1) << 28;

// The material channels a texture step's maps may stand for (glTF metal-roughness, plus the
// sheen colour), with their names in the table ("maps": [{"channel": ...}]). Base colour is
// always a texture step's first map.
enum class Channel { kBaseColor, kNormal, kOcclusionRoughnessMetallic, kEmissive, kSheenColor };
constexpr std::array<const char*, 5> kChannelNames = {
    "base_color", "normal", "occlusion_roughness_metallic", "emissive", "sheen_color"};
inline const char* channel_name(Channel c) { return kChannelNames[size_t(c)]; }
// The channel a table name stands for; none for a name the format does not know.
inline std::optional<Channel> parse_channel(const std::string& name) {
  for (size_t i = 0; i < kChannelNames.size(); ++i)
    if (name == kChannelNames[i]) return Channel(i);
  return std::nullopt;
}
inline bool is_texture_channel(const std::string& name) { return parse_channel(name).has_value(); }
inline const char* const kBaseColorChannel = kChannelNames[0];

// The files a texture chunk's maps and kept images may be: JPEG, PNG, or KTX2 (Basis Universal,
// glTF's KHR_texture_basisu: `convert --textures ktx2`, the GPU decodes it without RGBA).
inline bool is_map_mime(const std::string& mime) {
  return mime == "image/jpeg" || mime == "image/png" || mime == "image/ktx2";
}

// One block of a mesh's block hierarchy as the package table has it (the mesh's "blocks").
struct StreamBlock {
  uint32_t level = 0;  // 0: the finest blocks; the root's pieces (the first blocks) the coarsest
  double error = 0;    // the geometric error its refinement removes (diagonal units)
  uint16_t box[6] = {0, 0, 0, 0, 0, 0};  // bounds of what it refines, on the mesh's position
                                         // grid (stream/quantize.h): min (floored), max (ceiled)
  std::vector<uint32_t> deps;  // blocks to apply first, ascending, each below this block's index
  // Its vertices' and faces' stream numbers (not written: the reader derives them from the
  // parts, as stream/format.h "Blocks" says).
  uint32_t vertex_begin = 0, vertex_end = 0, face_begin = 0, face_end = 0;
};

// One step of the multiplexed order: a chunk of the package.
struct StreamStep {
  // kComplete: a package chunk only (the completion, "complete"); a plan's steps name mesh
  // layers, and the writer makes the completion layer's step that chunk.
  enum Kind { kMesh, kTexture, kComplete } kind = kMesh;
  size_t mesh_layer = 0;     // kMesh: the mesh layer that arrives (its parts, in layer order)
  size_t texture_level = 0;  // kTexture: the texture level (index into TextureLevels::levels)
  double distortion = 0;     // expected distortion once this step is applied
};

// A further order of the same steps (a baseline): a permutation of step indices keeping the
// mesh steps' relative order, with the distortion after each step.
struct StreamOrder {
  std::string name;
  std::vector<uint32_t> steps;
  std::vector<double> distortion;
};

// The view and shading the distortion was measured with (the table's "view"), so a client
// frames and shades as the multiplexer did. Written as the shortest decimals of floats.
struct PackageView {
  double fov_y_degrees = 0, fill = 0, clip_margin = 0;
  double direction[3] = {0, 0, 0};
  double ambient = 0, diffuse = 0;
  double light_direction[3] = {0, 0, 0};
  bool light_follows_camera = true;
  bool physical = false;       // "shading": "physical" (else "lambert", also when absent)
  double environment = 0;      // physical: uniform environment radiance
  double light_intensity = 0;  // physical: the directional light's intensity
  int display[2] = {0, 0};     // the display the order was made for, device pixels (0: not said)
  // The distortion's measure ("metric"): the mean squared error per RGB channel (0..255) over the
  // covered pixels, or the mean CIEDE2000 there (also when absent: packages before the field).
  bool mse = false;
};

// The distortion of the grid's cells (mesh layers received × texture levels received) seen
// from each view of the viewing sphere, for a client that re-plans the order for its own
// camera (Yang, Shen and Kuo §3: interpolated over the viewing mesh's triangle around the
// camera direction). The table's "view_table".
struct ViewTable {
  std::vector<Vec3> directions;                    // unit, from the model's centre to each view
  std::vector<std::array<uint32_t, 3>> triangles;  // the viewing mesh over them
  int mesh_layers = 0, texture_layers = 0;         // the grid, m × n
  // Per cell i * texture_layers + j: the metric from each view (empty: not measured).
  std::vector<std::vector<double>> cells;
};

}  // namespace meshmux
