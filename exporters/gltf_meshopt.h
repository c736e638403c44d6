// One mesh → EXT_meshopt_compression bufferViews over KHR_mesh_quantization attributes, for the
// glTF exporter (exporters/gltf.h, option `meshopt`). Vertex order and face order are kept
// exactly (the stream package's client takes the vertices and faces of its base as the stream
// encoder laid them out, in vertex-cache order); the index codec (version 1) may rotate a
// triangle's corners, which keeps its winding. Values use stream/quantize.h so
// they agree bit for bit with the stream encoder:
// - POSITION: unsigned short (not normalized) VEC3 on the mesh's grid, stride 8 (4th short 0);
//   the dequantization translate(origin)·scale(step) belongs in the transforms of the nodes.
// - NORMAL: normalized byte VEC3, stride 4. TEXCOORD_n: normalized unsigned short VEC2 holding
//   uv12_to_unorm16(quantize_uv(u)) when the whole set lies in [0, 1], else float VEC2.
//   COLOR_0: normalized unsigned byte VEC4.
// - Indices: unsigned short when the primitive has at most 65535 vertices, else unsigned int,
//   coded in mode TRIANGLES; attributes in mode ATTRIBUTES (vertex codec version 0, which every
//   decoder, three.js's MeshoptDecoder included, reads).
// - Identical attribute arrays (same bytes, same format) within the mesh share one accessor.
// No meshoptimizer types leak out of this header; the caller writes the JSON.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/status.h"
#include "scene/math.h"
#include "stream/quantize.h"

namespace meshmux {

// Attribute arrays of one primitive, all with positions.size() entries (normals, uv sets and
// colours may be empty). Normals should be unit length, uvs and colours finite.
struct MeshoptInput {
  const std::vector<Vec3>* positions = nullptr;
  const std::vector<Vec3>* normals = nullptr;
  const std::vector<std::vector<Vec2>>* uvs = nullptr;  // TEXCOORD_0, TEXCOORD_1, ...
  const std::vector<Vec4>* colors = nullptr;            // linear RGBA in [0, 1]
  const std::vector<uint32_t>* indices = nullptr;       // 3 per triangle, all < positions.size()
};

// One accessor with its own compressed bufferView.
struct MeshoptAccessor {
  std::vector<uint8_t> encoded;  // the meshopt bitstream of the view
  bool triangles = false;        // mode TRIANGLES (index data); else ATTRIBUTES
  uint32_t count = 0;            // elements (vertices or indices)
  uint32_t stride = 0;           // bytes per decoded element: the view's byteStride
  int component_type = 0;        // GL enum (5120 BYTE .. 5126 FLOAT)
  int components = 1;            // 1 SCALAR, 2 VEC2, 3 VEC3, 4 VEC4
  bool normalized = false;       // accessor.normalized
  std::vector<double> min, max;  // accessor min/max, written when not empty (POSITION)
};

// One primitive's accessors, as indices into MeshoptMesh::accessors.
struct MeshoptPrimitive {
  std::vector<std::pair<std::string, int>> attributes;  // "POSITION", "NORMAL", ... in that order
  int indices = -1;
};

struct MeshoptMesh {
  std::vector<MeshoptAccessor> accessors;    // in first-use order
  std::vector<MeshoptPrimitive> primitives;  // one per input, in input order
  size_t clamped_coordinates = 0;  // position components more than half a step off the grid
};

// Encodes the primitives of one mesh on the grid `grid`. Errors (kInternal) carry no prefix.
// O(vertices + indices) over all primitives, plus a byte comparison per shared-candidate array.
Result<MeshoptMesh> meshopt_encode_mesh(const std::vector<MeshoptInput>& primitives,
                                        const PositionQuantization& grid);

}  // namespace meshmux
