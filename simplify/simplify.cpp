// Instance-aware progressive simplification.
// - Azim, Cheslack-Postava and Levis, "Instance-aware simplification of 3D polygonal meshes"
//   (IAS) §3.2: vertex quadrics summed over instance transforms (equation 5), boundary
//   constraint planes weighted by edge length, no vanishing submeshes, the < 1.75
//   instances-per-submesh flatten fallback (§4).
// - Hoppe, "Octaviewer: spherically parameterized progressive meshes": half-edge collapses
//   only, so every level is a prefix of one vertex buffer with a parent per vertex; seam
//   duplicates collapse together (no cracks).
// - Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion of 3D models for
//   interactive metaverses" §4.5: the base level stops at log(1+E)/log(1+Emax) ≥ 0.9
//   (formula 1); small models ship whole.
// - Attribute terms after Hoppe 1999 ("New quadric metric for simplifying meshes with
//   appearance attributes"): per face, each attribute channel is a linear function of position
//   over the face; its squared deviation, area-weighted, is folded into the wedge's quadric.
//
// The collapse loop runs in passes (Simplifier::run): the positions whose neighbourhood changed
// re-costed on every core, the cheapest independent collapses applied, in a unit put in
// spatial order first (spatial_order). This keeps the work near O(T log T), the memory reads
// mostly local, and the result deterministic.
#include "simplify/simplify.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <functional>
#include <mutex>
#include <unordered_map>

#include "clean/flatten.h"
#include "core/key_table.h"
#include "core/parallel.h"
#include "scene/dvec3.h"
#include "scene/position_key.h"

namespace meshmux {

namespace {

// Symmetric 4x4 quadric on homogeneous positions: E(p) = pᵀAp + 2bᵀp + c.
struct Quadric {
  double a00 = 0, a01 = 0, a02 = 0, a11 = 0, a12 = 0, a22 = 0;
  double b0 = 0, b1 = 0, b2 = 0, c = 0;
  double w = 0;  // total weight (area) folded in

  void add(const Quadric& q) {
    a00 += q.a00, a01 += q.a01, a02 += q.a02, a11 += q.a11, a12 += q.a12, a22 += q.a22;
    b0 += q.b0, b1 += q.b1, b2 += q.b2, c += q.c, w += q.w;
  }
  double eval(double x, double y, double z) const {
    return a00 * x * x + a11 * y * y + a22 * z * z + 2 * (a01 * x * y + a02 * x * z + a12 * y * z) +
           2 * (b0 * x + b1 * y + b2 * z) + c;
  }
  // weight * (n·p + d)², n unit.
  static Quadric plane(double nx, double ny, double nz, double d, double weight) {
    Quadric q;
    q.a00 = weight * nx * nx, q.a01 = weight * nx * ny, q.a02 = weight * nx * nz;
    q.a11 = weight * ny * ny, q.a12 = weight * ny * nz, q.a22 = weight * nz * nz;
    q.b0 = weight * nx * d, q.b1 = weight * ny * d, q.b2 = weight * nz * d;
    q.c = weight * d * d;
    q.w = weight;
    return q;
  }
  // Mᵀ Q M for an affine M (column-major 4x4): the quadric in M's source space.
  Quadric pulled_back(const Mat4& M) const {
    double Q[4][4] = {
        {a00, a01, a02, b0}, {a01, a11, a12, b1}, {a02, a12, a22, b2}, {b0, b1, b2, c}};
    double QM[4][4];
    for (int r = 0; r < 4; ++r)
      for (int k = 0; k < 4; ++k) {
        double s = 0;
        for (int j = 0; j < 4; ++j) s += Q[r][j] * M.at(j, k);
        QM[r][k] = s;
      }
    double R[4][4];
    for (int r = 0; r < 4; ++r)
      for (int k = 0; k < 4; ++k) {
        double s = 0;
        for (int j = 0; j < 4; ++j) s += M.at(j, r) * QM[j][k];
        R[r][k] = s;
      }
    Quadric out;
    out.a00 = R[0][0], out.a01 = R[0][1], out.a02 = R[0][2], out.a11 = R[1][1];
    out.a12 = R[1][2], out.a22 = R[2][2], out.b0 = R[0][3], out.b1 = R[1][3], out.b2 = R[2][3];
    out.c = R[3][3], out.w = w;
    return out;
  }
};

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

// An instance transform prepared for the instance quadric (see init_quadrics).
struct Placement {
  double cof[3][3];  // A⁻ᵀ
  double absdet;
  bool similar;  // rotation, uniform scale, translation (mirrors allowed)
  double s2;     // the uniform scale squared, when similar
};

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

// One submesh prepared for simplification: wedges (the mesh's vertices) over welded positions.
struct Unit {
  // Wedges, concatenated over the mesh's primitives.
  std::vector<uint32_t> wedge_pos;     // wedge → position
  std::vector<uint32_t> wedge_group;   // wedge → (position, non-normal attributes) class
  std::vector<uint32_t> wedge_prim;    // wedge → source primitive
  std::vector<uint32_t> wedge_vertex;  // wedge → its vertex in that primitive
  std::vector<Vec3> wedge_normal;      // may be empty
  std::vector<float> attr;  // wedge × channels, weighted attribute values (products of floats)
  int channels = 0;
  std::vector<DVec3> pos;         // position → mesh-space point
  std::vector<uint32_t> corners;  // face × 3 wedges (current, remapped as we go)
  std::vector<uint32_t> face_prim;
};

// Per-collapse record.
struct Collapse {
  uint32_t first_map = 0, map_count = 0;    // range in the (wedge, target) list
  uint32_t first_face = 0, face_count = 0;  // range in the removed-face list
  float error = 0;
  float queue_min = 0;  // the collapse's own error (the greedy's E_current: see run())
  float queue_max = 0;  // the largest candidate error of the pass (Terrace et al.'s E_max)
};

// Wedges a collapse leaves without faces while never collapsed themselves: at a hard edge or
// a seam a collapse removes the faces L and R, and the far ends' wedges in them may have no
// other face (on faceted geometry every face has wedges of its own: every collapse orphans two).
// Kept as base vertices, they filled the base's vertex prefix with vertices no base face uses
// (a faceted 58k-triangle level: 45.6k base vertices for 3,964 triangles, the base 4× the bytes
// of its Draco twin). They are sent instead with the split that brings their faces back, each
// with a parent alive before it (Hoppe, "Progressive meshes": a vertex appears when the first
// face that needs it does).
struct OrphanSchedule {
  std::vector<uint32_t> last_state;  // per wedge: the last state (collapses applied) in which
                                     // it is present: its collapse's index, the collapse that
                                     // removed its last face, or the collapse count
  std::vector<uint32_t> parent;      // per orphan: a wedge present before it; UINT32_MAX else
};

struct Candidate {
  float error;
  uint32_t u, v;
  bool operator<(const Candidate& o) const {
    return error != o.error ? error < o.error : (u != o.u ? u < o.u : v < o.v);
  }
};

// Each position's live faces, in one pooled array: a run of slots per position, moved to the
// pool's end with twice the room when it outgrows them (a position that collapses onto others
// gathers their faces). One allocation for all, where a vector per position cost a heap block
// and a pointer chase each (at 4M triangles ~130 MB and most of the costing's cache misses).
class FaceLists {
 public:
  struct Span {
    const uint32_t *first, *last;
    const uint32_t* begin() const { return first; }
    const uint32_t* end() const { return last; }
  };
  // Lists for n positions from (position, face) incidences given by `each(add)`: add(p, f).
  template <class Each>
  void build(size_t n, const Each& each) {
    start_.assign(n + 1, 0);
    each([&](uint32_t p, uint32_t) { ++start_[p + 1]; });
    for (size_t p = 0; p < n; ++p) start_[p + 1] += start_[p];
    size_.assign(n, 0);
    cap_.resize(n);
    for (size_t p = 0; p < n; ++p) cap_[p] = start_[p + 1] - start_[p];
    data_.assign(start_[n] + start_[n] / 4, 0);  // room to grow without moving the pool
    used_ = start_[n];
    start_.pop_back();
    each([&](uint32_t p, uint32_t f) { data_[start_[p] + size_[p]++] = f; });
  }
  Span operator[](uint32_t p) const {
    const uint32_t* b = data_.data() + start_[p];
    return {b, b + size_[p]};
  }
  void push(uint32_t p, uint32_t f) {
    if (size_[p] == cap_[p]) {
      const uint32_t cap = std::max<uint32_t>(8, 2 * cap_[p]);
      if (used_ + cap > data_.size()) data_.resize(std::max(used_ + cap, data_.size() * 3 / 2));
      std::copy_n(data_.begin() + start_[p], size_[p], data_.begin() + used_);
      start_[p] = uint32_t(used_), cap_[p] = cap;
      used_ += cap;
    }
    data_[start_[p] + size_[p]++] = f;
  }
  // Removes face f from p's list (order not kept).
  void remove(uint32_t p, uint32_t f) {
    uint32_t* b = data_.data() + start_[p];
    for (uint32_t i = 0; i < size_[p]; ++i)
      if (b[i] == f) {
        b[i] = b[--size_[p]];
        return;
      }
  }
  void clear(uint32_t p) { size_[p] = 0; }
  void release() {
    std::vector<uint32_t>().swap(data_), std::vector<uint32_t>().swap(start_);
    std::vector<uint32_t>().swap(size_), std::vector<uint32_t>().swap(cap_);
  }

 private:
  std::vector<uint32_t> start_, size_, cap_;  // per position: first slot, faces, slots
  std::vector<uint32_t> data_;
  size_t used_ = 0;  // slots handed out
};

// Scratch space of one costing thread: the loaded fan of a position and what is derived from it.
struct Scratch {
  struct FanFace {
    uint32_t face, wa, p1, w1, p2, w2;  // the face, its wedge at a, then the next two corners
  };
  std::vector<FanFace> fan;
  std::vector<std::pair<uint32_t, uint32_t>> nb_a, nb_b;  // (neighbour position, faces on the edge)
  std::vector<std::pair<uint32_t, uint32_t>> map;         // (wedge of a, wedge of b)
  std::vector<uint32_t> a_wedges;
  std::vector<Candidate> bounds;  // per neighbour, the geometric lower bound
};
using FanFace = Scratch::FanFace;

class Simplifier {
 public:
  Simplifier(Unit& unit, const std::vector<Mat4>& transforms, const SimplifyOptions& opt,
             SimplifyReport& report)
      : u_(unit), opt_(opt), report_(report), original_corners_(unit.corners) {
    init_quadrics(transforms);
  }

  // Passes of independent collapses under a rising error bound, as meshoptimizer's simplifier
  // works (Kapoulkine, meshoptimizer: edge collapse passes). Each pass (1) re-costs, on every
  // core, the positions whose neighbourhood changed (each position's cheapest valid collapse, a
  // pure function of the current mesh); (2) keeps every live candidate sorted by (error, u, v);
  // (3) chooses, cheapest first, collapses whose ends no chosen one shares, until
  // `pass_fraction` of the live faces would go or the error passes `pass_error_growth` times
  // the error at the pass's expected collapse count, and applies them in spatial order. A
  // collapse's geometric cost reads only its two ends' quadrics, so with the ends locked it is
  // the one it was chosen by (the seam's target wedge may change where an earlier collapse of
  // the pass took a face of the target); validity (link, flips, vanishing) and the cost are
  // checked again on the current mesh as each is applied. With small passes the order stays close
  // to a true greedy's (the loop this replaces: Hausdorff distances on the shared models within a
  // few percent either way). Deterministic: the order is a strict total order and the costing is
  // pure, whatever the thread count.
  // `on_progress` (may be empty) is called with the collapses so far, every few thousand.
  void run(const std::function<void(uint64_t)>& on_progress = {}) {
    const size_t np = u_.pos.size();
    uint64_t done = 0, reported = 0;
    alive_.assign(u_.corners.size() / 3, 1);
    live_faces_ = alive_.size();
    dead_pos_.assign(np, 0);
    queued_.assign(np, Candidate{INFINITY, 0, 0});
    build_adjacency();
    std::vector<uint32_t> dirty(np), locked_list;
    std::vector<Candidate> live, fresh, merged, chosen;
    for (uint32_t p = 0; p < np; ++p) dirty[p] = p;
    std::vector<uint8_t> is_dirty(np, 1), stale(np, 0), locked(np, 0);
    auto mark = [&](uint32_t p) {
      if (!is_dirty[p] && !dead_pos_[p]) is_dirty[p] = 1, dirty.push_back(p);
    };
    while (true) {
      // (1) Re-cost what changed.
      parallel_chunks(dirty.size(), 512, [&](size_t begin, size_t end) {
        Scratch s;
        for (size_t i = begin; i < end; ++i) queued_[dirty[i]] = best_candidate(dirty[i], s);
      });
      // (2) The live candidates, kept sorted by (error, u, v) as values: the stale ones out
      // (re-costed, refused, or their position gone), the re-costed ones merged in. Both
      // stream through memory, where selecting the cheapest afresh every pass chased
      // pointers. The dearest is Terrace et al.'s E_max.
      for (uint32_t p : dirty) stale[p] = 1;
      size_t kept = 0;
      for (const Candidate& c : live)
        if (!stale[c.u]) live[kept++] = c;
      live.resize(kept);
      fresh.clear();
      for (uint32_t p : dirty) {
        is_dirty[p] = 0;
        stale[p] = 0;
        if (std::isfinite(queued_[p].error)) fresh.push_back(queued_[p]);
      }
      dirty.clear();
      std::sort(fresh.begin(), fresh.end());
      merged.resize(live.size() + fresh.size());
      std::merge(live.begin(), live.end(), fresh.begin(), fresh.end(), merged.begin());
      live.swap(merged);
      if (live.empty()) break;
      // The base's stopping rule (record()) reads each collapse's own error as E_current and
      // the pass's dearest candidate as E_max. A pass applies its collapses in spatial order,
      // so the rule may cut inside a pass (at most one pass, 1% of the faces, unevenly over
      // the surface); cutting between passes instead (the pass's cheapest as E_current) took
      // one pass more into the base: 2CylinderEngine's area +3.2% against the greedy's, +0.7%
      // this way.
      const float pass_max = live.back().error;
      const size_t goal = std::max<size_t>(1, size_t(double(live_faces_) * opt_.pass_fraction));
      const float error_goal =
          opt_.pass_error_growth * live[std::min(live.size() - 1, goal / 2)].error;
      // (3) Choose, cheapest first, collapses whose ends no chosen one shares (about two faces
      // each); then apply them in spatial order (position index), where consecutive collapses
      // read neighbouring memory, re-checking each one's validity on the current mesh.
      chosen.clear();
      for (const Candidate& c : live) {
        if (2 * chosen.size() >= goal) break;
        if (c.error > error_goal && 2 * chosen.size() > goal / 6) break;
        if (locked[c.u] || locked[c.v]) continue;
        for (uint32_t p : {c.u, c.v}) locked[p] = 1, locked_list.push_back(p);
        chosen.push_back(c);
      }
      std::sort(chosen.begin(), chosen.end(),
                [](const Candidate& x, const Candidate& y) { return x.u < y.u; });
      for (const Candidate& c : chosen) {
        const size_t faces = collapse(c, c.error, pass_max);
        stale[c.u] = 1;  // refused on the current mesh: out until its neighbourhood changes;
                         // collapsed: gone
        if (faces == 0) continue;
        ++done;
        // Re-costed next pass: the target, every neighbour of the removed end, and the
        // neighbours of the target whose choice was the target (its quadric grew).
        mark(c.v);
        for (const auto& n : s_.nb_a) mark(n.first);
        for (const auto& n : s_.nb_b)
          if (queued_[n.first].v == c.v || queued_[n.first].v == c.u) mark(n.first);
      }
      for (uint32_t p : locked_list) locked[p] = 0;
      locked_list.clear();
      if (on_progress && done - reported >= 4096) on_progress(reported = done);
      std::sort(dirty.begin(), dirty.end());
    }
    release_costing();
  }

  // Frees what only the costing reads (quadrics, adjacency, the unit's attributes, positions
  // and current corners: two thirds of the simplifier's memory) before record() allocates the
  // progressive mesh: at 4M triangles the two together would not fit the memory target.
  void release_costing() {
    auto release = [](auto& v) { std::remove_reference_t<decltype(v)>().swap(v); };
    release(pos_q_), release(attr_q_), release(attr_gd_), release(queued_);
    release(dead_pos_), release(u_.attr), release(u_.pos), release(u_.corners);
    release(u_.wedge_group);
    pos_faces_.release();
  }

  // Builds the ProgressiveMesh from the collapse history (after run()).
  void record(const Mesh& mesh, uint32_t mesh_index, ProgressiveMesh& pm) const;
  // When each never-collapsed wedge is last used and, for those a collapse orphans, the wedge
  // each splits from (OrphanSchedule). O(wedges + faces + collapses).
  OrphanSchedule orphan_schedule() const;

 private:
  void init_quadrics(const std::vector<Mat4>& transforms);
  void build_adjacency();
  Candidate best_candidate(uint32_t p, Scratch& s) const;
  // Fills map_ (wedge → target) for collapsing position a onto b; returns false if refused.
  bool map_wedges(uint32_t b, uint32_t* faceL, uint32_t* faceR, int* shared, Scratch& s) const;
  void load_fan(uint32_t a, Scratch& s) const;
  float cost(uint32_t a, uint32_t b, const Scratch& s) const;
  size_t collapse(const Candidate& c, float queue_min, float queue_max);
  void gather_neighbours(uint32_t p, std::vector<std::pair<uint32_t, uint32_t>>& out) const;
  static bool is_border(const Scratch& s, bool* locked);

  Unit& u_;
  const SimplifyOptions& opt_;
  SimplifyReport& report_;
  std::vector<uint32_t> original_corners_;  // the full mesh's corners, before any remapping
  std::vector<Quadric> pos_q_;              // per position
  std::vector<Quadric> attr_q_;  // per wedge: the position-dependent part of the attribute error
  std::vector<double> attr_gd_;  // per wedge × channel: G (3) and D (1)
  std::vector<uint8_t> alive_;   // per face
  size_t live_faces_ = 0;
  std::vector<uint8_t> dead_pos_;
  std::vector<Candidate> queued_;  // per position: its cheapest valid collapse, or error ∞
  FaceLists pos_faces_;            // position → live faces, kept up to date
  Scratch s_;                      // the sequential part's (collapse's) scratch
  // History.
  std::vector<Collapse> collapses_;
  std::vector<std::pair<uint32_t, uint32_t>> maps_;  // all (wedge, parent) pairs in order
  std::vector<uint32_t> removed_faces_;
};

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
    parallel_chunks(n, 1024, [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) {
        block[i] = FaceTerms{};
        terms(f0 + i, block[i], &block_gd[i * kg]);
      }
    });
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

void Simplifier::record(const Mesh& mesh, uint32_t mesh_index, ProgressiveMesh& pm) const {
  size_t nw = u_.wedge_pos.size(), nf = alive_.size();
  // Appearance order of wedges: base wedges (never collapsed and used by a face of the
  // coarsest level, in index order), then per collapse from the last to the first the orphans
  // it made (orphan_schedule), ascending, and its wedges.
  const OrphanSchedule orphans = orphan_schedule();
  const uint32_t m_all = uint32_t(collapses_.size());
  std::vector<std::vector<uint32_t>> orphaned_by(m_all);
  std::vector<uint8_t> collapsed(nw, 0);
  for (const auto& m : maps_) collapsed[m.first] = 1;
  std::vector<uint32_t> order;  // new index → wedge
  order.reserve(nw);
  for (uint32_t w = 0; w < nw; ++w)
    if (!collapsed[w]) {
      if (orphans.last_state[w] < m_all)
        orphaned_by[orphans.last_state[w]].push_back(w);
      else
        order.push_back(w);
    }
  // A wedge that no face ever used would not be reachable; clean() removed those.
  uint32_t base_vertices = uint32_t(order.size());
  std::vector<uint32_t> parent_of(nw, UINT32_MAX);
  for (const auto& m : maps_) parent_of[m.first] = m.second;
  for (uint32_t w = 0; w < nw; ++w)
    if (orphans.parent[w] != UINT32_MAX) parent_of[w] = orphans.parent[w];
  std::vector<uint32_t> face_order;
  face_order.reserve(nf);
  for (uint32_t f = 0; f < nf; ++f)
    if (alive_[f]) face_order.push_back(f);
  uint32_t base_faces = uint32_t(face_order.size());
  pm.levels.clear();
  pm.levels.push_back({base_vertices, base_faces, base_faces, 0});
  for (size_t i = collapses_.size(); i-- > 0;) {
    const Collapse& c = collapses_[i];
    // The orphans first: the collapse's wedges may have them as targets.
    for (uint32_t w : orphaned_by[i]) order.push_back(w);
    for (uint32_t k = 0; k < c.map_count; ++k) order.push_back(maps_[c.first_map + k].first);
    for (uint32_t k = 0; k < c.face_count; ++k)
      face_order.push_back(removed_faces_[c.first_face + k]);
    pm.levels.push_back(
        {uint32_t(order.size()), uint32_t(face_order.size()), uint32_t(face_order.size()), 0});
  }
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

  // Write vertices in appearance order.
  std::vector<uint32_t> new_index(nw);
  for (uint32_t i = 0; i < order.size(); ++i) new_index[order[i]] = i;
  pm.source_mesh = mesh_index;
  pm.positions.resize(nw);
  pm.parent.resize(nw);
  bool has_normals = !u_.wedge_normal.empty();
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
  for (uint32_t i = 0; i < nw; ++i) {
    uint32_t w = order[i];
    const Primitive& src = mesh.primitives[u_.wedge_prim[w]];
    const uint32_t v = u_.wedge_vertex[w];
    pm.positions[i] = src.positions[v];
    if (has_normals && !src.normals.empty()) pm.normals[i] = src.normals[v];
    for (size_t s = 0; s < src.uvs.size(); ++s) pm.uvs[s][i] = src.uvs[s][v];
    if (colors && !src.colors.empty()) pm.colors[i] = src.colors[v];
    pm.parent[i] = parent_of[w] == UINT32_MAX ? i : new_index[parent_of[w]];
  }
  pm.indices.resize(nf * 3);
  pm.face_primitive.resize(nf);
  // Faces keep their full-mesh corners: the original wedges.
  for (uint32_t i = 0; i < face_order.size(); ++i) {
    uint32_t f = face_order[i];
    for (int k = 0; k < 3; ++k) pm.indices[3 * i + k] = new_index[original_corners_[3 * f + k]];
    pm.face_primitive[i] = u_.face_prim[f];
  }
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

// Morton code of a point quantized to 21 bits per axis inside `lo` + [0, extent).
uint64_t morton(const DVec3& p, const DVec3& lo, double scale) {
  auto spread = [](uint64_t v) {
    v &= 0x1FFFFF;
    v = (v | v << 32) & 0x1F00000000FFFFull;
    v = (v | v << 16) & 0x1F0000FF0000FFull;
    v = (v | v << 8) & 0x100F00F00F00F00Full;
    v = (v | v << 4) & 0x10C30C30C30C30C3ull;
    v = (v | v << 2) & 0x1249249249249249ull;
    return v;
  };
  auto q = [&](double x, double l) {
    double t = (x - l) * scale;
    return uint64_t(std::clamp(t, 0.0, 2097151.0));
  };
  return spread(q(p.x, lo.x)) | spread(q(p.y, lo.y)) << 1 | spread(q(p.z, lo.z)) << 2;
}

// Puts the unit in spatial order: positions along a Morton curve, wedges by position, faces by
// their first position in that order. The collapse loop reads a position's faces, their
// corners, the neighbours' quadrics and wedges: in the source's order (a scan's shuffled
// vertices and triangles) nearly every read is a cache miss; in spatial order the neighbours
// are near in memory. What the loop decides depends on the numbering only through ties, the
// order a pass applies its collapses in (a refusal caused by a neighbour applied earlier) and
// the rounding of the quadric sums: the same input in another order gives a record of the same
// quality, not the same bytes.
void spatial_order(Unit& u) {
  const size_t np = u.pos.size(), nw = u.wedge_pos.size(), nf = u.face_prim.size();
  const size_t k = size_t(u.channels);
  DVec3 lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  for (const DVec3& p : u.pos) {
    lo = {std::min(lo.x, p.x), std::min(lo.y, p.y), std::min(lo.z, p.z)};
    hi = {std::max(hi.x, p.x), std::max(hi.y, p.y), std::max(hi.z, p.z)};
  }
  const double extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  const double scale = extent > 0 && std::isfinite(extent) ? 2097151.0 / extent : 0.0;
  std::vector<std::pair<uint64_t, uint32_t>> keyed(np);
  for (uint32_t p = 0; p < np; ++p) keyed[p] = {morton(u.pos[p], lo, scale), p};
  std::sort(keyed.begin(), keyed.end());
  std::vector<uint32_t> new_pos(np);
  std::vector<DVec3> pos(np);
  for (uint32_t i = 0; i < np; ++i) new_pos[keyed[i].second] = i, pos[i] = u.pos[keyed[i].second];
  u.pos.swap(pos);
  // Wedges by (new position, old index): a counting sort.
  std::vector<uint32_t> start(np + 1, 0);
  for (uint32_t w = 0; w < nw; ++w) ++start[new_pos[u.wedge_pos[w]] + 1];
  for (size_t p = 0; p < np; ++p) start[p + 1] += start[p];
  std::vector<uint32_t> new_wedge(nw);
  for (uint32_t w = 0; w < nw; ++w) new_wedge[w] = start[new_pos[u.wedge_pos[w]]]++;
  auto permute = [&](auto& v, size_t width) {
    if (v.empty()) return;
    std::remove_reference_t<decltype(v)> out(v.size());
    for (size_t w = 0; w < nw; ++w)
      for (size_t c = 0; c < width; ++c) out[new_wedge[w] * width + c] = v[w * width + c];
    v.swap(out);
  };
  for (uint32_t& p : u.wedge_pos) p = new_pos[p];
  permute(u.wedge_pos, 1);
  permute(u.wedge_group, 1);
  permute(u.wedge_prim, 1);
  permute(u.wedge_vertex, 1);
  permute(u.wedge_normal, 1);
  permute(u.attr, k);
  // Faces by their smallest new position (a counting sort, stable).
  std::fill(start.begin(), start.end(), 0);
  auto face_key = [&](size_t f) {
    return std::min({u.wedge_pos[new_wedge[u.corners[3 * f]]],
                     u.wedge_pos[new_wedge[u.corners[3 * f + 1]]],
                     u.wedge_pos[new_wedge[u.corners[3 * f + 2]]]});
  };
  std::vector<uint32_t> fkey(nf);
  for (size_t f = 0; f < nf; ++f) fkey[f] = face_key(f), ++start[fkey[f] + 1];
  for (size_t p = 0; p < np; ++p) start[p + 1] += start[p];
  std::vector<uint32_t> corners(3 * nf), face_prim(nf);
  for (size_t f = 0; f < nf; ++f) {
    const uint32_t to = start[fkey[f]]++;
    for (int c = 0; c < 3; ++c)
      corners[3 * size_t(to) + size_t(c)] = new_wedge[u.corners[3 * f + size_t(c)]];
    face_prim[to] = u.face_prim[f];
  }
  u.corners.swap(corners);
  u.face_prim.swap(face_prim);
}

// Builds the simplification unit for one mesh: wedges = the primitives' vertices, positions
// welded exactly, attribute classes (position + everything but the normal) for wedge mapping.
Unit make_unit(const Mesh& mesh, const SimplifyOptions& opt) {
  Unit u;
  size_t uv_sets = 0;
  bool colors = false, normals = true;
  for (const Primitive& p : mesh.primitives) {
    uv_sets = std::max(uv_sets, p.uvs.size());
    colors = colors || !p.colors.empty();
    normals = normals && !p.normals.empty();
  }
  u.channels = int((normals ? 3 : 0) + 2 * uv_sets + (colors ? 4 : 0));
  size_t wedges = 0;
  for (const Primitive& p : mesh.primitives) wedges += p.vertex_count();
  KeyTable pos_of(wedges);    // position hash → positions
  KeyTable group_of(wedges);  // class hash → classes
  std::vector<uint32_t> group_first_wedge;
  for (uint32_t pi = 0; pi < mesh.primitives.size(); ++pi) {
    const Primitive& p = mesh.primitives[pi];
    uint32_t first = uint32_t(u.wedge_pos.size());
    for (size_t v = 0; v < p.vertex_count(); ++v) {
      Vec3 x = p.positions[v];
      uint64_t h = position_hash(x);
      uint32_t pid = pos_of.find(h, [&](uint32_t c) {
        return u.pos[c].x == x.x && u.pos[c].y == x.y && u.pos[c].z == x.z;
      });
      if (pid == KeyTable::kEmpty) {
        pid = uint32_t(u.pos.size());
        u.pos.push_back(to_dvec3(x));
        pos_of.insert(h, pid);
      }
      uint32_t w = uint32_t(u.wedge_pos.size());
      u.wedge_pos.push_back(pid);
      u.wedge_prim.push_back(pi);
      u.wedge_vertex.push_back(uint32_t(v));
      if (normals) u.wedge_normal.push_back(p.normals[v]);
      // Weighted attribute channels.
      if (normals)
        for (float c : {p.normals[v].x, p.normals[v].y, p.normals[v].z})
          u.attr.push_back(c * opt.normal_weight);
      for (size_t s = 0; s < uv_sets; ++s) {
        Vec2 t = s < p.uvs.size() ? p.uvs[s][v] : Vec2{};
        u.attr.push_back(t.x * opt.uv_weight);
        u.attr.push_back(t.y * opt.uv_weight);
      }
      if (colors) {
        Vec4 c = p.colors.empty() ? Vec4{1, 1, 1, 1} : p.colors[v];
        for (float ch : {c.x, c.y, c.z, c.w}) u.attr.push_back(ch * opt.color_weight);
      }
      // Class: position, primitive, uv and colour bits (normal excluded).
      uint64_t g =
          uint64_t(pid) * 0x9E3779B97F4A7C15ull ^ (uint64_t(pi) + 1) * 0xD6E8FEB86659FD93ull;
      size_t skip = normals ? 3 : 0;
      size_t k = size_t(u.channels);
      for (size_t c = skip; c < k; ++c) {
        const float val = u.attr[size_t(w) * k + c];
        uint32_t b;
        std::memcpy(&b, &val, 4);
        g = (g ^ b) * 0x100000001B3ull;
      }
      uint32_t gid = group_of.find(g, [&](uint32_t cand) {
        uint32_t w0 = group_first_wedge[cand];
        if (u.wedge_pos[w0] != pid || u.wedge_prim[w0] != pi) return false;
        bool same = true;
        for (size_t c = skip; c < k && same; ++c)
          same = u.attr[size_t(w0) * k + c] == u.attr[size_t(w) * k + c];
        return same;
      });
      if (gid == KeyTable::kEmpty) {
        gid = uint32_t(group_first_wedge.size());
        group_first_wedge.push_back(w);
        group_of.insert(g, gid);
      }
      u.wedge_group.push_back(gid);
    }
    for (size_t t = 0; t + 2 < p.indices.size(); t += 3) {
      for (int c = 0; c < 3; ++c) u.corners.push_back(first + p.indices[t + size_t(c)]);
      u.face_prim.push_back(pi);
    }
  }
  spatial_order(u);
  return u;
}

size_t counts_for(const Scene& scene, uint32_t mesh) {
  size_t n = 0;
  for (const Instance& inst : scene.instances) n += inst.mesh == mesh;
  return n;
}

uint64_t splitmix(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Instance order for thinning: instances that stay inside the scene bounds when scaled up 2x
// about their centre come first, then the rest; within each, a fixed pseudo-random order so
// the kept ones spread over the scene (Azim et al. §3.2's stochastic simplification).
InstanceOrder instance_order(const Scene& scene, uint32_t mesh, const Bounds& scene_box) {
  InstanceOrder io;
  io.mesh = mesh;
  Bounds local = mesh_bounds(scene.meshes[mesh]);
  struct Entry {
    int outside;
    uint64_t key;
    uint32_t index;
    Vec3 centre;
  };
  std::vector<Entry> entries;
  for (uint32_t i = 0; i < scene.instances.size(); ++i) {
    const Instance& inst = scene.instances[i];
    if (inst.mesh != mesh) continue;
    Bounds wb;
    for (int c = 0; c < 8; ++c)
      wb.add(inst.world.transform_point({c & 1 ? local.max.x : local.min.x,
                                         c & 2 ? local.max.y : local.min.y,
                                         c & 4 ? local.max.z : local.min.z}));
    Vec3 centre = wb.center();
    Vec3 half = (wb.max - wb.min) * 0.5f * 2.0f;  // scaled up 2x
    bool inside = centre.x - half.x >= scene_box.min.x && centre.x + half.x <= scene_box.max.x &&
                  centre.y - half.y >= scene_box.min.y && centre.y + half.y <= scene_box.max.y &&
                  centre.z - half.z >= scene_box.min.z && centre.z + half.z <= scene_box.max.z;
    entries.push_back({inside ? 0 : 1, splitmix(i), i, centre});
  }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    return a.outside != b.outside ? a.outside < b.outside
                                  : (a.key != b.key ? a.key < b.key : a.index < b.index);
  });
  for (const Entry& e : entries) {
    io.order.push_back(e.index);
    io.centres.push_back(e.centre);
  }
  return io;
}

}  // namespace

std::array<double, 16> instance_face_quadric(Vec3 a, Vec3 b, Vec3 c,
                                             const std::vector<Mat4>& transforms) {
  DVec3 P[3] = {to_dvec3(a), to_dvec3(b), to_dvec3(c)}, Q[3], un;
  double area0, world_area = 0;
  Quadric unit_q, sum;
  if (instance_plane(P, Mat4::identity(), Q, &un, &area0, &unit_q))
    sum = scaled(unit_q, placement_factor(make_placements(transforms), un, area0, &world_area),
                 world_area);
  return {sum.a00, sum.a01, sum.a02, sum.b0, sum.a01, sum.a11, sum.a12, sum.b1,
          sum.a02, sum.a12, sum.a22, sum.b2, sum.b0,  sum.b1,  sum.b2,  sum.c};
}

// The scene without its primitives' vertex and index arrays (everything else kept): what the
// record refers to, where a full copy would hold the geometry twice beside the record.
Scene without_vertex_data(const Scene& scene) {
  Scene out = empty_like(scene);
  out.instances = scene.instances;
  out.meshes.resize(scene.meshes.size());
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    out.meshes[m].name = scene.meshes[m].name;
    for (const Primitive& p : scene.meshes[m].primitives) {
      Primitive q;
      q.material = p.material;
      q.flat = p.flat;
      out.meshes[m].primitives.push_back(std::move(q));
    }
  }
  return out;
}

ProgressiveScene build_progressive(const Scene& cleaned, const SimplifyOptions& options,
                                   SimplifyReport* report, Progress* progress) {
  auto start = std::chrono::steady_clock::now();
  SimplifyReport r;
  SceneStats st = compute_stats(cleaned);
  r.input_triangles = st.scene_triangles;
  r.instances_per_submesh = instances_per_submesh(cleaned);
  ProgressiveScene ps;
  ps.flattened = should_flatten(cleaned, options.flatten_below_ips);
  const Scene flat = ps.flattened ? flatten_geometry(cleaned) : Scene{};
  const Scene& scene = ps.flattened ? flat : cleaned;  // the geometry the record is made from
  ps.scene = without_vertex_data(scene);
  if (ps.flattened) ps.scene.images = cleaned.images;  // flatten_geometry left them out
  r.flattened = ps.flattened;
  double norm = scene.normalization_scale > 0 ? scene.normalization_scale : 1.0;
  Mat4 normalize_m = Mat4::scale(norm, norm, norm);
  Bounds box = scene_bounds(scene);
  ps.meshes.resize(scene.meshes.size());
  ps.instance_orders.resize(scene.meshes.size());
  // Progress: collapses over all submeshes' vertices (an upper bound of the positions).
  uint64_t total_vertices = 0;
  for (const Mesh& mesh : scene.meshes)
    for (const Primitive& p : mesh.primitives) total_vertices += p.positions.size();
  // Submeshes are independent: each is simplified on its own thread (its own report, summed in
  // mesh order below), so the record is the same whatever the thread count.
  std::vector<SimplifyReport> reports(scene.meshes.size());
  std::vector<std::atomic<uint64_t>> collapsed(scene.meshes.size());
  std::mutex progress_mutex;
  parallel_chunks(scene.meshes.size(), 1, [&](size_t begin, size_t end) {
    for (uint32_t m = uint32_t(begin); m < end; ++m) {
      std::vector<Mat4> transforms;
      for (const Instance& inst : scene.instances)
        if (inst.mesh == m) transforms.push_back(normalize_m * inst.world);
      if (transforms.empty()) transforms.push_back(normalize_m);  // unplaced: its own space
      Unit unit = make_unit(scene.meshes[m], options);
      Simplifier s(unit, transforms, options, reports[m]);
      s.run([&](uint64_t collapses) {
        collapsed[m] = collapses;
        if (!progress) return;
        uint64_t done = 0;
        for (const auto& c : collapsed) done += c;
        std::lock_guard<std::mutex> lock(progress_mutex);
        report_fraction(progress, double(done) / double(std::max<uint64_t>(1, total_vertices)));
      });
      s.record(scene.meshes[m], m, ps.meshes[m]);
      ps.instance_orders[m] = instance_order(scene, m, box);
    }
  });
  for (const SimplifyReport& x : reports) {
    r.collapses += x.collapses;
    r.refused_flip += x.refused_flip;
    r.refused_link += x.refused_link;
    r.refused_wedge += x.refused_wedge;
    r.refused_vanish += x.refused_vanish;
  }
  // Terrace et al. §4.5: small models, or ones whose refinements would be under 10% of the mesh,
  // ship whole: the base level is the full mesh.
  uint64_t base_tris = 0, full_tris = 0;
  for (uint32_t m = 0; m < ps.meshes.size(); ++m) {
    const ProgressiveMesh& pm = ps.meshes[m];
    base_tris += uint64_t(pm.levels[pm.base_level].triangles) * counts_for(ps.scene, m);
    full_tris += uint64_t(pm.levels.back().triangles) * counts_for(ps.scene, m);
  }
  if (full_tris < options.ship_whole_below ||
      double(full_tris - base_tris) < options.ship_whole_fraction * double(full_tris))
    for (ProgressiveMesh& pm : ps.meshes) pm.base_level = pm.levels.size() - 1;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (report) *report = r;
  return ps;
}

}  // namespace meshmux
