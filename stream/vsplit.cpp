// Compact vertex splits (stream/vsplit.h): the state both ends of the stream keep and the decoder.
// docs/ARCHITECTURE.md "Package"; Hoppe, "Octaviewer: spherically parameterized progressive meshes"
// (vertex order, parents); the ring-relative connectivity and barycentric prediction follow
// compressed progressive meshes (Pajarola & Rossignac 2000) and valence-driven progressive coding
// (Alliez & Desbrun 2001), adapted to corner lists.
#include "stream/vsplit.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "stream/quantize.h"

namespace meshmux {

void VsplitMesh::reset(uint32_t capacity_vertices, uint32_t capacity_faces) {
  contexts = VsplitContexts();
  vertices.clear(), indices.clear(), head.clear(), next.clear();
  forget_seen();
  twin_slots_.assign(16, 0), twin_count_ = 0, twin_previous_.clear();
  holes_.clear();
  solid = 0, moved_floor = 0;
  moved.clear();
  capacity_vertices_ = capacity_vertices, capacity_faces_ = capacity_faces;
}

void VsplitMesh::reserve_capacities(size_t twin_positions) {
  vertices.reserve(capacity_vertices_), head.reserve(capacity_vertices_);
  twin_previous_.reserve(capacity_vertices_);
  indices.reserve(size_t(capacity_faces_) * 3), next.reserve(size_t(capacity_faces_) * 3);
  // Sized once for every position a split comes from: the table never grows (a rehash holds both
  // tables).
  size_t slots = 16;
  while (3 * slots < 4 * std::min<size_t>(twin_positions, capacity_vertices_)) slots *= 2;
  if (slots > twin_slots_.size()) twin_table_resize(slots);
}

uint32_t VsplitMesh::add_vertex(const QuantizedVertex& q) {
  vertices.push_back(q);
  head.push_back(-1);
  twin_previous_.push_back(-1);
  return uint32_t(vertices.size() - 1);
}

void VsplitMesh::add_vertex_at(uint32_t index, const QuantizedVertex& q) {
  if (index >= vertices.size()) {
    if (holes_.empty()) holes_.assign(vertices.size(), 0);
    vertices.resize(size_t(index) + 1), head.resize(size_t(index) + 1, -1);
    twin_previous_.resize(size_t(index) + 1, -1), holes_.resize(size_t(index) + 1, 1);
  }
  vertices[index] = q, head[index] = -1, twin_previous_[index] = -1;
  if (!holes_.empty()) holes_[index] = 0;
}

void VsplitMesh::add_face(uint32_t a, uint32_t b, uint32_t c) {
  for (uint32_t v : {a, b, c}) {
    int32_t corner = int32_t(indices.size());
    indices.push_back(v);
    next.push_back(head[v]);
    head[v] = corner;
  }
  if (a != b && b != c && a != c) ++solid;
}

void VsplitMesh::move_corner(uint32_t p, int32_t previous, int32_t corner, uint32_t v) {
  if (previous < 0)
    head[p] = next[size_t(corner)];
  else
    next[size_t(previous)] = next[size_t(corner)];
  size_t f = size_t(corner) / 3 * 3;
  bool before = indices[f] != indices[f + 1] && indices[f + 1] != indices[f + 2] &&
                indices[f] != indices[f + 2];
  indices[size_t(corner)] = v;
  if (uint32_t(corner) < moved_floor) moved.push_back(uint32_t(corner));
  next[size_t(corner)] = head[v];
  head[v] = corner;
  bool after = indices[f] != indices[f + 1] && indices[f + 1] != indices[f + 2] &&
               indices[f] != indices[f + 2];
  solid += uint64_t(after) - uint64_t(before);
}

bool VsplitMesh::first_sight(uint32_t w) {
  if (seen_hashed_) return hash_sight(w);
  for (uint32_t x : seen_list_)
    if (x == w) return false;
  seen_list_.push_back(w);
  if (seen_list_.size() > kSeenListed) {
    seen_hashed_ = true;
    for (uint32_t x : seen_list_) hash_sight(x);
  }
  return true;
}

bool VsplitMesh::hash_sight(uint32_t w) {
  if (2 * (seen_used_.size() + 1) > seen_slots_.size()) {  // grow: rehash what was seen
    std::vector<uint32_t> seen;
    for (uint32_t slot : seen_used_) seen.push_back(seen_slots_[slot]);
    seen_slots_.assign(2 * seen_slots_.size(), UINT32_MAX);
    seen_used_.clear();
    for (uint32_t x : seen) hash_sight(x);
  }
  const size_t mask = seen_slots_.size() - 1;
  size_t i = size_t(uint32_t(w * 0x9E3779B1u) >> 7) & mask;
  for (; seen_slots_[i] != UINT32_MAX; i = (i + 1) & mask)
    if (seen_slots_[i] == w) return false;
  seen_slots_[i] = w;
  seen_used_.push_back(uint32_t(i));
  return true;
}

void VsplitMesh::forget_seen() {
  seen_list_.clear();
  if (!seen_hashed_) return;
  for (uint32_t slot : seen_used_) seen_slots_[slot] = UINT32_MAX;
  seen_used_.clear();
  seen_hashed_ = false;
}

void VsplitMesh::ring(uint32_t p, uint32_t v, uint32_t limit, std::vector<uint32_t>& out) {
  out.clear();
  forget_seen();
  first_sight(p), first_sight(v);
  for (uint32_t centre : {v, p})
    for (int32_t c = head[centre]; c >= 0; c = next[size_t(c)]) {
      size_t f = size_t(c) / 3 * 3, slot = size_t(c) - f;
      for (size_t k = 1; k <= 2; ++k) {
        uint32_t w = indices[f + (slot + k) % 3];
        if (!first_sight(w)) continue;
        out.push_back(w);
        if (out.size() >= limit) return;
      }
    }
}

namespace {
// round(sum / n) with halves up, for any sign: floor((2·sum + n) / (2n)).
int64_t mean(int64_t sum, int64_t n) {
  int64_t a = 2 * sum + n, b = 2 * n;
  int64_t q = a / b;
  if ((a % b != 0) && (a < 0)) --q;
  return q;
}
}  // namespace

QuantizedVertex VsplitMesh::predict(uint32_t v, uint32_t p, uint32_t* extent_class) {
  int64_t sp[3] = {0, 0, 0}, sn[3] = {0, 0, 0}, st[2] = {0, 0};
  uint32_t lo[3] = {65535, 65535, 65535}, hi[3] = {0, 0, 0};
  int64_t n = 0;
  forget_seen();
  first_sight(v);
  for (int32_t c = head[v]; c >= 0; c = next[size_t(c)]) {
    size_t f = size_t(c) / 3 * 3, slot = size_t(c) - f;
    for (size_t k = 1; k <= 2; ++k) {
      uint32_t w = indices[f + (slot + k) % 3];
      if (!first_sight(w)) continue;
      const QuantizedVertex& q = vertices[w];
      for (int i = 0; i < 3; ++i) {
        sp[i] += q.p[i], sn[i] += q.n[i];
        lo[i] = std::min<uint32_t>(lo[i], q.p[i]), hi[i] = std::max<uint32_t>(hi[i], q.p[i]);
      }
      st[0] += q.t[0], st[1] += q.t[1];
      ++n;
    }
  }
  *extent_class = 0;
  if (n == 0) return vertices[p];
  uint32_t extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  *extent_class = uint32_t(std::min(bit_length(extent), kExtentClasses - 1));
  QuantizedVertex out;
  for (int i = 0; i < 3; ++i)
    out.p[i] = uint16_t(mean(sp[i], n)), out.n[i] = int8_t(mean(sn[i], n));
  out.t[0] = uint16_t(mean(st[0], n)), out.t[1] = uint16_t(mean(st[1], n));
  return out;
}

bool VsplitMesh::fan(uint32_t p, uint32_t start, uint32_t count, std::vector<uint8_t>& moved,
                     uint32_t& vl, uint32_t& vr) const {
  uint32_t n1[kFanLimit], n2[kFanLimit], d = 0;
  for (int32_t c = head[p]; c >= 0; c = next[size_t(c)]) {
    if (d == kFanLimit) return false;
    size_t f = size_t(c) / 3 * 3, slot = size_t(c) - f;
    n1[d] = indices[f + (slot + 1) % 3], n2[d] = indices[f + (slot + 2) % 3];
    if (n1[d] == p || n2[d] == p || n1[d] == n2[d]) return false;
    for (uint32_t j = 0; j < d; ++j)
      if (n1[j] == n1[d]) return false;
    ++d;
  }
  if (start >= d || count == 0 || count > d) return false;
  moved.assign(d, 0);
  uint32_t at = start;
  for (uint32_t k = 0;; ++k) {
    if (moved[at]) return false;
    moved[at] = 1;
    if (k + 1 == count) break;
    uint32_t j = 0;
    while (j < d && n1[j] != n2[at]) ++j;
    if (j == d) return false;
    at = j;
  }
  vl = n1[start], vr = n2[at];
  return vl != vr;
}

bool VsplitMesh::predict_uv(uint32_t v, uint32_t p, const uint16_t position[3],
                            uint16_t uv[2]) const {
  // w: the third vertex of v's newest face with p.
  int64_t w = -1;
  for (int32_t c = head[v]; c >= 0 && w < 0; c = next[size_t(c)]) {
    size_t f = size_t(c) / 3 * 3;
    uint32_t a = indices[f], b = indices[f + 1], d = indices[f + 2];
    if (a == p || b == p || d == p) w = int64_t(a != v && a != p ? a : b != v && b != p ? b : d);
  }
  if (w < 0 || uint32_t(w) == v || uint32_t(w) == p) return false;
  // x: the third vertex of p's first face with w but without v (across the edge p-w).
  int64_t x = -1;
  for (int32_t c = head[p]; c >= 0 && x < 0; c = next[size_t(c)]) {
    size_t f = size_t(c) / 3 * 3;
    uint32_t a = indices[f], b = indices[f + 1], d = indices[f + 2];
    if (a == v || b == v || d == v || (a != w && b != w && d != w)) continue;
    x = int64_t(a != uint32_t(w) && a != p ? a : b != uint32_t(w) && b != p ? b : d);
  }
  if (x < 0 || uint32_t(x) == p || uint32_t(x) == uint32_t(w)) return false;
  // v's place along and off the edge p→w in 3D, carried to uv space on the side away from x.
  // Plain double operations in a fixed order, as the web client does them.
  const QuantizedVertex &P = vertices[p], &W = vertices[size_t(w)], &X = vertices[size_t(x)];
  double ex = double(W.p[0]) - double(P.p[0]), ey = double(W.p[1]) - double(P.p[1]),
         ez = double(W.p[2]) - double(P.p[2]);
  double dx = double(position[0]) - double(P.p[0]), dy = double(position[1]) - double(P.p[1]),
         dz = double(position[2]) - double(P.p[2]);
  double ee = ex * ex + ey * ey + ez * ez;
  if (!(ee > 0)) return false;
  double s = (dx * ex + dy * ey + dz * ez) / ee;
  double rx = dx - s * ex, ry = dy - s * ey, rz = dz - s * ez;
  double t = std::sqrt((rx * rx + ry * ry + rz * rz) / ee);
  double ux = double(W.t[0]) - double(P.t[0]), uy = double(W.t[1]) - double(P.t[1]);
  double side = ux * (double(X.t[1]) - double(P.t[1])) - uy * (double(X.t[0]) - double(P.t[0]));
  double k = side > 0 ? -t : t;  // along the left normal (-uy, ux), away from x
  double u0 = double(P.t[0]) + s * ux - k * uy, u1 = double(P.t[1]) + s * uy + k * ux;
  auto round_uv = [](double a) {
    double r = std::floor(a + 0.5);
    return uint16_t(r < 0 ? 0 : r > kUvMax ? kUvMax : r);
  };
  uv[0] = round_uv(u0), uv[1] = round_uv(u1);
  return true;
}

void VsplitMesh::fan_normal(uint32_t v, const uint16_t centre[3], int64_t normal[3]) const {
  int64_t n[3] = {0, 0, 0};
  for (int32_t c = head[v]; c >= 0; c = next[size_t(c)]) {
    size_t f = size_t(c) / 3 * 3, slot = size_t(c) - f;
    const QuantizedVertex& b = vertices[indices[f + (slot + 1) % 3]];
    const QuantizedVertex& d = vertices[indices[f + (slot + 2) % 3]];
    int64_t b0 = int64_t(b.p[0]) - centre[0], b1 = int64_t(b.p[1]) - centre[1],
            b2 = int64_t(b.p[2]) - centre[2];
    int64_t d0 = int64_t(d.p[0]) - centre[0], d1 = int64_t(d.p[1]) - centre[1],
            d2 = int64_t(d.p[2]) - centre[2];
    n[0] += b1 * d2 - b2 * d1, n[1] += b2 * d0 - b0 * d2, n[2] += b0 * d1 - b1 * d0;
  }
  auto half = [](int64_t x) { return x >= 0 ? x / 2 : -((-x + 1) / 2); };  // floor(x / 2)
  const int64_t limit = int64_t(1) << 31;
  while (std::abs(n[0]) >= limit || std::abs(n[1]) >= limit || std::abs(n[2]) >= limit)
    for (int64_t& x : n) x = half(x);
  for (int i = 0; i < 3; ++i) normal[i] = n[i];
}

bool plane_axes(const int64_t normal[3], int order[3]) {
  int a = 0;
  for (int i = 1; i < 3; ++i)
    if (std::abs(normal[i]) > std::abs(normal[a])) a = i;
  if (normal[a] == 0) {
    order[0] = 0, order[1] = 1, order[2] = 2;
    return false;
  }
  order[0] = a == 0 ? 1 : 0, order[1] = a == 2 ? 1 : 2, order[2] = a;
  return true;
}

int64_t plane_predict(const int64_t normal[3], const int order[3], const uint16_t mean[3],
                      int64_t xb, int64_t xc) {
  const int b = order[0], c = order[1], a = order[2];
  int64_t num = -(normal[b] * (xb - mean[b]) + normal[c] * (xc - mean[c]));
  int64_t den = normal[a];
  if (den < 0) num = -num, den = -den;
  // floor((2·num + den) / (2·den)): round(num / den), halves up.
  int64_t top = 2 * num + den, bottom = 2 * den;
  int64_t q = top / bottom;
  if (top % bottom != 0 && top < 0) --q;
  return int64_t(mean[a]) + q;
}

namespace {
uint64_t position_key(const QuantizedVertex& q) {
  return uint64_t(q.p[0]) << 32 | uint64_t(q.p[1]) << 16 | uint64_t(q.p[2]);
}
}  // namespace

size_t VsplitMesh::twin_slot(const QuantizedVertex& at) const {
  const size_t mask = twin_slots_.size() - 1;
  size_t i = size_t((position_key(at) * 0x9E3779B97F4A7C15ull) >> 32) & mask;
  for (; twin_slots_[i] != 0; i = (i + 1) & mask) {
    const QuantizedVertex& rep = vertices[size_t(twin_slots_[i] >> 32) - 1];
    if (rep.p[0] == at.p[0] && rep.p[1] == at.p[1] && rep.p[2] == at.p[2]) break;
  }
  return i;
}

void VsplitMesh::twin_table_resize(size_t slots) {
  std::vector<uint64_t> old(slots, 0);
  old.swap(twin_slots_);
  const size_t mask = slots - 1;
  for (uint64_t s : old) {
    if (s == 0) continue;
    size_t i =
        size_t((position_key(vertices[size_t(s >> 32) - 1]) * 0x9E3779B97F4A7C15ull) >> 32) & mask;
    while (twin_slots_[i] != 0) i = (i + 1) & mask;  // keys in `old` are distinct
    twin_slots_[i] = s;
  }
}

uint32_t VsplitMesh::twins(uint32_t p, uint32_t* out) const {
  const uint64_t s = twin_slots_[twin_slot(vertices[p])];
  uint32_t n = 0;
  for (int32_t u = s == 0 ? -1 : int32_t(uint32_t(s)); u >= 0 && n < kTwinLimit;
       u = twin_previous_[size_t(u)])
    out[n++] = uint32_t(u);
  return n;
}

void VsplitMesh::add_twin(uint32_t p, uint32_t v) {
  size_t slot = twin_slot(vertices[p]);
  if (twin_slots_[slot] != 0) {
    twin_previous_[v] = int32_t(uint32_t(twin_slots_[slot]));
    twin_slots_[slot] = (twin_slots_[slot] >> 32) << 32 | v;
    return;
  }
  if (4 * (twin_count_ + 1) > 3 * twin_slots_.size()) {  // at most three quarters full
    twin_table_resize(2 * twin_slots_.size());
    slot = twin_slot(vertices[p]);
  }
  twin_slots_[slot] = (uint64_t(p) + 1) << 32 | v;
  ++twin_count_;
}

uint32_t state_digest(const VsplitMesh& mesh) {
  uint32_t h = 2166136261u;
  auto byte = [&h](uint32_t b) { h = (h ^ (b & 0xffu)) * 16777619u; };
  for (const QuantizedVertex& q : mesh.vertices) {
    for (uint16_t x : q.p) byte(x), byte(x >> 8);
    for (int8_t x : q.n) byte(uint8_t(x));
    for (uint16_t x : q.t) byte(x), byte(x >> 8);
  }
  for (uint32_t i : mesh.indices) byte(i), byte(i >> 8), byte(i >> 16), byte(i >> 24);
  return h;
}

VsplitContexts::VsplitContexts() {
  for (uint16_t& p : mode) p = kProbabilityHalf;
  for (auto& m : mask)
    for (uint16_t& p : m) p = kProbabilityHalf;
}

bool part_size_plausible(uint64_t bytes, uint64_t splits, uint64_t faces) {
  return bytes >= uint64_t(kRangeCoderFlushBytes) &&
         splits + faces <= kPartElementsPerByte * bytes + kPartElementsConstant;
}

Status decode_vsplit(VsplitMesh& mesh, const uint8_t* data, size_t size, uint32_t placed,
                     uint32_t splits, uint32_t faces, const std::vector<uint32_t>* candidates);

Status decode_vsplit_part(VsplitMesh& mesh, const uint8_t* data, size_t size, uint32_t splits,
                          uint32_t faces) {
  return decode_vsplit(mesh, data, size, UINT32_MAX, splits, faces, nullptr);
}

Status block_parent_candidates(const VsplitMesh& mesh, const std::vector<StreamBlock>& blocks,
                               uint32_t base_vertices, uint32_t block, std::vector<uint32_t>& out) {
  return collect_block_candidates(
      blocks, base_vertices, block, [&](uint32_t v) { return mesh.has_vertex(v); },
      [&](uint32_t v) {
        const uint16_t* p = mesh.vertices[v].p;
        return std::array<uint16_t, 3>{p[0], p[1], p[2]};
      },
      out);
}

Status decode_vsplit_block_part(VsplitMesh& mesh, const uint8_t* data, size_t size,
                                const std::vector<StreamBlock>& blocks, uint32_t base_vertices,
                                uint32_t block, uint32_t splits, uint32_t faces) {
  std::vector<uint32_t> candidates;
  if (Status s = block_parent_candidates(mesh, blocks, base_vertices, block, candidates); !s)
    return s;
  const uint32_t vertex_begin = blocks[block].vertex_begin;
  if (vertex_begin == UINT32_MAX)
    return Status::error("block part at vertex 2^32 - 1", ErrorKind::kInput);
  mesh.contexts = VsplitContexts();
  return decode_vsplit(mesh, data, size, vertex_begin, splits, faces, &candidates);
}

// Both decoders: `placed` is the first vertex's stream number (a block part, whose parents are
// indices into `candidates` then its own vertices), or UINT32_MAX (appended: a part in stream
// order, its parents stream numbers).
Status decode_vsplit(VsplitMesh& mesh, const uint8_t* data, size_t size, uint32_t placed,
                     uint32_t splits, uint32_t faces, const std::vector<uint32_t>* candidates) {
  if (!part_size_plausible(size, splits, faces))
    return Status::error(std::to_string(size) + " bytes cannot hold " + std::to_string(splits) +
                             " splits and " + std::to_string(faces) + " faces",
                         ErrorKind::kInput);
  const uint64_t first = placed == UINT32_MAX ? mesh.vertex_count() : placed;
  if (first + splits > mesh.capacity_vertices_ ||
      uint64_t(mesh.face_count()) + faces > mesh.capacity_faces_)
    return Status::error("more vertices or faces than the mesh holds", ErrorKind::kInput);
  if (placed != UINT32_MAX)
    for (uint64_t v = first; v < first + splits; ++v)
      if (mesh.has_vertex(uint32_t(v)))
        return Status::error("vertex " + std::to_string(v) + " is held already", ErrorKind::kInput);
  RangeDecoder in(data, size);
  VsplitContexts& x = mesh.contexts;
  const bool normals = in.get_direct(1) != 0, uvs = in.get_direct(1) != 0;
  std::vector<uint32_t> by_number;  // a block part's candidates in stream numbers
  if (candidates && in.get_direct(1) == 0) {
    by_number = *candidates;
    std::sort(by_number.begin(), by_number.end());
    candidates = &by_number;
  }
  const uint32_t face_goal = mesh.face_count() + faces;
  uint32_t previous = 0, previous_mode = 1;
  std::vector<uint32_t> ring;
  std::vector<uint8_t> moved;
  auto fail = [](uint32_t i, const std::string& what) {
    return Status::error("split " + std::to_string(i) + ": " + what, ErrorKind::kInput);
  };
  for (uint32_t i = 0; i < splits; ++i) {
    if (in.failed()) return fail(i, "the part's bytes end early");
    int64_t parent = int64_t(previous) + unzigzag(in.get_uint(x.parent));
    if (candidates) {  // an index into the block's candidates, then its own vertices
      const int64_t listed = int64_t(candidates->size());
      if (parent < 0 || parent > listed + splits ||
          (parent >= listed + i && parent < listed + splits))
        return fail(i, "parent index " + std::to_string(parent) + " of " +
                           std::to_string(listed + i) + " candidates");
      if (parent < listed + splits) previous = uint32_t(parent);  // an escape leaves it
      parent = parent < listed            ? int64_t((*candidates)[size_t(parent)])
               : parent < listed + splits ? int64_t(first) + (parent - listed)
                                          : int64_t(in.get_uint(x.escape));
    }
    if (parent < 0 || parent >= int64_t(mesh.vertex_count()) || !mesh.has_vertex(uint32_t(parent)))
      return fail(
          i, "parent " + std::to_string(parent) + " of " + std::to_string(mesh.vertex_count()) +
                 " vertices" +
                 (parent >= 0 && parent < int64_t(mesh.vertex_count()) ? ", not held" : ""));
    const uint32_t p = uint32_t(parent);
    if (!candidates) previous = p;
    const bool fan_mode = in.get_bit(x.mode[previous_mode]) != 0;
    previous_mode = fan_mode;
    uint32_t k = 2, vl = 0, vr = 0;
    uint32_t v;
    if (placed == UINT32_MAX) {
      v = mesh.add_vertex(QuantizedVertex{});
    } else {
      v = uint32_t(first) + i;
      mesh.add_vertex_at(v, QuantizedVertex{});
    }
    if (fan_mode) {  // the arguments' contexts by the parent's corner count, at most kFanLimit
      uint32_t dc = 0;
      for (int32_t c = mesh.head[p]; c >= 0 && dc < kFanLimit; c = mesh.next[size_t(c)]) ++dc;
      uint32_t start = in.get_tree(x.fan_start[dc]), count = in.get_tree(x.fan_count[dc]) + 1;
      if (!mesh.fan(p, start, count, moved, vl, vr))
        return fail(i, "parent " + std::to_string(p) + " has no such fan");
    } else {
      k = in.get_uint(x.faces);
    }
    uint32_t position = 0, last = 0;
    for (int32_t c = mesh.head[p], prev = -1; c >= 0; ++position) {
      int32_t after = mesh.next[size_t(c)];
      bool take;
      if (fan_mode) {
        take = moved[position] != 0;
      } else {
        last = in.get_bit(x.mask[std::min(position, 7u)][last]);
        take = last != 0;
      }
      if (take)
        mesh.move_corner(p, prev, c, v);
      else
        prev = c;
      c = after;
    }
    if (in.failed()) return fail(i, "the part's bytes end early");
    if (!fan_mode && k > 0) mesh.ring(p, v, kRingLimit, ring);
    if (uint64_t(mesh.face_count()) + k > face_goal)
      return fail(i, "more than the part's " + std::to_string(faces) + " faces");
    if (fan_mode) {
      mesh.add_face(v, p, vl);
      mesh.add_face(v, vr, p);
      k = 0;
    }
    for (uint32_t f = 0; f < k; ++f) {
      uint32_t code = in.get_uint(x.face), w;
      uint32_t index = code >> 1;
      if (in.failed()) return fail(i, "the part's bytes end early");
      if (index < ring.size()) {
        w = ring[index];
      } else if (index == ring.size()) {
        w = in.get_uint(x.escape);
        if (w >= v || w == p || !mesh.has_vertex(w))
          return fail(i, "face names vertex " + std::to_string(w));
      } else {
        return fail(
            i, "ring position " + std::to_string(index) + " of " + std::to_string(ring.size()));
      }
      if (code & 1)
        mesh.add_face(v, w, p);
      else
        mesh.add_face(v, p, w);
    }
    uint32_t extent_class = 0;
    QuantizedVertex q = mesh.predict(v, p, &extent_class);
    uint32_t twin[kTwinLimit], twins = mesh.twins(p, twin), pick = 0;
    if (twins > 0 && (pick = in.get_tree(x.twin[twins])) > twins)
      return fail(i, "twin index past the candidates");
    if (pick) {
      q.p[0] = mesh.vertices[twin[pick - 1]].p[0], q.p[1] = mesh.vertices[twin[pick - 1]].p[1];
      q.p[2] = mesh.vertices[twin[pick - 1]].p[2];
    } else {
      int64_t normal[3];
      int order[3];
      mesh.fan_normal(v, q.p, normal);
      const bool plane = plane_axes(normal, order);
      int64_t got[3];
      for (int role = 0; role < 3; ++role) {
        const int axis = order[role];
        int64_t base = role == 2 && plane ? plane_predict(normal, order, q.p, got[0], got[1])
                                          : int64_t(q.p[axis]);
        got[role] =
            base + unzigzag(in.get_uint(x.position[role][extent_class], kResidualModelledBits));
        if (got[role] < 0 || got[role] > 65535) return fail(i, "attribute out of range");
      }
      for (int role = 0; role < 3; ++role) q.p[order[role]] = uint16_t(got[role]);
    }
    for (int c = 0; c < 3; ++c) {
      int64_t y = normals
                      ? int64_t(q.n[c]) + unzigzag(in.get_uint(x.normal[c], kResidualModelledBits))
                      : (c == 2 ? 127 : 0);
      if (y < -128 || y > 127) return fail(i, "attribute out of range");
      q.n[c] = int8_t(y);
    }
    const uint32_t uv_predicted = uvs && mesh.predict_uv(v, p, q.p, q.t) ? 1 : 0;
    for (int c = 0; c < 2 && !uvs; ++c) q.t[c] = 0;
    for (int c = 0; c < 2 && uvs; ++c) {
      int64_t t =
          int64_t(q.t[c]) + unzigzag(in.get_uint(x.uv[c][uv_predicted], kResidualModelledBits));
      if (t < 0 || t > 65535) return fail(i, "attribute out of range");
      q.t[c] = uint16_t(t);
    }
    mesh.vertices[v] = q;
    mesh.add_twin(p, v);
  }
  uint32_t extra = in.get_uint(x.extra);
  if (in.failed()) return Status::error("extra face count missing", ErrorKind::kInput);
  if (uint64_t(mesh.face_count()) + extra != face_goal)
    return Status::error(std::to_string(face_goal - mesh.face_count()) + " faces expected, " +
                             std::to_string(extra) + " extra faces follow the splits",
                         ErrorKind::kInput);
  for (uint32_t f = 0; f < extra; ++f) {
    uint32_t a = in.get_uint(x.escape), b = in.get_uint(x.escape), c = in.get_uint(x.escape);
    if (in.failed()) return Status::error("extra faces cut short", ErrorKind::kInput);
    if (!mesh.has_vertex(a) || !mesh.has_vertex(b) || !mesh.has_vertex(c))
      return Status::error("extra face " + std::to_string(f) + " names a vertex not received",
                           ErrorKind::kInput);
    mesh.add_face(a, b, c);
  }
  if (in.failed()) return Status::error("the part's bytes end early", ErrorKind::kInput);
  if (in.consumed() != size)
    return Status::error(std::to_string(size - in.consumed()) + " of the part's bytes left over",
                         ErrorKind::kInput);
  return Status::ok();
}

}  // namespace meshmux
