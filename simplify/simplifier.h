// The collapse loop's internals, shared by simplify.cpp (the units, the record) and
// block_levels.cpp (the block hierarchy of big meshes): the quadrics, a unit's wedges over
// welded positions, the history of collapses, and the Simplifier that runs the passes and
// records the progressive mesh. Not part of the stage's contract (simplify.h is).
// Papers: see simplify.cpp (Azim et al.; Hoppe; Terrace et al.; Kapoulkine).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <utility>
#include <vector>

#include "core/parallel.h"
#include "core/spill_file.h"
#include "scene/dvec3.h"
#include "scene/progressive.h"
#include "scene/scene.h"
#include "simplify/simplify.h"

namespace meshmux::simplify_detail {

// An array of plain values, owned (a vector) or a view into mapped pages (whose owner keeps
// them mapped while the view is used). Indexed as a vector is; copying is not allowed.
template <typename T>
class Store {
 public:
  Store() = default;
  Store(std::vector<T> v) : own_(std::move(v)), data_(own_.data()), size_(own_.size()) {}
  Store(T* view, size_t size) : data_(view), size_(size) {}
  Store(Store&& o) noexcept { swap(o); }
  Store& operator=(Store&& o) noexcept {
    Store(std::move(o)).swap(*this);
    return *this;
  }
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;
  void assign(size_t n, const T& value) {
    own_.assign(n, value);
    data_ = own_.data(), size_ = n;
  }
  void swap(Store& o) noexcept {
    own_.swap(o.own_), std::swap(data_, o.data_), std::swap(size_, o.size_);
  }
  T& operator[](size_t i) { return data_[i]; }
  const T& operator[](size_t i) const { return data_[i]; }
  size_t size() const { return size_; }
  T* begin() { return data_; }
  const T* begin() const { return data_; }

 private:
  std::vector<T> own_;
  T* data_ = nullptr;
  size_t size_ = 0;
};

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
                    Quadric* pq);

// An instance transform prepared for the instance quadric (see init_quadrics).
struct Placement {
  double cof[3][3];  // A⁻ᵀ
  double absdet;
  bool similar;  // rotation, uniform scale, translation (mirrors allowed)
  double s2;     // the uniform scale squared, when similar
};

// Placements of the non-singular transforms, in order (singular ones place nothing).
std::vector<Placement> make_placements(const std::vector<Mat4>& transforms);

// Σᵢ |det Aᵢ| / |Aᵢ⁻ᵀ n̂|: the factor that turns the mesh-space plane quadric of a face (unit
// normal n̂, weighted by its area) into the instance-summed one; adds the placed areas
// (area₀ Σ |det Aᵢ| |Aᵢ⁻ᵀ n̂|) to *world_area.
double placement_factor(const std::vector<Placement>& places, DVec3 un, double area0,
                        double* world_area);

// q with its quadric terms times f and its weight set to w.
Quadric scaled(Quadric q, double f, double w);

// One submesh prepared for simplification: wedges (the mesh's vertices) over welded positions.
struct Unit {
  // Wedges, concatenated over the mesh's primitives.
  std::vector<uint32_t> wedge_pos;     // wedge → position
  std::vector<uint32_t> wedge_group;   // wedge → (position, non-normal attributes) class
  std::vector<uint32_t> wedge_prim;    // wedge → source primitive (empty: all 0, one primitive)
  std::vector<uint32_t> wedge_vertex;  // wedge → its vertex in that primitive
  std::vector<Vec3> wedge_normal;      // may be empty (always, once a unit's costing is over)
  bool normals = false;                // the wedges have normals (wedge_normal while costing)
  std::vector<float> attr;  // wedge × channels, weighted attribute values (products of floats)
  int channels = 0;
  std::vector<DVec3> pos;           // position → mesh-space point
  std::vector<uint32_t> corners;    // face × 3 wedges (current, remapped as we go)
  std::vector<uint32_t> face_prim;  // face → source primitive (empty: all 0, one primitive)
  uint32_t prim_of_wedge(size_t w) const { return wedge_prim.empty() ? 0 : wedge_prim[w]; }
  uint32_t prim_of_face(size_t f) const { return face_prim.empty() ? 0 : face_prim[f]; }
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
  bool empty() const { return start_.empty(); }  // not built, or released
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
  // How the quadrics are made: summed now on every core (a whole unit), summed now on the
  // calling thread (a block of a bigger unit), or later by the first block level, block by
  // block, so that the whole unit's quadrics are never held at once (run_block_levels).
  enum class Quadrics { kNow, kNowSerial, kByBlocks };
  Simplifier(Unit& unit, const std::vector<Mat4>& transforms, const SimplifyOptions& opt,
             SimplifyReport& report, Quadrics quadrics = Quadrics::kNow)
      : u_(unit), opt_(opt), report_(report) {
    serial_ = quadrics == Quadrics::kNowSerial;
    // A block's own are never recorded; a big unit's wait in the spill file until the record.
    if (!serial_) keep_original_corners(unit.corners, quadrics == Quadrics::kByBlocks);
    if (quadrics == Quadrics::kByBlocks)
      transforms_ = transforms;
    else
      init_quadrics(transforms);
  }
  // A unit whose quadrics were summed already (a block of a bigger unit, or the rest of one
  // after its first level: block_levels.cpp); it is never recorded (record() is the unit's).
  // `mapped`: the pages the quadrics are views into, or null (they own their values).
  Simplifier(Unit& unit, Store<Quadric> pos_q, Store<Quadric> attr_q, Store<double> attr_gd,
             const SimplifyOptions& opt, SimplifyReport& report,
             std::shared_ptr<MappedPages> mapped = nullptr)
      : u_(unit),
        opt_(opt),
        report_(report),
        mapped_(std::move(mapped)),
        pos_q_(std::move(pos_q)),
        attr_q_(std::move(attr_q)),
        attr_gd_(std::move(attr_gd)) {}

  // What a position may do in a block's loop (role_): neither collapse nor be a target (it
  // lies outside the block), be a target only (it has a face outside the block: its border is
  // locked), or both.
  enum Role : uint8_t { kFixed = 0, kTargetOnly = 1, kFree = 2 };

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
  // It continues from the state the block levels left, when they ran (run_block_levels).
  void run(const std::function<void(uint64_t)>& on_progress = {}) {
    if (finished_) return;  // the block levels' compacted rest ran it (run_block_levels)
    const size_t np = u_.pos.size();
    uint64_t done = collapses_.size(), reported = done;
    if (alive_.empty()) begin_state();
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
      auto recost = [&](size_t begin, size_t end) {
        Scratch s;
        for (size_t i = begin; i < end; ++i) queued_[dirty[i]] = best_candidate(dirty[i], s);
      };
      if (serial_)
        recost(0, dirty.size());
      else
        parallel_chunks(dirty.size(), 512, recost);
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
      if (live.empty() || live_faces_ <= stop_faces_ || live.front().error > stop_error_) break;
      // The base's stopping rule (record()) reads each collapse's own error as E_current and
      // the pass's dearest candidate as E_max. A pass applies its collapses in spatial order,
      // so the rule may cut inside a pass (at most one pass, 1% of the faces, unevenly over
      // the surface); cutting between passes instead (the pass's cheapest as E_current) took
      // one pass more into the base: 2CylinderEngine's area +3.2% against the greedy's, +0.7%
      // this way.
      const float pass_max = live.back().error;
      size_t goal = std::max<size_t>(1, size_t(double(live_faces_) * opt_.pass_fraction));
      if (stop_faces_ > 0) goal = std::min(goal, live_faces_ - stop_faces_ + 1);
      const float error_goal =
          opt_.pass_error_growth * live[std::min(live.size() - 1, goal / 2)].error;
      // (3) Choose, cheapest first, collapses whose ends no chosen one shares (about two faces
      // each); then apply them in spatial order (position index), where consecutive collapses
      // read neighbouring memory, re-checking each one's validity on the current mesh.
      chosen.clear();
      for (const Candidate& c : live) {
        if (2 * chosen.size() >= goal) break;
        if (c.error > error_goal && 2 * chosen.size() > goal / 6) break;
        if (c.error > stop_error_) break;
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
    if (!keep_costing_) release_costing();
  }

  // The first state: every face alive, no position collapsed.
  void begin_state() {
    alive_.assign(u_.corners.size() / 3, 1);
    live_faces_ = alive_.size();
    dead_pos_.assign(u_.pos.size(), 0);
  }

  // The block hierarchy of a big unit (block_levels.cpp): levels of blocks simplified on every
  // core with their borders locked, each under the level's error bound (level_error_bound) and
  // to at most a quarter of its faces, the blocks shifted between levels so that
  // one level's borders lie inside the next level's blocks (Ponchio and Dellepiane's batched
  // multi-triangulation in Nexus; Kapoulkine's clusterlod), until at most `opt_.block_until`
  // faces are live or a level removes under a tenth of them. run() then finishes the record
  // on the whole unit. Returns the levels run. Needs a Simplifier made with Quadrics::kByBlocks.
  size_t run_block_levels(const std::function<void(uint64_t)>& on_progress = {});
  size_t live_faces() const { return live_faces_; }

  // Frees what only the costing reads (quadrics, adjacency, the unit's attributes, positions
  // and current corners: two thirds of the simplifier's memory) before record() allocates the
  // progressive mesh: at 4M triangles the two together would not fit the memory target.
  void release_costing() {
    auto release = [](auto& v) { std::remove_reference_t<decltype(v)>().swap(v); };
    release(pos_q_), release(attr_q_), release(attr_gd_), release(queued_), mapped_.reset();
    release(dead_pos_), release(u_.attr), release(u_.pos), release(u_.corners);
    release(u_.wedge_group), release(u_.wedge_normal);  // u_.normals says whether there were
    pos_faces_.release();
  }

  // Builds the ProgressiveMesh from the collapse history (after run()), releasing the history
  // as it goes: the simplifier has nothing left to record afterwards.
  void record(const Mesh& mesh, uint32_t mesh_index, ProgressiveMesh& pm);
  // When each never-collapsed wedge is last used and, for those a collapse orphans, the wedge
  // each splits from (OrphanSchedule). O(wedges + faces + collapses).
  OrphanSchedule orphan_schedule() const;

 private:
  struct BlockResult;
  struct BlockUnit;
  struct Rest;
  // Hands a block's final quadrics back: into the unit's arrays (`keep_here`), or into `out`
  // (the unit has none: the first level), where they may go on to the spill file.
  void keep_block_quadrics(const Simplifier& s, const BlockUnit& b, const uint32_t* positions,
                           size_t count, bool keep_here, BlockResult& out);
  // What a block does with quadrics: copies the unit's, makes its own from its faces (the
  // unit's are made by blocks: Quadrics::kByBlocks), or only costs a sample of its cheapest
  // collapses with its own (for the first level's error bound).
  enum BlockMode { kCopyQuadrics, kMakeQuadrics, kCostsOnly };
  BlockUnit make_block_unit(const uint32_t* positions, size_t count,
                            const std::vector<uint32_t>& block_of, uint32_t block) const;
  // The levels from `level` on (its parity decides the first shift); returns the levels run.
  size_t block_levels_from(size_t level, const std::function<void(uint64_t)>& on_progress);
  // The first level's bound, where the unit has no quadrics yet: the third quartile of the
  // cheapest collapses of every eighth position of one block in sixteen, with its own.
  float sampled_error_bound(const std::vector<uint32_t>& live, const std::vector<size_t>& starts,
                            const std::vector<uint32_t>& block_of);
  static float third_quartile(std::vector<float>& cost);
  // The first level's faces per block (block_faces_), where the unit has no adjacency: the
  // whole unit's lists (~21 bytes per face) are never built.
  void block_face_lists(const std::vector<uint32_t>& block_of, size_t blocks);
  // After a level whose quadrics the blocks made: the live part of the unit as a unit of its
  // own (positions, wedges and faces renumbered in order, the blocks' quadrics moved in), the
  // unit's costing arrays freed. With a spill file, the rest's quadrics are pages of a file of
  // their own, which the levels' blocks map in and drop as they go (a 4M scan's rest: 258 MB
  // that the whole level held at once otherwise).
  Rest compact(std::vector<BlockResult>& results);
  // The live part as a unit of its own (compact() and compact_quadrics()): `pos_id` and `wedge_id`
  // become each live position's and wedge's number in it (UINT32_MAX: dead); the unit's
  // costing arrays but the quadrics are freed.
  Rest compact_unit(std::vector<uint32_t>& pos_id, std::vector<uint32_t>& wedge_id,
                    size_t& live_pos, size_t& live_wedges);
  // The live part again, its quadrics copied into a mapping of their own (`mapped`: a rest
  // whose levels left most positions dead) or into memory (after the levels: a few hundred
  // thousand faces are left, and the whole-unit loop would touch every page of the rest's).
  Rest compact_quadrics(bool mapped);
  // A rest's unit and its quadrics' arrays, unfilled: pages of a file of their own in the spill
  // directory (`mapped`, when it has room), else memory (compact(), compact_quadrics()).
  struct RestDraft;
  RestDraft draft_rest(bool mapped);
  // After the levels: the whole-unit loop, on the live part with its quadrics in memory where
  // they are mapped (compact_quadrics), its history absorbed.
  void finish_levels(const std::function<void(uint64_t)>& on_progress);
  // The full mesh's corners kept for the record: in the spill file for a big unit (`spill`,
  // with a spill directory: 240 MB at 20M triangles that no level reads), else in memory.
  void keep_original_corners(const std::vector<uint32_t>& corners, bool spill);
  // Reads them back from the spill file (the record's first step); a no-op when held.
  void load_original_corners();
  // Drops the mapped quadrics' pages from memory (see MappedPages), when there are any.
  void drop_mapped() const {
    if (mapped_) mapped_->drop();
  }
  // The block hierarchy so far goes to a rest about to run more levels (absorb takes it back).
  void hand_blocks(Simplifier& rest);
  // The rest's history (and the faces it leaves alive) in the unit's numbering, after ours,
  // with its blocks.
  void absorb(Rest& rest);
  // The history's arrays sized for the blocks' collapses about to be merged in: grown by
  // doubling, they kept up to half again of slack into the record's allocation (the stage's
  // peak at 4M triangles).
  void reserve_history(const std::vector<BlockResult>& results);
  // One level: the live positions, in the unit's spatial order, cut into runs of
  // `block_positions` (the first one half as long on odd levels); each run's faces simplified
  // by a Simplifier of their own; their histories merged by error, each collapse tagged with its
  // block (blocks_, collapse_block_). Returns the collapses made.
  // `on_progress` (may be empty) hears the collapses so far as blocks finish (any thread).
  size_t run_block_level(size_t block_positions, size_t level,
                         std::vector<BlockResult>* quadrics_made = nullptr,
                         const std::function<void(uint64_t)>& on_progress = {});
  // The level's error bound: the third quartile of the cost of the cheapest collapse of every
  // eighth live position, so that blocks on flat or dense parts go further than rough ones, as
  // the whole-unit loop's error order would (at the median, levels removed ~30% of the faces
  // each, 8 levels on a 4M scan, 7.9 s; at the third quartile ~45%, 5 levels, 6.0 s; Hausdorff
  // against meshopt_simplify 0.66/0.96/1.04 and 0.64/0.96/1.07 at 25/6/1.5%).
  float level_error_bound(const std::vector<uint32_t>& live) const;
  BlockResult simplify_block(const uint32_t* positions, size_t count,
                             const std::vector<uint32_t>& block_of, uint32_t block, float bound,
                             BlockMode mode);
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
  // ... or where they wait, for a unit whose block levels run (load_original_corners).
  std::shared_ptr<SpillFile> corners_spill_;
  size_t corners_count_ = 0;
  // The pages the quadrics below are views into (a big unit's rest: compact()), or null.
  std::shared_ptr<MappedPages> mapped_;
  Store<Quadric> pos_q_;        // per position
  Store<Quadric> attr_q_;       // per wedge: the position-dependent part of the attribute error
  Store<double> attr_gd_;       // per wedge × channel: G (3) and D (1)
  std::vector<uint8_t> alive_;  // per face
  size_t live_faces_ = 0;
  std::vector<uint8_t> dead_pos_;
  std::vector<Candidate> queued_;  // per position: its cheapest valid collapse, or error ∞
  FaceLists pos_faces_;            // position → live faces, kept up to date
  Scratch s_;                      // the sequential part's (collapse's) scratch
  std::vector<uint8_t> role_;      // per position a Role, or empty: all free
  bool serial_ = false;            // costing on the calling thread (blocks run beside each other)
  std::vector<Mat4> transforms_;   // Quadrics::kByBlocks: the instances, for the blocks' quadrics
  std::shared_ptr<SpillFile> spill_;      // the first level's quadrics, written out meanwhile
  std::vector<uint32_t> block_faces_;     // the first level's faces, by block
  std::vector<size_t> block_face_start_;  // per block: its first entry in block_faces_
  bool finished_ = false;                 // the history is complete (run() has nothing left to do)
  bool keep_costing_ = false;             // run() keeps the quadrics (a block's are handed back)
  size_t stop_faces_ = 0;                 // run() stops once at most this many faces are live
  float stop_error_ = INFINITY;  // ... or once the cheapest collapse left costs more than this
  // History.
  std::vector<Collapse> collapses_;
  std::vector<std::pair<uint32_t, uint32_t>> maps_;  // all (wedge, parent) pairs in order
  std::vector<uint32_t> removed_faces_;
  // The block hierarchy (ProgressiveMesh::blocks): blocks_[0] is the root; collapse_block_[i]
  // is collapse i's block, where collapses past its end are the root's (the whole-unit loop).
  // Handed to a rest and back (absorb) with the history.
  std::vector<ProgressiveBlock> blocks_ = std::vector<ProgressiveBlock>(1);
  std::vector<uint16_t> collapse_block_;
};

}  // namespace meshmux::simplify_detail
