// Viewing sphere, camera placement and view interpolation (Yang, Shen and Kuo, "Progressive
// coding of 3D textured graphic model via joint mesh-texture optimization" §3, "layered
// sampling").
#include "multiplex/viewpoints.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include "scene/dvec3.h"

namespace meshmux {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Unit direction halfway (on the sphere) between two unit directions: the chord's midpoint
// pushed out to the sphere. Computed in double, rounded once to float.
Vec3 sphere_midpoint(Vec3 a, Vec3 b) {
  double x = double(a.x) + b.x, y = double(a.y) + b.y, z = double(a.z) + b.z;
  double l = std::sqrt(x * x + y * y + z * z);
  return {float(x / l), float(y / l), float(z / l)};
}

// Coefficients (a, b, c) with d = a·A + b·B + c·C; false when the triangle's vertex
// directions are degenerate (coplanar with the centre).
bool solve_coefficients(Vec3 A, Vec3 B, Vec3 C, Vec3 d, double out[3]) {
  DVec3 a = to_dvec3(A), b = to_dvec3(B), c = to_dvec3(C), v = to_dvec3(d);
  double det = dot(a, cross(b, c));
  if (!(std::fabs(det) > 1e-300)) return false;
  out[0] = dot(v, cross(b, c)) / det;
  out[1] = dot(a, cross(v, c)) / det;
  out[2] = dot(a, cross(b, v)) / det;
  return true;
}

}  // namespace

ViewingSphere viewing_sphere(int layers) {
  ViewingSphere s;
  const float k = float(1.0 / std::sqrt(3.0));
  // A regular tetrahedron inscribed in the unit sphere.
  s.directions = {{k, k, k}, {k, -k, -k}, {-k, k, -k}, {-k, -k, k}};
  // Each face lists the three vertices other than one, ordered so the normal points outward
  // (dot(cross(B - A, C - A), A + B + C) > 0).
  s.triangles = {{0, 1, 2}, {0, 3, 1}, {0, 2, 3}, {1, 3, 2}};

  for (int layer = 0; layer < layers; ++layer) {
    // Midpoints are shared between the two triangles of an edge: keyed by (min, max) index.
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> midpoints;
    auto midpoint = [&](uint32_t i, uint32_t j) {
      auto key = std::make_pair(std::min(i, j), std::max(i, j));
      auto it = midpoints.find(key);
      if (it != midpoints.end()) return it->second;
      uint32_t index = uint32_t(s.directions.size());
      s.directions.push_back(sphere_midpoint(s.directions[i], s.directions[j]));
      midpoints.emplace(key, index);
      return index;
    };
    std::vector<std::array<uint32_t, 3>> next;
    next.reserve(s.triangles.size() * 4);
    for (const auto& t : s.triangles) {
      uint32_t a = t[0], b = t[1], c = t[2];
      uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      // Same winding as the parent: three corner triangles and the middle one.
      next.push_back({a, ab, ca});
      next.push_back({ab, b, bc});
      next.push_back({ca, bc, c});
      next.push_back({ab, bc, ca});
    }
    s.triangles = std::move(next);
  }
  return s;
}

Camera camera_for(Vec3 d, const Bounds& bounds, float aspect, const ViewOptions& options) {
  Vec3 dir = normalize(d);
  if (length(dir) == 0) dir = {0, 0, 1};

  Vec3 target = bounds.empty() ? Vec3{0, 0, 0} : bounds.center();
  double radius = 0.5 * double(bounds.diagonal());
  if (!(radius > 0) || !std::isfinite(radius)) radius = 1;

  // The bounding sphere, seen from `distance`, spans a half-angle asin(radius / distance).
  // It should reach `fill` of the half-extent of the smaller viewport side on the image
  // plane: tan(half_angle) = fill · tan(fov_y / 2) · min(1, aspect) (aspect = width/height;
  // when the viewport is taller than wide, the horizontal half-extent is tan(fov_y/2)·aspect).
  double fov = double(options.fov_y_degrees) * kPi / 180.0;
  double side = std::min(1.0, aspect > 0 ? double(aspect) : 1.0);
  double half_angle = std::atan(double(options.fill) * std::tan(fov / 2) * side);
  if (!(half_angle > 0)) half_angle = fov / 2;
  double distance = radius / std::sin(half_angle);

  Camera cam;
  cam.target = target;
  cam.eye = target + dir * float(distance);
  cam.up = std::fabs(dir.y) > 0.99f ? Vec3{0, 0, 1} : Vec3{0, 1, 0};
  cam.fov_y_degrees = options.fov_y_degrees;
  double margin = double(options.clip_margin);
  cam.near_plane = float(std::max(distance - radius * margin, distance * 1e-3));
  cam.far_plane = float(distance + radius * margin);
  return cam;
}

std::pair<uint32_t, std::array<float, 3>> locate_view(const ViewingSphere& sphere, Vec3 d) {
  const std::array<float, 3> third{1.0f / 3, 1.0f / 3, 1.0f / 3};
  if (sphere.triangles.empty()) return {0, third};
  if (length(d) == 0) return {0, third};

  // The mesh is star-shaped around the centre, so the ray along d leaves through exactly one
  // triangle (or an edge / vertex shared by a few: the first in index order wins). A triangle
  // is hit when d is a non-negative combination of its vertex directions.
  const double kTolerance = -1e-6;
  uint32_t best = 0;
  double best_min = -INFINITY;
  double best_w[3] = {1.0 / 3, 1.0 / 3, 1.0 / 3};
  for (uint32_t t = 0; t < sphere.triangles.size(); ++t) {
    const auto& tri = sphere.triangles[t];
    double w[3];
    if (!solve_coefficients(sphere.directions[tri[0]], sphere.directions[tri[1]],
                            sphere.directions[tri[2]], d, w))
      continue;
    double sum = w[0] + w[1] + w[2];
    if (!(sum > 0)) continue;
    double lo = std::min({w[0], w[1], w[2]}) / sum;
    if (w[0] >= kTolerance && w[1] >= kTolerance && w[2] >= kTolerance) {
      std::array<float, 3> out;
      for (int i = 0; i < 3; ++i) out[i] = float(std::max(0.0, w[i]) / sum);
      float total = out[0] + out[1] + out[2];
      for (float& x : out) x /= total;
      return {t, out};
    }
    // Fallback bookkeeping (rounding on a badly conditioned mesh): the triangle the ray
    // misses least.
    if (lo > best_min) {
      best_min = lo;
      best = t;
      for (int i = 0; i < 3; ++i) best_w[i] = w[i] / sum;
    }
  }
  std::array<float, 3> out;
  double total = 0;
  for (int i = 0; i < 3; ++i) total += std::max(0.0, best_w[i]);
  if (!(total > 0)) return {best, third};
  for (int i = 0; i < 3; ++i) out[i] = float(std::max(0.0, best_w[i]) / total);
  return {best, out};
}

// Yang, Shen and Kuo write the blend as D' = Σ ||vp − vp_i|| · D_i / Σ ||vp − vp_i||; taken
// literally that gives the *farthest* vertex the most weight and a vertex no weight at its own
// position. We use the interpolation the paper intends (linear over the triangle, exact at the
// vertices): the barycentric weights of locate_view.
// Tables: one per sphere direction, all the same length. Returns an empty vector when `tables`
// does not have one entry per direction or the three vertices' tables differ in length.
std::vector<double> interpolate_table(const ViewingSphere& sphere,
                                      const std::vector<std::vector<double>>& tables, Vec3 d) {
  if (tables.size() != sphere.directions.size() || sphere.triangles.empty()) return {};
  auto [t, w] = locate_view(sphere, d);
  const auto& tri = sphere.triangles[t];
  const auto& t0 = tables[tri[0]];
  const auto& t1 = tables[tri[1]];
  const auto& t2 = tables[tri[2]];
  if (t0.size() != t1.size() || t0.size() != t2.size()) return {};
  std::vector<double> out(t0.size());
  for (size_t k = 0; k < out.size(); ++k)
    out[k] = double(w[0]) * t0[k] + double(w[1]) * t1[k] + double(w[2]) * t2[k];
  return out;
}

}  // namespace meshmux
