// The block hierarchy's DAG: see block_dag.h (Ponchio and Dellepiane, Nexus; Hoppe,
// view-dependent refinement).
#include "simplify/block_dag.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
#include <string>
#include <tuple>

namespace meshmux {

namespace {

constexpr uint16_t kNone = 0xFFFF;

void include(BlockNode& n, const Vec3& p) {
  n.box_min = {std::min(n.box_min.x, p.x), std::min(n.box_min.y, p.y), std::min(n.box_min.z, p.z)};
  n.box_max = {std::max(n.box_max.x, p.x), std::max(n.box_max.y, p.y), std::max(n.box_max.z, p.z)};
}

// Per vertex, a number shared by exactly the vertices at the same position (its bits): the
// twin chains' keys (the decoder keys them by position). A sort of the vertices by position.
std::vector<uint32_t> position_ids(const std::vector<Vec3>& positions) {
  auto bits = [&](uint32_t v) {
    std::array<uint32_t, 3> k;
    std::memcpy(k.data(), &positions[v], 12);
    return k;
  };
  std::vector<uint32_t> order(positions.size()), id(positions.size(), 0);
  for (uint32_t v = 0; v < order.size(); ++v) order[v] = v;
  std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) { return bits(a) < bits(b); });
  for (size_t i = 1; i < order.size(); ++i)
    id[order[i]] = id[order[i - 1]] + (bits(order[i]) != bits(order[i - 1]) ? 1 : 0);
  return id;
}

// Kahn's order of the blocks (ascending ids among the ready ones), or empty on a cycle.
std::vector<uint16_t> topological_order(const std::vector<std::vector<uint16_t>>& deps) {
  const size_t n = deps.size();
  std::vector<std::vector<uint16_t>> users(n);
  std::vector<uint32_t> waiting(n, 0);
  for (size_t x = 0; x < n; ++x)
    for (uint16_t d : deps[x]) users[d].push_back(uint16_t(x)), ++waiting[x];
  std::vector<uint16_t> ready, order;
  for (size_t x = n; x-- > 0;)
    if (waiting[x] == 0) ready.push_back(uint16_t(x));
  while (!ready.empty()) {
    std::sort(ready.begin(), ready.end(), std::greater<uint16_t>());
    const uint16_t x = ready.back();
    ready.pop_back();
    order.push_back(x);
    for (uint16_t u : users[x])
      if (--waiting[u] == 0) ready.push_back(u);
  }
  if (order.size() != n) order.clear();
  return order;
}

// Drops each dependency reachable through another (bitsets of reachability in topological
// order); left as found past kReduceLimit blocks (the bitsets would grow as the square).
constexpr size_t kReduceLimit = 8192;
void reduce(std::vector<std::vector<uint16_t>>& deps, const std::vector<uint16_t>& order) {
  const size_t n = deps.size();
  if (n > kReduceLimit) return;
  const size_t words = (n + 63) / 64;
  std::vector<uint64_t> reach(n * words, 0);  // reach[x]: blocks x depends on, transitively
  for (uint16_t x : order) {
    uint64_t* rx = &reach[size_t(x) * words];
    for (uint16_t d : deps[x]) {
      const uint64_t* rd = &reach[size_t(d) * words];
      for (size_t w = 0; w < words; ++w) rx[w] |= rd[w];
    }
    std::vector<uint16_t> kept;
    for (uint16_t d : deps[x]) {
      bool through = false;
      for (uint16_t e : deps[x])
        if (e != d && (reach[size_t(e) * words + d / 64] >> (d % 64) & 1)) through = true;
      if (!through) kept.push_back(d);
    }
    for (uint16_t d : deps[x]) rx[d / 64] |= uint64_t(1) << (d % 64);
    deps[x] = std::move(kept);
  }
}

}  // namespace

BlockReplay::BlockReplay(const ProgressiveMesh& pm, bool keep_corners)
    : pm_(pm), keep_corners_(keep_corners) {
  const size_t nv = pm.vertex_count(), nf = pm.face_count();
  // Ancestry as intervals (depth-first numbering; parents precede children).
  size_.assign(nv, 1), enter_.assign(nv, 0);
  for (size_t v = nv; v-- > 0;)
    if (pm.parent[v] < v) size_[pm.parent[v]] += size_[v];
  {
    std::vector<uint32_t> next_free(nv, 0);
    uint32_t roots = 0;
    for (uint32_t v = 0; v < nv; ++v) {
      const uint32_t up = pm.parent[v];
      if (up >= v)
        enter_[v] = roots, roots += size_[v];
      else
        enter_[v] = next_free[up], next_free[up] += size_[v];
      next_free[v] = enter_[v] + 1;
    }
  }
  present_.assign(nv, 0), appeared_.assign(nf, 0);
  if (keep_corners_) cur_.assign(3 * nf, 0);
  next_.assign(3 * nf, -1), head_.assign(nv, -1);
  mark_face_.assign(nf, 0), mark_list_.assign(nv, 0);
  const ProgressiveLevel& first = pm.levels.front();
  for (uint32_t v = 0; v < first.vertex_end; ++v) present_[v] = 1;
  for (uint32_t f = 0; f < first.face_end; ++f) {
    appeared_[f] = 1;
    for (int k = 0; k < 3; ++k) {
      const size_t c = 3 * size_t(f) + size_t(k);
      const uint32_t x = mapped(pm.indices[c]);
      if (keep_corners_) cur_[c] = x;
      next_[c] = head_[x], head_[x] = int32_t(c);
    }
  }
}

uint32_t BlockReplay::mapped(uint32_t v) const {
  while (!present_[v] && pm_.parent[v] < v) v = pm_.parent[v];
  return v;
}

std::vector<uint32_t>& BlockReplay::twins_at(uint32_t p) {
  std::array<uint32_t, 3> key;
  std::memcpy(key.data(), &pm_.positions[p], 12);
  return twins_[key];
}

void BlockReplay::sign_list(uint32_t v) {
  for (int32_t c = head_[v]; c >= 0; c = next_[size_t(c)]) {
    const size_t f = size_t(c) / 3;
    sign(uint64_t(c));
    for (int k = 0; k < 3; ++k) sign(cur_[3 * f + size_t(k)]);
  }
  sign(~0ull);
}

std::vector<uint32_t> BlockReplay::corner_list(uint32_t v) const {
  std::vector<uint32_t> out;
  for (int32_t c = head_[v]; c >= 0; c = next_[size_t(c)]) out.push_back(uint32_t(c));
  return out;
}

Status BlockReplay::apply_level(size_t r) {
  lists_touched.clear(), faces_written.clear(), faces_read.clear(), parents.clear();
  signature = signatures ? 14695981039346656037ull : 0;
  auto fail = [&](const std::string& what) {
    return Status::error("block replay: level " + std::to_string(r) + ": " + what,
                         ErrorKind::kInternal);
  };
  if (r == 0 || r >= pm_.levels.size()) return fail("no such level");
  const ProgressiveLevel &before = pm_.levels[r - 1], &after = pm_.levels[r];
  std::vector<uint32_t>& faces = met_;  // met, in order (marks: 1 read, 2 written)
  faces.clear();
  auto list = [&](uint32_t v) {
    if (!mark_list_[v]) mark_list_[v] = 1, lists_touched.push_back(v);
  };
  auto face = [&](uint32_t f, uint8_t how) {
    if (!mark_face_[f]) faces.push_back(f);
    mark_face_[f] = std::max(mark_face_[f], how);
  };
  for (uint32_t v = before.vertex_end; v < after.vertex_end; ++v) {
    const uint32_t p = pm_.parent[v];
    if (p >= v || !present_[p] || present_[v])
      return fail("vertex " + std::to_string(v) + ": its parent " + std::to_string(p) +
                  " is not present");
    present_[v] = 1;
    list(p), list(v), parents.push_back(p);
    if (signatures && keep_corners_) {
      sign(p), sign_list(p);
      std::vector<uint32_t>& twins = twins_at(p);
      for (size_t i = twins.size(); i-- > 0 && twins.size() - i <= 4;) sign(twins[i]);
      twins.push_back(v);
    }
    int32_t previous = -1;
    for (int32_t c = head_[p]; c >= 0;) {
      const int32_t following = next_[size_t(c)];
      face(uint32_t(c) / 3, 1);
      const uint32_t o = enter_[pm_.indices[size_t(c)]];
      if (enter_[v] <= o && o < enter_[v] + size_[v]) {  // descends from v: v stands for it now
        (previous < 0 ? head_[p] : next_[size_t(previous)]) = following;
        next_[size_t(c)] = head_[v], head_[v] = c;
        if (keep_corners_) cur_[size_t(c)] = v;
        face(uint32_t(c) / 3, 2);
      } else {
        previous = c;
      }
      c = following;
    }
  }
  for (uint32_t f = before.face_end; f < after.face_end; ++f) {
    if (appeared_[f]) return fail("face " + std::to_string(f) + " appeared before");
    appeared_[f] = 1;
    uint32_t held[3];
    for (int k = 0; k < 3; ++k) {
      const size_t c = 3 * size_t(f) + size_t(k);
      const uint32_t x = mapped(pm_.indices[c]);
      if (!present_[x]) return fail("face " + std::to_string(f) + ": no present corner");
      held[k] = x;
      if (keep_corners_) cur_[c] = x;
      next_[c] = head_[x], head_[x] = int32_t(c);
      list(x);
    }
    if (held[0] == held[1] || held[1] == held[2] || held[0] == held[2])
      return fail("face " + std::to_string(f) + " is degenerate");
    face(f, 2);
  }
  // The ring and predictors read every face around the new vertices once they are made.
  for (uint32_t v = before.vertex_end; v < after.vertex_end; ++v) {
    for (int32_t c = head_[v]; c >= 0; c = next_[size_t(c)]) face(uint32_t(c) / 3, 1);
    if (signatures && keep_corners_) sign_list(v), sign_list(pm_.parent[v]);
  }
  for (uint32_t f : faces) {
    (mark_face_[f] == 2 ? faces_written : faces_read).push_back(f);
    mark_face_[f] = 0;
  }
  for (uint32_t v : lists_touched) mark_list_[v] = 0;
  return Status::ok();
}

Result<BlockDag> block_dag(const ProgressiveMesh& pm) {
  const size_t blocks = pm.blocks.size();
  auto fail = [](const std::string& what) {
    return Status::error("block dag: " + what, ErrorKind::kInternal);
  };
  if (blocks == 0 || pm.level_block.size() + 1 != pm.levels.size() || blocks > kNone)
    return fail("the record has no block hierarchy");
  BlockDag dag;
  dag.nodes.resize(blocks);
  for (size_t b = 0; b < blocks; ++b) {
    dag.nodes[b].error = pm.blocks[b].error;
    dag.nodes[b].box_min = {INFINITY, INFINITY, INFINITY};
    dag.nodes[b].box_max = {-INFINITY, -INFINITY, -INFINITY};
  }
  std::vector<std::vector<uint16_t>> deps(blocks);
  std::vector<uint16_t> list_last(pm.vertex_count(), kNone), writer(pm.face_count(), kNone);
  std::vector<std::array<uint16_t, 3>> readers(pm.face_count(), {kNone, kNone, kNone});
  const std::vector<uint32_t> position_id = position_ids(pm.positions);
  std::vector<uint16_t> twin_last(pm.vertex_count(), kNone);  // per position id
  BlockReplay replay(pm, /*keep_corners=*/false);
  for (size_t r = 1; r < pm.levels.size(); ++r) {
    const uint16_t x = pm.level_block[r - 1];
    if (x >= blocks) return fail("level " + std::to_string(r) + ": no block " + std::to_string(x));
    if (Status s = replay.apply_level(r); !s) return s;
    BlockNode& node = dag.nodes[x];
    if (node.levels++ == 0) node.first_level = uint32_t(r);
    node.vertices += pm.levels[r].vertex_end - pm.levels[r - 1].vertex_end;
    node.faces += pm.levels[r].face_end - pm.levels[r - 1].face_end;
    auto depend = [&](uint16_t y) {  // repeats in a row dropped (most are): sorted out below
      if (y != kNone && y != x && (deps[x].empty() || deps[x].back() != y)) deps[x].push_back(y);
    };
    for (uint32_t v : replay.lists_touched) {
      depend(list_last[v]), list_last[v] = x;
      include(node, pm.positions[v]);
    }
    for (uint32_t p : replay.parents) {
      uint16_t& last = twin_last[position_id[p]];
      depend(last), last = x;
    }
    for (uint32_t f : replay.faces_read) {
      depend(writer[f]);
      std::array<uint16_t, 3>& rd = readers[f];
      if (std::find(rd.begin(), rd.end(), x) != rd.end()) continue;
      auto slot = std::find(rd.begin(), rd.end(), kNone);
      if (slot == rd.end()) {
        // Readers of coarser levels give way: this block then depends on them, so a later
        // writer that depends on it is ordered after them too.
        for (uint16_t& y : rd)
          if (pm.blocks[y].level != pm.blocks[x].level) depend(y), y = kNone;
        slot = std::find(rd.begin(), rd.end(), kNone);
        if (slot == rd.end()) {  // cannot happen: a level has ≤ 3 readers of a face
          for (uint16_t& y : rd) depend(y), y = kNone;
          slot = rd.begin();
        }
      }
      *slot = x;
    }
    for (uint32_t f : replay.faces_written) {
      depend(writer[f]);
      for (uint16_t& y : readers[f]) depend(y), y = kNone;
      writer[f] = x;
    }
  }
  for (auto& d : deps) {
    std::sort(d.begin(), d.end());
    d.erase(std::unique(d.begin(), d.end()), d.end());
  }
  const std::vector<uint16_t> order = topological_order(deps);
  if (order.empty()) return fail("the blocks' dependencies form a cycle");
  reduce(deps, order);
  for (size_t b = 0; b < blocks; ++b) {
    dag.nodes[b].deps = std::move(deps[b]);
    if (dag.nodes[b].levels == 0) dag.nodes[b].box_min = dag.nodes[b].box_max = Vec3{};
  }
  return dag;
}

namespace {

// v's items in their new order: the first `kept` as they are, then each run (old first item,
// count) in turn. Out of place, one array at a time, each copy sequential: a level's vertices and
// faces move as runs, where following the permutation's cycles item by item wrote all over the
// array (a 20M-triangle record: seconds of cache misses); the copy held beside the record is at
// most the faces' indices (12 bytes a face), below what the DAG's replay holds after it.
template <typename T>
void gather_runs(std::vector<T>& v, size_t kept,
                 const std::vector<std::pair<uint32_t, uint32_t>>& runs, size_t stride) {
  if (v.empty()) return;
  std::vector<T> out;
  out.reserve(v.size());
  out.insert(out.end(), v.begin(), v.begin() + long(kept * stride));
  for (const auto& [first, count] : runs)
    out.insert(out.end(), v.begin() + long(size_t(first) * stride),
               v.begin() + long((size_t(first) + count) * stride));
  v.swap(out);
}

}  // namespace

// The root's pieces: each ends at the first level past kRootGrowth times the triangles it
// started from, and at least kRootPieceMin triangles on (order_by_blocks).
constexpr double kRootGrowth = 1.25;  // finer than the stream's layers grow (~1.8× at 4M)
constexpr uint32_t kRootPieceMin = 1024;

Status order_by_blocks(ProgressiveMesh& pm) {
  auto fail = [](const std::string& what) {
    return Status::error("block order: " + what, ErrorKind::kInternal);
  };
  const size_t levels = pm.levels.size(), blocks = pm.blocks.size();
  if (blocks == 0 || pm.level_block.size() + 1 != levels)
    return fail("the record has no block hierarchy");
  for (uint16_t b : pm.level_block)
    if (b >= blocks) return fail("a level's block " + std::to_string(b) + " does not exist");
  // The new order of the levels 1..m: by block (the root's level is the highest; within a level,
  // the blocks of larger error first, as a greedy simplifier's chain would refine them: a level's
  // blocks never depend on each other), then as recorded.
  std::vector<uint32_t> order(levels - 1);
  for (size_t r = 1; r < levels; ++r) order[r - 1] = uint32_t(r);
  auto rank = [&](uint32_t r) {
    const ProgressiveBlock& b = pm.blocks[pm.level_block[r - 1]];
    return std::make_tuple(-int(b.level), -b.error, b.block, r);
  };
  std::stable_sort(order.begin(), order.end(),
                   [&](uint32_t a, uint32_t b) { return rank(a) < rank(b); });
  // Where each vertex and face goes.
  const ProgressiveLevel first = pm.levels.front();
  std::vector<uint32_t> vertex_to(pm.vertex_count()), face_to(pm.face_count());
  for (uint32_t v = 0; v < first.vertex_end; ++v) vertex_to[v] = v;
  for (uint32_t f = 0; f < first.face_end; ++f) face_to[f] = f;
  uint32_t nv = first.vertex_end, nf = first.face_end;
  std::vector<ProgressiveLevel> out_levels = {first};
  std::vector<uint16_t> out_block;
  std::vector<std::pair<uint32_t, uint32_t>> vertex_runs, face_runs;  // (old first, count)
  for (uint32_t r : order) {
    const ProgressiveLevel &a = pm.levels[r - 1], &b = pm.levels[r];
    vertex_runs.push_back({a.vertex_end, b.vertex_end - a.vertex_end});
    face_runs.push_back({a.face_end, b.face_end - a.face_end});
    for (uint32_t v = a.vertex_end; v < b.vertex_end; ++v) vertex_to[v] = nv++;
    for (uint32_t f = a.face_end; f < b.face_end; ++f) face_to[f] = nf++;
    out_levels.push_back({nv, nf, nf, 0});
    out_block.push_back(pm.level_block[r - 1]);
  }
  // Errors: the largest error of the blocks with a level still to apply.
  std::vector<uint32_t> left(blocks, 0);
  for (uint16_t b : out_block) ++left[b];
  std::multiset<float> open;
  for (size_t b = 0; b < blocks; ++b)
    if (left[b]) open.insert(pm.blocks[b].error);
  for (size_t r = 0; r < out_levels.size(); ++r) {
    out_levels[r].error = open.empty() ? 0.0f : *open.rbegin();
    if (r + 1 < out_levels.size() && --left[out_block[r]] == 0)
      open.erase(open.find(pm.blocks[out_block[r]].error));
  }
  // The root's levels are the record's first ones, in place: their errors stay exact.
  size_t root_levels = 0;
  while (root_levels < out_block.size() && out_block[root_levels] == 0) ++root_levels;
  for (size_t r = 0; r <= root_levels; ++r) out_levels[r].error = pm.levels[r].error;
  // The base: where it was while the root holds it.
  const size_t base = std::min(pm.base_level, root_levels);
  // The arrays renumbered.
  for (uint32_t& p : pm.parent) p = vertex_to[p];
  for (uint32_t& i : pm.indices) i = vertex_to[i];
  std::vector<uint32_t>().swap(vertex_to), std::vector<uint32_t>().swap(face_to);
  gather_runs(pm.parent, first.vertex_end, vertex_runs, 1);
  gather_runs(pm.positions, first.vertex_end, vertex_runs, 1);
  gather_runs(pm.normals, first.vertex_end, vertex_runs, 1);
  for (std::vector<Vec2>& uv : pm.uvs) gather_runs(uv, first.vertex_end, vertex_runs, 1);
  gather_runs(pm.colors, first.vertex_end, vertex_runs, 1);
  gather_runs(pm.indices, first.face_end, face_runs, 3);
  gather_runs(pm.face_primitive, first.face_end, face_runs, 1);
  pm.levels = std::move(out_levels);
  pm.base_level = base;
  // The root (one global chain, every block's ancestor) in pieces of growing triangles from the
  // coarsest level, each a block of its own after the one before it: a stream's parts are whole
  // blocks, and the root whole would be one part from the base to a quarter of a million faces.
  std::vector<ProgressiveBlock> kept;
  {
    uint32_t start = std::max<uint32_t>(pm.levels[0].triangles, 1);
    for (size_t r = 1; r <= root_levels; ++r) {
      if (kept.empty() || (r > 1 && pm.levels[r - 1].triangles >= kRootGrowth * double(start) &&
                           pm.levels[r - 1].triangles - start >= kRootPieceMin)) {
        if (!kept.empty()) start = pm.levels[r - 1].triangles;
        ProgressiveBlock piece = pm.blocks[0];
        piece.block = uint32_t(kept.size());
        piece.error = pm.levels[r - 1].error;  // the largest collapse it undoes and after
        kept.push_back(piece);
      }
      if (kept.size() >= 0xFFFF - blocks) return fail("the root in too many pieces");
      out_block[r - 1] = uint16_t(kept.size() - 1);
    }
  }
  // The other blocks renumbered in the order their runs come; blocks that made no collapse are
  // dropped.
  std::vector<uint16_t> renumber(blocks, kNone);
  for (size_t i = root_levels; i < out_block.size(); ++i) {
    uint16_t& b = out_block[i];
    if (renumber[b] == kNone) renumber[b] = uint16_t(kept.size()), kept.push_back(pm.blocks[b]);
    b = renumber[b];
  }
  pm.blocks = std::move(kept);
  pm.level_block = std::move(out_block);
  return Status::ok();
}

Status order_block_records(ProgressiveScene& ps) {
  for (size_t m = 0; m < ps.meshes.size(); ++m) {
    ProgressiveMesh& pm = ps.meshes[m];
    if (pm.blocks.empty()) continue;
    const std::string where = "simplify: mesh " + std::to_string(m);
    if (Status s = order_by_blocks(pm); !s) return s.with_prefix(where);
    Result<BlockDag> dag = block_dag(pm);
    if (!dag) return dag.status().with_prefix(where);
    for (size_t b = 0; b < pm.blocks.size(); ++b) {
      BlockNode& node = dag->nodes[b];
      for (uint16_t d : node.deps)
        if (d >= b)
          return Status::error(where + ": block " + std::to_string(b) +
                                   " depends on a later block " + std::to_string(d),
                               ErrorKind::kInternal);
      pm.blocks[b].deps = std::move(node.deps);
      pm.blocks[b].box_min = node.box_min, pm.blocks[b].box_max = node.box_max;
    }
  }
  return Status::ok();
}

}  // namespace meshmux
