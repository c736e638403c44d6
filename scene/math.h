// Small vector and matrix types for the scene model. Plain aggregates, no SIMD, no Eigen
// (Eigen stays inside the .cpp files that solve systems). Matrices are 4x4, column-major
// like glTF and OpenGL: m[col * 4 + row]; a point p maps to M * (p, 1).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>

namespace meshmux {

struct Vec2 {
  float x = 0, y = 0;
};

struct Vec3 {
  float x = 0, y = 0, z = 0;
};

struct Vec4 {
  float x = 0, y = 0, z = 0, w = 0;
};

inline Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline Vec3 operator*(Vec3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
inline bool operator==(Vec2 a, Vec2 b) { return a.x == b.x && a.y == b.y; }
inline bool operator==(Vec3 a, Vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }
inline bool operator==(Vec4 a, Vec4 b) {
  return a.x == b.x && a.y == b.y && a.z == b.z && a.w == b.w;
}
inline float dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline float length(Vec3 a) { return std::sqrt(dot(a, a)); }
// Unit vector along a; the zero vector stays zero.
inline Vec3 normalize(Vec3 a) {
  float l = length(a);
  return l > 0 ? a * (1.0f / l) : Vec3{};
}

// 4x4 affine or projective transform, column-major, double precision so that deep
// hierarchies and large world coordinates do not lose bits.
struct Mat4 {
  std::array<double, 16> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

  static Mat4 identity() { return Mat4{}; }
  static Mat4 translation(double x, double y, double z);
  static Mat4 scale(double x, double y, double z);
  // Rotation by a unit quaternion (x, y, z, w), glTF's convention.
  static Mat4 rotation(double qx, double qy, double qz, double qw);
  // glTF TRS order: T * R * S.
  static Mat4 trs(const double t[3], const double q[4], const double s[3]);

  double& at(int row, int col) { return m[col * 4 + row]; }
  double at(int row, int col) const { return m[col * 4 + row]; }
  bool is_identity(double eps = 0) const;
  // Determinant of the upper-left 3x3 (negative for mirroring transforms).
  double det3() const;
  // General inverse; returns identity when singular (check det3() first where it matters).
  Mat4 inverse() const;
  Vec3 transform_point(Vec3 p) const;
  Vec3 transform_vector(Vec3 v) const;  // ignores translation
  // Transforms a normal by the inverse transpose of the 3x3 part, renormalized.
  Vec3 transform_normal(Vec3 n) const;
};

Mat4 operator*(const Mat4& a, const Mat4& b);
bool operator==(const Mat4& a, const Mat4& b);

// Splits an affine matrix into glTF translation, rotation quaternion (x,y,z,w) and scale.
// Returns false when the matrix has shear or perspective (not representable as TRS within
// `tolerance`, relative to the largest scale).
bool decompose_trs(const Mat4& m, double t[3], double q[4], double s[3], double tolerance = 1e-5);

// Axis-aligned box. Empty when min > max.
struct Bounds {
  Vec3 min{INFINITY, INFINITY, INFINITY};
  Vec3 max{-INFINITY, -INFINITY, -INFINITY};
  bool empty() const { return min.x > max.x; }
  void add(Vec3 p);
  void add(const Bounds& b);
  Vec3 center() const { return (min + max) * 0.5f; }
  float diagonal() const { return empty() ? 0.0f : length(max - min); }
};

}  // namespace meshmux
