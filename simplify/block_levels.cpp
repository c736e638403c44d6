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
#include <malloc.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <memory>
#include <optional>
#include <queue>
#include <stdexcept>
#include <unordered_map>

#include "core/parallel.h"
#include "core/release_pages.h"
#include "simplify/simplifier.h"

namespace meshmux::simplify_detail {

// A block's collapses in the unit's numbering, in the order the block made them.
struct Simplifier::BlockResult {
  std::vector<Collapse> collapses;  // first_map / first_face index the two lists below
  std::vector<std::pair<uint32_t, uint32_t>> maps;
  std::vector<uint32_t> removed_faces;
  SimplifyReport report;
  // kMakeQuadrics: the quadrics of the block's live positions and of their wedges, in the
  // unit's numbering (the unit holds none of its own).
  std::vector<uint32_t> positions, wedges;
  std::vector<Quadric> pos_q, wedge_q;
  std::vector<double> wedge_gd;  // wedges × channels × 4
  std::vector<float> costs;      // kCostsOnly: a sample of the block's cheapest collapses
  // Where pos_q, wedge_q and wedge_gd wait in the spill file (their sizes: positions' and
  // wedges'), or empty: held above.
  std::optional<std::array<uint64_t, 3>> spilled;
};

void Simplifier::keep_original_corners(const std::vector<uint32_t>& corners, bool spill) {
  if (spill && !opt_.spill_dir.empty() && !corners.empty()) {
    auto file = std::make_shared<SpillFile>(opt_.spill_dir);
    if (file->ok() && file->put(corners.data(), corners.size() * sizeof(uint32_t)) == 0) {
      corners_spill_ = std::move(file), corners_count_ = corners.size();
      return;
    }
  }
  original_corners_ = corners;
}

void Simplifier::load_original_corners() {
  if (!corners_spill_) return;
  original_corners_.resize(corners_count_);
  corners_spill_->get(0, original_corners_.data(), corners_count_ * sizeof(uint32_t));
  corners_spill_.reset();
}

// The live part of a unit after a level, as a unit of its own (see compact()).
struct Simplifier::Rest {
  std::unique_ptr<Unit> unit;
  std::unique_ptr<Simplifier> s;
  std::vector<uint32_t> wedge_of;  // rest wedge → unit wedge
  std::vector<uint32_t> face_of;   // rest face → unit face
};

// One block as a unit of its own: the block's positions first, then the others its faces
// reach; wedges as met; every live face with a corner in the block (those with a corner
// outside stay as they are, but their edges are seen by the link and border tests).
struct Simplifier::BlockUnit {
  Unit unit;
  std::vector<uint32_t> faces, global_pos, global_wedge;  // local → unit numbering
  std::vector<uint8_t> role, face_owned;  // per local position / face (all corners in block)
  size_t owned = 0;                       // faces with all corners in the block
};

Simplifier::BlockUnit Simplifier::make_block_unit(const uint32_t* positions, size_t count,
                                                  const std::vector<uint32_t>& block_of,
                                                  uint32_t block) const {
  BlockUnit b;
  if (pos_faces_.empty()) {  // the first level: its lists (run_block_level)
    b.faces.assign(block_faces_.begin() + ptrdiff_t(block_face_start_[block]),
                   block_faces_.begin() + ptrdiff_t(block_face_start_[block + 1]));
  } else {
    for (size_t i = 0; i < count; ++i)
      for (uint32_t f : pos_faces_[positions[i]]) b.faces.push_back(f);
    std::sort(b.faces.begin(), b.faces.end());
    b.faces.erase(std::unique(b.faces.begin(), b.faces.end()), b.faces.end());
  }
  Unit& sub = b.unit;
  sub.channels = u_.channels, sub.normals = u_.normals;
  const size_t k = size_t(u_.channels);
  std::unordered_map<uint32_t, uint32_t> local_pos, local_wedge;
  local_pos.reserve(2 * count), local_wedge.reserve(4 * count);
  for (size_t i = 0; i < count; ++i) {
    local_pos.emplace(positions[i], uint32_t(i));
    b.global_pos.push_back(positions[i]);
    sub.pos.push_back(u_.pos[positions[i]]);
    b.role.push_back(kFree);
  }
  auto position = [&](uint32_t p) {
    auto [it, added] = local_pos.emplace(p, uint32_t(b.global_pos.size()));
    if (added) b.global_pos.push_back(p), sub.pos.push_back(u_.pos[p]), b.role.push_back(kFixed);
    return it->second;
  };
  auto wedge = [&](uint32_t w) {
    auto [it, added] = local_wedge.emplace(w, uint32_t(b.global_wedge.size()));
    if (!added) return it->second;
    b.global_wedge.push_back(w);
    sub.wedge_pos.push_back(position(u_.wedge_pos[w]));
    sub.wedge_group.push_back(u_.wedge_group[w]);  // compared for equality only
    if (!u_.wedge_normal.empty()) sub.wedge_normal.push_back(u_.wedge_normal[w]);
    sub.attr.insert(sub.attr.end(), u_.attr.begin() + ptrdiff_t(w * k),
                    u_.attr.begin() + ptrdiff_t((w + 1) * k));
    return it->second;
  };
  b.face_owned.assign(b.faces.size(), 1);
  for (size_t i = 0; i < b.faces.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const uint32_t w = u_.corners[3 * size_t(b.faces[i]) + size_t(c)];
      sub.corners.push_back(wedge(w));
      if (block_of[u_.wedge_pos[w]] != block) b.face_owned[i] = 0;
    }
    b.owned += b.face_owned[i];
  }
  // A block position with a face outside the block keeps its place (its border is locked).
  for (size_t i = 0; i < b.faces.size(); ++i)
    if (!b.face_owned[i])
      for (int c = 0; c < 3; ++c) {
        const uint32_t p = sub.wedge_pos[sub.corners[3 * i + size_t(c)]];
        if (b.role[p] == kFree) b.role[p] = kTargetOnly;
      }
  return b;
}

size_t Simplifier::run_block_levels(const std::function<void(uint64_t)>& on_progress) {
  if (alive_.empty()) begin_state();
  // Quadrics by blocks: the first level makes them; the rest goes on as a unit of its own.
  spill_ = std::make_shared<SpillFile>(opt_.spill_dir);
  std::vector<BlockResult> made;
  run_block_level(std::max<size_t>(64, opt_.block_positions), 0, &made, on_progress);
  if (on_progress) on_progress(collapses_.size());
  Rest rest = compact(made);
  report_.spilled_bytes = spill_->ok() ? spill_->size() : 0;
  spill_.reset();
  const uint64_t before = collapses_.size();
  auto rest_progress = [&](uint64_t n) {
    if (on_progress) on_progress(before + n);
  };
  hand_blocks(*rest.s);
  const size_t levels = 1 + rest.s->block_levels_from(1, rest_progress);
  rest.s->finish_levels(rest_progress);
  absorb(rest);
  return levels;
}

size_t Simplifier::block_levels_from(size_t level,
                                     const std::function<void(uint64_t)>& on_progress) {
  if (alive_.empty()) begin_state();
  build_adjacency();
  size_t levels = 0;
  while (live_faces_ > opt_.block_until) {
    const size_t before = live_faces_;
    run_block_level(std::max<size_t>(64, opt_.block_positions), level + levels, nullptr,
                    on_progress);
    ++levels;
    if (on_progress) on_progress(collapses_.size());
    if (10 * (before - live_faces_) < before) break;  // stuck: the whole-unit loop goes on
    size_t live_pos = 0;
    for (uint8_t dead : dead_pos_) live_pos += !dead;
    if (mapped_ && live_faces_ > opt_.block_until && 2 * live_pos < dead_pos_.size()) {
      // Mostly dead: a block's live positions would spread over twice the pages. The live
      // part goes on as a unit of its own, its quadrics in a mapping of their own.
      Rest next = compact_quadrics(true);
      hand_blocks(*next.s);
      const uint64_t at = collapses_.size();
      auto next_progress = [&](uint64_t n) {
        if (on_progress) on_progress(at + n);
      };
      levels += next.s->block_levels_from(level + levels, next_progress);
      next.s->finish_levels(next_progress);
      absorb(next);
      break;
    }
  }
  return levels;
}

void Simplifier::finish_levels(const std::function<void(uint64_t)>& on_progress) {
  if (finished_) return;
  if (!mapped_) return run(on_progress);
  // The whole-unit loop on the live part, its quadrics in memory.
  Rest last = compact_quadrics(false);
  hand_blocks(*last.s);
  const uint64_t at = collapses_.size();
  last.s->run([&](uint64_t n) {
    if (on_progress) on_progress(at + n);
  });
  absorb(last);
}

size_t Simplifier::run_block_level(size_t block_positions, size_t level,
                                   std::vector<BlockResult>* quadrics_made,
                                   const std::function<void(uint64_t)>& on_progress) {
  const size_t np = u_.pos.size();
  std::vector<uint32_t> live;
  if (pos_faces_.empty()) {  // no adjacency (the first level): the positions live faces use
    std::vector<uint8_t> used(np, 0);
    for (size_t f = 0; f < alive_.size(); ++f)
      if (alive_[f])
        for (int c = 0; c < 3; ++c) used[u_.wedge_pos[u_.corners[3 * f + size_t(c)]]] = 1;
    for (uint32_t p = 0; p < np; ++p)
      if (used[p] && !dead_pos_[p]) live.push_back(p);
  } else {
    for (uint32_t p = 0; p < np; ++p)
      if (!dead_pos_[p] && pos_faces_[p].begin() != pos_faces_[p].end()) live.push_back(p);
  }
  std::vector<size_t> starts = {0};
  const bool shifted = level % 2 == 1;
  for (size_t s = shifted ? block_positions / 2 : block_positions; s < live.size();
       s += block_positions)
    starts.push_back(s);
  starts.push_back(live.size());
  const size_t blocks = starts.size() - 1;
  std::vector<uint32_t> block_of(np, UINT32_MAX);
  for (uint32_t b = 0; b < blocks; ++b)
    for (size_t i = starts[b]; i < starts[b + 1]; ++i) block_of[live[i]] = b;
  if (pos_faces_.empty()) block_face_lists(block_of, blocks);
  const BlockMode mode = quadrics_made ? kMakeQuadrics : kCopyQuadrics;
  const float bound =
      quadrics_made ? sampled_error_bound(live, starts, block_of) : level_error_bound(live);
  std::vector<BlockResult> results(blocks);
  std::atomic<uint64_t> collapsed{collapses_.size()};
  parallel_chunks(blocks, 1, [&](size_t begin, size_t end) {
    for (size_t b = begin; b < end; ++b) {
      results[b] = simplify_block(&live[starts[b]], starts[b + 1] - starts[b], block_of,
                                  uint32_t(b), bound, mode);
      drop_mapped();  // the block's quadrics are written back
      const uint64_t done = collapsed += results[b].collapses.size();
      if (on_progress) on_progress(done);
    }
  });
  // The histories merged by each collapse's error when chosen (its queue_min), each block's
  // own order kept (a collapse may need the ones before it in its block); ties by block.
  using Head = std::pair<float, uint32_t>;  // (error, block)
  std::priority_queue<Head, std::vector<Head>, std::greater<Head>> heads;
  std::vector<size_t> next(blocks, 0);
  for (uint32_t b = 0; b < blocks; ++b)
    if (!results[b].collapses.empty()) heads.push({results[b].collapses[0].queue_min, b});
  reserve_history(results);
  // The level's blocks in the hierarchy, one block id each (one for the whole level where
  // ids would pass 16 bits: the level is then one block, still a valid one, as its collapses
  // are contiguous in the history).
  // (Past 65,535 ids at all, the level joins the last block: consecutive levels are
  // contiguous in the history too.)
  const bool one_id = blocks_.size() + blocks > 0xFFFF;
  if (blocks_.size() < 0xFFFF)
    for (uint32_t b = 0; b < (one_id ? 1 : blocks); ++b)
      blocks_.push_back({uint16_t(std::min<size_t>(level, 0xFFFE)), b, 0.0f});
  const size_t first_id = one_id ? blocks_.size() - 1 : blocks_.size() - blocks;
  collapse_block_.resize(collapses_.size(), 0);
  size_t made = 0;
  // The history grows as the blocks' lists shrink, where holding both to the end was the
  // conversion's peak (a 20M-triangle scan's first level: ~330 MB twice). The merge reads every
  // block's lists from the front at about the same pace (each block's errors rise as the
  // level's do), so a list's pages read for the last time go back to the OS as it is read
  // (SimplifyOptions::merge_release_bytes: release_pages), and a block's lists are freed once its
  // last collapse is merged, the freed pages handed back every kTrimBytes.
  constexpr size_t kTrimBytes = size_t(32) << 20;
  const size_t release_bytes = opt_.merge_release_bytes;
  std::vector<size_t> released(blocks, 0);  // per block: collapses read when it last released
  size_t freed = 0;
  while (!heads.empty()) {
    const uint32_t b = heads.top().second;
    heads.pop();
    BlockResult& r = results[b];
    const Collapse c0 = r.collapses[next[b]++];
    Collapse c = c0;
    const uint32_t first_map = uint32_t(maps_.size()), first_face = uint32_t(removed_faces_.size());
    maps_.insert(maps_.end(), r.maps.begin() + c.first_map,
                 r.maps.begin() + c.first_map + c.map_count);
    removed_faces_.insert(removed_faces_.end(), r.removed_faces.begin() + c.first_face,
                          r.removed_faces.begin() + c.first_face + c.face_count);
    live_faces_ -= c.face_count;
    c.first_map = first_map, c.first_face = first_face;
    collapses_.push_back(c);
    const size_t id = first_id + (one_id ? 0 : b);
    collapse_block_.push_back(uint16_t(id));
    blocks_[id].error = std::max(blocks_[id].error, c.error);
    ++made;
    if (release_bytes && (next[b] - released[b]) * sizeof(Collapse) >= release_bytes) {
      // A block's collapses list their maps and faces in order (each block records its own):
      // what this one and those before it use is read for the last time.
      released[b] = next[b];
      release_pages(r.collapses.data(), next[b] * sizeof(Collapse));
      release_pages(r.maps.data(), (size_t(c0.first_map) + c0.map_count) * sizeof(r.maps[0]));
      release_pages(r.removed_faces.data(),
                    (size_t(c0.first_face) + c0.face_count) * sizeof(uint32_t));
    }
    if (next[b] < r.collapses.size()) {
      heads.push({r.collapses[next[b]].queue_min, b});
      continue;
    }
    freed += r.collapses.capacity() * sizeof(Collapse) + r.maps.capacity() * sizeof(r.maps[0]) +
             r.removed_faces.capacity() * sizeof(uint32_t);
    std::vector<Collapse>().swap(r.collapses);
    std::vector<std::pair<uint32_t, uint32_t>>().swap(r.maps);
    std::vector<uint32_t>().swap(r.removed_faces);
    if (freed >= kTrimBytes) malloc_trim(0), freed = 0;
  }
  for (const BlockResult& r : results) {
    report_.collapses += r.report.collapses;
    report_.refused_flip += r.report.refused_flip;
    report_.refused_link += r.report.refused_link;
    report_.refused_wedge += r.report.refused_wedge;
    report_.refused_vanish += r.report.refused_vanish;
  }
  std::vector<uint32_t>().swap(block_faces_), std::vector<size_t>().swap(block_face_start_);
  if (quadrics_made)
    quadrics_made->swap(results);
  else
    build_adjacency();
  return made;
}

void Simplifier::block_face_lists(const std::vector<uint32_t>& block_of, size_t blocks) {
  // Each live face is listed in every block one of its corners is in (a counting sort, faces
  // in order within a block).
  auto each = [&](const auto& add) {
    for (size_t f = 0; f < alive_.size(); ++f) {
      if (!alive_[f]) continue;
      uint32_t seen[3];
      for (int c = 0; c < 3; ++c) {
        seen[c] = block_of[u_.wedge_pos[u_.corners[3 * f + size_t(c)]]];
        if ((c < 1 || seen[c] != seen[0]) && (c < 2 || seen[c] != seen[1])) add(seen[c], f);
      }
    }
  };
  block_face_start_.assign(blocks + 1, 0);
  each([&](uint32_t b, size_t) { ++block_face_start_[b + 1]; });
  for (size_t b = 0; b < blocks; ++b) block_face_start_[b + 1] += block_face_start_[b];
  block_faces_.resize(block_face_start_[blocks]);
  std::vector<size_t> fill(block_face_start_.begin(), block_face_start_.end() - 1);
  each([&](uint32_t b, size_t f) { block_faces_[fill[b]++] = uint32_t(f); });
}

float Simplifier::level_error_bound(const std::vector<uint32_t>& live) const {
  const size_t samples = (live.size() + 7) / 8;
  std::vector<float> cost(samples, INFINITY);
  // Mapped quadrics: in runs of about a block's positions, each one's pages dropped after it
  // (read only here).
  const size_t run = mapped_ ? 4096 : std::max<size_t>(samples, 1);
  for (size_t from = 0; from < samples; from += run) {
    parallel_chunks(std::min(run, samples - from), 1024, [&](size_t begin, size_t end) {
      Scratch s;
      for (size_t i = from + begin; i < from + end; ++i)
        cost[i] = best_candidate(live[8 * i], s).error;
    });
    drop_mapped();
  }
  return third_quartile(cost);
}

float Simplifier::sampled_error_bound(const std::vector<uint32_t>& live,
                                      const std::vector<size_t>& starts,
                                      const std::vector<uint32_t>& block_of) {
  const size_t blocks = starts.size() - 1, step = std::max<size_t>(1, blocks / 16);
  std::vector<size_t> sampled;
  for (size_t b = 0; b < blocks; b += step) sampled.push_back(b);
  std::vector<BlockResult> results(sampled.size());
  parallel_chunks(sampled.size(), 1, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const size_t b = sampled[i];
      results[i] = simplify_block(&live[starts[b]], starts[b + 1] - starts[b], block_of,
                                  uint32_t(b), INFINITY, kCostsOnly);
    }
  });
  std::vector<float> cost;
  for (const BlockResult& r : results) cost.insert(cost.end(), r.costs.begin(), r.costs.end());
  return third_quartile(cost);
}

float Simplifier::third_quartile(std::vector<float>& cost) {
  if (cost.empty()) return INFINITY;
  const size_t q = cost.size() * 3 / 4;
  std::nth_element(cost.begin(), cost.begin() + ptrdiff_t(q), cost.end());
  return cost[q];
}

Simplifier::BlockResult Simplifier::simplify_block(const uint32_t* positions, size_t count,
                                                   const std::vector<uint32_t>& block_of,
                                                   uint32_t block, float bound, BlockMode mode) {
  BlockUnit b = make_block_unit(positions, count, block_of, block);
  Unit& sub = b.unit;
  const size_t kg = size_t(u_.channels) * 4;
  BlockResult out;
  std::unique_ptr<Simplifier> made;
  if (mode == kCopyQuadrics) {
    // The quadrics of the block's positions and their wedges (the others are never read).
    std::vector<Quadric> pq(b.global_pos.size()), aq(b.global_wedge.size());
    std::vector<double> gd(b.global_wedge.size() * kg, 0.0);
    for (size_t i = 0; i < count; ++i) pq[i] = pos_q_[positions[i]];
    for (size_t w = 0; w < b.global_wedge.size(); ++w) {
      if (sub.wedge_pos[w] >= count) continue;
      aq[w] = attr_q_[b.global_wedge[w]];
      std::copy_n(attr_gd_.begin() + ptrdiff_t(b.global_wedge[w] * kg), kg,
                  gd.begin() + ptrdiff_t(w * kg));
    }
    made = std::make_unique<Simplifier>(sub, std::move(pq), std::move(aq), std::move(gd), opt_,
                                        out.report);
  } else {
    // Made from the block's faces: every face around a block position is one of them, so its
    // quadrics are the whole unit's (the others' are partial and never read).
    made = std::make_unique<Simplifier>(sub, transforms_, opt_, out.report, Quadrics::kNowSerial);
  }
  Simplifier& s = *made;
  s.role_ = std::move(b.role);
  s.serial_ = true;
  if (mode == kCostsOnly) {
    s.begin_state();
    s.build_adjacency();
    Scratch scratch;
    for (uint32_t p = 0; p < count; p += 8)
      if (s.role_[p] == kFree) out.costs.push_back(s.best_candidate(p, scratch).error);
    return out;
  }
  s.keep_costing_ = true;
  s.stop_faces_ = b.faces.size() - b.owned * 3 / 4;
  s.stop_error_ = bound;
  s.run();
  // Back in the unit's numbering.
  out.collapses = s.collapses_;
  out.maps.reserve(s.maps_.size());
  for (const auto& [w, t] : s.maps_) out.maps.push_back({b.global_wedge[w], b.global_wedge[t]});
  out.removed_faces.reserve(s.removed_faces_.size());
  for (uint32_t f : s.removed_faces_) out.removed_faces.push_back(b.faces[f]);
  // The state the block leaves, written where only this block writes (see the file comment).
  for (size_t i = 0; i < b.faces.size(); ++i) {
    if (!b.face_owned[i]) continue;
    const uint32_t f = b.faces[i];
    alive_[f] = s.alive_[i];
    for (int c = 0; c < 3; ++c)
      u_.corners[3 * size_t(f) + size_t(c)] = b.global_wedge[sub.corners[3 * i + size_t(c)]];
  }
  for (size_t i = 0; i < count; ++i) dead_pos_[positions[i]] = s.dead_pos_[i];
  keep_block_quadrics(s, b, positions, count, mode == kCopyQuadrics, out);
  return out;
}

void Simplifier::keep_block_quadrics(const Simplifier& s, const BlockUnit& b,
                                     const uint32_t* positions, size_t count, bool keep_here,
                                     BlockResult& out) {
  const Unit& sub = b.unit;
  const size_t kg = size_t(u_.channels) * 4;
  if (!keep_here) {
    const size_t live =
        size_t(std::count(s.dead_pos_.begin(), s.dead_pos_.begin() + ptrdiff_t(count), 0));
    out.positions.reserve(live), out.pos_q.reserve(live);
  }
  for (size_t i = 0; i < count; ++i) {
    if (keep_here) {
      pos_q_[positions[i]] = s.pos_q_[i];
    } else if (!s.dead_pos_[i]) {
      out.positions.push_back(positions[i]);
      out.pos_q.push_back(s.pos_q_[i]);
    }
  }
  // Wedges in the unit's order (compact() appends the blocks' lists as they come).
  std::vector<uint32_t> order(b.global_wedge.size());
  for (uint32_t w = 0; w < order.size(); ++w) order[w] = w;
  std::sort(order.begin(), order.end(),
            [&](uint32_t x, uint32_t y) { return b.global_wedge[x] < b.global_wedge[y]; });
  if (!keep_here) {  // exact sizes: the level holds every block's lists at once
    size_t wedges = 0;
    for (uint32_t w : order) wedges += sub.wedge_pos[w] < count && !s.dead_pos_[sub.wedge_pos[w]];
    out.wedges.reserve(wedges), out.wedge_q.reserve(wedges), out.wedge_gd.reserve(wedges * kg);
  }
  for (uint32_t w : order) {
    const uint32_t p = sub.wedge_pos[w];
    if (p >= count) continue;
    const double* gd = &s.attr_gd_[w * kg];
    if (keep_here) {
      attr_q_[b.global_wedge[w]] = s.attr_q_[w];
      std::copy_n(gd, kg, attr_gd_.begin() + ptrdiff_t(b.global_wedge[w] * kg));
    } else if (!s.dead_pos_[p]) {
      out.wedges.push_back(b.global_wedge[w]);
      out.wedge_q.push_back(s.attr_q_[w]);
      out.wedge_gd.insert(out.wedge_gd.end(), gd, gd + kg);
    }
  }
  if (keep_here || !spill_ || !spill_->ok()) return;
  // To the spill file until compact() reads them back, block by block.
  const uint64_t a = spill_->put(out.pos_q.data(), out.pos_q.size() * sizeof(Quadric));
  const uint64_t w = spill_->put(out.wedge_q.data(), out.wedge_q.size() * sizeof(Quadric));
  const uint64_t g = spill_->put(out.wedge_gd.data(), out.wedge_gd.size() * sizeof(double));
  if (a == SpillFile::kFailed || w == SpillFile::kFailed || g == SpillFile::kFailed)
    return;  // kept here
  out.spilled = {a, w, g};
  std::vector<Quadric>().swap(out.pos_q), std::vector<Quadric>().swap(out.wedge_q);
  std::vector<double>().swap(out.wedge_gd);
}

Simplifier::Rest Simplifier::compact_unit(std::vector<uint32_t>& pos_id,
                                          std::vector<uint32_t>& wedge_id, size_t& live_pos,
                                          size_t& live_wedges) {
  const size_t np = u_.pos.size(), nw = u_.wedge_pos.size(), nf = alive_.size();
  const size_t k = size_t(u_.channels);
  Rest r;
  r.unit = std::make_unique<Unit>();
  Unit& rest = *r.unit;
  rest.channels = u_.channels, rest.normals = u_.normals;
  pos_id.assign(np, UINT32_MAX), wedge_id.assign(nw, UINT32_MAX);
  for (uint32_t f = 0; f < nf; ++f) {
    if (!alive_[f]) continue;
    r.face_of.push_back(f);
    for (int c = 0; c < 3; ++c) {
      const uint32_t w = u_.corners[3 * size_t(f) + size_t(c)];
      wedge_id[w] = 0, pos_id[u_.wedge_pos[w]] = 0;
    }
  }
  live_pos = 0, live_wedges = 0;
  for (uint32_t p = 0; p < np; ++p) live_pos += pos_id[p] == 0;
  for (uint32_t w = 0; w < nw; ++w) live_wedges += wedge_id[w] == 0;
  rest.pos.reserve(live_pos), rest.wedge_pos.reserve(live_wedges);
  rest.wedge_group.reserve(live_wedges), rest.attr.reserve(live_wedges * k);
  if (!u_.wedge_normal.empty()) rest.wedge_normal.reserve(live_wedges);
  r.wedge_of.reserve(live_wedges);
  // The unit keeps only what the record reads (before the quadrics come in), each array let go
  // as soon as the rest has its part (they would otherwise sit beside the rest's copies).
  auto release = [](auto& v) { std::remove_reference_t<decltype(v)>().swap(v); };
  for (uint32_t p = 0; p < np; ++p)
    if (pos_id[p] == 0) pos_id[p] = uint32_t(rest.pos.size()), rest.pos.push_back(u_.pos[p]);
  release(u_.pos);
  for (uint32_t w = 0; w < nw; ++w) {  // wedges stay by position (make_unit's spatial order)
    if (wedge_id[w] != 0) continue;
    wedge_id[w] = uint32_t(r.wedge_of.size());
    r.wedge_of.push_back(w);
    rest.wedge_pos.push_back(pos_id[u_.wedge_pos[w]]);
    rest.wedge_group.push_back(u_.wedge_group[w]);
    if (!u_.wedge_normal.empty()) rest.wedge_normal.push_back(u_.wedge_normal[w]);
    rest.attr.insert(rest.attr.end(), u_.attr.begin() + ptrdiff_t(w * k),
                     u_.attr.begin() + ptrdiff_t((w + 1) * k));
  }
  release(u_.attr), release(u_.wedge_group), release(u_.wedge_normal);  // u_.normals stays
  rest.corners.reserve(3 * r.face_of.size());
  for (uint32_t f : r.face_of)
    for (int c = 0; c < 3; ++c)
      rest.corners.push_back(wedge_id[u_.corners[3 * size_t(f) + size_t(c)]]);
  release(u_.corners), release(dead_pos_), release(queued_);
  pos_faces_.release();
  return r;
}

// A rest being made: the live part as a unit of its own, each live position's and wedge's
// number in it (UINT32_MAX: dead), and its quadrics' arrays, to be filled.
struct Simplifier::RestDraft {
  Rest rest;
  std::vector<uint32_t> pos_id, wedge_id;
  size_t live_pos = 0, live_wedges = 0;
  std::shared_ptr<MappedPages> pages;  // the arrays' pages, or null: memory
  Store<Quadric> pq, aq;
  Store<double> gd;
  // The rest's Simplifier, the arrays moved in.
  Rest finish(const SimplifyOptions& opt, SimplifyReport& report) {
    rest.s = std::make_unique<Simplifier>(*rest.unit, std::move(pq), std::move(aq), std::move(gd),
                                          opt, report, std::move(pages));
    return std::move(rest);
  }
};

Simplifier::RestDraft Simplifier::draft_rest(bool mapped) {
  RestDraft d;
  d.rest = compact_unit(d.pos_id, d.wedge_id, d.live_pos, d.live_wedges);
  const size_t kg = size_t(u_.channels) * 4;
  const size_t pq_bytes = d.live_pos * sizeof(Quadric);
  const size_t aq_bytes = d.live_wedges * sizeof(Quadric);
  if (mapped && !opt_.spill_dir.empty())
    d.pages =
        SpillFile(opt_.spill_dir).map(pq_bytes + aq_bytes + d.live_wedges * kg * sizeof(double));
  if (d.pages) {
    report_.mapped_bytes += d.pages->bytes;
    char* base = static_cast<char*>(d.pages->base);
    d.pq = Store<Quadric>(reinterpret_cast<Quadric*>(base), d.live_pos);
    d.aq = Store<Quadric>(reinterpret_cast<Quadric*>(base + pq_bytes), d.live_wedges);
    d.gd = Store<double>(reinterpret_cast<double*>(base + pq_bytes + aq_bytes), d.live_wedges * kg);
  } else {
    d.pq.assign(d.live_pos, Quadric{}), d.aq.assign(d.live_wedges, Quadric{});
    d.gd.assign(d.live_wedges * kg, 0.0);
  }
  return d;
}

Simplifier::Rest Simplifier::compact(std::vector<BlockResult>& results) {
  const size_t kg = size_t(u_.channels) * 4;
  RestDraft d = draft_rest(true);
  // The quadrics the blocks made: every live position is one block's, with its wedges. The
  // blocks hold runs of positions, so each fills a run of the rest's arrays; each block's lists
  // are freed once placed (or read back from the spill file), and the rest's arrays fill as
  // they go (never both whole at once). Blocks on every core: each writes only its own slots,
  // so the arrays are the same whatever the thread count, and the first touch of their fresh
  // pages (a file's: 1.4 GB at 20M triangles, 2.6 s of faults on one core) is shared.
  std::atomic<size_t> freed{0}, pn{0}, wn{0};
  parallel_chunks(results.size(), 1, [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) {
      BlockResult& b = results[k];
      if (b.spilled) {
        b.pos_q.resize(b.positions.size()), b.wedge_q.resize(b.wedges.size());
        b.wedge_gd.resize(b.wedges.size() * kg);
        spill_->get((*b.spilled)[0], b.pos_q.data(), b.pos_q.size() * sizeof(Quadric));
        spill_->get((*b.spilled)[1], b.wedge_q.data(), b.wedge_q.size() * sizeof(Quadric));
        spill_->get((*b.spilled)[2], b.wedge_gd.data(), b.wedge_gd.size() * sizeof(double));
      }
      size_t placed_pos = 0, placed_wedges = 0;
      for (size_t i = 0; i < b.positions.size(); ++i)
        if (const uint32_t to = d.pos_id[b.positions[i]]; to != UINT32_MAX)
          d.pq[to] = b.pos_q[i], ++placed_pos;
      for (size_t i = 0; i < b.wedges.size(); ++i)
        if (const uint32_t to = d.wedge_id[b.wedges[i]]; to != UINT32_MAX) {
          d.aq[to] = b.wedge_q[i];
          std::copy_n(b.wedge_gd.begin() + ptrdiff_t(i * kg), kg, d.gd.begin() + size_t(to) * kg);
          ++placed_wedges;
        }
      pn += placed_pos, wn += placed_wedges;
      b = BlockResult{};
      // The blocks' lists live in the allocator's arenas, which keep freed pages: handed back
      // as we go, or the rest's arrays would come on top of them (4M scan: +220 MB at the
      // peak); the rest's pages written so far go to the file (dropping a page another thread
      // is writing only unmaps it: the file keeps what was written).
      if (++freed % 8 == 0) {
        malloc_trim(0);
        if (d.pages) d.pages->drop();
      }
    }
  });
  malloc_trim(0);
  if (d.pages) d.pages->drop();
  if (pn != d.live_pos || wn != d.live_wedges)
    throw std::logic_error("simplify: block levels: a live position or wedge without quadrics");
  return d.finish(opt_, report_);
}

Simplifier::Rest Simplifier::compact_quadrics(bool mapped) {
  const size_t kg = size_t(u_.channels) * 4;
  RestDraft d = draft_rest(mapped);
  auto drop = [&] {  // the pages read and written so far, out of memory
    drop_mapped();
    if (d.pages) d.pages->drop();
  };
  constexpr size_t kRun = 65536;  // positions or wedges between drops
  for (size_t p = 0; p < d.pos_id.size(); ++p) {
    if (d.pos_id[p] != UINT32_MAX) d.pq[d.pos_id[p]] = pos_q_[p];
    if (p % kRun == kRun - 1) drop();
  }
  drop();
  for (size_t w = 0; w < d.wedge_id.size(); ++w) {
    if (const uint32_t to = d.wedge_id[w]; to != UINT32_MAX) {
      d.aq[to] = attr_q_[w];
      std::copy_n(attr_gd_.begin() + w * kg, kg, d.gd.begin() + size_t(to) * kg);
    }
    if (w % kRun == kRun - 1) drop();
  }
  drop();
  auto release = [](auto& v) { std::remove_reference_t<decltype(v)>().swap(v); };
  release(pos_q_), release(attr_q_), release(attr_gd_), mapped_.reset();
  return d.finish(opt_, report_);
}

void Simplifier::reserve_history(const std::vector<BlockResult>& results) {
  size_t collapses = collapses_.size(), maps = maps_.size(), faces = removed_faces_.size();
  for (const BlockResult& r : results)
    collapses += r.collapses.size(), maps += r.maps.size(), faces += r.removed_faces.size();
  collapses_.reserve(collapses), maps_.reserve(maps), removed_faces_.reserve(faces);
}

void Simplifier::hand_blocks(Simplifier& rest) {
  rest.blocks_ = std::move(blocks_);
  rest.collapse_block_.clear();
}

void Simplifier::absorb(Rest& rest) {
  Simplifier& t = *rest.s;
  blocks_ = std::move(t.blocks_);
  if (!t.collapse_block_.empty()) {
    collapse_block_.resize(collapses_.size(), 0);
    collapse_block_.insert(collapse_block_.end(), t.collapse_block_.begin(),
                           t.collapse_block_.end());
  }
  std::vector<uint16_t>().swap(t.collapse_block_);
  collapses_.reserve(collapses_.size() + t.collapses_.size());
  maps_.reserve(maps_.size() + t.maps_.size());
  removed_faces_.reserve(removed_faces_.size() + t.removed_faces_.size());
  for (const Collapse& c0 : t.collapses_) {
    Collapse c = c0;
    c.first_map = uint32_t(maps_.size()), c.first_face = uint32_t(removed_faces_.size());
    for (uint32_t i = 0; i < c0.map_count; ++i) {
      const auto& [w, target] = t.maps_[c0.first_map + i];
      maps_.push_back({rest.wedge_of[w], rest.wedge_of[target]});
    }
    for (uint32_t i = 0; i < c0.face_count; ++i)
      removed_faces_.push_back(rest.face_of[t.removed_faces_[c0.first_face + i]]);
    collapses_.push_back(c);
  }
  for (size_t i = 0; i < rest.face_of.size(); ++i) alive_[rest.face_of[i]] = t.alive_[i];
  live_faces_ = t.live_faces_;
  finished_ = true;
}

}  // namespace meshmux::simplify_detail
