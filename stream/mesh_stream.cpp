// Mesh stream encoding (stream/mesh_stream.h): compact vertex splits (stream/vsplit.h,
// docs/ARCHITECTURE.md "Package"; Hoppe, "Octaviewer: spherically parameterized progressive meshes"
// for the vertex order and parents). The encoder simulates the client's state (its corner lists,
// the base faces as meshopt's index codec rotates them) and codes each split against it: the parent
// as a delta within a part whose splits are reordered parents-first then by parent (the batch
// ordering of compressed progressive meshes), the corners the new vertex takes as a mask over the
// parent's corners, each new face's third vertex as a ring position, and the new vertex's quantized
// attributes as residuals from its ring's mean (the barycentric predictor of valence-driven
// coding), or, for a seam or hard-edge copy, the twin it coincides with. Everything goes through
// the adaptive range coder (stream/range_coder.h), each field with contexts of its own.
#include "stream/mesh_stream.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <map>
#include <string>

#include "core/release_pages.h"

namespace meshmux {

namespace {

Status internal(uint32_t mesh, const std::string& what) {
  return Status::error("package: mesh " + std::to_string(mesh) + ": " + what, ErrorKind::kInternal);
}

// A block part's parents as indices into its candidates (stream/vsplit.h "Z"): the candidates
// in Morton order (block_parent_candidates) or in stream numbers (`morton` false).
class CandidateIndex {
 public:
  CandidateIndex() = default;
  explicit CandidateIndex(const std::vector<uint32_t>& candidates) : size_(candidates.size()) {
    listed_.reserve(candidates.size());
    for (uint32_t i = 0; i < candidates.size(); ++i) listed_.emplace_back(candidates[i], i);
    std::sort(listed_.begin(), listed_.end());
  }
  bool morton = true;
  uint32_t size() const { return uint32_t(size_); }
  // The index of stream vertex v in the chosen order, or -1 when it is no candidate.
  int64_t find(uint32_t v) const {
    auto at = std::lower_bound(listed_.begin(), listed_.end(), std::make_pair(v, 0u));
    if (at == listed_.end() || at->first != v) return -1;
    return morton ? at->second : int64_t(at - listed_.begin());
  }
  // Sets `morton` to the order in which `parents` (stream numbers, candidates) cost less: their
  // sorted indices' gaps, each ~2 log2(gap + 1) + 1 bits as an adaptive coder of small integers
  // spends.
  void choose(const std::vector<uint32_t>& parents) {
    double bits[2] = {0, 0};
    for (int order = 0; order < 2; ++order) {
      morton = order != 0;
      std::vector<int64_t> keys;
      for (uint32_t p : parents)
        if (int64_t k = find(p); k >= 0) keys.push_back(k);
      std::sort(keys.begin(), keys.end());
      int64_t previous = 0;
      for (int64_t k : keys)
        bits[order] += 2 * std::log2(double(k - previous) + 1) + 1, previous = k;
    }
    morton = bits[1] <= bits[0];
  }

 private:
  size_t size_ = 0;
  std::vector<std::pair<uint32_t, uint32_t>> listed_;  // (stream number, Morton index), by number
};

// The encoder's own checks on a progressive mesh: what the package reader will demand.
Status check_mesh(const ProgressiveMesh& pm, uint32_t m) {
  if (pm.vertex_count() > kMaxStreamElements || pm.face_count() > kMaxStreamElements)
    return internal(m, "more than 2^28 vertices or faces");
  if (pm.parent.size() != pm.vertex_count())
    return internal(m, "parent count differs from the vertex count");
  if (pm.indices.size() % 3) return internal(m, "index count is not a multiple of 3");
  if (pm.levels.empty()) return internal(m, "no levels");
  for (uint32_t i : pm.indices)
    if (i >= pm.vertex_count()) return internal(m, "index " + std::to_string(i) + " out of range");
  for (size_t l = 0; l < pm.levels.size(); ++l)
    if (pm.levels[l].vertex_end > pm.vertex_count() || pm.levels[l].face_end > pm.face_count())
      return internal(m, "level " + std::to_string(l) + " past the mesh's vertices or faces");
  return Status::ok();
}

}  // namespace

MeshStreamEncoder::MeshStreamEncoder(const ProgressiveMesh& pm,
                                     const PositionQuantization& quantization, uint32_t mesh,
                                     size_t base_level, EncodeCounts* counts)
    : pm_(pm),
      quantization_(quantization),
      mesh_(mesh),
      level_(base_level),
      planned_level_(base_level),
      level_at_start_(base_level),
      counts_(counts) {
  if (Status s = check_mesh(pm, mesh); !s) {
    status_ = s;
    return;
  }
  if (base_level >= pm.levels.size()) {
    status_ = internal(mesh, "base level out of range");
    return;
  }
  const uint32_t nv = uint32_t(pm.vertex_count()), nf = uint32_t(pm.face_count());
  for (uint32_t v = 0; v < nv; ++v)
    if (pm.parent[v] > v || (pm.parent[v] == v && v >= pm.levels[0].vertex_end)) {
      status_ = internal(
          mesh, "vertex " + std::to_string(v) + " has parent " + std::to_string(pm.parent[v]));
      return;
    }
  normals_ = stream_carries_normals(pm);
  uvs_ = !pm.uvs.empty();
  block_parts_ = !pm.blocks.empty();
  if (block_parts_ &&
      (pm.level_block.size() + 1 != pm.levels.size() || pm.blocks.size() > 0xFFFF)) {
    status_ = internal(mesh, "the block hierarchy does not fit the record");
    return;
  }
  rank_.resize(nv);
  for (uint32_t v = 0; v < nv; ++v) rank_[v] = v;
  // Ancestry intervals: parents precede children (checked above), so subtree sizes sum from
  // the last vertex down and each vertex takes the next slot of its parent's interval.
  size_.assign(nv, 1);
  enter_.assign(nv, 0);
  for (uint32_t v = nv; v-- > 0;)
    if (pm.parent[v] != v) size_[pm.parent[v]] += size_[v];
  {
    std::vector<uint32_t> next_free(nv, 0);
    uint32_t roots = 0;
    for (uint32_t v = 0; v < nv; ++v) {
      const uint32_t up = pm.parent[v];
      if (up == v) {
        enter_[v] = roots, roots += size_[v];
      } else {
        enter_[v] = next_free[up], next_free[up] += size_[v];
      }
      next_free[v] = enter_[v] + 1;
    }
  }
  const ProgressiveLevel& b = pm.levels[base_level];
  sim_.reset(nv, nf);
  // The encoder reaches them (the whole record is coded); splits come from the positions of the
  // vertices that have children (size_ > 1), or fewer where seams share one.
  size_t parents = 0;
  for (uint32_t v = 0; v < nv; ++v) parents += size_[v] > 1;
  sim_.reserve_capacities(parents);
  order_.reserve(nv);
  face_source_.reserve(nf);
  // The base's faces grouped by source primitive (the base .glb writes one glTF primitive per
  // group, in primitive order, with exactly these indices), each group in vertex-cache order,
  // and its vertices in the order those faces first use them: what meshopt's index and vertex
  // codecs compress best (MeshStreamBase::base_order). Later vertices keep their order per part.
  const size_t nbase = b.face_end;
  auto primitive_of = [&](size_t f) {
    return f < pm.face_primitive.size() ? size_t(pm.face_primitive[f]) : size_t(0);
  };
  size_t nprim = 0;
  for (size_t f = 0; f < nbase; ++f) nprim = std::max(nprim, primitive_of(f) + 1);
  std::vector<std::vector<uint32_t>> group(nprim);  // base faces per primitive
  for (uint32_t f = 0; f < nbase; ++f) group[primitive_of(f)].push_back(f);
  std::vector<uint32_t> cached, face_of;  // all groups' faces in cache order; their base faces
  std::vector<size_t> group_end;
  for (const std::vector<uint32_t>& faces : group) {
    if (faces.empty()) continue;
    const size_t count = faces.size() * 3;
    std::vector<uint32_t> mapped(count), out(count);
    for (size_t k = 0; k < faces.size(); ++k)
      for (size_t c = 0; c < 3; ++c)
        mapped[k * 3 + c] = rep(pm.indices[size_t(faces[k]) * 3 + c], b.vertex_end);
    meshopt_optimizeVertexCache(out.data(), mapped.data(), count, b.vertex_end);
    // The optimizer keeps each face's corners as they were: find each output face's source.
    std::map<std::array<uint32_t, 3>, std::vector<uint32_t>> source;
    for (size_t k = faces.size(); k-- > 0;)
      source[{mapped[k * 3], mapped[k * 3 + 1], mapped[k * 3 + 2]}].push_back(faces[k]);
    for (size_t k = 0; k < faces.size(); ++k) {
      auto& list = source[{out[k * 3], out[k * 3 + 1], out[k * 3 + 2]}];
      if (list.empty()) {
        status_ = internal(mesh, "vertex cache optimization changed a face");
        return;
      }
      face_of.push_back(list.back());
      list.pop_back();
    }
    cached.insert(cached.end(), out.begin(), out.end());
    group_end.push_back(cached.size());
  }
  std::vector<uint32_t> remap(b.vertex_end, ~0u);
  size_t used = cached.empty() ? 0
                               : meshopt_optimizeVertexFetchRemap(remap.data(), cached.data(),
                                                                  cached.size(), b.vertex_end);
  for (uint32_t v = 0; v < b.vertex_end; ++v)
    if (remap[v] == ~0u) remap[v] = uint32_t(used++);
  order_.assign(b.vertex_end, 0);
  for (uint32_t v = 0; v < b.vertex_end; ++v) rank_[v] = remap[v], order_[remap[v]] = v;
  for (uint32_t i = 0; i < b.vertex_end; ++i) sim_.add_vertex(quantize(order_[i]));
  for (uint32_t& i : cached) i = remap[i];
  // Each group as the client decodes it from the .glb (meshopt's index codec, version 1, may
  // rotate a face's corners): the encoder learns the rotation by decoding its own bytes.
  meshopt_encodeIndexVersion(1);
  size_t begin = 0;
  for (size_t end : group_end) {
    const size_t count = end - begin;
    std::vector<uint32_t> faces(cached.begin() + long(begin), cached.begin() + long(end));
    std::vector<uint8_t> bytes(
        meshopt_encodeIndexBufferBound(count, std::max<size_t>(b.vertex_end, 1)));
    size_t size = meshopt_encodeIndexBuffer(bytes.data(), bytes.size(), faces.data(), count);
    std::vector<uint32_t> decoded(count);
    if (size == 0 || meshopt_decodeIndexBuffer(decoded.data(), count, sizeof(uint32_t),
                                               bytes.data(), size) != 0) {
      status_ = internal(mesh, "base faces do not encode and decode");
      return;
    }
    for (size_t f = 0; f < count / 3; ++f) {
      const uint32_t *d = &decoded[f * 3], *e = &faces[f * 3];
      int r = 0;
      while (r < 3 && !(d[0] == e[r] && d[1] == e[(r + 1) % 3] && d[2] == e[(r + 2) % 3])) ++r;
      if (r == 3) {
        status_ = internal(mesh, "index codec changed a face");
        return;
      }
      sim_.add_face(d[0], d[1], d[2]);
      // Slot s of the decoded face holds original corner (s + r) % 3.
      face_source_.push_back(face_of[begin / 3 + f] << 2 | uint32_t(r));
    }
    base_faces_.push_back(std::move(faces));
    begin = end;
  }
}

QuantizedVertex MeshStreamEncoder::quantize(uint32_t pm_vertex) const {
  QuantizedVertex q = quantize_vertex(pm_, quantization_, pm_vertex);
  if (!normals_) q.n[0] = 0, q.n[1] = 0, q.n[2] = 127;
  return q;
}

bool stream_carries_normals(const ProgressiveMesh& pm) {
  if (pm.primitive_flat.empty()) return true;
  for (uint8_t flat : pm.primitive_flat)
    if (!flat) return true;
  return false;
}

uint32_t MeshStreamEncoder::rep(uint32_t v, uint32_t prefix) const {
  while (rank_[v] >= prefix) v = pm_.parent[v];
  return v;
}

Result<EncodedMeshPart> MeshStreamEncoder::next(size_t level) {
  auto plan = prepare(level);
  if (!plan.ok()) return plan.status();
  adopt(*plan);
  return encode(plan.take());
}

Result<MeshStreamEncoder::PartPlan> MeshStreamEncoder::prepare(size_t level) {
  if (!status_) return status_;
  if (level >= pm_.levels.size() || level < planned_level_)
    return internal(mesh_, "level " + std::to_string(level) + " out of order");
  const ProgressiveLevel &from = pm_.levels[planned_level_], &to = pm_.levels[level];
  if (to.vertex_end < from.vertex_end || to.face_end < from.face_end)
    return internal(mesh_, "levels shrink");
  const uint32_t va = from.vertex_end, vb = to.vertex_end, fa = from.face_end, fb = to.face_end;
  if (block_parts_)
    for (size_t r = planned_level_ + 1; r < level; ++r)
      if (pm_.level_block[r - 1] != pm_.level_block[level - 1])
        return internal(mesh_, "a part from level " + std::to_string(planned_level_) + " to " +
                                   std::to_string(level) + " spans blocks " +
                                   std::to_string(pm_.level_block[r - 1]) + " and " +
                                   std::to_string(pm_.level_block[level - 1]));
  PartPlan plan;
  plan.level = level, plan.va = va, plan.vb = vb, plan.fa = fa, plan.fb = fb;
  // Stream order of this part's splits: by generation (a parent split in this part comes
  // first), then by the parent's stream index.
  std::vector<uint32_t> gen(vb - va, 0);
  uint32_t generations = 0;
  for (uint32_t x = va; x < vb; ++x) {
    uint32_t p = pm_.parent[x];
    gen[x - va] = p >= va ? gen[p - va] + 1 : 0;
    generations = std::max(generations, gen[x - va] + 1);
  }
  std::vector<std::vector<uint32_t>> by_gen(generations);
  for (uint32_t x = va; x < vb; ++x) by_gen[gen[x - va]].push_back(x);
  // The part's own stream indices are the plan's until adopt(): encode() of the part before
  // may read the stream index of any vertex meanwhile (those past it still their own).
  std::vector<uint32_t>& ranks = plan.ranks;
  ranks.resize(vb - va);
  for (uint32_t x = va; x < vb; ++x) ranks[x - va] = x;
  auto rank = [&](uint32_t v) { return v >= va && v < vb ? ranks[v - va] : rank_[v]; };
  auto rep_at = [&](uint32_t v, uint32_t prefix) {
    while (rank(v) >= prefix) v = pm_.parent[v];
    return v;
  };
  // A block part's parents go by their index in its candidates (stream/vsplit.h "Z"): generation 0
  // in the candidates' cheaper order, later ones by their own stream index (after every
  // candidate); a parent outside the candidates after them.
  CandidateIndex index;
  if (block_parts_ && level > 0) {
    plan.block = int32_t(pm_.level_block[level - 1]);
    if (Status s = block_candidates(uint32_t(plan.block), plan.candidates); !s) return s;
    index = CandidateIndex(plan.candidates);
    std::vector<uint32_t> parents;
    if (!by_gen.empty())
      for (uint32_t x : by_gen[0]) parents.push_back(rank(pm_.parent[x]));
    index.choose(parents);
    plan.morton = index.morton;
  }
  const uint64_t unlisted = uint64_t(1) << 32;
  auto key = [&](uint32_t parent) -> uint64_t {
    const uint32_t r = rank(parent);
    if (plan.block < 0) return r;
    const int64_t k = r < va ? index.find(r) : -1;
    return k >= 0 ? uint64_t(k) : unlisted + r;
  };
  uint32_t id = va;
  for (auto& bucket : by_gen) {
    std::vector<std::pair<uint64_t, uint32_t>> keyed(bucket.size());
    for (size_t i = 0; i < bucket.size(); ++i) keyed[i] = {key(pm_.parent[bucket[i]]), bucket[i]};
    std::stable_sort(keyed.begin(), keyed.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [k, x] : keyed) ranks[x - va] = id++, plan.order.push_back(x);
  }
  // Each new face appears at the split that first makes its three corners distinct; faces that
  // do not (none in a well-formed record) are sent whole after the splits.
  // The faces each split brings, as one list in split order (face order within a split): a
  // list per split cost a heap block each (a 4M-triangle record's last part: ~1M of them).
  std::vector<uint32_t> split_of(fb - fa, UINT32_MAX);
  std::vector<uint32_t>&faces_start = plan.faces_start, &faces_of = plan.faces_of;
  std::vector<uint32_t>& extras = plan.extras;
  faces_start.assign(vb - va + 1, 0);
  // Two corners' representatives differ at prefix P exactly when P is past the rank of the
  // vertex just below their meeting point on either side (that vertex present, the branches
  // apart): walking both ancestor chains up to where they meet gives it (UINT32_MAX: the same
  // vertex already at vb; 0: chains that never meet, apart at every prefix). A face is distinct
  // past the largest of its three pairs'. One walk per pair instead of a binary search of
  // walks (a 4M-triangle record spent 3 s here).
  auto apart = [&](uint32_t a, uint32_t b) -> uint32_t {
    a = rep_at(a, vb), b = rep_at(b, vb);
    if (a == b) return UINT32_MAX;
    uint32_t below = UINT32_MAX;  // the smaller rank of the two sides' last steps
    bool stepped_a = false, stepped_b = false;
    uint32_t last_a = 0, last_b = 0;
    while (a != b) {
      uint32_t& x = rank(a) > rank(b) ? a : b;
      const uint32_t up = pm_.parent[x];
      if (up == x) return 0;  // a root: the chains never meet
      (&x == &a ? (stepped_a = true, last_a) : (stepped_b = true, last_b)) = rank(x);
      x = up;
    }
    if (stepped_a) below = std::min(below, last_a);
    if (stepped_b) below = std::min(below, last_b);
    return below;
  };
  for (uint32_t f = fa; f < fb; ++f) {
    const uint32_t* o = &pm_.indices[size_t(f) * 3];
    const uint32_t t = std::max({apart(o[0], o[1]), apart(o[1], o[2]), apart(o[0], o[2])});
    if (t == UINT32_MAX || t < va) {  // never distinct in this part, or already before it
      extras.push_back(f);
      continue;
    }
    split_of[f - fa] = t - va;
    ++faces_start[t - va + 1];
  }
  for (uint32_t i = 0; i < vb - va; ++i) faces_start[i + 1] += faces_start[i];
  faces_of.resize(faces_start[vb - va]);
  {
    std::vector<uint32_t> fill(faces_start.begin(), faces_start.end() - 1);
    for (uint32_t f = fa; f < fb; ++f)
      if (split_of[f - fa] != UINT32_MAX) faces_of[fill[split_of[f - fa]]++] = f;
  }
  planned_level_ = level;
  return plan;
}

void MeshStreamEncoder::adopt(PartPlan& plan) {
  for (uint32_t x = plan.va; x < plan.vb; ++x) rank_[x] = plan.ranks[x - plan.va];
  if (plan.block >= 0 && size_t(plan.block) < blocks_.size()) {  // its range, for those after it
    StreamBlock& b = blocks_[size_t(plan.block)];
    b.vertex_begin = plan.va, b.vertex_end = plan.vb, b.face_begin = plan.fa, b.face_end = plan.fb;
  }
  order_.insert(order_.end(), plan.order.begin(), plan.order.end());
  std::vector<uint32_t>().swap(plan.ranks);
  std::vector<uint32_t>().swap(plan.order);
}

Result<EncodedMeshPart> MeshStreamEncoder::encode(PartPlan plan) {
  if (!status_) return status_;
  const uint32_t va = plan.va, vb = plan.vb, fa = plan.fa, fb = plan.fb;
  const std::vector<uint32_t>&faces_start = plan.faces_start, &faces_of = plan.faces_of;
  std::vector<uint32_t> extras = std::move(plan.extras);  // and faces found malformed below
  EncodedMeshPart e;
  e.part = {mesh_, va, vb, fa, fb, 0, -1};
  if (block_parts_ && plan.level > 0) e.part.block = int32_t(pm_.level_block[plan.level - 1]);
  RangeEncoder out;
  CandidateIndex index(plan.candidates);  // a block part's parents are indices into these
  index.morton = plan.morton;
  const uint32_t candidates = index.size();
  std::vector<uint32_t>().swap(plan.candidates);
  if (block_parts_) sim_.contexts = VsplitContexts();
  VsplitContexts& x = sim_.contexts;  // carried over from the mesh's previous part
  auto field = [&](StreamField f) { out.count_bits(&e.field_bits[size_t(f)]); };
  field(StreamField::kOther);
  out.put_direct(normals_ ? 1 : 0, 1);
  out.put_direct(uvs_ ? 1 : 0, 1);
  if (block_parts_) out.put_direct(plan.morton ? 1 : 0, 1);
  std::vector<uint8_t> takes, moved;  // per corner of the parent: taken by the new vertex
  std::vector<uint32_t> ring;
  struct NewFace {
    uint32_t w, flip, source;  // source: the record's face << 2 | the rotation taking v first
  };
  std::vector<NewFace> made;  // one split's new faces (reused)
  uint32_t previous = 0, previous_mode = 1;
  // The parents' corner lists are scattered over the client's corner arrays (a big record's
  // split loop waited on those loads most of its time): the parent a few splits ahead has its
  // list head fetched early, and the one half as far its first corner's link and vertex.
  constexpr uint32_t kAhead = 16;
  auto parent_at = [&](uint32_t v) { return rank_[pm_.parent[order_[v]]]; };
  for (uint32_t v = va; v < vb; ++v) {
    if (v + kAhead < vb) {
      __builtin_prefetch(&sim_.head[parent_at(v + kAhead)]);
      // The new vertex's attributes, for quantize() (its record vertex is far from the last's).
      const uint32_t ahead = order_[v + kAhead];
      __builtin_prefetch(&pm_.positions[ahead]);
      if (ahead < pm_.normals.size()) __builtin_prefetch(&pm_.normals[ahead]);
      if (!pm_.uvs.empty() && ahead < pm_.uvs[0].size()) __builtin_prefetch(&pm_.uvs[0][ahead]);
    }
    if (v + kAhead / 2 < vb)
      if (const int32_t c = sim_.head[parent_at(v + kAhead / 2)]; c >= 0)
        __builtin_prefetch(&sim_.next[size_t(c)]), __builtin_prefetch(&face_source_[size_t(c) / 3]);
    uint32_t xv = order_[v], p = rank_[pm_.parent[xv]];
    field(StreamField::kParent);
    if (block_parts_) {  // an index into the block's candidates, then its own vertices
      const int64_t listed = p < va ? index.find(p) : -1;
      const uint32_t escape = candidates + (vb - va);
      const uint32_t at = p >= va ? candidates + (p - va) : listed >= 0 ? uint32_t(listed) : escape;
      out.put_uint(x.parent, zigzag(int32_t(at) - int32_t(previous)));
      if (at == escape) {
        out.put_uint(x.escape, p);
        ++escaped_parents_;
      } else {
        previous = at;
      }
    } else {
      out.put_uint(x.parent, zigzag(int32_t(p) - int32_t(previous)));
      previous = p;
    }
    sim_.add_vertex(QuantizedVertex{});
    // Which of p's corners (in list order) the new vertex takes: those whose full-mesh vertex
    // descends from it (every vertex between them and p is still to come, so the new vertex is
    // their representative exactly then).
    takes.clear();
    const uint32_t from = enter_[xv], to = from + size_[xv];
    for (int32_t c = sim_.head[p]; c >= 0; c = sim_.next[size_t(c)]) {
      const uint32_t o = corner_enter(c);
      takes.push_back(from <= o && o < to);
    }
    const uint32_t dc = std::min(uint32_t(takes.size()), kFanLimit);
    // The new faces as (v, p, w) or (v, w, p), with the record's face behind each.
    made.clear();
    for (uint32_t i = faces_start[v - va]; i < faces_start[v - va + 1]; ++i) {
      const uint32_t f = faces_of[i];
      const uint32_t* o = &pm_.indices[size_t(f) * 3];
      uint32_t s[3];
      for (int k = 0; k < 3; ++k) s[k] = rank_[rep(o[k], v + 1)];
      int j = s[0] == v ? 0 : s[1] == v ? 1 : 2;
      uint32_t s1 = s[(j + 1) % 3], s2 = s[(j + 2) % 3];
      NewFace nf{0, 0, f << 2 | uint32_t(j)};
      if (s[j] != v || (s1 != p && s2 != p)) {
        extras.push_back(f);  // not a split face (a malformed record): sent whole
        continue;
      }
      nf.flip = s1 == p ? 0 : 1;
      nf.w = s1 == p ? s2 : s1;
      made.push_back(nf);
    }
    // Hoppe's split on a manifold fan (VsplitMesh::fan) when the new faces are (v, p, vl) and
    // (v, vr, p) and the corners taken are the fan from vl to vr: two small numbers instead of
    // the mask, the face count and the face codes.
    bool fan_mode = false;
    uint32_t start = 0, count = 0;
    if (made.size() == 2 && made[0].flip != made[1].flip) {
      if (made[0].flip) std::swap(made[0], made[1]);
      uint32_t position = 0, vl = 0, vr = 0;
      bool found = false;
      for (int32_t c = sim_.head[p]; c >= 0; c = sim_.next[size_t(c)], ++position) {
        size_t f = size_t(c) / 3 * 3, slot = size_t(c) - f;
        if (!found && sim_.indices[f + (slot + 1) % 3] == made[0].w) start = position, found = true;
      }
      for (uint8_t t : takes) count += t;
      fan_mode = found && count > 0 && sim_.fan(p, start, count, moved, vl, vr) &&
                 vl == made[0].w && vr == made[1].w && moved == takes;
    }
    field(StreamField::kMode);
    out.put_bit(x.mode[previous_mode], fan_mode);
    previous_mode = fan_mode;
    field(StreamField::kConnectivity);
    if (fan_mode) {  // fan() allows at most kFanLimit corners: both fit 5 bits
      out.put_tree(x.fan_start[dc], start);
      out.put_tree(x.fan_count[dc], count - 1);
    } else {
      out.put_uint(x.faces, uint32_t(made.size()));
      uint32_t last = 0;
      for (size_t position = 0; position < takes.size(); ++position) {
        out.put_bit(x.mask[std::min<size_t>(position, 7)][last], takes[position]);
        last = takes[position];
      }
    }
    uint32_t position = 0;
    for (int32_t c = sim_.head[p], prev = -1; c >= 0; ++position) {
      int32_t after = sim_.next[size_t(c)];
      if (takes[position])
        sim_.move_corner(p, prev, c, v);
      else
        prev = c;
      c = after;
    }
    if (!fan_mode && !made.empty()) sim_.ring(p, v, kRingLimit, ring);
    for (const NewFace& nf : made) {
      if (!fan_mode) {
        uint32_t i = uint32_t(std::find(ring.begin(), ring.end(), nf.w) - ring.begin());
        out.put_uint(x.face, (i << 1) | nf.flip);
        if (i == ring.size()) out.put_uint(x.escape, nf.w);
      }
      if (nf.flip)
        sim_.add_face(v, nf.w, p);
      else
        sim_.add_face(v, p, nf.w);
      face_source_.push_back(nf.source);
    }
    uint32_t extent_class = 0;
    QuantizedVertex pred = sim_.predict(v, p, &extent_class), q = quantize(xv);
    // A twin where the new vertex sits (a seam or hard-edge copy split with another) spares
    // its position.
    uint32_t twin[kTwinLimit], twins = sim_.twins(p, twin), pick = 0;
    for (uint32_t t = 0; t < twins && pick == 0; ++t) {
      const QuantizedVertex& u = sim_.vertices[twin[t]];
      if (u.p[0] == q.p[0] && u.p[1] == q.p[1] && u.p[2] == q.p[2]) pick = t + 1;
    }
    field(StreamField::kTwin);
    if (twins > 0) out.put_tree(x.twin[twins], pick);
    field(StreamField::kPosition);
    e.twins += pick > 0;
    if (pick == 0) {  // two axes along the fan from the ring's mean, the third on its plane
      int64_t normal[3];
      int order[3];
      sim_.fan_normal(v, pred.p, normal);
      const bool plane = plane_axes(normal, order);
      for (int role = 0; role < 3; ++role) {
        const int axis = order[role];
        int64_t base = role == 2 && plane
                           ? plane_predict(normal, order, pred.p, q.p[order[0]], q.p[order[1]])
                           : int64_t(pred.p[axis]);
        out.put_uint(x.position[role][extent_class], zigzag(int32_t(int64_t(q.p[axis]) - base)),
                     kResidualModelledBits);
      }
    }
    field(StreamField::kNormal);
    for (int k = 0; k < 3 && normals_; ++k)
      out.put_uint(x.normal[k], zigzag(int32_t(q.n[k]) - int32_t(pred.n[k])),
                   kResidualModelledBits);
    // The decoder knows v's position by then.
    const uint32_t uv_predicted = uvs_ && sim_.predict_uv(v, p, q.p, pred.t) ? 1 : 0;
    field(StreamField::kUv);
    for (int k = 0; k < 2 && uvs_; ++k)
      out.put_uint(x.uv[k][uv_predicted], zigzag(int32_t(q.t[k]) - int32_t(pred.t[k])),
                   kResidualModelledBits);
    sim_.vertices[v] = q;
    sim_.add_twin(p, v);
  }
  field(StreamField::kOther);
  out.put_uint(x.extra, uint32_t(extras.size()));
  for (uint32_t f : extras) {
    uint32_t s[3];
    for (int k = 0; k < 3; ++k) {
      uint32_t o = pm_.indices[size_t(f) * 3 + size_t(k)];
      s[k] = rank_[rep(o, vb)];
      out.put_uint(x.escape, s[k]);
    }
    sim_.add_face(s[0], s[1], s[2]);
    face_source_.push_back(f << 2);
  }
  std::vector<uint8_t> plain = out.finish();
  if (!part_size_plausible(plain.size(), vb - va, fb - fa))
    return internal(mesh_, "a part's splits are more than the format allows for its bytes");
  e.data = std::move(plain);
  e.part.bytes = e.data.size();
  level_ = plan.level;
  count(counts_, &EncodeCounts::mesh_parts);
  return e;
}

Status MeshStreamEncoder::block_candidates(uint32_t block, std::vector<uint32_t>& out) {
  if (blocks_.empty()) blocks_ = stream_blocks();
  const uint32_t adopted = uint32_t(order_.size());
  auto position = [&](uint32_t v) {
    const Vec3 p = pm_.positions[order_[v]];
    const PositionQuantization& q = quantization_;
    return std::array<uint16_t, 3>{quantize_coordinate(p.x, q.origin.x, q.step),
                                   quantize_coordinate(p.y, q.origin.y, q.step),
                                   quantize_coordinate(p.z, q.origin.z, q.step)};
  };
  const uint32_t base_vertices = pm_.levels[level_at_start_].vertex_end;
  Status s = collect_block_candidates(
      blocks_, base_vertices, block, [&](uint32_t v) { return v < adopted; }, position, out);
  return s ? s : internal(mesh_, s.message());
}

std::vector<StreamBlock> MeshStreamEncoder::stream_blocks() const {
  std::vector<StreamBlock> out;
  const size_t base = level_at_start_, levels = pm_.levels.size();
  if (pm_.blocks.empty() || base + 1 >= levels) return out;  // a chain, or the base is whole
  out.resize(pm_.blocks.size());
  // Their stream ranges are left out: the package does not write them (the reader derives them
  // from the parts, stream/format.h "Blocks").
  for (size_t k = 0; k < out.size(); ++k) {
    StreamBlock& x = out[k];
    const ProgressiveBlock& pb = pm_.blocks[k];
    x.level = pb.level, x.error = pb.error;
    // On the grid, floored and ceiled (a box of nothing: empty at the origin).
    const Vec3 lo = pb.box_min, hi = pb.box_max;
    const float min[3] = {lo.x, lo.y, lo.z}, max[3] = {hi.x, hi.y, hi.z};
    const float origin[3] = {quantization_.origin.x, quantization_.origin.y,
                             quantization_.origin.z};
    for (int i = 0; i < 3; ++i) {
      const double a = std::floor((double(min[i]) - origin[i]) / quantization_.step),
                   z = std::ceil((double(max[i]) - origin[i]) / quantization_.step);
      x.box[i] = uint16_t(std::isfinite(a) ? std::clamp(a, 0.0, double(kPositionMax)) : 0.0);
      x.box[3 + i] = uint16_t(
          std::isfinite(z) ? std::clamp(z, double(x.box[i]), double(kPositionMax)) : x.box[i]);
    }
    x.deps.assign(pb.deps.begin(), pb.deps.end());
  }
  return out;
}

namespace {

// A chunk's payload sized for its parts' bytes, none in it yet.
std::vector<uint8_t> payload_for(const std::vector<EncodedMeshPart>& parts) {
  size_t bytes = 0;
  for (const EncodedMeshPart& p : parts) bytes += p.data.size();
  std::vector<uint8_t> out;
  out.reserve(bytes);
  return out;
}

}  // namespace

std::vector<uint8_t> mesh_chunk_payload(const std::vector<EncodedMeshPart>& parts) {
  std::vector<uint8_t> out = payload_for(parts);
  for (const EncodedMeshPart& p : parts) out.insert(out.end(), p.data.begin(), p.data.end());
  return out;
}

std::vector<uint8_t> take_chunk_payload(std::vector<EncodedMeshPart>& parts) {
  std::vector<uint8_t> out = payload_for(parts);
  for (EncodedMeshPart& p : parts) {
    out.insert(out.end(), p.data.begin(), p.data.end());
    release_pages(p.data.data(), p.data.size());
    std::vector<uint8_t>().swap(p.data);
  }
  return out;
}

Bounds package_bounds(const ProgressiveMesh& pm) {
  Bounds b;
  for (Vec3 p : pm.positions)
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) b.add(p);
  if (b.empty()) b.min = b.max = Vec3{0, 0, 0};
  return b;
}

PositionQuantization package_quantization(const ProgressiveMesh& pm) {
  return position_quantization(package_bounds(pm));
}

QuantizedVertex quantize_vertex(const ProgressiveMesh& pm, const PositionQuantization& q,
                                uint32_t v) {
  QuantizedVertex out;
  Vec3 p = pm.positions[v];
  out.p[0] = quantize_coordinate(p.x, q.origin.x, q.step);
  out.p[1] = quantize_coordinate(p.y, q.origin.y, q.step);
  out.p[2] = quantize_coordinate(p.z, q.origin.z, q.step);
  Vec3 n = v < pm.normals.size() ? unit_normal(pm.normals[v]) : Vec3{0, 0, 1};
  out.n[0] = quantize_normal(n.x), out.n[1] = quantize_normal(n.y), out.n[2] = quantize_normal(n.z);
  Vec2 t = !pm.uvs.empty() && v < pm.uvs[0].size() ? pm.uvs[0][v] : Vec2{};
  out.t[0] = quantize_uv(t.x), out.t[1] = quantize_uv(t.y);
  return out;
}

}  // namespace meshmux
