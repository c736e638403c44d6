// Atlas pages (atlas/atlas.h; DESIGN.md "Atlas"): where the charts at their sources' native
// density do not fit one max_size² atlas, the atlas adds pages (one more image set and material
// each) instead of shrinking every chart.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "atlas/atlas.h"
#include "atlas/pack.h"
#include "test_util.h"

namespace meshmux {
namespace {

// Five 100² textures at native density need five 128² cells (100 texels and the gutters): four
// fill a 256² page, the fifth starts page 1. Before pages, max_size shrank every chart to ~64%
// of its source's texels (min_density ≈ 0.4) to squeeze all five into one 256².
TEST(AtlasPages, ChartsPastMaxSizeGoToAFurtherPageAtNativeDensity) {
  Scene s = testing::quads_with_own_textures(5, 100);
  AtlasOptions o;
  o.max_size = 256;
  AtlasReport rep;
  auto out = build_atlas(s, o, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_FALSE(rep.reused_source);
  ASSERT_EQ(rep.pages.size(), 2u);
  EXPECT_GE(rep.min_density, 0.999);
  EXPECT_EQ(rep.pages[0].width, 256);
  EXPECT_EQ(rep.pages[0].charts, 4u);
  EXPECT_EQ(rep.pages[1].charts, 1u);
  EXPECT_LE(rep.pages[1].width, 128);  // the last page as small as its charts allow
  // One material per page (one material group here), each sampling its own page's image.
  ASSERT_EQ(out->materials.size(), 2u);
  ASSERT_EQ(rep.page_materials, (std::vector<int32_t>{0, 1}));
  ASSERT_EQ(rep.page_images, 1u);
  ASSERT_EQ(out->images.size(), 2u);
  EXPECT_EQ(out->materials[0].base_color.image, 0);
  EXPECT_EQ(out->materials[1].base_color.image, 1);
  EXPECT_EQ(out->images[1].width, rep.pages[1].width);
  EXPECT_EQ(out->images[1].height, rep.pages[1].height);
  // Every quad lies whole in one primitive, whose material is its page's: four quads on page
  // 0, one on page 1, each at its source's density (≥ 100 texels a side) and showing its own
  // texture (red 40·k at its centre).
  std::vector<int> quads_on(2, 0);
  for (const Mesh& mesh : out->meshes)
    for (const Primitive& p : mesh.primitives) {
      ASSERT_GE(p.material, 0);
      ASSERT_LT(p.material, 2);
      const Image& page = out->images[size_t(p.material)];
      std::vector<int> quad_vertices(5, 0);
      for (size_t v = 0; v < p.positions.size(); ++v)
        ++quad_vertices[size_t(std::lround(p.positions[v].x - 0.5f) / 2)];
      for (int k = 0; k < 5; ++k) {
        if (quad_vertices[size_t(k)] == 0) continue;
        EXPECT_EQ(quad_vertices[size_t(k)], 4) << "quad " << k << " split between materials";
        ++quads_on[size_t(p.material)];
        float lo_u = 1, hi_u = 0, lo_v = 1, hi_v = 0;
        for (size_t v = 0; v < p.positions.size(); ++v) {
          if (std::lround(p.positions[v].x - 0.5f) / 2 != k) continue;
          lo_u = std::min(lo_u, p.uvs[0][v].x), hi_u = std::max(hi_u, p.uvs[0][v].x);
          lo_v = std::min(lo_v, p.uvs[0][v].y), hi_v = std::max(hi_v, p.uvs[0][v].y);
        }
        EXPECT_GE((hi_u - lo_u) * page.width, 99.5) << "quad " << k;
        EXPECT_GE((hi_v - lo_v) * page.height, 99.5) << "quad " << k;
        const int cx = int(0.5f * (lo_u + hi_u) * page.width);
        const int cy = int(0.5f * (lo_v + hi_v) * page.height);
        const uint8_t red = page.rgba[(size_t(cy) * size_t(page.width) + size_t(cx)) * 4];
        EXPECT_NEAR(red, 40 * k, 2) << "quad " << k;
      }
    }
  EXPECT_EQ(quads_on, (std::vector<int>{4, 1}));
}

// What fits one max_size² atlas stays one page, as before pages.
TEST(AtlasPages, ChartsThatFitStayOnePage) {
  Scene s = testing::quads_with_own_textures(4, 100);
  AtlasOptions o;
  o.max_size = 256;
  AtlasReport rep;
  auto out = build_atlas(s, o, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  EXPECT_EQ(rep.pages.size(), 1u);
  EXPECT_EQ(out->materials.size(), 1u);
  EXPECT_GE(rep.min_density, 0.999);
}

// Cells go, largest first, to the first page with room; a cell larger than a page has one of
// its own and nothing joins it.
TEST(AtlasPages, PackCellsPagesFirstFitLargestFirst) {
  std::vector<PackRect> rects = {{100, 100}, {300, 20},  {60, 60},  {128, 128},
                                 {128, 128}, {128, 128}, {128, 128}};
  PagedCells paged = pack_cells_pages(rects, 256, 256);
  EXPECT_EQ(paged.pages, 3u);
  // 512×32 (larger than a page) first: a page of its own; then the five 128² cells: four
  // fill page 1, the fifth and the 64² go to page 2.
  EXPECT_EQ(paged.page, (std::vector<int32_t>{1, 0, 2, 1, 1, 1, 2}));
}

}  // namespace
}  // namespace meshmux
