#include "scene/math.h"

#include <algorithm>

namespace meshmux {

Mat4 Mat4::translation(double x, double y, double z) {
  Mat4 r;
  r.at(0, 3) = x;
  r.at(1, 3) = y;
  r.at(2, 3) = z;
  return r;
}

Mat4 Mat4::scale(double x, double y, double z) {
  Mat4 r;
  r.at(0, 0) = x;
  r.at(1, 1) = y;
  r.at(2, 2) = z;
  return r;
}

Mat4 Mat4::rotation(double x, double y, double z, double w) {
  Mat4 r;
  r.at(0, 0) = 1 - 2 * (y * y + z * z);
  r.at(0, 1) = 2 * (x * y - z * w);
  r.at(0, 2) = 2 * (x * z + y * w);
  r.at(1, 0) = 2 * (x * y + z * w);
  r.at(1, 1) = 1 - 2 * (x * x + z * z);
  r.at(1, 2) = 2 * (y * z - x * w);
  r.at(2, 0) = 2 * (x * z - y * w);
  r.at(2, 1) = 2 * (y * z + x * w);
  r.at(2, 2) = 1 - 2 * (x * x + y * y);
  return r;
}

Mat4 Mat4::trs(const double t[3], const double q[4], const double s[3]) {
  return translation(t[0], t[1], t[2]) * rotation(q[0], q[1], q[2], q[3]) * scale(s[0], s[1], s[2]);
}

bool Mat4::is_identity(double eps) const {
  Mat4 id;
  for (int i = 0; i < 16; ++i)
    if (std::abs(m[i] - id.m[i]) > eps) return false;
  return true;
}

double Mat4::det3() const {
  return at(0, 0) * (at(1, 1) * at(2, 2) - at(1, 2) * at(2, 1)) -
         at(0, 1) * (at(1, 0) * at(2, 2) - at(1, 2) * at(2, 0)) +
         at(0, 2) * (at(1, 0) * at(2, 1) - at(1, 1) * at(2, 0));
}

Mat4 Mat4::inverse() const {
  // Cofactor expansion (the classic MESA gluInvertMatrix layout), column-major.
  const auto& a = m;
  std::array<double, 16> inv{};
  inv[0] = a[5] * a[10] * a[15] - a[5] * a[11] * a[14] - a[9] * a[6] * a[15] + a[9] * a[7] * a[14] +
           a[13] * a[6] * a[11] - a[13] * a[7] * a[10];
  inv[4] = -a[4] * a[10] * a[15] + a[4] * a[11] * a[14] + a[8] * a[6] * a[15] -
           a[8] * a[7] * a[14] - a[12] * a[6] * a[11] + a[12] * a[7] * a[10];
  inv[8] = a[4] * a[9] * a[15] - a[4] * a[11] * a[13] - a[8] * a[5] * a[15] + a[8] * a[7] * a[13] +
           a[12] * a[5] * a[11] - a[12] * a[7] * a[9];
  inv[12] = -a[4] * a[9] * a[14] + a[4] * a[10] * a[13] + a[8] * a[5] * a[14] -
            a[8] * a[6] * a[13] - a[12] * a[5] * a[10] + a[12] * a[6] * a[9];
  inv[1] = -a[1] * a[10] * a[15] + a[1] * a[11] * a[14] + a[9] * a[2] * a[15] -
           a[9] * a[3] * a[14] - a[13] * a[2] * a[11] + a[13] * a[3] * a[10];
  inv[5] = a[0] * a[10] * a[15] - a[0] * a[11] * a[14] - a[8] * a[2] * a[15] + a[8] * a[3] * a[14] +
           a[12] * a[2] * a[11] - a[12] * a[3] * a[10];
  inv[9] = -a[0] * a[9] * a[15] + a[0] * a[11] * a[13] + a[8] * a[1] * a[15] - a[8] * a[3] * a[13] -
           a[12] * a[1] * a[11] + a[12] * a[3] * a[9];
  inv[13] = a[0] * a[9] * a[14] - a[0] * a[10] * a[13] - a[8] * a[1] * a[14] + a[8] * a[2] * a[13] +
            a[12] * a[1] * a[10] - a[12] * a[2] * a[9];
  inv[2] = a[1] * a[6] * a[15] - a[1] * a[7] * a[14] - a[5] * a[2] * a[15] + a[5] * a[3] * a[14] +
           a[13] * a[2] * a[7] - a[13] * a[3] * a[6];
  inv[6] = -a[0] * a[6] * a[15] + a[0] * a[7] * a[14] + a[4] * a[2] * a[15] - a[4] * a[3] * a[14] -
           a[12] * a[2] * a[7] + a[12] * a[3] * a[6];
  inv[10] = a[0] * a[5] * a[15] - a[0] * a[7] * a[13] - a[4] * a[1] * a[15] + a[4] * a[3] * a[13] +
            a[12] * a[1] * a[7] - a[12] * a[3] * a[5];
  inv[14] = -a[0] * a[5] * a[14] + a[0] * a[6] * a[13] + a[4] * a[1] * a[14] - a[4] * a[2] * a[13] -
            a[12] * a[1] * a[6] + a[12] * a[2] * a[5];
  inv[3] = -a[1] * a[6] * a[11] + a[1] * a[7] * a[10] + a[5] * a[2] * a[11] - a[5] * a[3] * a[10] -
           a[9] * a[2] * a[7] + a[9] * a[3] * a[6];
  inv[7] = a[0] * a[6] * a[11] - a[0] * a[7] * a[10] - a[4] * a[2] * a[11] + a[4] * a[3] * a[10] +
           a[8] * a[2] * a[7] - a[8] * a[3] * a[6];
  inv[11] = -a[0] * a[5] * a[11] + a[0] * a[7] * a[9] + a[4] * a[1] * a[11] - a[4] * a[3] * a[9] -
            a[8] * a[1] * a[7] + a[8] * a[3] * a[5];
  inv[15] = a[0] * a[5] * a[10] - a[0] * a[6] * a[9] - a[4] * a[1] * a[10] + a[4] * a[2] * a[9] +
            a[8] * a[1] * a[6] - a[8] * a[2] * a[5];
  double det = a[0] * inv[0] + a[1] * inv[4] + a[2] * inv[8] + a[3] * inv[12];
  Mat4 r;
  if (det == 0 || !std::isfinite(det)) return r;
  for (int i = 0; i < 16; ++i) r.m[i] = inv[i] / det;
  return r;
}

Vec3 Mat4::transform_point(Vec3 p) const {
  double x = at(0, 0) * p.x + at(0, 1) * p.y + at(0, 2) * p.z + at(0, 3);
  double y = at(1, 0) * p.x + at(1, 1) * p.y + at(1, 2) * p.z + at(1, 3);
  double z = at(2, 0) * p.x + at(2, 1) * p.y + at(2, 2) * p.z + at(2, 3);
  return {float(x), float(y), float(z)};
}

Vec3 Mat4::transform_vector(Vec3 v) const {
  double x = at(0, 0) * v.x + at(0, 1) * v.y + at(0, 2) * v.z;
  double y = at(1, 0) * v.x + at(1, 1) * v.y + at(1, 2) * v.z;
  double z = at(2, 0) * v.x + at(2, 1) * v.y + at(2, 2) * v.z;
  return {float(x), float(y), float(z)};
}

Vec3 Mat4::transform_normal(Vec3 n) const {
  // Inverse transpose of the 3x3 part equals the cofactor matrix / det; the sign of det
  // is kept so mirrored transforms still flip normals correctly, and the scale drops out
  // in the normalization.
  double c00 = at(1, 1) * at(2, 2) - at(1, 2) * at(2, 1);
  double c01 = at(1, 2) * at(2, 0) - at(1, 0) * at(2, 2);
  double c02 = at(1, 0) * at(2, 1) - at(1, 1) * at(2, 0);
  double c10 = at(0, 2) * at(2, 1) - at(0, 1) * at(2, 2);
  double c11 = at(0, 0) * at(2, 2) - at(0, 2) * at(2, 0);
  double c12 = at(0, 1) * at(2, 0) - at(0, 0) * at(2, 1);
  double c20 = at(0, 1) * at(1, 2) - at(0, 2) * at(1, 1);
  double c21 = at(0, 2) * at(1, 0) - at(0, 0) * at(1, 2);
  double c22 = at(0, 0) * at(1, 1) - at(0, 1) * at(1, 0);
  // n' = C n (row i of the cofactor matrix C dotted with n): C = det · A⁻ᵀ. (Cᵀ n, the
  // adjugate, would be ∝ A⁻¹ and turn a rotation's normals by Rᵀ.)
  double d = det3() < 0 ? -1.0 : 1.0;
  Vec3 r{float(d * (c00 * n.x + c01 * n.y + c02 * n.z)),
         float(d * (c10 * n.x + c11 * n.y + c12 * n.z)),
         float(d * (c20 * n.x + c21 * n.y + c22 * n.z))};
  return normalize(r);
}

Mat4 operator*(const Mat4& a, const Mat4& b) {
  Mat4 r;
  for (int c = 0; c < 4; ++c)
    for (int row = 0; row < 4; ++row) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += a.at(row, k) * b.at(k, c);
      r.at(row, c) = s;
    }
  return r;
}

bool operator==(const Mat4& a, const Mat4& b) { return a.m == b.m; }

bool decompose_trs(const Mat4& mat, double t[3], double q[4], double s[3], double tolerance) {
  if (std::abs(mat.at(3, 0)) > 1e-12 || std::abs(mat.at(3, 1)) > 1e-12 ||
      std::abs(mat.at(3, 2)) > 1e-12 || std::abs(mat.at(3, 3) - 1) > 1e-12)
    return false;
  for (int i = 0; i < 3; ++i) t[i] = mat.at(i, 3);
  double col[3][3];
  for (int c = 0; c < 3; ++c) {
    for (int r = 0; r < 3; ++r) col[c][r] = mat.at(r, c);
    s[c] = std::sqrt(col[c][0] * col[c][0] + col[c][1] * col[c][1] + col[c][2] * col[c][2]);
    if (s[c] == 0 || !std::isfinite(s[c])) return false;
  }
  if (mat.det3() < 0) s[0] = -s[0];
  double r[3][3];  // r[c][row], orthonormal columns
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 3; ++k) r[c][k] = col[c][k] / s[c];
  // Shear check: columns must stay orthogonal.
  for (int a = 0; a < 3; ++a)
    for (int b = a + 1; b < 3; ++b) {
      double d = r[a][0] * r[b][0] + r[a][1] * r[b][1] + r[a][2] * r[b][2];
      if (std::abs(d) > tolerance) return false;
    }
  // Rotation matrix element R(row, col) = r[col][row].
  auto R = [&](int row, int c) { return r[c][row]; };
  double trace = R(0, 0) + R(1, 1) + R(2, 2);
  if (trace > 0) {
    double k = 0.5 / std::sqrt(trace + 1.0);
    q[3] = 0.25 / k;
    q[0] = (R(2, 1) - R(1, 2)) * k;
    q[1] = (R(0, 2) - R(2, 0)) * k;
    q[2] = (R(1, 0) - R(0, 1)) * k;
  } else if (R(0, 0) > R(1, 1) && R(0, 0) > R(2, 2)) {
    double k = 2.0 * std::sqrt(1.0 + R(0, 0) - R(1, 1) - R(2, 2));
    q[3] = (R(2, 1) - R(1, 2)) / k;
    q[0] = 0.25 * k;
    q[1] = (R(0, 1) + R(1, 0)) / k;
    q[2] = (R(0, 2) + R(2, 0)) / k;
  } else if (R(1, 1) > R(2, 2)) {
    double k = 2.0 * std::sqrt(1.0 + R(1, 1) - R(0, 0) - R(2, 2));
    q[3] = (R(0, 2) - R(2, 0)) / k;
    q[0] = (R(0, 1) + R(1, 0)) / k;
    q[1] = 0.25 * k;
    q[2] = (R(1, 2) + R(2, 1)) / k;
  } else {
    double k = 2.0 * std::sqrt(1.0 + R(2, 2) - R(0, 0) - R(1, 1));
    q[3] = (R(1, 0) - R(0, 1)) / k;
    q[0] = (R(0, 2) + R(2, 0)) / k;
    q[1] = (R(1, 2) + R(2, 1)) / k;
    q[2] = 0.25 * k;
  }
  double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  for (int i = 0; i < 4; ++i) q[i] /= n;
  if (q[3] < 0)
    for (int i = 0; i < 4; ++i) q[i] = -q[i];  // canonical sign: deterministic output
  return true;
}

void Bounds::add(Vec3 p) {
  min = {std::min(min.x, p.x), std::min(min.y, p.y), std::min(min.z, p.z)};
  max = {std::max(max.x, p.x), std::max(max.y, p.y), std::max(max.z, p.z)};
}

void Bounds::add(const Bounds& b) {
  if (b.empty()) return;
  add(b.min);
  add(b.max);
}

}  // namespace meshmux
