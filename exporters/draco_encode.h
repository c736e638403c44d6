// One triangle mesh → Draco bitstream for KHR_draco_mesh_compression, checked by decoding it
// again. Used by the glTF exporter; no Draco types leak out of this header.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/status.h"
#include "scene/math.h"

namespace meshmux {

// Attribute arrays of one primitive, all with positions.size() entries (normals and colours
// may be empty). Normals should be unit length.
struct DracoInput {
  const std::vector<Vec3>* positions = nullptr;
  const std::vector<Vec3>* normals = nullptr;
  const std::vector<std::vector<Vec2>>* uvs = nullptr;  // TEXCOORD_0, TEXCOORD_1, ...
  const std::vector<Vec4>* colors = nullptr;
  const std::vector<uint32_t>* indices = nullptr;  // 3 per triangle, all < positions.size()
};

struct DracoSettings {
  int position_bits = 14;
  int normal_bits = 10;
  int uv_bits = 12;
  int color_bits = 8;
  int speed = 3;  // 0..10, used for both encoding and decoding speed
  // The positions' quantization grid: origin and side of the cube it spans (mesh units); a
  // side of 0 lets Draco take the positions' own bounds. The parts of one split primitive
  // share the whole's grid, so their common vertices land on the same points (no crack) at
  // the whole's precision (no bytes spent on finer grids).
  float position_origin[3] = {0, 0, 0};
  float position_range = 0;
};

// The encoded buffer and what a decoder gets back from it.
struct DracoOutput {
  std::vector<uint8_t> bytes;
  uint32_t num_points = 0;  // decoded vertex count: the count of every attribute accessor
  uint32_t num_faces = 0;   // decoded triangle count
  // Draco unique ids of the attributes (-1 when absent), for the extension's attribute map.
  int position_id = -1;
  int normal_id = -1;
  int color_id = -1;
  std::vector<int> uv_ids;
  // Exact bounds of the decoded positions.
  float position_min[3] = {0, 0, 0};
  float position_max[3] = {0, 0, 0};
};

// Errors (kInternal) carry Draco's message without a prefix; the caller adds the element.
Result<DracoOutput> draco_encode(const DracoInput& input, const DracoSettings& settings);

}  // namespace meshmux
