// Attribute quantization (stream/quantize.h): one integer value per vertex attribute, shared by
// the base .glb and the stream's vertex splits.
#include "stream/quantize.h"

#include <algorithm>
#include <cmath>

namespace meshmux {

PositionQuantization position_quantization(const Bounds& bounds) {
  PositionQuantization q;
  if (bounds.empty()) return q;
  q.origin = bounds.min;
  double extent =
      std::max({double(bounds.max.x) - bounds.min.x, double(bounds.max.y) - bounds.min.y,
                double(bounds.max.z) - bounds.min.z});
  if (std::isfinite(extent) && extent > 0) q.step = extent / kPositionMax;
  return q;
}

uint16_t quantize_coordinate(float x, float origin, double step) {
  double t = (double(x) - double(origin)) / step;
  if (!(t >= 0)) return 0;  // also NaN
  if (t >= kPositionMax) return uint16_t(kPositionMax);
  return uint16_t(std::lround(t));
}

Vec3 unit_normal(Vec3 v) {
  double l = std::sqrt(double(v.x) * v.x + double(v.y) * v.y + double(v.z) * v.z);
  if (!(l > 1e-20) || !std::isfinite(l)) return {0, 0, 1};
  return {float(v.x / l), float(v.y / l), float(v.z / l)};
}

int8_t quantize_normal(float x) {
  if (std::isnan(x)) return 0;
  return int8_t(std::lround(std::clamp(double(x) * 127, -127.0, 127.0)));
}

uint16_t quantize_uv(float u) {
  double t = double(u);
  if (!(t >= 0)) return 0;
  if (t >= 1) return uint16_t(kUvMax);
  return uint16_t(std::lround(t * kUvMax));
}

uint16_t uv12_to_unorm16(uint16_t q) {
  return uint16_t((uint32_t(std::min<uint32_t>(q, kUvMax)) * 65535u + kUvMax / 2) / kUvMax);
}
uint16_t unorm16_to_uv12(uint16_t u) { return uint16_t((uint32_t(u) * kUvMax + 32767u) / 65535u); }

}  // namespace meshmux
