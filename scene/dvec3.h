// Double-precision 3-vectors for the geometry that float cannot carry (quadrics, camera
// matrices, barycentric solves, distances in the benches). One type for every stage.
#pragma once

#include <cmath>

#include "scene/math.h"

namespace meshmux {

struct DVec3 {
  double x = 0, y = 0, z = 0;
};

inline DVec3 to_dvec3(Vec3 v) { return {double(v.x), double(v.y), double(v.z)}; }
inline DVec3 add(DVec3 a, DVec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline DVec3 sub(DVec3 a, DVec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline DVec3 mul(DVec3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline double dot(DVec3 a, DVec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline DVec3 cross(DVec3 a, DVec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double length(DVec3 a) { return std::sqrt(dot(a, a)); }
// a / |a|, or zero for a zero vector.
inline DVec3 normalize(DVec3 a) {
  double l = length(a);
  return l > 0 ? DVec3{a.x / l, a.y / l, a.z / l} : DVec3{0, 0, 0};
}

}  // namespace meshmux
