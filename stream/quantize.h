// Attribute quantization shared by the stream package's base .glb (EXT_meshopt_compression with
// KHR_mesh_quantization) and its vertex-split refinements (stream/mesh_stream), so that a
// vertex has one integer value wherever it is coded (docs/ARCHITECTURE.md "Package").
//
// - Positions: unsigned integers of kPositionBits bits on a uniform grid (one step for all three
//   axes, as gltfpack and Draco quantize, so normals stay valid under the dequantizing scale):
//   q = round((x - origin) / step), x ≈ origin + q·step. The base .glb stores q as unsigned
//   short (not normalized) and puts the dequantization, translate(origin)·scale(step), into the
//   transform of every node that draws the mesh; the web client keeps stream positions in the
//   same integer space.
// - Normals: int8 per component, round(n·127) (glTF's normalized byte).
// - Texture coordinates: kUvBits bits over [0, 1] (clamped); the .glb holds them as unsigned
//   short normalized, uv12_to_unorm16(q), from which unorm16_to_uv12 recovers q exactly.
#pragma once

#include <cstdint>

#include "scene/math.h"

namespace meshmux {

constexpr int kPositionBits = 14;  // as model.glb's Draco positions
constexpr int kUvBits = 12;        // as model.glb's Draco texture coordinates
constexpr uint32_t kPositionMax = (1u << kPositionBits) - 1;
constexpr uint32_t kUvMax = (1u << kUvBits) - 1;

struct PositionQuantization {
  Vec3 origin{0, 0, 0};  // mesh units: the grid's corner (the bounds' minimum)
  double step = 1;       // mesh units per integer step, > 0 (1 for an empty or point-like mesh)
};

// The grid covering `bounds` with kPositionBits bits along its longest side. O(1).
PositionQuantization position_quantization(const Bounds& bounds);

// One coordinate onto the grid, clamped to [0, kPositionMax]; NaN → 0.
uint16_t quantize_coordinate(float x, float origin, double step);
inline float dequantize_coordinate(uint32_t q, float origin, double step) {
  return float(double(origin) + double(q) * step);
}

// A normal scaled to unit length as the .glb writer writes it (float(x / |n|) in double);
// zero-length or non-finite normals become +Z.
Vec3 unit_normal(Vec3 n);

// One normal component, round(x·127) clamped to [-127, 127]; NaN → 0.
int8_t quantize_normal(float x);

// One texture coordinate onto kUvBits bits over [0, 1] (clamped; NaN → 0).
uint16_t quantize_uv(float u);
// The unsigned-short normalized value the .glb stores for a kUvBits value, and back (exact).
uint16_t uv12_to_unorm16(uint16_t q);
uint16_t unorm16_to_uv12(uint16_t u);

}  // namespace meshmux
