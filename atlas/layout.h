// Chart sizing and packing, pages included (Terrace, Cheslack-Postava, Levis and Freedman,
// "Unsupervised conversion of 3D models for interactive metaverses" §4.3 formula 2 sizing, §4.4
// power-of-two-safe packing): each flattened chart becomes a pack item sized to keep the density
// of the source texels it samples (the others by formula 2), the items are packed into the
// smallest W × W or W × W/2 atlas that holds them (atlas/pack.h pack_cells_into), and where they
// do not fit one max_size² atlas at that density they go to further pages (docs/ARCHITECTURE.md
// "Atlas pages") instead of every chart shrinking. Internal to atlas/ (atlas.cpp's steps 2–3).
// Deterministic.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "atlas/atlas.h"
#include "atlas/atlas_types.h"
#include "atlas/bake.h"
#include "atlas/pack.h"
#include "scene/scene.h"

namespace meshmux {

// The pixels (width × height) of the images the materials' base colours reference, each image
// once. O(materials + images).
double referenced_pixels(const Scene& scene);

// The pack items: one per textured chart, one block per distinct flat colour.
struct Items {
  std::vector<size_t> chart_item;  // per chart: its item
  std::vector<PackRect> rects;     // per item (textured ones sized by plan_pages)
  std::vector<double> item_scale;  // per item: texels per chart-uv unit (0: a flat block)
  std::vector<size_t> item_chart;  // the chart whose uv rect the item holds (flat: first)
  std::vector<char> item_native;   // per item: sized from its own source texels (density)
  double reuse_scale = 1;          // density × this: the bytes bound where sources are reused
  double target_texels = 0;        // T
  double reference_texels = 0;     // the base-colour texels the materials reference, T for
                                   // vertex colours (reported)
  bool any_textured = false;
  size_t flat_colors = 0;
};

// Step 2, formula 2 sizing: A''_c = cbrt((L²_c/ΣL²)(A_c/ΣA)(A'_c/ΣA')) · T. A_c is the chart's
// area in the world (mean over the mesh's instances); A'_c its footprint in the source texture.
// A chart that samples source texels keeps their density (AtlasOptions::density, times the
// reuse scale of the bytes bound); T = min(Σ A'_c, max_size²), or vertex_color_target's for
// scenes whose only texture is vertex colour. The textured items' rects are left empty (the
// packing sizes them). `views[m]` views fc's mesh m. O(faces + charts log charts).
Items size_charts(const Scene& scene, const std::vector<MeshView>& views, const FlatCharts& fc,
                  const AtlasOptions& o);

// One page's packing (layout.cpp's pack_charts, §4.4): the cells placed, the factor f every
// textured chart was scaled by, and each chart's growth to fill its cell.
struct Packing {
  PackResult packed;
  int flat_block = 4;        // side of each flat colour's block, texels
  double shrink = 1;         // the factor f
  std::vector<double> grow;  // per item: the fill-the-cell factor
  int gutter = 0;            // texels around each textured chart
  double utilization = 0;    // packed texels / atlas texels
};

// One atlas page (docs/ARCHITECTURE.md "Atlas pages"): its charts (the scene's chart indices,
// ascending), their pack items (chart_item and item_chart indexing the page's charts), their
// packing and layout (indexed by the page's charts), and, once baked, which chart each of its
// texels holds (the page's chart indices).
struct Page {
  std::vector<uint32_t> charts;
  Items items;
  Packing packing;
  AtlasLayout layout;
  std::vector<int32_t> texel_chart;
};

// The charts, as FlatCharts, of one page (its charts in page order; face_chart left empty).
// Copies the charts and their uvs.
FlatCharts page_charts(const FlatCharts& fc, const Page& pg);

// Step 3, the pages (Atlas pages, DESIGN.md "Atlas"): one page as packed when every chart fits
// one max_size² atlas at its size (or no chart has a native density to keep). Otherwise, rather
// than shrinking every chart, the items at their sizes (factor 1, flat blocks as at max_size)
// go, largest first, each to the first max_size² page with room (pack_cells_pages); each page
// is then packed on its own as a one-page atlas is (its smallest size that holds it). `items`
// (from size_charts) is consumed: its rects are sized, and a single page takes it over. Each
// page's layout is made; texel_chart stays empty until baked. Errors: kInput when the charts do
// not fit max_size even at one texel each, kInternal when a packing that fitted fails.
Result<std::vector<Page>> plan_pages(const FlatCharts& fc, Items& items, const AtlasOptions& o);

}  // namespace meshmux
