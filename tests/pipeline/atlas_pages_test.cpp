// Atlas pages through the pipeline (atlas/atlas.h, DESIGN.md "Atlas"): a page after the first is
// one more material in model.glb, and the stream brings its images up with the texture levels
// (as kept maps, image/kept_levels.h), at each level's scale; report.json lists the pages and
// the draw calls.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "pipeline/convert.h"
#include "stream/package.h"
#include "test_util.h"

namespace meshmux {
namespace {

// With max_size 256 the five quads at native density need two pages (four 128² cells fill the
// first): two materials and two draw calls, and every texture step of the package carries the
// second page's image at that level's scale (the finest: the page whole).
TEST(ConvertAtlasPages, SecondPageStreamsWithTheLevels) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  Scene s = testing::quads_with_own_textures(5, 100);
  ConvertOptions o;
  o.atlas_options.max_size = 256;
  Warnings warnings;
  auto out = convert(s, o, &warnings, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  EXPECT_EQ(out->output.materials, 2u);
  EXPECT_EQ(out->output.draw_calls, 2u);
  auto report = nlohmann::json::parse(out->report_json);
  ASSERT_TRUE(report.contains("output"));
  EXPECT_EQ(report["output"]["atlas_pages"].size(), 2u);
  EXPECT_EQ(report["output"]["atlas_pages"][0][0].get<int>(), 256);
  EXPECT_EQ(report["output"]["draw_calls"].get<uint64_t>(), 2u);
  ASSERT_FALSE(out->package.empty()) << out->not_streamed;
  auto pkg = read_package(out->package);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  const int page_side = report["output"]["atlas_pages"][1][0].get<int>();
  size_t steps = 0, finest = 0;
  for (const PackageChunk& c : pkg->chunks) {
    if (c.kind != StreamStep::kTexture) continue;
    ++steps;
    for (const PackageMap& k : c.kept) {
      EXPECT_EQ(k.image, 1) << "page 2's base colour (the second page's first image)";
      if (c.width == pkg->texture_width) finest = size_t(k.width);
    }
  }
  ASSERT_GE(steps, 1u);
  EXPECT_EQ(finest, size_t(page_side)) << "the finest step brings page 2 whole";
}

}  // namespace
}  // namespace meshmux
