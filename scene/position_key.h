// Exact position welding: a hashable key from a position's float bits, with −0 and +0 folded
// together (as clean() welds them). Used wherever faces meet "across shared positions".
#pragma once

#include <cstdint>
#include <cstring>

#include "scene/math.h"

namespace meshmux {

inline uint32_t float_bits(float f) {
  if (f == 0) f = 0;  // −0 → +0
  uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}

struct PositionKey {
  uint32_t x, y, z;
  explicit PositionKey(Vec3 p) : x(float_bits(p.x)), y(float_bits(p.y)), z(float_bits(p.z)) {}
  bool operator==(const PositionKey& o) const { return x == o.x && y == o.y && z == o.z; }
};

struct PositionKeyHash {
  size_t operator()(const PositionKey& k) const {
    uint64_t h = 1469598103934665603ull;  // FNV-1a over the three words
    for (uint32_t w : {k.x, k.y, k.z}) h = (h ^ w) * 1099511628211ull;
    return size_t(h ^ (h >> 29));
  }
};

}  // namespace meshmux
