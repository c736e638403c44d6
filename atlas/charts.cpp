// Chart segmentation for the texture atlas.
// - Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion of 3D models for
//   interactive metaverses" §4.2: every face starts as its own chart; adjacent charts merge
//   greedily, cheapest first (priority queue); no merging of back-to-back twins; textured only with
//   textured, flat colour only with the same colour; stop by formula 1,
//   log(1 + E_current) / log(1 + E_max) ≥ stop_ratio.
// - Garland, Willmott and Heckbert 2001 ("Hierarchical face clustering on polygonal surfaces")
//   and Sander et al. 2001 §5 (chart merging): the cost of a merge is the planarity error of
//   the merged chart (area-weighted mean squared distance to its least-squares plane, from
//   per-chart moments merged in O(1)) plus a compactness term (perimeter² / (4π area) − 1).
//
// Product decisions beyond the papers (docs/ARCHITECTURE.md "Atlas"):
// - Planarity is divided by the mesh's bounding-box diagonal², so the costs and the stop rule
//   do not depend on the model's units or size.
// - Normal guard: a merge is refused when some face of the merged chart would face away from
//   the fitted plane by more than ~84° (normal · plane normal < 0.1, the plane normal oriented
//   by the area-weighted mean normal). Charts stay height fields over their plane, so they
//   flatten without folds; closed surfaces always end up as several charts. The test uses, per
//   chart, the faces whose normals are extreme in 26 fixed directions (kept in O(1) per merge);
//   a violation it finds is real; one it misses would be a face between those extremes (on UV
//   spheres of 224 to 36k faces no face ended below 0.1).
// - E_max is the dearest merge still queued (a max-heap with lazy invalidation). Near the end
//   of the merging the queue holds few entries and E_max falls towards E_current, so the rule
//   alone would stop before merges that cost almost nothing (the two halves of a flat sheet).
//   Safeguard: flat, compact merges are made whatever the ratio says (kFreePlanarity); once
//   the rule has fired, only such merges go on. On the shared models the rule fires late (the
//   normal guard ends most merging first): with the rule off they would have 1-18% fewer
//   charts; the safeguard changes none of them.
// - Faces with the same three positions in the same winding (duplicates across primitives,
//   which clean keeps) are kept apart like back-to-back twins: they would overlap in uv.
// Deterministic: costs tie-break on chart indices, charts come out ordered by first face.
#include "atlas/charts.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <eigen3/Eigen/Dense>
#include <queue>
#include <tuple>
#include <unordered_map>

#include "scene/position_key.h"

namespace meshmux {

std::vector<FaceRef> mesh_faces(const Mesh& mesh) {
  std::vector<FaceRef> out;
  size_t n = 0;
  for (const Primitive& p : mesh.primitives) n += p.triangle_count();
  out.reserve(n);
  for (uint32_t pi = 0; pi < mesh.primitives.size(); ++pi) {
    uint32_t t = uint32_t(mesh.primitives[pi].triangle_count());
    for (uint32_t i = 0; i < t; ++i) out.push_back({pi, i});
  }
  return out;
}

namespace {

using Eigen::Matrix3d;
using Eigen::Vector3d;

// A face of the merged chart may not lean further than this from the chart's plane normal.
constexpr double kMinNormalDot = 0.1;
// Safeguard for formula 1 (E_max is the dearest merge still queued, so near the end of the
// merging, when few charts are left, E_max falls to E_current and the ratio reaches 1 even when
// the merge is harmless: the last two halves of a flat sheet). A merge whose chart stays flat
// (mean squared distance to its plane below kFreePlanarity diagonal², i.e. rms 0.1% of the
// mesh's diagonal) and not elongated (P² / (4πA) − 1 below kFreeCompactness: a 4:1 rectangle is
// 0.99, a square 0.27) is made whatever the ratio says. On the shared models the rule fires only
// in the last few percent of merges (the normal guard ends most merging), so this changes nothing
// there; it keeps flat regions whole.
constexpr double kFreePlanarity = 1e-6;
constexpr double kFreeCompactness = 1.0;
constexpr uint32_t kNone = 0xffffffffu;
constexpr int kDirs = 26;

const std::array<Vector3d, kDirs>& directions() {
  static const std::array<Vector3d, kDirs> dirs = [] {
    std::array<Vector3d, kDirs> d;
    int k = 0;
    for (int x = -1; x <= 1; ++x)
      for (int y = -1; y <= 1; ++y)
        for (int z = -1; z <= 1; ++z)
          if (x || y || z) d[k++] = Vector3d(x, y, z).normalized();
    return d;
  }();
  return dirs;
}

Vector3d to_d(Vec3 v) { return Vector3d(v.x, v.y, v.z); }

struct Face {
  uint32_t pos[3];
  double area = 0;
  double perimeter = 0;
  Vector3d normal = Vector3d::Zero();  // unit (zero for a numerically degenerate face)
  uint32_t cls = 0;                    // 0 textured, else flat colour id
  uint32_t twin_group = kNone;         // faces with the same three positions
};

struct Neighbor {
  uint32_t chart;
  double shared;  // length of the boundary the two charts share
};

struct ChartState {
  double area = 0;
  double perimeter = 0;
  Vector3d centroid = Vector3d::Zero();
  Matrix3d moment = Matrix3d::Zero();
  Vector3d normal_sum = Vector3d::Zero();  // Σ area · face normal
  uint32_t cls = 0;
  uint32_t version = 0;
  uint32_t faces = 1;
  uint32_t head = kNone, tail = kNone;  // linked list of faces (Segmenter::next_)
  uint32_t extremes = kNone;            // slot in the extremes pool; kNone: the one face `head`
  bool alive = true;
  bool has_twins = false;
  std::vector<uint32_t> twin_faces;  // member faces that have a twin
  std::vector<Neighbor> neighbors;
};

struct Candidate {
  double cost;
  bool free;        // exempt from the stop rule (kFreePlanarity, kFreeCompactness)
  uint32_t a, b;    // a < b
  uint32_t va, vb;  // versions when costed
};
struct MinOrder {
  bool operator()(const Candidate& x, const Candidate& y) const {
    if (x.cost != y.cost) return x.cost > y.cost;
    if (x.a != y.a) return x.a > y.a;
    return x.b > y.b;
  }
};
struct MaxOrder {
  bool operator()(const Candidate& x, const Candidate& y) const {
    if (x.cost != y.cost) return x.cost < y.cost;
    if (x.a != y.a) return x.a > y.a;
    return x.b > y.b;
  }
};

// Merged planarity data of two charts, by the parallel-axis rule (numerically stable).
struct Merged {
  double area;
  Vector3d centroid;
  Matrix3d moment;
};
Merged merge_moments(double a1, const Vector3d& c1, const Matrix3d& m1, double a2,
                     const Vector3d& c2, const Matrix3d& m2) {
  Merged r;
  r.area = a1 + a2;
  if (r.area <= 0) return {0, c1, m1 + m2};
  Vector3d d = c1 - c2;
  r.centroid = (a1 * c1 + a2 * c2) / r.area;
  r.moment = m1 + m2 + (a1 * a2 / r.area) * (d * d.transpose());
  return r;
}

// What one primitive's faces show (charts.h): a texture (or varying vertex colours), or one
// flat colour with its factors. Returns true when textured; otherwise fills `flat`.
struct FlatClass {
  Vec4 color;
  Vec3 orm, emissive, sheen;
  bool operator==(const FlatClass& o) const {
    return color == o.color && orm == o.orm && emissive == o.emissive && sheen == o.sheen;
  }
};
bool primitive_textured(const Scene& scene, const Primitive& p, FlatClass* flat) {
  bool textured = false;
  Vec4 factor{1, 1, 1, 1};
  Vec3 orm{1, 1, 1}, emissive{0, 0, 0}, sheen{0, 0, 0};  // the glTF default material's
  if (p.material >= 0 && size_t(p.material) < scene.materials.size()) {
    const Material& m = scene.materials[size_t(p.material)];
    textured = m.base_color.present() || m.normal.present() || m.occlusion.present() ||
               m.metallic_roughness.present() || m.emissive.present() || m.sheen_color.present();
    factor = m.base_color_factor;
    orm = {1, m.roughness_factor, m.metallic_factor};
    emissive = m.emissive_factor;
    sheen = m.sheen_color_factor;
  }
  Vec4 vertex_color{1, 1, 1, 1};
  if (!p.colors.empty()) {
    vertex_color = p.colors[0];
    for (const Vec4& c : p.colors)
      if (!(c == vertex_color)) textured = true;
  }
  if (!textured)
    *flat = {{factor.x * vertex_color.x, factor.y * vertex_color.y, factor.z * vertex_color.z,
              factor.w * vertex_color.w},
             orm,
             emissive,
             sheen};
  return textured;
}

class Segmenter {
 public:
  Segmenter(const Scene& scene, uint32_t mesh_index, const ChartOptions& options)
      : scene_(scene), mesh_(scene.meshes[mesh_index]), options_(options) {}

  // Appends the charts (ordered by first face) and fills `face_chart` with their indices.
  void run(uint32_t mesh_index, std::vector<Chart>& charts, std::vector<uint32_t>& face_chart);

 private:
  void build_faces();
  void build_adjacency();
  bool evaluate(uint32_t a, uint32_t b, double shared, double* cost, bool* free) const;
  bool twins_apart(uint32_t a, uint32_t b) const;
  void push_candidate(uint32_t a, uint32_t b, double shared);
  bool valid(const Candidate& c) const {
    return charts_[c.a].alive && charts_[c.b].alive && charts_[c.a].version == c.va &&
           charts_[c.b].version == c.vb;
  }
  void merge(uint32_t a, uint32_t b);
  uint32_t extreme(uint32_t chart, int k) const {
    const ChartState& c = charts_[chart];
    return c.extremes == kNone ? c.head : pool_[size_t(c.extremes) * kDirs + k];
  }

  const Scene& scene_;
  const Mesh& mesh_;
  const ChartOptions& options_;
  double diag2_ = 1;
  std::vector<Face> faces_;
  std::vector<FlatClass> colors_;  // flat colour per class id (index 0 unused: textured)
  std::vector<std::vector<uint32_t>> twin_groups_;
  std::vector<ChartState> charts_;  // one per face at the start; chart i starts as face i
  std::vector<uint32_t> next_;      // per face: next face of its chart
  std::vector<uint32_t> chart_of_;  // per face: its chart
  std::vector<uint32_t> pool_;      // extremes of multi-face charts, kDirs per slot
  std::vector<uint32_t> free_slots_;
  std::vector<uint32_t> slot_;  // scratch for merge(): kNone except during a merge
  std::priority_queue<Candidate, std::vector<Candidate>, MinOrder> min_heap_;
  std::priority_queue<Candidate, std::vector<Candidate>, MaxOrder> max_heap_;
  bool stopped_ = false;  // formula 1 reached: only free merges from here on
};

void Segmenter::build_faces() {
  Bounds b = mesh_bounds(mesh_);
  double diag = b.diagonal();
  diag2_ = diag > 0 && std::isfinite(diag) ? diag * diag : 1.0;
  Vector3d origin = b.empty() ? Vector3d::Zero() : to_d(b.center());

  std::unordered_map<PositionKey, uint32_t, PositionKeyHash> pos_ids;
  colors_.assign(1, FlatClass{{1, 1, 1, 1}, {1, 1, 1}, {0, 0, 0}, {0, 0, 0}});
  auto color_class = [&](const FlatClass& c) -> uint32_t {
    // Exact identity: colour and factors equal.
    for (uint32_t i = 1; i < colors_.size(); ++i)
      if (colors_[i] == c) return i;
    colors_.push_back(c);
    return uint32_t(colors_.size() - 1);
  };

  for (const Primitive& p : mesh_.primitives) {
    // Textured or one flat colour, decided per primitive (charts.h).
    FlatClass flat;
    const uint32_t cls = primitive_textured(scene_, p, &flat) ? 0 : color_class(flat);

    for (size_t t = 0; t < p.triangle_count(); ++t) {
      Face f;
      Vector3d v[3];
      for (int k = 0; k < 3; ++k) {
        Vec3 q = p.positions[p.indices[3 * t + k]];
        PositionKey key(Vec3{q.x, q.y, q.z});
        auto it = pos_ids.emplace(key, uint32_t(pos_ids.size())).first;
        f.pos[k] = it->second;
        v[k] = to_d(q) - origin;
      }
      Vector3d n = (v[1] - v[0]).cross(v[2] - v[0]);
      double len = n.norm();
      f.area = 0.5 * len;
      f.normal = len > 0 ? Vector3d(n / len) : Vector3d::Zero();
      f.perimeter = (v[1] - v[0]).norm() + (v[2] - v[1]).norm() + (v[0] - v[2]).norm();
      f.cls = cls;
      faces_.push_back(f);
      // The face's chart: area, centroid, ∫ (x − centroid)(x − centroid)ᵀ dA.
      ChartState c;
      c.area = f.area;
      c.perimeter = f.perimeter;
      c.centroid = (v[0] + v[1] + v[2]) / 3.0;
      for (int k = 0; k < 3; ++k) {
        Vector3d d = v[k] - c.centroid;
        c.moment += d * d.transpose();
      }
      c.moment *= f.area / 12.0;
      c.normal_sum = f.normal * f.area;
      c.cls = cls;
      charts_.push_back(std::move(c));
    }
  }

  // Twins and duplicates: faces over the same three positions.
  struct Tri {
    uint32_t a, b, c, face;
  };
  std::vector<Tri> tris(faces_.size());
  for (uint32_t i = 0; i < faces_.size(); ++i) {
    uint32_t s[3] = {faces_[i].pos[0], faces_[i].pos[1], faces_[i].pos[2]};
    std::sort(s, s + 3);
    tris[i] = {s[0], s[1], s[2], i};
  }
  std::sort(tris.begin(), tris.end(), [](const Tri& x, const Tri& y) {
    return std::tie(x.a, x.b, x.c, x.face) < std::tie(y.a, y.b, y.c, y.face);
  });
  for (size_t i = 0; i < tris.size();) {
    size_t j = i + 1;
    while (j < tris.size() && tris[j].a == tris[i].a && tris[j].b == tris[i].b &&
           tris[j].c == tris[i].c)
      ++j;
    if (j - i > 1) {
      std::vector<uint32_t> group;
      for (size_t k = i; k < j; ++k) {
        group.push_back(tris[k].face);
        faces_[tris[k].face].twin_group = uint32_t(twin_groups_.size());
      }
      twin_groups_.push_back(std::move(group));
    }
    i = j;
  }

  size_t n = faces_.size();
  next_.assign(n, kNone);
  slot_.assign(n, kNone);
  chart_of_.resize(n);
  for (uint32_t i = 0; i < n; ++i) {
    const Face& f = faces_[i];
    ChartState& c = charts_[i];
    c.head = c.tail = i;
    chart_of_[i] = i;
    if (f.twin_group != kNone) {
      c.has_twins = true;
      c.twin_faces.push_back(i);
    }
  }
}

void Segmenter::build_adjacency() {
  struct EdgeFace {
    uint64_t key;
    uint32_t face;
    double length;
  };
  std::vector<EdgeFace> edges;
  edges.reserve(faces_.size() * 3);
  const Mesh& m = mesh_;
  uint32_t fi = 0;
  for (const Primitive& p : m.primitives) {
    for (size_t t = 0; t < p.triangle_count(); ++t, ++fi) {
      const Face& f = faces_[fi];
      for (int k = 0; k < 3; ++k) {
        uint32_t a = f.pos[k], b = f.pos[(k + 1) % 3];
        if (a == b) continue;
        uint64_t key = (uint64_t(std::min(a, b)) << 32) | std::max(a, b);
        Vec3 pa = p.positions[p.indices[3 * t + k]],
             pb = p.positions[p.indices[3 * t + (k + 1) % 3]];
        edges.push_back({key, fi, double(length(pa - pb))});
      }
    }
  }
  std::sort(edges.begin(), edges.end(), [](const EdgeFace& x, const EdgeFace& y) {
    return x.key != y.key ? x.key < y.key : x.face < y.face;
  });
  // Face pairs sharing an edge (all pairs on a non-manifold edge, up to a small fan).
  constexpr size_t kMaxFan = 16;
  for (size_t i = 0; i < edges.size();) {
    size_t j = i + 1;
    while (j < edges.size() && edges[j].key == edges[i].key) ++j;
    size_t end = std::min(j, i + kMaxFan);
    for (size_t x = i; x < end; ++x)
      for (size_t y = x + 1; y < end; ++y) {
        uint32_t a = edges[x].face, b = edges[y].face;
        if (a == b) continue;
        double len = edges[x].length;
        auto add = [&](uint32_t from, uint32_t to) {
          for (Neighbor& nb : charts_[from].neighbors)
            if (nb.chart == to) {
              nb.shared += len;
              return;
            }
          charts_[from].neighbors.push_back({to, len});
        };
        add(a, b);
        add(b, a);
      }
    i = j;
  }
}

bool Segmenter::twins_apart(uint32_t a, uint32_t b) const {
  const ChartState& ca = charts_[a];
  const ChartState& cb = charts_[b];
  if (!ca.has_twins || !cb.has_twins) return true;
  const ChartState& small = ca.twin_faces.size() <= cb.twin_faces.size() ? ca : cb;
  uint32_t other = &small == &ca ? b : a;
  for (uint32_t f : small.twin_faces)
    for (uint32_t g : twin_groups_[faces_[f].twin_group])
      if (g != f && chart_of_[g] == other) return false;
  return true;
}

bool Segmenter::evaluate(uint32_t a, uint32_t b, double shared, double* cost, bool* free) const {
  const ChartState& ca = charts_[a];
  const ChartState& cb = charts_[b];
  if (ca.cls != cb.cls) return false;
  if (uint64_t(ca.faces) + cb.faces > options_.max_faces) return false;
  if (!twins_apart(a, b)) return false;
  Merged m = merge_moments(ca.area, ca.centroid, ca.moment, cb.area, cb.centroid, cb.moment);
  if (!(m.area > 0)) return false;

  Eigen::SelfAdjointEigenSolver<Matrix3d> es;
  es.computeDirect(m.moment);
  double lambda = std::max(0.0, es.eigenvalues()(0));
  Vector3d n = es.eigenvectors().col(0);
  Vector3d ns = ca.normal_sum + cb.normal_sum;
  if (n.dot(ns) < 0) n = -n;
  // Normal guard over the extreme faces of both charts.
  for (int k = 0; k < kDirs; ++k) {
    if (faces_[extreme(a, k)].normal.dot(n) < kMinNormalDot) return false;
    if (faces_[extreme(b, k)].normal.dot(n) < kMinNormalDot) return false;
  }
  double planarity = lambda / m.area / diag2_;
  double perimeter = std::max(0.0, ca.perimeter + cb.perimeter - 2 * shared);
  double compactness = std::max(0.0, perimeter * perimeter / (4 * M_PI * m.area) - 1);
  double c = planarity + double(options_.compactness_weight) * compactness;
  if (!std::isfinite(c)) return false;
  *cost = c;
  *free = planarity < kFreePlanarity && compactness < kFreeCompactness;
  return true;
}

void Segmenter::push_candidate(uint32_t a, uint32_t b, double shared) {
  if (a > b) std::swap(a, b);
  double cost;
  bool free;
  if (!evaluate(a, b, shared, &cost, &free)) return;
  if (stopped_ && !free) return;  // formula 1 has spoken: only free merges remain
  Candidate c{cost, free, a, b, charts_[a].version, charts_[b].version};
  min_heap_.push(c);
  if (!stopped_) max_heap_.push(c);
}

void Segmenter::merge(uint32_t a, uint32_t b) {
  // The larger chart survives (ties: the lower index), so relabelling is small-to-large.
  uint32_t s = a, o = b;
  if (charts_[b].faces > charts_[a].faces || (charts_[b].faces == charts_[a].faces && b < a))
    std::swap(s, o);
  ChartState& cs = charts_[s];
  ChartState& co = charts_[o];

  double shared = 0;
  for (const Neighbor& nb : cs.neighbors)
    if (nb.chart == o) shared = nb.shared;

  Merged m = merge_moments(cs.area, cs.centroid, cs.moment, co.area, co.centroid, co.moment);
  cs.area = m.area;
  cs.centroid = m.centroid;
  cs.moment = m.moment;
  cs.normal_sum += co.normal_sum;
  cs.perimeter = std::max(0.0, cs.perimeter + co.perimeter - 2 * shared);

  // Extremes: per direction, the better of the two.
  if (cs.extremes == kNone) {
    uint32_t slot;
    if (!free_slots_.empty()) {
      slot = free_slots_.back();
      free_slots_.pop_back();
    } else {
      slot = uint32_t(pool_.size() / kDirs);
      pool_.resize(pool_.size() + kDirs);
    }
    for (int k = 0; k < kDirs; ++k) pool_[size_t(slot) * kDirs + k] = cs.head;
    cs.extremes = slot;
  }
  const auto& dirs = directions();
  for (int k = 0; k < kDirs; ++k) {
    uint32_t& e = pool_[size_t(cs.extremes) * kDirs + k];
    uint32_t f = extreme(o, k);
    double df = faces_[f].normal.dot(dirs[k]), de = faces_[e].normal.dot(dirs[k]);
    if (df > de || (df == de && f < e)) e = f;
  }
  if (co.extremes != kNone) {
    free_slots_.push_back(co.extremes);
    co.extremes = kNone;
  }

  // Faces: relabel the absorbed chart's faces and splice its list onto the survivor's.
  for (uint32_t f = co.head; f != kNone; f = next_[f]) chart_of_[f] = s;
  next_[cs.tail] = co.head;
  cs.tail = co.tail;
  cs.faces += co.faces;
  if (co.has_twins) {
    cs.has_twins = true;
    cs.twin_faces.insert(cs.twin_faces.end(), co.twin_faces.begin(), co.twin_faces.end());
    std::vector<uint32_t>().swap(co.twin_faces);
  }

  // Neighbours: the union, shared lengths summed; every neighbour of o now sees s.
  // O(deg s + deg o) with a scratch index per chart (slot_): where a chart sits in `merged`.
  std::vector<Neighbor> merged;
  merged.reserve(cs.neighbors.size() + co.neighbors.size());
  for (const Neighbor& nb : cs.neighbors)
    if (nb.chart != o) {
      slot_[nb.chart] = uint32_t(merged.size());
      merged.push_back(nb);
    }
  for (const Neighbor& nb : co.neighbors) {
    if (nb.chart == s) continue;
    if (slot_[nb.chart] != kNone) {
      merged[slot_[nb.chart]].shared += nb.shared;
    } else {
      slot_[nb.chart] = uint32_t(merged.size());
      merged.push_back(nb);
    }
    // Rewrite the neighbour's own list.
    std::vector<Neighbor>& list = charts_[nb.chart].neighbors;
    size_t io = list.size(), is = list.size();
    for (size_t i = 0; i < list.size(); ++i) {
      if (list[i].chart == o) io = i;
      if (list[i].chart == s) is = i;
    }
    if (io < list.size()) {
      if (is < list.size()) {
        list[is].shared += list[io].shared;
        list.erase(list.begin() + std::ptrdiff_t(io));
      } else {
        list[io].chart = s;
      }
    }
  }
  for (const Neighbor& nb : merged) slot_[nb.chart] = kNone;
  cs.neighbors = std::move(merged);
  std::vector<Neighbor>().swap(co.neighbors);
  co.alive = false;
  ++cs.version;
  ++co.version;

  for (const Neighbor& nb : cs.neighbors) push_candidate(s, nb.chart, nb.shared);
}

void Segmenter::run(uint32_t mesh_index, std::vector<Chart>& charts,
                    std::vector<uint32_t>& face_chart) {
  build_faces();
  build_adjacency();
  for (uint32_t a = 0; a < charts_.size(); ++a)
    for (const Neighbor& nb : charts_[a].neighbors)
      if (a < nb.chart) push_candidate(a, nb.chart, nb.shared);

  // Cheapest first until formula 1 says stop; after that only free merges go on.
  double ratio_limit = double(options_.stop_ratio);
  while (!min_heap_.empty()) {
    Candidate c = min_heap_.top();
    min_heap_.pop();
    if (!valid(c)) continue;
    if (!stopped_) {
      // E_max: the dearest valid merge still queued (c included).
      while (!max_heap_.empty() && !valid(max_heap_.top())) max_heap_.pop();
      double e_max = max_heap_.empty() ? c.cost : std::max(c.cost, max_heap_.top().cost);
      double ratio = e_max > 0 ? std::log1p(c.cost) / std::log1p(e_max) : 0.0;
      if (ratio >= ratio_limit) {
        stopped_ = true;
        std::priority_queue<Candidate, std::vector<Candidate>, MaxOrder>().swap(max_heap_);
      }
    }
    if (stopped_ && !c.free) continue;
    merge(c.a, c.b);
  }

  // Output: charts ordered by their first (smallest) face.
  face_chart.assign(faces_.size(), 0);
  std::vector<uint32_t> local(charts_.size(), kNone);
  for (uint32_t f = 0; f < faces_.size(); ++f) {
    uint32_t c = chart_of_[f];
    if (local[c] == kNone) {
      local[c] = uint32_t(charts.size());
      Chart out;
      out.mesh = mesh_index;
      out.textured = charts_[c].cls == 0;
      if (!out.textured) {
        out.color = colors_[charts_[c].cls].color;
        out.orm = colors_[charts_[c].cls].orm;
        out.emissive = colors_[charts_[c].cls].emissive;
        out.sheen = colors_[charts_[c].cls].sheen;
      }
      charts.push_back(std::move(out));
    }
    charts[local[c]].faces.push_back(f);  // ascending: f runs in order
    face_chart[f] = local[c];
  }
}

}  // namespace

ChartSet segment_charts(const Scene& scene, const ChartOptions& options) {
  ChartSet out;
  out.face_chart.resize(scene.meshes.size());
  for (uint32_t m = 0; m < scene.meshes.size(); ++m) {
    // A mesh whose every primitive is one flat colour needs no segmentation: its faces go to
    // palette blocks by colour whatever their charts (a CAD assembly in 7 colours
    // took seconds to chart). One chart per colour, ordered by first face, as segmentation
    // orders its charts.
    const Mesh& mesh = scene.meshes[m];
    std::vector<FlatClass> classes(mesh.primitives.size());
    bool any_textured = false;
    for (size_t i = 0; i < mesh.primitives.size() && !any_textured; ++i)
      any_textured = primitive_textured(scene, mesh.primitives[i], &classes[i]);
    if (any_textured) {
      Segmenter seg(scene, m, options);
      seg.run(m, out.charts, out.face_chart[m]);
      continue;
    }
    std::vector<size_t> chart_of_class;  // per distinct colour: its chart in out.charts
    std::vector<FlatClass> distinct;
    uint32_t face = 0;
    for (size_t i = 0; i < mesh.primitives.size(); ++i) {
      size_t k = std::find(distinct.begin(), distinct.end(), classes[i]) - distinct.begin();
      const size_t triangles = mesh.primitives[i].triangle_count();
      if (triangles == 0) continue;
      if (k == distinct.size()) {
        distinct.push_back(classes[i]);
        chart_of_class.push_back(out.charts.size());
        Chart c;
        c.mesh = m;
        c.textured = false;
        c.color = classes[i].color, c.orm = classes[i].orm;
        c.emissive = classes[i].emissive, c.sheen = classes[i].sheen;
        out.charts.push_back(std::move(c));
      }
      Chart& c = out.charts[chart_of_class[k]];
      for (size_t t = 0; t < triangles; ++t, ++face) {
        c.faces.push_back(face);
        out.face_chart[m].push_back(uint32_t(chart_of_class[k]));
      }
    }
    // Faces ascending per chart: primitives run in order, so they already are.
  }
  return out;
}

}  // namespace meshmux
