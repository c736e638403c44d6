// The block hierarchy of a big unit (Simplifier::run_block_levels, see simplifier.h): the
// shape of Ponchio and Dellepiane's Nexus build ("Multiresolution and fast decompression for
// optimal web-based rendering": blocks simplified with locked borders, the partition changed
// between levels so that one level's borders are inside the next level's blocks) and of
// Kapoulkine's clusterlod in meshoptimizer (groups simplified to half, regrouped across the
// old borders), with our own collapses inside each block: the same quadrics, wedges and
// checks as the whole-unit loop, so the record keeps one history of half-edge collapses and
// the progressive mesh and its coding do not change.
//
// Why it is safe to run blocks at once: a block is a run of live positions in the unit's
// spatial (Morton) order; a position may collapse only when every face around it has all its
// corners in the block, and may be a target only when it is in the block. A collapse then
// changes only faces whose corners are all in its block, and the quadrics of positions and
// wedges of its block, so blocks write disjoint parts of the unit; faces that straddle blocks
// do not change in the level.
#include <algorithm>
#include <queue>
#include <unordered_map>

#include "core/parallel.h"
#include "simplify/simplifier.h"

namespace meshmux::simplify_detail {

// A block's collapses in the unit's numbering, in the order the block made them.
struct Simplifier::BlockResult {
  std::vector<Collapse> collapses;  // first_map / first_face index the two lists below
  std::vector<std::pair<uint32_t, uint32_t>> maps;
  std::vector<uint32_t> removed_faces;
  SimplifyReport report;
};

size_t Simplifier::run_block_levels(const std::function<void(uint64_t)>& on_progress) {
  if (alive_.empty()) begin_state();
  build_adjacency();
  size_t levels = 0;
  while (live_faces_ > opt_.block_until) {
    const size_t before = live_faces_;
    run_block_level(std::max<size_t>(64, opt_.block_positions), levels % 2 == 1);
    ++levels;
    if (on_progress) on_progress(collapses_.size());
    if (10 * (before - live_faces_) < before) break;  // stuck: the whole-unit loop goes on
  }
  return levels;
}

size_t Simplifier::run_block_level(size_t block_positions, bool shifted) {
  const size_t np = u_.pos.size();
  std::vector<uint32_t> live;
  for (uint32_t p = 0; p < np; ++p)
    if (!dead_pos_[p] && pos_faces_[p].begin() != pos_faces_[p].end()) live.push_back(p);
  std::vector<size_t> starts = {0};
  for (size_t s = shifted ? block_positions / 2 : block_positions; s < live.size();
       s += block_positions)
    starts.push_back(s);
  starts.push_back(live.size());
  const size_t blocks = starts.size() - 1;
  std::vector<uint32_t> block_of(np, UINT32_MAX);
  for (uint32_t b = 0; b < blocks; ++b)
    for (size_t i = starts[b]; i < starts[b + 1]; ++i) block_of[live[i]] = b;
  const float bound = level_error_bound(live);
  std::vector<BlockResult> results(blocks);
  parallel_chunks(blocks, 1, [&](size_t begin, size_t end) {
    for (size_t b = begin; b < end; ++b)
      results[b] =
          simplify_block(&live[starts[b]], starts[b + 1] - starts[b], block_of, uint32_t(b), bound);
  });
  // The histories merged by each collapse's error when chosen (its queue_min), each block's
  // own order kept (a collapse may need the ones before it in its block); ties by block.
  using Head = std::pair<float, uint32_t>;  // (error, block)
  std::priority_queue<Head, std::vector<Head>, std::greater<Head>> heads;
  std::vector<size_t> next(blocks, 0);
  for (uint32_t b = 0; b < blocks; ++b)
    if (!results[b].collapses.empty()) heads.push({results[b].collapses[0].queue_min, b});
  size_t made = 0;
  while (!heads.empty()) {
    const uint32_t b = heads.top().second;
    heads.pop();
    const BlockResult& r = results[b];
    Collapse c = r.collapses[next[b]++];
    const uint32_t first_map = uint32_t(maps_.size()), first_face = uint32_t(removed_faces_.size());
    maps_.insert(maps_.end(), r.maps.begin() + c.first_map,
                 r.maps.begin() + c.first_map + c.map_count);
    removed_faces_.insert(removed_faces_.end(), r.removed_faces.begin() + c.first_face,
                          r.removed_faces.begin() + c.first_face + c.face_count);
    live_faces_ -= c.face_count;
    c.first_map = first_map, c.first_face = first_face;
    collapses_.push_back(c);
    ++made;
    if (next[b] < r.collapses.size()) heads.push({r.collapses[next[b]].queue_min, b});
  }
  for (const BlockResult& r : results) {
    report_.collapses += r.report.collapses;
    report_.refused_flip += r.report.refused_flip;
    report_.refused_link += r.report.refused_link;
    report_.refused_wedge += r.report.refused_wedge;
    report_.refused_vanish += r.report.refused_vanish;
  }
  build_adjacency();
  return made;
}

float Simplifier::level_error_bound(const std::vector<uint32_t>& live) const {
  const size_t samples = (live.size() + 7) / 8;
  std::vector<float> cost(samples, INFINITY);
  parallel_chunks(samples, 1024, [&](size_t begin, size_t end) {
    Scratch s;
    for (size_t i = begin; i < end; ++i) cost[i] = best_candidate(live[8 * i], s).error;
  });
  if (cost.empty()) return INFINITY;
  std::nth_element(cost.begin(), cost.begin() + ptrdiff_t(samples * 3 / 4), cost.end());
  return cost[samples * 3 / 4];
}

Simplifier::BlockResult Simplifier::simplify_block(const uint32_t* positions, size_t count,
                                                   const std::vector<uint32_t>& block_of,
                                                   uint32_t block, float bound) {
  // The block's faces: every live face with a corner in it (those with a corner outside stay
  // as they are, but their edges are seen by the link and border tests).
  std::vector<uint32_t> faces;
  for (size_t i = 0; i < count; ++i)
    for (uint32_t f : pos_faces_[positions[i]]) faces.push_back(f);
  std::sort(faces.begin(), faces.end());
  faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
  // Its unit: the block's positions first, then the others its faces reach; wedges as met.
  Unit sub;
  sub.channels = u_.channels;
  const size_t k = size_t(u_.channels), kg = k * 4;
  std::unordered_map<uint32_t, uint32_t> local_pos, local_wedge;
  local_pos.reserve(2 * count), local_wedge.reserve(4 * count);
  std::vector<uint32_t> global_pos, global_wedge;
  std::vector<uint8_t> role;
  for (size_t i = 0; i < count; ++i) {
    local_pos.emplace(positions[i], uint32_t(i));
    global_pos.push_back(positions[i]);
    sub.pos.push_back(u_.pos[positions[i]]);
    role.push_back(kFree);
  }
  auto position = [&](uint32_t p) {
    auto [it, added] = local_pos.emplace(p, uint32_t(global_pos.size()));
    if (added) global_pos.push_back(p), sub.pos.push_back(u_.pos[p]), role.push_back(kFixed);
    return it->second;
  };
  auto wedge = [&](uint32_t w) {
    auto [it, added] = local_wedge.emplace(w, uint32_t(global_wedge.size()));
    if (!added) return it->second;
    global_wedge.push_back(w);
    sub.wedge_pos.push_back(position(u_.wedge_pos[w]));
    sub.wedge_group.push_back(u_.wedge_group[w]);  // compared for equality only
    if (!u_.wedge_normal.empty()) sub.wedge_normal.push_back(u_.wedge_normal[w]);
    sub.attr.insert(sub.attr.end(), u_.attr.begin() + ptrdiff_t(w * k),
                    u_.attr.begin() + ptrdiff_t((w + 1) * k));
    return it->second;
  };
  size_t owned = 0;
  std::vector<uint8_t> face_owned(faces.size(), 1);
  for (size_t i = 0; i < faces.size(); ++i) {
    const uint32_t f = faces[i];
    for (int c = 0; c < 3; ++c) {
      const uint32_t w = u_.corners[3 * size_t(f) + size_t(c)];
      sub.corners.push_back(wedge(w));
      if (block_of[u_.wedge_pos[w]] != block) face_owned[i] = 0;
    }
    sub.face_prim.push_back(u_.face_prim[f]);
    owned += face_owned[i];
  }
  // A block position with a face outside the block keeps its place (its border is locked).
  for (size_t i = 0; i < faces.size(); ++i)
    if (!face_owned[i])
      for (int c = 0; c < 3; ++c) {
        const uint32_t p = sub.wedge_pos[sub.corners[3 * i + size_t(c)]];
        if (role[p] == kFree) role[p] = kTargetOnly;
      }
  // The quadrics of the block's positions and their wedges (the others are never read).
  std::vector<Quadric> pq(global_pos.size()), aq(global_wedge.size());
  std::vector<double> gd(global_wedge.size() * kg, 0.0);
  for (size_t i = 0; i < count; ++i) pq[i] = pos_q_[positions[i]];
  for (size_t w = 0; w < global_wedge.size(); ++w) {
    if (sub.wedge_pos[w] >= count) continue;
    aq[w] = attr_q_[global_wedge[w]];
    std::copy_n(attr_gd_.begin() + ptrdiff_t(global_wedge[w] * kg), kg,
                gd.begin() + ptrdiff_t(w * kg));
  }
  BlockResult out;
  Simplifier s(sub, std::move(pq), std::move(aq), std::move(gd), opt_, out.report);
  s.role_ = std::move(role);
  s.serial_ = true;
  s.keep_costing_ = true;
  s.stop_faces_ = faces.size() - owned * 3 / 4;
  s.stop_error_ = bound;
  s.run();
  // Back in the unit's numbering.
  out.collapses = s.collapses_;
  out.maps.reserve(s.maps_.size());
  for (const auto& [w, t] : s.maps_) out.maps.push_back({global_wedge[w], global_wedge[t]});
  out.removed_faces.reserve(s.removed_faces_.size());
  for (uint32_t f : s.removed_faces_) out.removed_faces.push_back(faces[f]);
  // The state the block leaves, written where only this block writes (see the file comment).
  for (size_t i = 0; i < faces.size(); ++i) {
    if (!face_owned[i]) continue;
    const uint32_t f = faces[i];
    alive_[f] = s.alive_[i];
    for (int c = 0; c < 3; ++c)
      u_.corners[3 * size_t(f) + size_t(c)] = global_wedge[sub.corners[3 * i + size_t(c)]];
  }
  for (size_t i = 0; i < count; ++i) {
    pos_q_[positions[i]] = s.pos_q_[i];
    dead_pos_[positions[i]] = s.dead_pos_[i];
  }
  for (size_t w = 0; w < global_wedge.size(); ++w) {
    if (sub.wedge_pos[w] >= count) continue;
    attr_q_[global_wedge[w]] = s.attr_q_[w];
    std::copy_n(s.attr_gd_.begin() + ptrdiff_t(w * kg), kg,
                attr_gd_.begin() + ptrdiff_t(global_wedge[w] * kg));
  }
  return out;
}

}  // namespace meshmux::simplify_detail
