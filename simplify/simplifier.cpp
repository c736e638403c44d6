// The collapse loop (Simplifier, see simplifier.h): instance quadrics (Azim et al. §3.2,
// equation 5), attribute terms (Hoppe 1999), passes of independent half-edge collapses
// (Kapoulkine, meshoptimizer's simplifier), and the record of the collapse history as a
// progressive mesh (Hoppe, "Octaviewer") with Terrace et al.'s base level (§4.5, formula 1).
#include "simplify/simplifier.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <unordered_map>

#include "core/parallel.h"

namespace meshmux::simplify_detail {

// The face P (mesh space) placed by M: world corners Q, unit normal, world area, and its
// area-weighted plane quadric pulled back to mesh space (Azim et al. equation 4: Tᵀ Q T).
bool instance_plane(const DVec3 P[3], const Mat4& M, DVec3 Q[3], DVec3* un, double* area,
                    Quadric* pq) {
  for (int i = 0; i < 3; ++i)
    Q[i] = {M.at(0, 0) * P[i].x + M.at(0, 1) * P[i].y + M.at(0, 2) * P[i].z + M.at(0, 3),
            M.at(1, 0) * P[i].x + M.at(1, 1) * P[i].y + M.at(1, 2) * P[i].z + M.at(1, 3),
            M.at(2, 0) * P[i].x + M.at(2, 1) * P[i].y + M.at(2, 2) * P[i].z + M.at(2, 3)};
  DVec3 n = cross(sub(Q[1], Q[0]), sub(Q[2], Q[0]));
  double len = std::sqrt(dot(n, n));
  if (!(len > 0)) return false;
  *area = 0.5 * len;
  *un = {n.x / len, n.y / len, n.z / len};
  Quadric q = Quadric::plane(un->x, un->y, un->z, -dot(*un, Q[0]), *area);
  *pq = M.is_identity() ? q : q.pulled_back(M);
  return true;
}

// Placements of the non-singular transforms, in order (singular ones place nothing).
std::vector<Placement> make_placements(const std::vector<Mat4>& transforms) {
  std::vector<Placement> places;
  for (const Mat4& M : transforms) {
    Placement pl{};
    double det = M.det3();
    if (!(std::abs(det) > 0) || !std::isfinite(det)) {
      pl.absdet = 0;
      places.push_back(pl);
      continue;
    }
    // A⁻ᵀ = cofactor(A) / det.
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        int r1 = (r + 1) % 3, r2 = (r + 2) % 3, c1 = (c + 1) % 3, c2 = (c + 2) % 3;
        pl.cof[r][c] = (M.at(r1, c1) * M.at(r2, c2) - M.at(r1, c2) * M.at(r2, c1)) / det;
      }
    pl.absdet = std::abs(det);
    double col[3][3];
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) col[c][r] = M.at(r, c);
    auto d = [&](int a, int b) {
      return col[a][0] * col[b][0] + col[a][1] * col[b][1] + col[a][2] * col[b][2];
    };
    double n0 = d(0, 0), tol = 1e-6 * n0;
    pl.similar = std::abs(d(1, 1) - n0) <= tol && std::abs(d(2, 2) - n0) <= tol &&
                 std::abs(d(0, 1)) <= tol && std::abs(d(0, 2)) <= tol && std::abs(d(1, 2)) <= tol;
    pl.s2 = n0;
    places.push_back(pl);
  }
  return places;
}

// Σᵢ |det Aᵢ| / |Aᵢ⁻ᵀ n̂|: the factor that turns the mesh-space plane quadric of a face (unit
// normal n̂, weighted by its area) into the instance-summed one; adds the placed areas
// (area₀ Σ |det Aᵢ| |Aᵢ⁻ᵀ n̂|) to *world_area.
double placement_factor(const std::vector<Placement>& places, DVec3 un, double area0,
                        double* world_area) {
  double factor = 0;
  for (const Placement& pl : places) {
    if (pl.absdet == 0) continue;
    DVec3 m{pl.cof[0][0] * un.x + pl.cof[0][1] * un.y + pl.cof[0][2] * un.z,
            pl.cof[1][0] * un.x + pl.cof[1][1] * un.y + pl.cof[1][2] * un.z,
            pl.cof[2][0] * un.x + pl.cof[2][1] * un.y + pl.cof[2][2] * un.z};
    double len = std::sqrt(dot(m, m));
    factor += pl.absdet / len;
    *world_area += area0 * pl.absdet * len;
  }
  return factor;
}

Quadric scaled(Quadric q, double f, double w) {
  q.a00 *= f, q.a01 *= f, q.a02 *= f, q.a11 *= f, q.a12 *= f, q.a22 *= f;
  q.b0 *= f, q.b1 *= f, q.b2 *= f, q.c *= f;
  q.w = w;
  return q;
}

// What one face adds to the quadrics (see init_quadrics), computed on any thread and added in
// face order, so the sums are the same whatever the thread count.
struct FaceTerms {
  Quadric face_q;     // Σ over instances of the face's plane, pulled back to mesh space
  Quadric border[3];  // the constraint plane of edge e (corners e, e + 1), when it is open
  uint8_t open = 0;   // bit e: edge e is open (one face)
  bool attr = false;  // attribute terms present (aq, and gd in the block's array)
  Quadric aq;         // the position-dependent part of the attribute error
};

void Simplifier::init_quadrics(const std::vector<Mat4>& transforms) {
  const size_t np = u_.pos.size(), nw = u_.wedge_pos.size(), nf = u_.corners.size() / 3;
  const int k = u_.channels;
  const size_t kg = size_t(k) * 4;
  pos_q_.assign(np, Quadric{});
  attr_q_.assign(nw, Quadric{});
  attr_gd_.assign(nw * kg, 0.0);
  // Position → faces (compressed rows), for the open-edge test: the faces holding both ends of
  // an edge are the faces on it.
  std::vector<uint32_t> first(np + 1, 0), faces_at(3 * nf);
  for (size_t c = 0; c < 3 * nf; ++c) ++first[u_.wedge_pos[u_.corners[c]] + 1];
  for (size_t p = 0; p < np; ++p) first[p + 1] += first[p];
  {
    std::vector<uint32_t> fill(first.begin(), first.end() - 1);
    for (size_t c = 0; c < 3 * nf; ++c)
      faces_at[fill[u_.wedge_pos[u_.corners[c]]]++] = uint32_t(c / 3);
  }
  auto edge_faces = [&](uint32_t p, uint32_t q) {
    uint32_t n = 0;
    for (uint32_t i = first[p]; i < first[p + 1]; ++i) {
      const uint32_t* c = &u_.corners[3 * size_t(faces_at[i])];
      n += u_.wedge_pos[c[0]] == q || u_.wedge_pos[c[1]] == q || u_.wedge_pos[c[2]] == q;
    }
    return n;
  };

  // Pulled back to mesh space, a placed face's plane is still the face's own plane: for
  // x = A v + t, the distance of x to the placed plane is n̂ᵀ(v − p₀) / |A⁻ᵀ n̂| and the placed
  // area is area₀ |det A| |A⁻ᵀ n̂|. So Σᵢ Tᵢᵀ Qᵢ Tᵢ = area₀ Σᵢ (|det Aᵢ| / |Aᵢ⁻ᵀ n̂|) · Q(n̂, p₀):
  // one 3x3 product per instance and face instead of two 4x4 products (Azim et al. eq. 5,
  // evaluated exactly). Boundary constraint planes are not preserved by non-uniform scale, so
  // they take the general pull-back unless the transform is a similarity.
  const std::vector<Placement> places = make_placements(transforms);
  double sim_s2 = 0, sim_s4 = 0;  // Σ s², Σ s⁴ over the similarity placements
  for (const Placement& pl : places)
    if (pl.similar) sim_s2 += pl.s2, sim_s4 += pl.s2 * pl.s2;
  // The constraint plane on edge e of a face (corners P, unit normal un): for similarities the
  // mesh-space plane scaled by Σ s⁴ (weight Σ s² l²), else pulled back.
  auto border_plane = [&](int e, const DVec3 P[3], const DVec3& un) {
    auto plane = [&](const DVec3 Q[3], const DVec3& n) {
      DVec3 dv = sub(Q[(e + 1) % 3], Q[e]);
      double l2 = dot(dv, dv);
      DVec3 c = cross(dv, n);
      double cl = std::sqrt(dot(c, c));
      if (!(l2 > 0) || !(cl > 0)) return Quadric{};
      DVec3 cn{c.x / cl, c.y / cl, c.z / cl};
      // The constraint plane counts in the weight, so errors stay a weighted mean distance.
      return Quadric::plane(cn.x, cn.y, cn.z, -dot(cn, Q[e]), l2 * opt_.boundary_weight);
    };
    Quadric sum;
    if (sim_s4 > 0) {
      Quadric bq = plane(P, un);
      sum.add(scaled(bq, sim_s4, bq.w * sim_s2));
    }
    for (size_t i = 0; i < places.size(); ++i) {
      if (places[i].similar || places[i].absdet == 0) continue;
      const Mat4& M = transforms[i];
      DVec3 Q[3], n;
      double area;
      Quadric pq;
      if (!instance_plane(P, M, Q, &n, &area, &pq)) continue;
      sum.add(plane(Q, n).pulled_back(M));
    }
    return sum;
  };
  const Mat4 identity;
  // One face's terms; gd receives the k attribute gradients (G, D) weighted by the world area.
  auto terms = [&](size_t f, FaceTerms& t, double* gd) {
    const uint32_t w[3] = {u_.corners[3 * f], u_.corners[3 * f + 1], u_.corners[3 * f + 2]};
    const uint32_t p[3] = {u_.wedge_pos[w[0]], u_.wedge_pos[w[1]], u_.wedge_pos[w[2]]};
    const DVec3 P[3] = {u_.pos[p[0]], u_.pos[p[1]], u_.pos[p[2]]};
    double world_area = 0;
    DVec3 Q0[3], un;
    double area0;
    Quadric unit_q;
    if (instance_plane(P, identity, Q0, &un, &area0, &unit_q)) {
      double factor = placement_factor(places, un, area0, &world_area);
      // unit_q carries area₀ already (instance_plane weights by area).
      t.face_q = scaled(unit_q, factor, world_area);
      for (int e = 0; e < 3; ++e)
        if (edge_faces(p[e], p[(e + 1) % 3]) == 1) {
          t.open |= uint8_t(1 << e);
          t.border[e] = border_plane(e, P, un);
        }
    }
    if (k == 0 || !(world_area > 0)) return;
    // Attribute gradients in mesh space (Hoppe 1999), weighted by the world area.
    DVec3 e1 = sub(P[1], P[0]), e2 = sub(P[2], P[0]), n = cross(e1, e2);
    double n2 = dot(n, n);
    if (!(n2 > 0)) return;
    DVec3 a = cross(e2, n), b = cross(n, e1);
    Quadric& aq = t.aq;
    for (int j = 0; j < k; ++j) {
      double s0 = u_.attr[w[0] * size_t(k) + size_t(j)], s1 = u_.attr[w[1] * size_t(k) + size_t(j)],
             s2 = u_.attr[w[2] * size_t(k) + size_t(j)];
      DVec3 gr{((s1 - s0) * a.x + (s2 - s0) * b.x) / n2, ((s1 - s0) * a.y + (s2 - s0) * b.y) / n2,
               ((s1 - s0) * a.z + (s2 - s0) * b.z) / n2};
      double d = s0 - dot(gr, P[0]);
      double A = world_area;
      aq.a00 += A * gr.x * gr.x, aq.a01 += A * gr.x * gr.y, aq.a02 += A * gr.x * gr.z;
      aq.a11 += A * gr.y * gr.y, aq.a12 += A * gr.y * gr.z, aq.a22 += A * gr.z * gr.z;
      aq.b0 += A * gr.x * d, aq.b1 += A * gr.y * d, aq.b2 += A * gr.z * d, aq.c += A * d * d;
      gd[size_t(j) * 4 + 0] = A * gr.x, gd[size_t(j) * 4 + 1] = A * gr.y;
      gd[size_t(j) * 4 + 2] = A * gr.z, gd[size_t(j) * 4 + 3] = A * d;
    }
    aq.w = world_area;
    t.attr = true;
  };
  // Faces in blocks: terms on every core, then added in face order.
  constexpr size_t kBlock = 16384;
  std::vector<FaceTerms> block(std::min(nf, kBlock));
  std::vector<double> block_gd(block.size() * kg);
  for (size_t f0 = 0; f0 < nf; f0 += kBlock) {
    const size_t n = std::min(kBlock, nf - f0);
    auto make = [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) {
        block[i] = FaceTerms{};
        terms(f0 + i, block[i], &block_gd[i * kg]);
      }
    };
    if (serial_)
      make(0, n);
    else
      parallel_chunks(n, 1024, make);
    for (size_t i = 0; i < n; ++i) {
      const size_t f = f0 + i;
      const FaceTerms& t = block[i];
      const uint32_t* w = &u_.corners[3 * f];
      const uint32_t p[3] = {u_.wedge_pos[w[0]], u_.wedge_pos[w[1]], u_.wedge_pos[w[2]]};
      for (int e = 0; e < 3; ++e)
        if (t.open & (1 << e)) {
          pos_q_[p[e]].add(t.border[e]);
          pos_q_[p[(e + 1) % 3]].add(t.border[e]);
        }
      for (int c = 0; c < 3; ++c) pos_q_[p[c]].add(t.face_q);
      if (!t.attr) continue;
      for (int c = 0; c < 3; ++c) {
        attr_q_[w[c]].add(t.aq);
        double* dst = &attr_gd_[w[c] * kg];
        for (size_t x = 0; x < kg; ++x) dst[x] += block_gd[i * kg + x];
      }
    }
  }
}

void Simplifier::build_adjacency() {
  pos_faces_.build(u_.pos.size(), [&](const auto& add) {
    for (size_t f = 0; f < alive_.size(); ++f)
      if (alive_[f])
        for (int i = 0; i < 3; ++i) add(u_.wedge_pos[u_.corners[3 * f + i]], uint32_t(f));
  });
}

// Loads the fan of faces around position a: per face the corner wedge at a and the next two
// corners (positions and wedges) in winding order; the neighbour positions with the number of
// faces on each edge; a's distinct wedges.
void Simplifier::load_fan(uint32_t a, Scratch& s) const {
  s.fan.clear();
  s.nb_a.clear();
  s.a_wedges.clear();
  for (uint32_t f : pos_faces_[a]) {
    const uint32_t* c = &u_.corners[3 * f];
    int i = u_.wedge_pos[c[0]] == a ? 0 : u_.wedge_pos[c[1]] == a ? 1 : 2;
    FanFace ff{f,
               c[i],
               u_.wedge_pos[c[(i + 1) % 3]],
               c[(i + 1) % 3],
               u_.wedge_pos[c[(i + 2) % 3]],
               c[(i + 2) % 3]};
    s.fan.push_back(ff);
    for (uint32_t q : {ff.p1, ff.p2}) {
      bool found = false;
      for (auto& e : s.nb_a)
        if (e.first == q) {
          ++e.second;
          found = true;
          break;
        }
      if (!found) s.nb_a.push_back({q, 1});
    }
    if (std::find(s.a_wedges.begin(), s.a_wedges.end(), ff.wa) == s.a_wedges.end())
      s.a_wedges.push_back(ff.wa);
  }
}

// Neighbour positions of p with the number of live faces on each edge (p, neighbour).
void Simplifier::gather_neighbours(uint32_t p,
                                   std::vector<std::pair<uint32_t, uint32_t>>& out) const {
  out.clear();
  for (uint32_t f : pos_faces_[p]) {
    for (int i = 0; i < 3; ++i) {
      uint32_t q = u_.wedge_pos[u_.corners[3 * f + i]];
      if (q == p) continue;
      auto it = std::find_if(out.begin(), out.end(), [q](const auto& e) { return e.first == q; });
      if (it == out.end())
        out.push_back({q, 1});
      else
        ++it->second;
    }
  }
}

float Simplifier::cost(uint32_t a, uint32_t b, const Scratch& s) const {
  const DVec3& P = u_.pos[b];
  const Quadric &qa = pos_q_[a], &qb = pos_q_[b];
  double e = qa.eval(P.x, P.y, P.z) + qb.eval(P.x, P.y, P.z);
  double w = qa.w + qb.w;
  int k = u_.channels;
  if (k > 0) {
    for (const auto& m : s.map) {
      const float* val = &u_.attr[m.second * size_t(k)];
      for (uint32_t src : {m.first, m.second}) {
        const Quadric& aq = attr_q_[src];
        double s = aq.eval(P.x, P.y, P.z);
        const double* gd = &attr_gd_[src * size_t(k) * 4];
        for (int j = 0; j < k; ++j) {
          double lin = gd[4 * j] * P.x + gd[4 * j + 1] * P.y + gd[4 * j + 2] * P.z + gd[4 * j + 3];
          s += val[j] * (val[j] * aq.w - 2 * lin);
        }
        e += s;
      }
    }
  }
  if (!(w > 0)) w = 1e-30;
  return float(std::sqrt(std::max(0.0, e) / w));
}

// Classifies the loaded fan's position: border (has open edges) and locked (non-manifold
// edge, or not a single fan).
bool Simplifier::is_border(const Scratch& s, bool* locked) {
  int border_edges = 0;
  *locked = false;
  for (const auto& n : s.nb_a) {
    if (n.second == 1) ++border_edges;
    if (n.second > 2) *locked = true;
  }
  size_t faces = s.fan.size();
  if (border_edges == 0 && s.nb_a.size() != faces) *locked = true;
  if (border_edges > 0 && (border_edges != 2 || s.nb_a.size() != faces + 1)) *locked = true;
  return border_edges > 0;
}

// For collapsing the loaded fan's position a onto neighbour b: finds the faces L (and R) on the
// edge and fills s.map with each wedge of a and its target wedge of b. False when refused.
bool Simplifier::map_wedges(uint32_t b, uint32_t* faceL, uint32_t* faceR, int* shared,
                            Scratch& s) const {
  s.map.clear();
  *shared = 0;
  uint32_t fa[2] = {0, 0}, fb[2] = {0, 0}, ff[2] = {0, 0};
  for (const FanFace& f : s.fan) {
    uint32_t wb = f.p1 == b ? f.w1 : f.p2 == b ? f.w2 : UINT32_MAX;
    if (wb == UINT32_MAX) continue;
    if (*shared == 2) return false;  // non-manifold edge
    fa[*shared] = f.wa, fb[*shared] = wb, ff[*shared] = f.face;
    ++*shared;
  }
  if (*shared == 0) return false;
  *faceL = ff[0];
  *faceR = *shared == 2 ? ff[1] : UINT32_MAX;
  const uint32_t* group = u_.wedge_group.data();
  uint32_t ga0 = group[fa[0]], gb0 = group[fb[0]];
  uint32_t ga1 = *shared == 2 ? group[fa[1]] : ga0;
  uint32_t gb1 = *shared == 2 ? group[fb[1]] : gb0;
  if (ga0 == ga1 && gb0 != gb1) return false;  // a's one class would need two targets
  if (ga0 != ga1 && gb0 == gb1) return false;  // two classes of a would merge into one
  for (uint32_t w : s.a_wedges) {
    uint32_t target;
    if (w == fa[0]) {
      target = fb[0];
    } else if (*shared == 2 && w == fa[1]) {
      target = fb[1];
    } else {
      uint32_t g = group[w];
      uint32_t tg;
      if (g == ga0)
        tg = gb0;
      else if (g == ga1)
        tg = gb1;
      else
        return false;  // a seam of a that does not run along this edge
      // The wedge of b in class tg with the closest normal (ties: lowest index).
      target = UINT32_MAX;
      float best = -INFINITY;
      for (uint32_t fb2 : pos_faces_[b]) {
        const uint32_t* c = &u_.corners[3 * fb2];
        for (int i = 0; i < 3; ++i) {
          uint32_t wb = c[i];
          if (u_.wedge_pos[wb] != b || group[wb] != tg) continue;
          float d = u_.wedge_normal.empty() ? 0.0f : dot(u_.wedge_normal[w], u_.wedge_normal[wb]);
          if (d > best || (d == best && wb < target)) best = d, target = wb;
        }
      }
      if (target == UINT32_MAX) return false;
    }
    s.map.push_back({w, target});
  }
  return true;
}

Candidate Simplifier::best_candidate(uint32_t a, Scratch& s) const {
  Candidate best{INFINITY, a, a};
  if (!role_.empty() && role_[a] != kFree) return best;
  load_fan(a, s);
  bool locked;
  bool border = is_border(s, &locked);
  if (locked || s.nb_a.empty()) return best;
  // The geometric part of the cost is a lower bound of the whole (attribute terms are sums of
  // squares): cost neighbours cheapest-bound first and stop once the bound passes the best.
  s.bounds.clear();
  const Quadric& qa = pos_q_[a];
  for (const auto& n : s.nb_a) {
    uint32_t b = n.first;
    if (border && n.second != 1) continue;  // border vertices slide along the border only
    if (!role_.empty() && role_[b] == kFixed) continue;
    const DVec3& P = u_.pos[b];
    const Quadric& qb = pos_q_[b];
    double w = qa.w + qb.w;
    double e = qa.eval(P.x, P.y, P.z) + qb.eval(P.x, P.y, P.z);
    s.bounds.push_back({float(std::sqrt(std::max(0.0, e) / (w > 0 ? w : 1e-30))), b, b});
  }
  std::sort(s.bounds.begin(), s.bounds.end());
  for (const Candidate& lb : s.bounds) {
    if (lb.error > best.error) break;
    uint32_t b = lb.u;
    uint32_t L, R;
    int shared;
    if (!map_wedges(b, &L, &R, &shared, s)) continue;
    float e = u_.channels > 0 ? cost(a, b, s) : lb.error;
    if (e < best.error || (e == best.error && b < best.v)) best = {e, a, b};
  }
  return best;
}

size_t Simplifier::collapse(const Candidate& c, float queue_min, float queue_max) {
  uint32_t a = c.u, b = c.v;
  load_fan(a, s_);
  bool locked;
  bool border = is_border(s_, &locked);
  if (locked) return 0;
  auto edge =
      std::find_if(s_.nb_a.begin(), s_.nb_a.end(), [b](const auto& e) { return e.first == b; });
  if (edge == s_.nb_a.end() || (border && edge->second != 1)) return 0;
  uint32_t L, R;
  int shared;
  if (!map_wedges(b, &L, &R, &shared, s_)) {
    ++report_.refused_wedge;
    return 0;
  }
  // Link condition: the common neighbours of a and b are exactly the far corners of L and R.
  gather_neighbours(b, s_.nb_b);
  size_t common = 0;
  for (const auto& n : s_.nb_a)
    if (n.first != b && std::any_of(s_.nb_b.begin(), s_.nb_b.end(),
                                    [&](const auto& m) { return m.first == n.first; }))
      ++common;
  if (common != size_t(shared)) {
    ++report_.refused_link;
    return 0;
  }
  if (live_faces_ - size_t(shared) < std::max<uint32_t>(1, opt_.min_submesh_triangles)) {
    ++report_.refused_vanish;
    return 0;
  }
  // Flip check on the faces that move.
  const DVec3 &Pa = u_.pos[a], &Pb = u_.pos[b];
  for (const FanFace& f : s_.fan) {
    if (f.face == L || f.face == R) continue;
    const DVec3 &P1 = u_.pos[f.p1], &P2 = u_.pos[f.p2];
    DVec3 n0 = cross(sub(P1, Pa), sub(P2, Pa)), n1 = cross(sub(P1, Pb), sub(P2, Pb));
    double d = dot(n0, n1), l1 = dot(n1, n1);
    if (!(d > double(opt_.min_flip_cos) * std::sqrt(dot(n0, n0) * l1)) || !(l1 > 0)) {
      ++report_.refused_flip;
      return 0;
    }
  }
  float e = cost(a, b, s_);
  // Apply: remap a's wedges in its faces, kill L and R, merge quadrics.
  Collapse rec;
  rec.first_map = uint32_t(maps_.size());
  rec.map_count = uint32_t(s_.map.size());
  rec.first_face = uint32_t(removed_faces_.size());
  auto drop = [this](uint32_t p, uint32_t face) { pos_faces_.remove(p, face); };
  for (const FanFace& f : s_.fan) {
    if (f.face == L || f.face == R) {
      alive_[f.face] = 0;
      removed_faces_.push_back(f.face);
      drop(f.p1, f.face);
      drop(f.p2, f.face);
      continue;
    }
    pos_faces_.push(b, f.face);
    uint32_t* corner = &u_.corners[3 * f.face];
    for (int i = 0; i < 3; ++i) {
      if (corner[i] != f.wa) continue;
      for (const auto& m : s_.map)
        if (m.first == f.wa) {
          corner[i] = m.second;
          break;
        }
    }
  }
  rec.face_count = uint32_t(removed_faces_.size()) - rec.first_face;
  for (const auto& m : s_.map) {
    maps_.push_back(m);
    attr_q_[m.second].add(attr_q_[m.first]);
    int k = u_.channels;
    for (size_t t = 0; t < size_t(k) * 4; ++t)
      attr_gd_[m.second * size_t(k) * 4 + t] += attr_gd_[m.first * size_t(k) * 4 + t];
  }
  pos_q_[b].add(pos_q_[a]);
  live_faces_ -= rec.face_count;
  rec.error = e;
  rec.queue_min = queue_min;
  rec.queue_max = queue_max;
  collapses_.push_back(rec);
  ++report_.collapses;
  dead_pos_[a] = 1;
  pos_faces_.clear(a);
  return rec.face_count;
}

OrphanSchedule Simplifier::orphan_schedule() const {
  const size_t nw = u_.wedge_pos.size(), nf = alive_.size(), m = collapses_.size();
  OrphanSchedule out;
  out.last_state.assign(nw, uint32_t(m));
  out.parent.assign(nw, UINT32_MAX);
  // Each face's last state: the collapse that removed it (alive in states 0..i), m if never.
  std::vector<uint32_t> face_last(nf, uint32_t(m));
  for (uint32_t i = 0; i < m; ++i)
    for (uint32_t k = 0; k < collapses_[i].face_count; ++k)
      face_last[removed_faces_[collapses_[i].first_face + k]] = i;
  // Each wedge's root (the never-collapsed wedge its chain of targets ends at) and, for a
  // collapsed wedge, its last state (the collapse that took it); a collapse's target is alive
  // after it, so walking the collapses last to first finds each target's root first.
  std::vector<uint32_t> root(nw);
  std::vector<uint8_t> collapsed(nw, 0);
  for (uint32_t w = 0; w < nw; ++w) root[w] = w;
  for (size_t i = m; i-- > 0;)
    for (uint32_t k = 0; k < collapses_[i].map_count; ++k) {
      const auto& [w, target] = maps_[collapses_[i].first_map + k];
      root[w] = root[target];
      collapsed[w] = 1;
      out.last_state[w] = uint32_t(i);
    }
  // A root is referenced only while a face whose corner's chain ends at it is alive.
  std::vector<uint32_t> root_last(nw, 0);
  std::vector<uint8_t> used(nw, 0);
  for (uint32_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      const uint32_t r = root[original_corners_[3 * f + k]];
      root_last[r] = used[r] ? std::max(root_last[r], face_last[f]) : face_last[f];
      used[r] = 1;
    }
  // Wedges per position, for the orphans' parents.
  std::unordered_map<uint32_t, std::vector<uint32_t>> at;
  for (uint32_t w = 0; w < nw; ++w)
    if (!collapsed[w] && used[w] && root_last[w] < m) out.last_state[w] = root_last[w];
  for (uint32_t w = 0; w < nw; ++w)
    if (!collapsed[w] && out.last_state[w] < m) at[u_.wedge_pos[w]];
  if (at.empty()) return out;
  for (uint32_t w = 0; w < nw; ++w)
    if (auto it = at.find(u_.wedge_pos[w]); it != at.end()) it->second.push_back(w);
  for (uint32_t w = 0; w < nw; ++w) {
    const uint32_t d = out.last_state[w];
    if (collapsed[w] || d >= m) continue;
    // Present before it: a wedge alive in state d + 1; the one at its position living longest
    // (its position is then a twin's, not sent), else a target of the collapse orphaning it
    // that outlives it, else none (it stays a base vertex).
    uint32_t best = UINT32_MAX;
    for (uint32_t x : at[u_.wedge_pos[w]])
      if (x != w && out.last_state[x] > d &&
          (best == UINT32_MAX || out.last_state[x] > out.last_state[best] ||
           (out.last_state[x] == out.last_state[best] && x < best)))
        best = x;
    for (uint32_t k = 0; best == UINT32_MAX && k < collapses_[d].map_count; ++k) {
      const uint32_t t = maps_[collapses_[d].first_map + k].second;
      if (t != w && out.last_state[t] > d) best = t;
    }
    if (best == UINT32_MAX)
      out.last_state[w] = uint32_t(m);  // nothing present to split from: a base vertex
    else
      out.parent[w] = best;
  }
  return out;
}

void Simplifier::record(const Mesh& mesh, uint32_t mesh_index, ProgressiveMesh& pm) {
  auto release = [](auto& v) { std::remove_reference_t<decltype(v)>().swap(v); };
  size_t nw = u_.wedge_pos.size(), nf = alive_.size();
  // Appearance order of wedges: base wedges (never collapsed and used by a face of the
  // coarsest level, in index order), then per collapse from the last to the first the orphans
  // it made (orphan_schedule), ascending, and its wedges.
  load_original_corners();
  OrphanSchedule orphans = orphan_schedule();
  const uint32_t m_all = uint32_t(collapses_.size());
  // The orphans per collapse, ascending, as one list (a vector per collapse was 48 MB of empty
  // ones for a 4M-triangle scan, at the stage's peak).
  std::vector<uint8_t> collapsed(nw, 0);
  for (const auto& m : maps_) collapsed[m.first] = 1;
  std::vector<uint32_t> orphan_start(size_t(m_all) + 1, 0), orphaned;
  std::vector<uint32_t> order;  // new index → wedge
  order.reserve(nw);
  for (uint32_t w = 0; w < nw; ++w)
    if (!collapsed[w]) {
      if (orphans.last_state[w] < m_all)
        ++orphan_start[orphans.last_state[w] + 1];
      else
        order.push_back(w);
    }
  for (size_t i = 0; i < m_all; ++i) orphan_start[i + 1] += orphan_start[i];
  orphaned.resize(orphan_start[m_all]);
  {
    std::vector<uint32_t> fill(orphan_start.begin(), orphan_start.end() - 1);
    for (uint32_t w = 0; w < nw; ++w)
      if (!collapsed[w] && orphans.last_state[w] < m_all)
        orphaned[fill[orphans.last_state[w]]++] = w;
  }
  // A wedge that no face ever used would not be reachable; clean() removed those.
  uint32_t base_vertices = uint32_t(order.size());
  std::vector<uint32_t> parent_of(nw, UINT32_MAX);
  for (const auto& m : maps_) parent_of[m.first] = m.second;
  for (uint32_t w = 0; w < nw; ++w)
    if (orphans.parent[w] != UINT32_MAX) parent_of[w] = orphans.parent[w];
  // What is read no more goes as the record's arrays come (at 20M triangles the history and
  // the record side by side were the conversion's peak).
  release(orphans.parent), release(orphans.last_state), release(collapsed);
  std::vector<uint32_t> face_order;
  face_order.reserve(nf);
  for (uint32_t f = 0; f < nf; ++f)
    if (alive_[f]) face_order.push_back(f);
  release(alive_);
  uint32_t base_faces = uint32_t(face_order.size());
  pm.levels.clear();
  // One level per collapse, sized once: grown by doubling, the record kept up to 1.7× their 16
  // bytes each through every later stage (108 MB of slack at 20M triangles).
  pm.levels.reserve(collapses_.size() + 1);
  pm.levels.push_back({base_vertices, base_faces, base_faces, 0});
  for (size_t i = collapses_.size(); i-- > 0;) {
    const Collapse& c = collapses_[i];
    // The orphans first: the collapse's wedges may have them as targets.
    for (uint32_t k = orphan_start[i]; k < orphan_start[i + 1]; ++k) order.push_back(orphaned[k]);
    for (uint32_t k = 0; k < c.map_count; ++k) order.push_back(maps_[c.first_map + k].first);
    for (uint32_t k = 0; k < c.face_count; ++k)
      face_order.push_back(removed_faces_[c.first_face + k]);
    pm.levels.push_back(
        {uint32_t(order.size()), uint32_t(face_order.size()), uint32_t(face_order.size()), 0});
  }
  release(orphan_start), release(orphaned), release(maps_), release(removed_faces_);
  // The block hierarchy: level r undoes collapse m - r.
  pm.level_block.clear(), pm.blocks.clear();
  if (blocks_.size() > 1) {
    collapse_block_.resize(collapses_.size(), 0);
    for (size_t i = 0; i < collapses_.size(); ++i)
      if (collapse_block_[i] == 0)
        blocks_[0].error = std::max(blocks_[0].error, collapses_[i].error);
    uint16_t top = 0;
    for (const ProgressiveBlock& b : blocks_) top = std::max(top, b.level);
    blocks_[0].level = uint16_t(std::min(top + 1, 0xFFFF));
    pm.level_block.assign(collapse_block_.rbegin(), collapse_block_.rend());
    pm.blocks = std::move(blocks_);
  }
  release(collapse_block_), release(blocks_);
  // Errors: level r (r collapses undone) keeps collapses [0, m - r): its error is their max.
  size_t m = collapses_.size();
  std::vector<float> prefix_max(m + 1, 0.0f);
  for (size_t i = 0; i < m; ++i) prefix_max[i + 1] = std::max(prefix_max[i], collapses_[i].error);
  for (size_t r = 0; r <= m; ++r) pm.levels[r].error = prefix_max[m - r];

  // Base level: Terrace et al. formula 1, log(1+E_current)/log(1+E_max) ≥ threshold. A true
  // greedy's E_current is the cheapest collapse left and E_max the dearest; here each
  // collapse's own error stands for E_current and its pass's dearest candidate for E_max
  // (Simplifier::run), and the base is the state before the first collapse where the rule
  // holds. On errors normalized to a unit diagonal the
  // rule fires only near the very end (the dearest candidates are outliers: corners, rims), so
  // the base also stops once the cheapest collapse left exceeds `base_max_error`.
  size_t stop = m;  // collapses applied in the base
  for (size_t i = 0; i < m; ++i) {
    double ec = collapses_[i].queue_min, em = collapses_[i].queue_max;
    bool ratio = em > 0 && std::log1p(ec) / std::log1p(em) >= opt_.stop_ratio;
    if (ratio || ec > opt_.base_max_error) {
      stop = i;
      break;
    }
  }
  pm.base_level = m - stop;
  release(prefix_max), release(collapses_);

  // Write vertices in appearance order.
  // The loops below write item i alone from what they read: in chunks on every core (their
  // reads are scattered: at 20M triangles ~2 s on one core).
  constexpr size_t kChunk = size_t(1) << 16;
  std::vector<uint32_t> new_index(nw);
  parallel_chunks(order.size(), kChunk, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) new_index[order[i]] = uint32_t(i);
  });
  pm.source_mesh = mesh_index;
  pm.positions.resize(nw);
  pm.parent.resize(nw);
  bool has_normals = u_.normals;
  pm.normals.assign(has_normals ? nw : 0, Vec3{});
  size_t uv_sets = 0;
  bool colors = false;
  for (const Primitive& p : mesh.primitives) {
    uv_sets = std::max(uv_sets, p.uvs.size());
    colors = colors || !p.colors.empty();
  }
  pm.uvs.assign(uv_sets, std::vector<Vec2>(nw));
  pm.colors.assign(colors ? nw : 0, Vec4{1, 1, 1, 1});
  // Source attributes per wedge, from its primitive's vertex.
  parallel_chunks(nw, kChunk, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const uint32_t w = order[i];
      const Primitive& src = mesh.primitives[u_.prim_of_wedge(w)];
      const uint32_t v = u_.wedge_vertex[w];
      pm.positions[i] = src.positions[v];
      if (has_normals && !src.normals.empty()) pm.normals[i] = src.normals[v];
      for (size_t s = 0; s < src.uvs.size(); ++s) pm.uvs[s][i] = src.uvs[s][v];
      if (colors && !src.colors.empty()) pm.colors[i] = src.colors[v];
      pm.parent[i] = parent_of[w] == UINT32_MAX ? uint32_t(i) : new_index[parent_of[w]];
    }
  });
  pm.indices.resize(nf * 3);
  const bool one_primitive = mesh.primitives.size() <= 1;
  pm.face_primitive.assign(one_primitive ? 0 : nf, 0);
  // Faces keep their full-mesh corners: the original wedges.
  parallel_chunks(face_order.size(), kChunk, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const uint32_t f = face_order[i];
      for (size_t k = 0; k < 3; ++k)
        pm.indices[3 * i + k] = new_index[original_corners_[3 * size_t(f) + k]];
      if (!one_primitive) pm.face_primitive[i] = u_.prim_of_face(f);
    }
  });
  pm.primitive_material.clear();
  pm.primitive_flat.clear();
  pm.primitive_uv_sets.clear();
  pm.primitive_has_colors.clear();
  for (const Primitive& p : mesh.primitives) {
    pm.primitive_material.push_back(p.material);
    pm.primitive_flat.push_back(p.flat ? 1 : 0);
    pm.primitive_uv_sets.push_back(uint8_t(p.uvs.size()));
    pm.primitive_has_colors.push_back(p.colors.empty() ? 0 : 1);
  }
}

}  // namespace meshmux::simplify_detail
