// Chart parameterization.
// - Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion of 3D models for
//   interactive metaverses" §4.3: charts are parameterized by a texture-stretch optimization
//   (after Sander et al., below);
//   single-colour charts map to one point.
// - Lévy, Petitjean, Ray and Maillot 2002, "Least squares conformal maps" §3: the start. Per
//   triangle, in its own orthonormal frame, the conformality residual ∇v − rot90(∇u) weighted
//   by √area; two pinned vertices (the extremes along the chart's principal axis); the sparse
//   least-squares problem is solved through its normal equations (Eigen SimplicialLDLT).
// - Sander, Snyder, Gortler and Hoppe 2001, "Texture mapping progressive meshes" §3–4: the
//   L2 stretch of a triangle, sqrt((|S_s|² + |S_t|²) / 2), the chart's L2 stretch
//   sqrt(Σ A·L2² / Σ A) normalized by the uv/3D area ratio (1 = isometric), the L∞ stretch
//   (largest singular value), and the optimization: per vertex, line searches in uv that
//   minimize the normalized stretch of the whole chart, never letting a triangle flip.
// Vertices are the chart's positions (welded bit for bit): corners that share a position share
// a uv, whatever their wedges were in the input. A chart made of several edge-connected pieces
// (not one from segment_charts, which are connected) has each piece mapped on its own and the
// pieces laid side by side.
// Orientation: the output is in glTF's uv convention (v down), not mirrored: a face seen from
// its front shows the texture the right way round, i.e. its signed uv area (u, v) is negative.
#include "atlas/parameterize.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <eigen3/Eigen/Dense>
#include <eigen3/Eigen/Sparse>
#include <unordered_map>

#include "scene/position_key.h"

namespace meshmux {

namespace {

using Eigen::Vector2d;
using Eigen::Vector3d;

double cross2(const Vector2d& a, const Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

struct Tri {
  uint32_t v[3];
  double area3 = 0;
};

// The chart as a small indexed mesh.
struct ChartMesh {
  std::vector<Vector3d> pos;  // relative to the chart's first vertex
  std::vector<Tri> tris;
  double area3 = 0;
};

double signed_area(const std::vector<Vector2d>& uv, const Tri& t) {
  return 0.5 * cross2(uv[t.v[1]] - uv[t.v[0]], uv[t.v[2]] - uv[t.v[0]]);
}

// Sander's per-triangle stretch: fills a = S_s·S_s, b = S_s·S_t, c = S_t·S_t for uv area A ≠ 0.
void stretch_terms(const Vector3d& q0, const Vector3d& q1, const Vector3d& q2, const Vector2d& p0,
                   const Vector2d& p1, const Vector2d& p2, double A, double* a, double* b,
                   double* c) {
  Vector3d ss =
      (q0 * (p1.y() - p2.y()) + q1 * (p2.y() - p0.y()) + q2 * (p0.y() - p1.y())) / (2 * A);
  Vector3d st =
      (q0 * (p2.x() - p1.x()) + q1 * (p0.x() - p2.x()) + q2 * (p1.x() - p0.x())) / (2 * A);
  *a = ss.dot(ss);
  *b = ss.dot(st);
  *c = st.dot(st);
}

// A3 · L2² of one triangle (infinite when its uv area is not positive).
double weighted_l2sq(const ChartMesh& m, const std::vector<Vector2d>& uv, const Tri& t) {
  double A = signed_area(uv, t);
  if (!(A > 0)) return INFINITY;
  double a, b, c;
  stretch_terms(m.pos[t.v[0]], m.pos[t.v[1]], m.pos[t.v[2]], uv[t.v[0]], uv[t.v[1]], uv[t.v[2]], A,
                &a, &b, &c);
  return t.area3 * 0.5 * (a + c);
}

// A3 · L2² of one triangle and its signed uv area, in one pass (the optimizer's inner loop).
double weighted_l2sq_area(const ChartMesh& m, const std::vector<Vector2d>& uv, const Tri& t,
                          double* area) {
  const Vector2d &p0 = uv[t.v[0]], &p1 = uv[t.v[1]], &p2 = uv[t.v[2]];
  double A2 = cross2(p1 - p0, p2 - p0);
  *area = 0.5 * A2;
  if (!(A2 > 0)) return INFINITY;
  const Vector3d &q0 = m.pos[t.v[0]], &q1 = m.pos[t.v[1]], &q2 = m.pos[t.v[2]];
  Vector3d ss = q0 * (p1.y() - p2.y()) + q1 * (p2.y() - p0.y()) + q2 * (p0.y() - p1.y());
  Vector3d st = q0 * (p2.x() - p1.x()) + q1 * (p0.x() - p2.x()) + q2 * (p1.x() - p0.x());
  return t.area3 * 0.5 * (ss.squaredNorm() + st.squaredNorm()) / (A2 * A2);
}

// Orthographic projection onto the chart's mean plane (the fallback start).
std::vector<Vector2d> project_to_plane(const ChartMesh& m) {
  Vector3d n = Vector3d::Zero();
  for (const Tri& t : m.tris)
    n += (m.pos[t.v[1]] - m.pos[t.v[0]]).cross(m.pos[t.v[2]] - m.pos[t.v[0]]);
  if (n.norm() == 0) n = Vector3d::UnitZ();
  n.normalize();
  Vector3d x = std::abs(n.x()) < 0.9 ? Vector3d::UnitX() : Vector3d::UnitY();
  x = (x - n * n.dot(x)).normalized();
  Vector3d y = n.cross(x);
  std::vector<Vector2d> uv(m.pos.size());
  for (size_t i = 0; i < m.pos.size(); ++i) uv[i] = Vector2d(m.pos[i].dot(x), m.pos[i].dot(y));
  return uv;
}

// Least-squares conformal map with two pinned vertices. False when the solver fails.
bool lscm(const ChartMesh& m, std::vector<Vector2d>* out) {
  size_t n = m.pos.size();
  // Pins: the extremes along the principal axis of the vertices.
  Vector3d mean = Vector3d::Zero();
  for (const Vector3d& p : m.pos) mean += p;
  mean /= double(n);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Vector3d& p : m.pos) cov += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  Vector3d axis = es.eigenvectors().col(2);
  uint32_t lo = 0, hi = 0;
  for (uint32_t i = 1; i < n; ++i) {
    double d = m.pos[i].dot(axis);
    if (d < m.pos[lo].dot(axis)) lo = i;
    if (d > m.pos[hi].dot(axis)) hi = i;
  }
  if (lo == hi) return false;
  Vector2d pin_lo(0, 0), pin_hi((m.pos[hi] - m.pos[lo]).norm(), 0);

  std::vector<int> col(n, -1);
  int free_count = 0;
  for (uint32_t i = 0; i < n; ++i)
    if (i != lo && i != hi) col[i] = free_count++;
  if (free_count == 0) {
    out->assign(n, Vector2d(0, 0));
    (*out)[lo] = pin_lo;
    (*out)[hi] = pin_hi;
    return true;
  }

  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(m.tris.size() * 12);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(Eigen::Index(m.tris.size() * 2));
  int row = 0;
  for (const Tri& t : m.tris) {
    const Vector3d &q0 = m.pos[t.v[0]], &q1 = m.pos[t.v[1]], &q2 = m.pos[t.v[2]];
    Vector3d e1 = q1 - q0, e2 = q2 - q0;
    Vector3d nrm = e1.cross(e2);
    double area = 0.5 * nrm.norm();
    double len = e1.norm();
    if (!(area > 0) || !(len > 0)) continue;
    Vector3d x = e1 / len, y = nrm.normalized().cross(x);
    Vector2d P[3] = {Vector2d(0, 0), Vector2d(len, 0), Vector2d(e2.dot(x), e2.dot(y))};
    double w = std::sqrt(area);
    for (int j = 0; j < 3; ++j) {
      Vector2d e = P[(j + 2) % 3] - P[(j + 1) % 3];
      Vector2d g = Vector2d(-e.y(), e.x()) / (2 * area);  // ∇ of vertex j's hat function
      uint32_t v = t.v[j];
      // Row x: Σ v_j g.x + u_j g.y; row y: Σ v_j g.y − u_j g.x.
      double cu[2] = {w * g.y(), -w * g.x()}, cv[2] = {w * g.x(), w * g.y()};
      for (int r = 0; r < 2; ++r) {
        if (col[v] >= 0) {
          triplets.emplace_back(row + r, 2 * col[v], cu[r]);
          triplets.emplace_back(row + r, 2 * col[v] + 1, cv[r]);
        } else {
          Vector2d pin = v == lo ? pin_lo : pin_hi;
          rhs(row + r) -= cu[r] * pin.x() + cv[r] * pin.y();
        }
      }
    }
    row += 2;
  }
  Eigen::SparseMatrix<double> M(row, 2 * free_count);
  M.setFromTriplets(triplets.begin(), triplets.end());
  Eigen::SparseMatrix<double> Mt = M.transpose();
  Eigen::SparseMatrix<double> normal = Mt * M;
  Eigen::VectorXd b = Mt * rhs.head(row);
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(normal);
  if (solver.info() != Eigen::Success) return false;
  Eigen::VectorXd x = solver.solve(b);
  if (solver.info() != Eigen::Success || !x.allFinite()) return false;
  out->assign(n, Vector2d(0, 0));
  for (uint32_t i = 0; i < n; ++i) {
    if (col[i] >= 0)
      (*out)[i] = Vector2d(x(2 * col[i]), x(2 * col[i] + 1));
    else
      (*out)[i] = i == lo ? pin_lo : pin_hi;
  }
  return true;
}

size_t count_nonpositive(const ChartMesh& m, const std::vector<Vector2d>& uv) {
  size_t bad = 0;
  for (const Tri& t : m.tris) bad += signed_area(uv, t) > 0 ? 0 : 1;
  return bad;
}

// Sander's per-vertex stretch minimization. The objective is the chart's normalized L2
// stretch squared, ∝ (Σ A3·L2²) · (Σ A_uv): invariant to uv scale, so no vertex needs pinning.
void optimize_stretch(const ChartMesh& m, std::vector<Vector2d>& uv, int rounds) {
  size_t n = uv.size();
  // Incident triangles per vertex (CSR).
  std::vector<uint32_t> start(n + 1, 0), inc(m.tris.size() * 3);
  for (const Tri& t : m.tris)
    for (uint32_t v : t.v) ++start[v + 1];
  for (size_t i = 0; i < n; ++i) start[i + 1] += start[i];
  std::vector<uint32_t> fill(start.begin(), start.end() - 1);
  for (uint32_t i = 0; i < m.tris.size(); ++i)
    for (uint32_t v : m.tris[i].v) inc[fill[v]++] = i;

  double previous = INFINITY;
  for (int round = 0; round < rounds; ++round) {
    double S = 0, U = 0;
    for (const Tri& t : m.tris) {
      S += weighted_l2sq(m, uv, t);
      U += signed_area(uv, t);
    }
    if (!std::isfinite(S) || !(U > 0)) return;  // flipped start: leave it as it is
    // Stop when a round gained less than 1e-5 of the (squared, normalized) stretch.
    double current = S * U;
    if (current > previous * (1 - 1e-5)) break;
    previous = current;
    // A triangle isometric up to the chart's uv/3D scale is at its optimum: vertices whose
    // triangles all are need no search (planar regions cost nothing).
    double sigma2 = U / m.area3;
    std::vector<uint8_t> settled(m.tris.size());
    for (size_t i = 0; i < m.tris.size(); ++i) {
      const Tri& t = m.tris[i];
      double a, bb, c;
      stretch_terms(m.pos[t.v[0]], m.pos[t.v[1]], m.pos[t.v[2]], uv[t.v[0]], uv[t.v[1]], uv[t.v[2]],
                    signed_area(uv, t), &a, &bb, &c);
      settled[i] = std::abs(a * sigma2 - 1) < 1e-4 && std::abs(c * sigma2 - 1) < 1e-4 &&
                   std::abs(bb * sigma2) < 1e-4;
    }
    bool moved = false;
    for (uint32_t v = 0; v < n; ++v) {
      uint32_t b = start[v], e = start[v + 1];
      if (b == e) continue;
      bool all_settled = true;
      for (uint32_t i = b; i < e && all_settled; ++i) all_settled = settled[inc[i]];
      if (all_settled) continue;
      auto local = [&](const Vector2d& p, double* s_loc, double* u_loc) {
        Vector2d keep = uv[v];
        uv[v] = p;
        double s = 0, u = 0;
        for (uint32_t i = b; i < e; ++i) {
          double a;
          s += weighted_l2sq_area(m, uv, m.tris[inc[i]], &a);
          u += a;
        }
        uv[v] = keep;
        *s_loc = s;
        *u_loc = u;
      };
      Vector2d p0 = uv[v];
      double s0, u0;
      local(p0, &s0, &u0);
      double s_rest = S - s0, u_rest = U - u0;
      auto objective = [&](const Vector2d& p) {
        double s, u;
        local(p, &s, &u);
        return std::isfinite(s) ? (s_rest + s) * (u_rest + u) : INFINITY;
      };
      // Local scale: the shortest incident uv edge.
      double scale = INFINITY;
      for (uint32_t i = b; i < e; ++i) {
        const Tri& t = m.tris[inc[i]];
        for (uint32_t w : t.v)
          if (w != v) scale = std::min(scale, (uv[w] - p0).norm());
      }
      if (!(scale > 0) || !std::isfinite(scale)) continue;
      double f0 = (s_rest + s0) * (u_rest + u0);
      // Directions: the descent direction (central differences), then its perpendicular.
      double h = 1e-4 * scale;
      Vector2d grad((objective(p0 + Vector2d(h, 0)) - objective(p0 - Vector2d(h, 0))) / (2 * h),
                    (objective(p0 + Vector2d(0, h)) - objective(p0 - Vector2d(0, h))) / (2 * h));
      Vector2d dirs[2];
      if (grad.allFinite() && grad.norm() > 0) {
        dirs[0] = -grad.normalized();
      } else {
        double angle = double((v * 2654435761u + uint32_t(round) * 40503u) % 6283u) / 1000.0;
        dirs[0] = Vector2d(std::cos(angle), std::sin(angle));
      }
      dirs[1] = Vector2d(-dirs[0].y(), dirs[0].x());
      for (const Vector2d& d : dirs) {
        // Keep every incident triangle positive: A(t) = A(0) + k t.
        double t_lo = -4 * scale, t_hi = 4 * scale;
        for (uint32_t i = b; i < e; ++i) {
          const Tri& t = m.tris[inc[i]];
          double a0 = signed_area(uv, t);
          uv[v] = p0 + d;
          double k = signed_area(uv, t) - a0;
          uv[v] = p0;
          if (k < 0) t_hi = std::min(t_hi, 0.9 * a0 / -k);
          if (k > 0) t_lo = std::max(t_lo, -0.9 * a0 / k);
        }
        if (!(t_hi > t_lo)) continue;
        // Coarse samples, then golden section around the best.
        constexpr int kSamples = 8;
        double best_t = 0, best_f = f0;
        double step = (t_hi - t_lo) / kSamples;
        for (int i = 0; i <= kSamples; ++i) {
          double t = t_lo + step * i;
          double f = objective(p0 + d * t);
          if (f < best_f) best_f = f, best_t = t;
        }
        double a = std::max(t_lo, best_t - step), c = std::min(t_hi, best_t + step);
        const double g = 0.6180339887498949;
        double x1 = c - g * (c - a), x2 = a + g * (c - a);
        double f1 = objective(p0 + d * x1), f2 = objective(p0 + d * x2);
        for (int it = 0; it < 12; ++it) {
          if (f1 < f2) {
            c = x2, x2 = x1, f2 = f1;
            x1 = c - g * (c - a);
            f1 = objective(p0 + d * x1);
          } else {
            a = x1, x1 = x2, f1 = f2;
            x2 = a + g * (c - a);
            f2 = objective(p0 + d * x2);
          }
        }
        if (f1 < best_f) best_f = f1, best_t = x1;
        if (f2 < best_f) best_f = f2, best_t = x2;
        if (best_f < f0 * (1 - 1e-12)) {
          Vector2d p = p0 + d * best_t;
          double s1, u1;
          local(p, &s1, &u1);
          if (!std::isfinite(s1)) continue;
          uv[v] = p;
          S = s_rest + s1, U = u_rest + u1;
          s0 = s1, u0 = u1, f0 = best_f, p0 = p;
          moved = true;
        }
      }
    }
    if (!moved) break;
  }
}

// Triangles grouped into pieces connected across edges (two shared vertices), each piece's
// triangles ascending, pieces ordered by their first triangle.
std::vector<std::vector<uint32_t>> edge_components(const ChartMesh& m) {
  size_t F = m.tris.size();
  std::vector<uint32_t> parent(F);
  for (uint32_t i = 0; i < F; ++i) parent[i] = i;
  auto find = [&](uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  std::unordered_map<uint64_t, uint32_t> edge_tri;
  edge_tri.reserve(F * 3);
  for (uint32_t i = 0; i < F; ++i)
    for (int k = 0; k < 3; ++k) {
      uint32_t a = m.tris[i].v[k], b = m.tris[i].v[(k + 1) % 3];
      uint64_t key = (uint64_t(std::min(a, b)) << 32) | std::max(a, b);
      auto it = edge_tri.emplace(key, i);
      if (!it.second) {
        uint32_t x = find(i), y = find(it.first->second);
        if (x != y) parent[std::max(x, y)] = std::min(x, y);
      }
    }
  std::vector<std::vector<uint32_t>> out;
  std::vector<uint32_t> slot(F, UINT32_MAX);
  for (uint32_t i = 0; i < F; ++i) {
    uint32_t r = find(i);
    if (slot[r] == UINT32_MAX) {
      slot[r] = uint32_t(out.size());
      out.emplace_back();
    }
    out[slot[r]].push_back(i);
  }
  return out;
}

// Triangles in a 2D grid; true when two triangles that do not share an edge overlap (each
// shrunk a hair towards its centroid, so triangles that merely touch do not count).
bool has_overlap(const ChartMesh& m, const std::vector<Vector2d>& uv) {
  size_t F = m.tris.size();
  if (F < 2) return false;
  std::vector<std::array<Vector2d, 3>> tri(F);
  std::vector<Eigen::AlignedBox2d> box(F);
  Eigen::AlignedBox2d all;
  for (size_t i = 0; i < F; ++i) {
    Vector2d c = (uv[m.tris[i].v[0]] + uv[m.tris[i].v[1]] + uv[m.tris[i].v[2]]) / 3.0;
    for (int k = 0; k < 3; ++k) {
      tri[i][k] = c + (uv[m.tris[i].v[k]] - c) * (1 - 1e-6);
      box[i].extend(tri[i][k]);
    }
    all.extend(box[i]);
  }
  auto shares_edge = [&](size_t i, size_t j) {
    int common = 0;
    for (uint32_t a : m.tris[i].v)
      for (uint32_t b : m.tris[j].v) common += a == b;
    return common >= 2;
  };
  auto separated = [&](const std::array<Vector2d, 3>& A, const std::array<Vector2d, 3>& B) {
    for (int pass = 0; pass < 2; ++pass) {
      const auto& P = pass ? B : A;
      const auto& Q = pass ? A : B;
      double orient = cross2(P[1] - P[0], P[2] - P[0]) >= 0 ? 1 : -1;
      for (int k = 0; k < 3; ++k) {
        Vector2d e = P[(k + 1) % 3] - P[k];
        bool all_out = true;
        for (int j = 0; j < 3 && all_out; ++j) all_out = orient * cross2(e, Q[j] - P[k]) <= 0;
        if (all_out) return true;
      }
    }
    return false;
  };
  auto test = [&](size_t i, size_t j) {
    return box[i].intersects(box[j]) && !shares_edge(i, j) && !separated(tri[i], tri[j]);
  };
  if (F <= 64) {
    for (size_t i = 0; i < F; ++i)
      for (size_t j = i + 1; j < F; ++j)
        if (test(i, j)) return true;
    return false;
  }
  Vector2d size = all.sizes();
  double cell = std::sqrt(std::max(size.x() * size.y(), 1e-300) / double(F)) * 1.5;
  if (!(cell > 0)) return false;
  int gx = std::clamp(int(size.x() / cell) + 1, 1, 1024),
      gy = std::clamp(int(size.y() / cell) + 1, 1, 1024);
  double cx = size.x() / gx, cy = size.y() / gy;
  auto cell_range = [&](size_t i, int* x0, int* x1, int* y0, int* y1) {
    auto cl = [](double v, int g) { return std::clamp(int(v), 0, g - 1); };
    *x0 = cl(cx > 0 ? (box[i].min().x() - all.min().x()) / cx : 0, gx);
    *x1 = cl(cx > 0 ? (box[i].max().x() - all.min().x()) / cx : 0, gx);
    *y0 = cl(cy > 0 ? (box[i].min().y() - all.min().y()) / cy : 0, gy);
    *y1 = cl(cy > 0 ? (box[i].max().y() - all.min().y()) / cy : 0, gy);
  };
  std::vector<uint32_t> start(size_t(gx) * gy + 1, 0);
  for (size_t i = 0; i < F; ++i) {
    int x0, x1, y0, y1;
    cell_range(i, &x0, &x1, &y0, &y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) ++start[size_t(y) * gx + x + 1];
  }
  for (size_t c = 0; c + 1 < start.size(); ++c) start[c + 1] += start[c];
  std::vector<uint32_t> items(start.back()), fill(start.begin(), start.end() - 1);
  for (size_t i = 0; i < F; ++i) {
    int x0, x1, y0, y1;
    cell_range(i, &x0, &x1, &y0, &y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) items[fill[size_t(y) * gx + x]++] = uint32_t(i);
  }
  std::vector<uint32_t> stamp(F, uint32_t(-1));
  for (size_t i = 0; i < F; ++i) {
    int x0, x1, y0, y1;
    cell_range(i, &x0, &x1, &y0, &y1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        size_t c = size_t(y) * gx + x;
        for (uint32_t k = start[c]; k < start[c + 1]; ++k) {
          uint32_t j = items[k];
          if (j <= i || stamp[j] == i) continue;
          stamp[j] = uint32_t(i);
          if (test(i, j)) return true;
        }
      }
  }
  return false;
}

// Start (isometric for one face, LSCM otherwise, plane projection when LSCM fails or folds
// where the projection does not), stretch optimization (kept only if it adds no overlap), then
// uv area scaled to the 3D area.
std::vector<Vector2d> flatten(const ChartMesh& m, int iterations) {
  std::vector<Vector2d> uv;
  if (m.tris.size() == 1) {
    const Tri& t = m.tris[0];
    Vector3d e1 = m.pos[t.v[1]] - m.pos[t.v[0]], e2 = m.pos[t.v[2]] - m.pos[t.v[0]];
    double len = e1.norm();
    Vector3d x = len > 0 ? Vector3d(e1 / len) : Vector3d::UnitX();
    Vector3d y = e1.cross(e2).normalized().cross(x);
    uv.assign(m.pos.size(), Vector2d(0, 0));
    uv[t.v[1]] = Vector2d(len, 0);
    uv[t.v[2]] = Vector2d(e2.dot(x), y.allFinite() ? e2.dot(y) : 0);
  } else {
    bool ok = lscm(m, &uv);
    size_t bad = ok ? count_nonpositive(m, uv) : m.tris.size();
    if (ok && bad * 2 > m.tris.size()) {  // mirrored as a whole
      for (Vector2d& p : uv) p.x() = -p.x();
      bad = count_nonpositive(m, uv);
    }
    if (bad > 0) {
      std::vector<Vector2d> proj = project_to_plane(m);
      size_t bad_proj = count_nonpositive(m, proj);
      if (!ok || bad_proj < bad) uv = std::move(proj), bad = bad_proj;
    }
    if (bad == 0 && iterations > 0) {
      // The optimization moves boundary vertices freely: if that makes the start overlap
      // itself, keep the start.
      std::vector<Vector2d> start = uv;
      optimize_stretch(m, uv, iterations);
      if (has_overlap(m, uv) && !has_overlap(m, start)) uv = std::move(start);
    }
  }
  double uv_area = 0;
  for (const Tri& t : m.tris) uv_area += std::abs(signed_area(uv, t));
  double s = uv_area > 0 && m.area3 > 0 ? std::sqrt(m.area3 / uv_area) : 1.0;
  for (Vector2d& p : uv) p *= s;
  return uv;
}

}  // namespace

ChartUv parameterize_chart(const Scene& scene, const Chart& chart,
                           const ParameterizeOptions& options) {
  ChartUv out;
  if (chart.mesh >= scene.meshes.size() || chart.faces.empty()) {
    out.valid = chart.faces.empty();
    return out;
  }
  const Mesh& mesh = scene.meshes[chart.mesh];
  std::vector<size_t> first_face(mesh.primitives.size() + 1, 0);
  for (size_t p = 0; p < mesh.primitives.size(); ++p)
    first_face[p + 1] = first_face[p] + mesh.primitives[p].triangle_count();

  // The chart as an indexed mesh over welded positions.
  ChartMesh m;
  std::unordered_map<PositionKey, uint32_t, PositionKeyHash> ids;
  Vector3d origin;
  bool have_origin = false;
  m.tris.reserve(chart.faces.size());
  for (uint32_t f : chart.faces) {
    size_t p = size_t(std::upper_bound(first_face.begin(), first_face.end(), size_t(f)) -
                      first_face.begin()) -
               1;
    if (p >= mesh.primitives.size()) {
      out.valid = false;
      return out;
    }
    const Primitive& prim = mesh.primitives[p];
    size_t t = f - first_face[p];
    Tri tri;
    for (int k = 0; k < 3; ++k) {
      Vec3 q = prim.positions[prim.indices[3 * t + k]];
      Vector3d qd(q.x, q.y, q.z);
      if (!have_origin) origin = qd, have_origin = true;
      auto it = ids.emplace(PositionKey(Vec3{q.x, q.y, q.z}), uint32_t(m.pos.size()));
      if (it.second) m.pos.push_back(qd - origin);
      tri.v[k] = it.first->second;
    }
    tri.area3 =
        0.5 * (m.pos[tri.v[1]] - m.pos[tri.v[0]]).cross(m.pos[tri.v[2]] - m.pos[tri.v[0]]).norm();
    m.area3 += tri.area3;
    m.tris.push_back(tri);
  }
  out.area_3d = m.area3;

  if (!chart.textured) {
    out.corner_uv.assign(chart.faces.size() * 3, Vec2{0, 0});
    return out;
  }

  // Each edge-connected piece is flattened on its own (a chart from segment_charts is one
  // piece; a hand-made or split one may not be) and the pieces are laid side by side.
  std::vector<Vector2d> uv;
  std::vector<std::vector<uint32_t>> pieces = edge_components(m);
  if (pieces.size() == 1) {
    uv = flatten(m, options.stretch_iterations);
  } else {
    // A position shared by two pieces (a bowtie corner) gets one vertex per piece: the
    // triangles keep their order, the vertices are renumbered piece by piece.
    ChartMesh split;
    split.area3 = m.area3;
    split.tris = m.tris;
    double x = 0;
    for (const std::vector<uint32_t>& piece : pieces) {
      ChartMesh sub;
      std::vector<uint32_t> local(m.pos.size(), UINT32_MAX);
      for (uint32_t ti : piece) {
        Tri t = m.tris[ti];
        for (uint32_t& v : t.v) {
          if (local[v] == UINT32_MAX) {
            local[v] = uint32_t(sub.pos.size());
            sub.pos.push_back(m.pos[v]);
          }
          v = local[v];
        }
        sub.area3 += t.area3;
        sub.tris.push_back(t);
      }
      std::vector<Vector2d> part = flatten(sub, options.stretch_iterations);
      Eigen::AlignedBox2d box;
      for (const Vector2d& p : part) box.extend(p);
      uint32_t base = uint32_t(split.pos.size());
      split.pos.insert(split.pos.end(), sub.pos.begin(), sub.pos.end());
      for (const Vector2d& p : part) uv.push_back(p - box.min() + Vector2d(x, 0));
      for (size_t i = 0; i < piece.size(); ++i)
        for (int k = 0; k < 3; ++k) split.tris[piece[i]].v[k] = base + sub.tris[i].v[k];
      x += box.sizes().x() + 0.02 * std::sqrt(std::max(m.area3, 0.0));
    }
    m = std::move(split);
  }

  // Stretch (uv areas taken unsigned so a flipped face still counts; zero-area faces skipped).
  double sum_l2 = 0, sum_a = 0, linf = 0;
  for (const Tri& t : m.tris) {
    double A = std::abs(signed_area(uv, t));
    if (!(A > 0)) continue;
    double a, b, c;
    stretch_terms(m.pos[t.v[0]], m.pos[t.v[1]], m.pos[t.v[2]], uv[t.v[0]], uv[t.v[1]], uv[t.v[2]],
                  A, &a, &b, &c);
    sum_l2 += t.area3 * 0.5 * (a + c);
    sum_a += t.area3;
    linf = std::max(linf, std::sqrt(0.5 * ((a + c) + std::sqrt((a - c) * (a - c) + 4 * b * b))));
  }
  out.stretch_l2 = sum_a > 0 ? std::sqrt(sum_l2 / sum_a) : 1.0;
  out.stretch_linf = sum_a > 0 ? linf : 1.0;

  bool overlap = has_overlap(m, uv);

  // glTF orientation (v down), min corner at the origin.
  double min_u = INFINITY, min_v = INFINITY, max_u = -INFINITY, max_v = -INFINITY;
  for (Vector2d& p : uv) {
    p.y() = -p.y();
    min_u = std::min(min_u, p.x()), min_v = std::min(min_v, p.y());
    max_u = std::max(max_u, p.x()), max_v = std::max(max_v, p.y());
  }
  out.size = {float(max_u - min_u), float(max_v - min_v)};
  out.corner_uv.resize(m.tris.size() * 3);
  for (size_t i = 0; i < m.tris.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      const Vector2d& p = uv[m.tris[i].v[k]];
      out.corner_uv[3 * i + k] = {float(p.x() - min_u), float(p.y() - min_v)};
    }

  // Valid: every face keeps the (mirrored-to-glTF) orientation with a non-zero area as stored,
  // and no two faces overlap.
  bool valid = !overlap;
  for (size_t i = 0; i < m.tris.size() && valid; ++i) {
    const Vec2* c = &out.corner_uv[3 * i];
    double A = 0.5 * ((double(c[1].x) - c[0].x) * (double(c[2].y) - c[0].y) -
                      (double(c[2].x) - c[0].x) * (double(c[1].y) - c[0].y));
    if (!(A < 0)) valid = false;
  }
  out.valid = valid;
  return out;
}

}  // namespace meshmux
