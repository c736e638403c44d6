// Exact position welding: a hashable key from a position's float bits, with −0 and +0 folded
// together (as clean() welds them). Used wherever faces meet "across shared positions".
#pragma once

#include <cstddef>
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

// FNV-1a over 32-bit words.
inline uint64_t fnv1a(const uint32_t* words, size_t n) {
  uint64_t h = 1469598103934665603ull;
  for (size_t i = 0; i < n; ++i) h = (h ^ words[i]) * 1099511628211ull;
  return h;
}

// A 64-bit hash of a position's exact bits (−0 folded into +0); equal positions hash equal.
inline uint64_t position_hash(Vec3 p) {
  return (uint64_t(float_bits(p.x)) * 0x9E3779B97F4A7C15ull) ^
         (uint64_t(float_bits(p.y)) * 0xC2B2AE3D27D4EB4Full) ^
         (uint64_t(float_bits(p.z)) * 0x165667B19E3779F9ull);
}

struct PositionKey {
  uint32_t x, y, z;
  explicit PositionKey(Vec3 p) : x(float_bits(p.x)), y(float_bits(p.y)), z(float_bits(p.z)) {}
  bool operator==(const PositionKey& o) const { return x == o.x && y == o.y && z == o.z; }
};

struct PositionKeyHash {
  size_t operator()(const PositionKey& k) const {
    const uint32_t words[3] = {k.x, k.y, k.z};
    uint64_t h = fnv1a(words, 3);
    return size_t(h ^ (h >> 29));
  }
};

}  // namespace meshmux
