// Chart packing with no chart crossing a power-of-two boundary (see pack.h).
//
// Reference implemented: Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion of
// 3D models for interactive metaverses" §4.4 ("Packing Charts into Atlas"): charts are inserted in
// decreasing order of size into a tree whose nodes are regions of the atlas; the tree is traversed
// recursively (here: depth first, first fit, with an explicit stack) until a free region holds the
// chart without it crossing a power-of-two boundary, and the chosen region is split (guillotine
// cuts) into the placement and the remaining free space.
//
// The boundary rule: a rectangle of largest side m, s = the power of two ≥ m, must lie inside one
// cell of the aligned grid of spacing s (aligned cells nest, so it then lies inside one cell of
// every coarser grid too). Inside a free region the first position that satisfies this is found
// per axis: the region's corner if the rectangle stays within the corner's s-cell, otherwise the
// next multiple of s. The strips skipped that way stay free for smaller rectangles, which come
// later and have smaller cells.
#include "atlas/pack.h"

#include <algorithm>
#include <limits>

namespace meshmux {
namespace {

long long next_pow2(long long v) {
  long long p = 1;
  while (p < v) p <<= 1;
  return p;
}

long long floor_div(long long a, long long b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }

// The first coordinate ≥ lo at which an extent `len` (≤ s) stays inside one aligned s-cell.
long long snap(long long lo, long long len, long long s) {
  long long cell = floor_div(lo, s);
  if (lo + len <= (cell + 1) * s) return lo;
  return (cell + 1) * s;
}

struct Node {
  int x = 0, y = 0, w = 0, h = 0;
  int child[2] = {-1, -1};
  int parent = -1;
  bool used = false;
  // Upper bounds over the live free leaves below (0 when none), for pruning: largest width,
  // height, shorter side and area.
  int free_w = 0, free_h = 0, free_min = 0;
  long long free_area = 0;
  bool leaf() const { return child[0] < 0; }
};

class Packer {
 public:
  explicit Packer(int size) {
    Node root;
    root.w = root.h = size;
    nodes_.push_back(root);
    refresh(0);
  }

  // Every rectangle still to come has a shorter side ≥ min_side and an area ≥ min_area (these
  // only grow as packing proceeds): free leaves smaller than that are dead for good and no
  // longer counted in the pruning bounds of new leaves.
  void set_floor(int min_side, long long min_area) {
    floor_side_ = min_side;
    floor_area_ = min_area;
  }

  // Places a w × h rectangle; false when no free region can take it.
  bool insert(int w, int h, PackPlacement* out) {
    const long long s = next_pow2(std::max(w, h));
    std::vector<int> stack{0};
    while (!stack.empty()) {
      int n = stack.back();
      stack.pop_back();
      const Node& node = nodes_[size_t(n)];
      if (node.free_w < w || node.free_h < h || node.free_min < std::min(w, h) ||
          node.free_area < (long long)w * h)
        continue;
      if (!node.leaf()) {
        stack.push_back(node.child[1]);  // child 0 is visited first
        stack.push_back(node.child[0]);
        continue;
      }
      long long px = snap(node.x, w, s), py = snap(node.y, h, s);
      if (px + w > node.x + node.w || py + h > node.y + node.h) continue;
      place(n, int(px), int(py), w, h);
      out->x = int(px);
      out->y = int(py);
      return true;
    }
    return false;
  }

 private:
  int add(int parent, int x, int y, int w, int h) {
    Node c;
    c.x = x;
    c.y = y;
    c.w = w;
    c.h = h;
    c.parent = parent;
    nodes_.push_back(c);
    refresh(int(nodes_.size()) - 1);
    return int(nodes_.size()) - 1;
  }

  void split(int n, bool vertical, int at) {
    Node nd = nodes_[size_t(n)];
    int a, b;
    if (vertical) {  // cut at x = at
      a = add(n, nd.x, nd.y, at - nd.x, nd.h);
      b = add(n, at, nd.y, nd.x + nd.w - at, nd.h);
    } else {  // cut at y = at
      a = add(n, nd.x, nd.y, nd.w, at - nd.y);
      b = add(n, nd.x, at, nd.w, nd.y + nd.h - at);
    }
    nodes_[size_t(n)].child[0] = a;
    nodes_[size_t(n)].child[1] = b;
  }

  // Splits leaf n until a leaf is exactly the rectangle at (px, py), marks it used and refreshes
  // the pruning bounds up to the root.
  void place(int n, int px, int py, int w, int h) {
    for (;;) {
      const Node nd = nodes_[size_t(n)];
      if (px > nd.x) {  // free strip on the left, skipped to respect the boundary
        split(n, true, px);
        n = nodes_[size_t(n)].child[1];
      } else if (py > nd.y) {  // free strip above
        split(n, false, py);
        n = nodes_[size_t(n)].child[1];
      } else if (nd.w == w && nd.h == h) {
        break;
      } else if (nd.w == w) {
        split(n, false, py + h);
        n = nodes_[size_t(n)].child[0];
      } else if (nd.h == h) {
        split(n, true, px + w);
        n = nodes_[size_t(n)].child[0];
      } else {
        // Both remainders non-empty: cut across the shorter leftover so the larger free piece
        // keeps the region's full extent (the classic guillotine rule).
        bool vertical = (nd.w - w) > (nd.h - h);
        split(n, vertical, vertical ? px + w : py + h);
        n = nodes_[size_t(n)].child[0];
      }
    }
    nodes_[size_t(n)].used = true;
    for (int m = n; m >= 0; m = nodes_[size_t(m)].parent) refresh(m);
  }

  void refresh(int n) {
    Node& nd = nodes_[size_t(n)];
    if (nd.leaf()) {
      const long long area = (long long)nd.w * nd.h;
      const bool live = !nd.used && std::min(nd.w, nd.h) >= floor_side_ && area >= floor_area_;
      nd.free_w = live ? nd.w : 0;
      nd.free_h = live ? nd.h : 0;
      nd.free_min = live ? std::min(nd.w, nd.h) : 0;
      nd.free_area = live ? area : 0;
      return;
    }
    const Node& a = nodes_[size_t(nd.child[0])];
    const Node& b = nodes_[size_t(nd.child[1])];
    nd.free_w = std::max(a.free_w, b.free_w);
    nd.free_h = std::max(a.free_h, b.free_h);
    nd.free_min = std::max(a.free_min, b.free_min);
    nd.free_area = std::max(a.free_area, b.free_area);
  }

  std::vector<Node> nodes_;
  int floor_side_ = 0;
  long long floor_area_ = 0;
};

}  // namespace

bool respects_power_of_two(int x, int y, int w, int h) {
  if (w <= 0 || h <= 0) return true;
  const long long s = next_pow2(std::max(w, h));
  return floor_div(x, s) == floor_div((long long)x + w - 1, s) &&
         floor_div(y, s) == floor_div((long long)y + h - 1, s);
}

PackResult pack_charts(const std::vector<PackRect>& rects, int min_size, int max_size) {
  PackResult result;
  result.placed.assign(rects.size(), PackPlacement{});

  // Decreasing largest side; ties by area, then by input index (stable and deterministic).
  std::vector<size_t> order;
  order.reserve(rects.size());
  long long total_area = 0;
  int largest = 0;
  for (size_t i = 0; i < rects.size(); ++i) {
    if (rects[i].w <= 0 || rects[i].h <= 0) continue;  // nothing to place: stays at (0, 0)
    order.push_back(i);
    total_area += (long long)rects[i].w * rects[i].h;
    largest = std::max({largest, rects[i].w, rects[i].h});
  }
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    const PackRect& ra = rects[a];
    const PackRect& rb = rects[b];
    int ma = std::max(ra.w, ra.h), mb = std::max(rb.w, rb.h);
    if (ma != mb) return ma > mb;
    long long aa = (long long)ra.w * ra.h, ab = (long long)rb.w * rb.h;
    if (aa != ab) return aa > ab;
    return a < b;
  });

  // Smallest shorter side and smallest area among the rectangles from each position on.
  std::vector<int> suffix_side(order.size() + 1, 0);
  std::vector<long long> suffix_area(order.size() + 1, 0);
  if (!order.empty()) {
    suffix_side[order.size()] = std::numeric_limits<int>::max();
    suffix_area[order.size()] = std::numeric_limits<long long>::max();
  }
  for (size_t k = order.size(); k-- > 0;) {
    const PackRect& r = rects[order[k]];
    suffix_side[k] = std::min(suffix_side[k + 1], std::min(r.w, r.h));
    suffix_area[k] = std::min(suffix_area[k + 1], (long long)r.w * r.h);
  }

  for (long long size = next_pow2(std::max(1, min_size)); size <= max_size; size *= 2) {
    result.size = int(size);
    // Cheap necessary conditions before trying.
    if (largest > size || total_area > size * size) continue;
    Packer packer{int(size)};
    std::vector<PackPlacement> placed(rects.size());
    bool fits = true;
    for (size_t k = 0; k < order.size(); ++k) {
      const size_t i = order[k];
      packer.set_floor(suffix_side[k], suffix_area[k]);
      if (!packer.insert(rects[i].w, rects[i].h, &placed[i])) {
        fits = false;
        break;
      }
    }
    if (fits) {
      result.ok = true;
      result.placed = std::move(placed);
      result.utilization = double(total_area) / (double(size) * double(size));
      return result;
    }
  }
  return result;
}

}  // namespace meshmux

namespace meshmux {

namespace {

int pow2_at_least(int v) {
  int p = 1;
  while (p < v) p <<= 1;
  return p;
}

// A 2D buddy allocator over aligned power-of-two rectangles: a free rectangle (x, y, w, h)
// always has x % w == 0 and y % h == 0; splitting halves one side, which keeps that.
struct FreeCell {
  int x, y, w, h;
};

// Places one cell into `free` (best fit: the smallest free rectangle that holds it; ties:
// top-most, left-most); false, `free` unchanged, when none holds it.
bool buddy_insert(std::vector<FreeCell>& free, int cw, int ch, PackPlacement* at) {
  size_t best = SIZE_MAX;
  for (size_t i = 0; i < free.size(); ++i) {
    const FreeCell& f = free[i];
    if (f.w < cw || f.h < ch) continue;
    if (best == SIZE_MAX) {
      best = i;
      continue;
    }
    const FreeCell& b = free[best];
    long long fa = (long long)f.w * f.h, ba = (long long)b.w * b.h;
    if (fa < ba || (fa == ba && (f.y < b.y || (f.y == b.y && f.x < b.x)))) best = i;
  }
  if (best == SIZE_MAX) return false;
  FreeCell f = free[best];
  free.erase(free.begin() + long(best));
  while (f.w > cw) {  // split off the right half
    f.w /= 2;
    free.push_back({f.x + f.w, f.y, f.w, f.h});
  }
  while (f.h > ch) {  // split off the bottom half
    f.h /= 2;
    free.push_back({f.x, f.y + f.h, f.w, f.h});
  }
  *at = {f.x, f.y};
  return true;
}

bool buddy_pack(const std::vector<PackRect>& cells, const std::vector<size_t>& order, int width,
                int height, std::vector<PackPlacement>& placed) {
  std::vector<FreeCell> free{{0, 0, width, height}};
  for (size_t idx : order)
    if (!buddy_insert(free, cells[idx].w, cells[idx].h, &placed[idx])) return false;
  return true;
}

}  // namespace

// Each rectangle's cell and the placing order (largest first), for both searches.
struct CellPlan {
  std::vector<size_t> order;
  long long area = 0;
  int longest = 1;
};
CellPlan plan_cells(const std::vector<PackRect>& rects, PackResult& r) {
  CellPlan plan;
  r.cells.resize(rects.size());
  for (size_t i = 0; i < rects.size(); ++i) {
    r.cells[i] = {pow2_at_least(std::max(1, rects[i].w)), pow2_at_least(std::max(1, rects[i].h))};
    plan.area += (long long)r.cells[i].w * r.cells[i].h;
    plan.longest = std::max({plan.longest, r.cells[i].w, r.cells[i].h});
  }
  plan.order.resize(rects.size());
  for (size_t i = 0; i < plan.order.size(); ++i) plan.order[i] = i;
  std::stable_sort(plan.order.begin(), plan.order.end(), [&](size_t a, size_t b) {
    long long aa = (long long)r.cells[a].w * r.cells[a].h,
              bb = (long long)r.cells[b].w * r.cells[b].h;
    if (aa != bb) return aa > bb;
    return std::max(r.cells[a].w, r.cells[a].h) > std::max(r.cells[b].w, r.cells[b].h);
  });
  return plan;
}

PackResult pack_cells_into(const std::vector<PackRect>& rects, int width, int height) {
  PackResult r;
  CellPlan plan = plan_cells(rects, r);
  r.size = width;
  r.height = height;
  r.placed.assign(rects.size(), {});
  if (width < 1 || height < 1 || plan.area > (long long)width * height) return r;
  r.ok = buddy_pack(r.cells, plan.order, width, height, r.placed);
  if (r.ok) {
    long long used = 0;
    for (const PackRect& q : rects) used += (long long)q.w * q.h;
    r.utilization = double(used) / (double(width) * height);
  }
  return r;
}

PackResult pack_cells(const std::vector<PackRect>& rects, int min_size, int max_size) {
  PackResult r;
  CellPlan plan = plan_cells(rects, r);
  const std::vector<size_t>& order = plan.order;
  const long long area = plan.area;
  const int longest = plan.longest;
  int size = pow2_at_least(std::max(1, min_size));
  while ((long long)size * size < area || size < longest) size *= 2;
  for (; size <= max_size; size *= 2) {
    r.placed.assign(rects.size(), {});
    if (buddy_pack(r.cells, order, size, size, r.placed)) {
      r.ok = true;
      r.size = r.height = size;
      long long used = 0;
      for (const PackRect& q : rects) used += (long long)q.w * q.h;
      r.utilization = double(used) / (double(size) * size);
      return r;
    }
  }
  r.size = r.height = max_size;
  r.placed.assign(rects.size(), {});
  return r;
}

PagedCells pack_cells_pages(const std::vector<PackRect>& rects, int width, int height) {
  PagedCells out;
  PackResult r;
  const CellPlan plan = plan_cells(rects, r);
  out.page.assign(rects.size(), 0);
  std::vector<std::vector<FreeCell>> free;
  for (size_t idx : plan.order) {
    const PackRect& cell = r.cells[idx];
    PackPlacement at;
    size_t p = 0;
    while (p < free.size() && !buddy_insert(free[p], cell.w, cell.h, &at)) ++p;
    if (p == free.size()) {  // a new page; a cell larger than a page has one of its own
      free.push_back({{0, 0, width, height}});
      if (!buddy_insert(free.back(), cell.w, cell.h, &at)) free.back().clear();
    }
    out.page[idx] = int32_t(p);
  }
  out.pages = free.size();
  return out;
}

}  // namespace meshmux
