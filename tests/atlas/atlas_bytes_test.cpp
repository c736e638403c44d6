// The atlas within its bytes bound (atlas/atlas_bytes.h): charts keep their sources' density
// while the atlas's encoded images cost no more than 1.1× the sources they replace (plus a
// small allowance per image); past that the density gives way, down to a floor.
#include "atlas/atlas_bytes.h"

#include <gtest/gtest.h>

#include <random>

#include "image/encode.h"
#include "image/texture_levels.h"
#include "test_util.h"

namespace meshmux {
namespace {

// Two quads, each sampling all of its own side² noise texture (noise: JPEG cannot shrink it,
// so bytes follow texels), whose files are said to weigh `file_bytes` each.
Scene noisy_quads(size_t file_bytes, int side = 128) {
  Scene s;
  std::mt19937 rng(7);
  Mesh mesh;
  for (int k = 0; k < 2; ++k) {
    Image img;
    img.width = img.height = side;
    for (int i = 0; i < side * side; ++i)
      img.rgba.insert(img.rgba.end(), {uint8_t(rng()), uint8_t(rng()), uint8_t(rng()), 255});
    img.encoded.assign(file_bytes, 0);
    img.mime_type = "image/jpeg";
    s.images.push_back(img);
    Material m;
    m.base_color.image = k;
    s.materials.push_back(m);
    mesh.primitives.push_back(testing::unit_quad(2.0f * float(k), k));
  }
  s.meshes.push_back(mesh);
  s.instances.push_back({0, Mat4::identity(), ""});
  return s;
}

// Sources of ample bytes (1 MB each, as lossless files of such textures are): one build, the
// charts at their native density, the figures reported.
TEST(AtlasBytes, WithinTheBoundChartsKeepTheirDensity) {
  AtlasReport rep;
  auto out = build_atlas_within_bytes(noisy_quads(1000000), {}, 85, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  EXPECT_TRUE(rep.bytes_rounds.empty());
  EXPECT_GE(rep.min_density, 0.999);
  EXPECT_EQ(rep.source_bytes, 2e6);
  EXPECT_GT(rep.atlas_bytes, 0);
  EXPECT_LE(rep.atlas_bytes, kAtlasBytesBound * rep.source_bytes);
}

// 256² sources said to weigh 2 kB each (heavily compressed): the native-density atlas costs
// far more, so it is rebuilt at a lower density until it fits or the floor stops it; each rebuild
// is reported, and the last build's figures either meet the bound or sit at the floor.
TEST(AtlasBytes, OverTheBoundTheDensityGivesWay) {
  AtlasReport rep;
  auto out = build_atlas_within_bytes(noisy_quads(2000, 256), {}, 85, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_FALSE(rep.bytes_rounds.empty());
  EXPECT_GT(rep.bytes_rounds[0].atlas_bytes, rep.bytes_rounds[0].bound);
  EXPECT_LT(rep.min_density, 0.999);
  const double bound =
      kAtlasBytesBound * rep.source_bytes + kAtlasImageAllowance * double(rep.atlas_images);
  const bool met = rep.atlas_bytes <= bound;
  const bool floor = rep.bytes_rounds.back().next_density <= kAtlasMinDensity;
  EXPECT_TRUE(met || floor) << rep.atlas_bytes << " B against " << bound << " B";
  EXPECT_LT(rep.atlas_bytes, rep.bytes_rounds[0].atlas_bytes);
}

// The atlas images' last encoding is the texture levels' top level: each image carries the bytes
// the bound measured (the same bytes an encode of its pixels gives), the levels take them as
// their top level instead of encoding the atlas again (a 4096² PNG base colour took a second
// each time), and every file is counted once: the atlas's images, then the levels below the top.
TEST(AtlasBytes, MeasuredBytesAreTheTopLevelEncodedOnce) {
  AtlasReport rep;
  EncodeCounts counts;
  auto out = build_atlas_within_bytes(noisy_quads(1000000), {}, 85, &rep, nullptr, &counts);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_GE(rep.atlas_images, 1u);
  EXPECT_EQ(counts.images, rep.atlas_images);
  const Image& atlas = out->images[0];
  ASSERT_FALSE(atlas.encoded.empty());
  EXPECT_EQ(atlas.encoded, encode_as_top_level(atlas, 85, true, nullptr));
  TextureLevelOptions to;
  to.jpeg_quality = 85;
  to.counts = &counts;
  to.top_from_encoded = true;
  auto levels = make_texture_levels(atlas, to);
  ASSERT_TRUE(levels.ok()) << levels.status().message();
  ASSERT_GE(levels->levels.size(), 2u);
  EXPECT_EQ(levels->levels.back().encoded, atlas.encoded);
  EXPECT_EQ(counts.images, rep.atlas_images + levels->levels.size() - 1)
      << "the top level was encoded again";
  // Without the option the top level is encoded from the pixels: the same bytes, one file more.
  to.top_from_encoded = false;
  auto again = make_texture_levels(atlas, to);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(again->levels.back().encoded, atlas.encoded);
}

}  // namespace
}  // namespace meshmux
