// Chart packing (Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion of 3D
// models for interactive metaverses" §4.4): rectangles placed in decreasing size order into a
// square power-of-two atlas such that no rectangle crosses a power-of-two boundary of the atlas (at
// any level: a rectangle inside the atlas of size S, placed at (x, y) with size (w, h), lies within
// one cell of the grid of spacing s for every power of two s ≥ its own rounded-up size), so every
// mip level keeps charts apart. A tree of free regions is split as rectangles are placed.
// Deterministic.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace meshmux {

struct PackRect {
  int w = 0, h = 0;  // texels, gutters included
};

struct PackPlacement {
  int x = 0, y = 0;  // top-left texel
};

struct PackResult {
  bool ok = false;                    // everything fitted
  int size = 0;                       // the atlas side (power of two); its width when not square
  int height = 0;                     // pack_cells_into: the atlas height (else = size)
  std::vector<PackPlacement> placed;  // one per input rectangle, input order
  double utilization = 0;             // Σ w·h / size²
  std::vector<PackRect> cells;        // pack_cells only: each rectangle's own cell, input order
};

// Packs into the smallest power-of-two square from `min_size` up to `max_size` that holds
// every rectangle. ok = false when even max_size does not.
PackResult pack_charts(const std::vector<PackRect>& rects, int min_size, int max_size);

// Exclusive cells: every rectangle gets an aligned power-of-two cell of its own, sides
// next_pow2(w) × next_pow2(h), x a multiple of the cell width and y of its height, placed at the
// cell's corner (2D buddy allocation, largest first). Then at every mip level at which a chart
// still spans at least one texel in both directions, the texels that filter into it come only
// from its own cell: no bleeding from smaller charts tucked beside it, which pack_charts allows.
// The caller may scale each chart up to fill its cell. Same size search as pack_charts.
PackResult pack_cells(const std::vector<PackRect>& rects, int min_size, int max_size);

// The same cells packed into exactly `width` × `height` texels (powers of two; a rectangle
// W × W/2 holds aligned cells exactly as the square does). ok = false when they do not fit.
PackResult pack_cells_into(const std::vector<PackRect>& rects, int width, int height);

// Atlas pages (docs/ARCHITECTURE.md "Atlas pages"): the same cells, largest first, each into the
// first of `width` × `height` pages whose free space holds it (buddy allocation as pack_cells),
// a new page when none does (a cell larger than a page gets one of its own). Packing a page's
// rectangles alone with pack_cells_into at that size places them as they were placed here.
struct PagedCells {
  std::vector<int32_t> page;  // per rectangle, input order
  size_t pages = 0;
};
PagedCells pack_cells_pages(const std::vector<PackRect>& rects, int width, int height);

// True when the rectangle does not cross a power-of-two boundary (the property above).
bool respects_power_of_two(int x, int y, int w, int h);

}  // namespace meshmux
