#include "image/texture_levels.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "image/decode.h"

namespace meshmux {
namespace {

// A smooth colour ramp with some structure: JPEG-friendly, and different at every level.
Image ramp(int w, int h, bool alpha = false) {
  Image img;
  img.name = "ramp";
  img.width = w;
  img.height = h;
  img.rgba.resize(size_t(w) * size_t(h) * 4);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      uint8_t* p = &img.rgba[(size_t(y) * size_t(w) + size_t(x)) * 4];
      p[0] = uint8_t(255 * x / std::max(1, w - 1));
      p[1] = uint8_t(255 * y / std::max(1, h - 1));
      p[2] = uint8_t(128 + 100 * std::sin(x * 0.05) * std::cos(y * 0.07));
      p[3] = alpha ? uint8_t(x * 255 / std::max(1, w - 1)) : 255;
    }
  return img;
}

// 512² gives 128², 256² and 512² with every mip level shipped, smallest first, each a JPEG
// that decodes on its own to its size and roughly its content.
TEST(TextureLevels, PyramidFromBaseToFullAsIndependentJpegs) {
  TextureLevelOptions every;
  every.level_halvings = 1;
  every.max_pyramid_ratio = INFINITY;
  auto levels = make_texture_levels(ramp(512, 512), every);
  ASSERT_TRUE(levels.ok()) << levels.status().message();
  ASSERT_EQ(levels->levels.size(), 3u);
  int expected = 128;
  for (const TextureLevel& l : levels->levels) {
    EXPECT_EQ(l.width, expected);
    EXPECT_EQ(l.height, expected);
    EXPECT_EQ(l.mime_type, "image/jpeg");
    Image decoded;
    decoded.name = "level";
    decoded.encoded = l.encoded;
    ASSERT_TRUE(decode_image(decoded).is_ok());
    EXPECT_EQ(decoded.width, expected);
    // Top-right texel is red-ish (x ramp), bottom-left green-ish (y ramp).
    const uint8_t* tr = &decoded.rgba[(size_t(expected) - 1) * 4];
    EXPECT_GT(tr[0], 200);
    EXPECT_LT(tr[1], 60);
    expected *= 2;
  }
}

// Any non-opaque texel: PNG levels, alpha kept.
TEST(TextureLevels, AlphaTexturesUsePng) {
  auto levels = make_texture_levels(ramp(256, 256, true), {});
  ASSERT_TRUE(levels.ok());
  ASSERT_EQ(levels->levels.size(), 2u);
  for (const TextureLevel& l : levels->levels) EXPECT_EQ(l.mime_type, "image/png");
  Image decoded;
  decoded.name = "level";
  decoded.encoded = levels->levels.back().encoded;
  ASSERT_TRUE(decode_image(decoded).is_ok());
  EXPECT_EQ(decoded.rgba[3], 0);                // left column transparent
  EXPECT_EQ(decoded.rgba[(255) * 4 + 3], 255);  // right column opaque
}

// A texture smaller than the base is its own single level; non-rectangular powers of two work.
TEST(TextureLevels, SmallAndNonSquareTextures) {
  auto small = make_texture_levels(ramp(64, 64), {});
  ASSERT_TRUE(small.ok());
  ASSERT_EQ(small->levels.size(), 1u);
  EXPECT_EQ(small->levels[0].width, 64);
  TextureLevelOptions unbounded;  // a ramp's tiny files are all headers: no byte bound here
  unbounded.max_pyramid_ratio = INFINITY;
  auto wide = make_texture_levels(ramp(512, 128), unbounded);
  ASSERT_TRUE(wide.ok());
  ASSERT_EQ(wide->levels.size(), 2u);  // every other mip level: 128×32 and 512×128
  EXPECT_EQ(wide->levels[0].width, 128);
  EXPECT_EQ(wide->levels[0].height, 32);
  EXPECT_EQ(wide->levels[1].width, 512);
}

// A detailed texture (as atlases are): grain on top of smooth structure.
Image detailed(int size) {
  Image img;
  img.name = "detail";
  img.width = img.height = size;
  img.rgba.resize(size_t(size) * size_t(size) * 4);
  uint32_t seed = 12345;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      seed = seed * 1664525u + 1013904223u;
      uint8_t* p = &img.rgba[(size_t(y) * size_t(size) + size_t(x)) * 4];
      double v = 128 + 60 * std::sin(x * 0.05) * std::cos(y * 0.031) + int(seed >> 28) - 8;
      p[0] = uint8_t(std::clamp(v, 0.0, 255.0));
      p[1] = uint8_t(std::clamp(255 - v + 20 * std::sin(x * y * 1e-4), 0.0, 255.0));
      p[2] = uint8_t((x ^ y) & 0xff);
      p[3] = 255;
    }
  return img;
}
double encoded_over_top(const TextureLevels& l) {
  size_t n = 0;
  for (const TextureLevel& t : l.levels) n += t.encoded.size();
  return double(n) / double(l.levels.back().encoded.size());
}

// By default every other mip level ships (1024² → 1024², 256², 64², previews at a lower quality)
// and the whole pyramid costs at most 1.15× the top level; every mip level at one quality costs
// more.
TEST(TextureLevels, DefaultPyramidCostsLittleMoreThanItsTop) {
  Image img = detailed(1024);
  auto def = make_texture_levels(img, {});
  ASSERT_TRUE(def.ok());
  ASSERT_EQ(def->levels.size(), 3u);
  EXPECT_EQ(def->levels[0].width, 64);
  EXPECT_EQ(def->levels[1].width, 256);
  EXPECT_TRUE(def->dropped.empty());
  TextureLevelOptions every;
  every.level_halvings = 1;
  every.preview_quality = every.jpeg_quality;
  every.max_pyramid_ratio = INFINITY;
  auto all = make_texture_levels(img, every);
  ASSERT_TRUE(all.ok());
  EXPECT_EQ(all->levels.size(), 4u);
  std::printf("[ levels ] pyramid / top: default %.3f, every level at one quality %.3f\n",
              encoded_over_top(*def), encoded_over_top(*all));
  EXPECT_LE(encoded_over_top(*def), 1.15);
  EXPECT_GT(encoded_over_top(*all), encoded_over_top(*def));
  EXPECT_EQ(def->levels.back().encoded, all->levels.back().encoded);  // the same top level
}

// Levels that would take the pyramid past the limit are dropped, most bytes first, the
// smallest and the top kept, and each drop says why.
TEST(TextureLevels, LevelsPastTheByteLimitAreDroppedWithAReason) {
  TextureLevelOptions o;
  o.level_halvings = 1;
  o.preview_quality = o.jpeg_quality;
  o.max_pyramid_ratio = 1.1;
  auto l = make_texture_levels(detailed(1024), o);
  ASSERT_TRUE(l.ok());
  ASSERT_FALSE(l->dropped.empty());
  EXPECT_LE(encoded_over_top(*l), 1.1);
  EXPECT_EQ(l->levels.front().width, 128);
  EXPECT_EQ(l->levels.back().width, 1024);
  EXPECT_EQ(l->levels.size() + l->dropped.size(), 4u);
  EXPECT_EQ(l->dropped[0].width, 512);  // the largest between the smallest and the top
  EXPECT_NE(l->dropped[0].why.find("limit 1.10"), std::string::npos) << l->dropped[0].why;
}

// A small detailed top level whose one preview level is too dear: the preview halves (and the
// level it replaced is reported) until the pair costs at most 1.15× the top.
TEST(TextureLevels, ATooDearSmallestLevelHalves) {
  TextureLevelOptions o;
  o.base_size = 64;
  o.preview_quality = o.jpeg_quality;
  auto l = make_texture_levels(detailed(256), o);  // 256² and 64²
  ASSERT_TRUE(l.ok());
  ASSERT_EQ(l->levels.size(), 2u);
  EXPECT_LE(encoded_over_top(*l), 1.15);
  ASSERT_FALSE(l->dropped.empty());
  EXPECT_EQ(l->dropped[0].width, 64);
  EXPECT_LT(l->levels[0].width, 64);
  EXPECT_NE(l->dropped[0].why.find("halves"), std::string::npos);
}

// A tiny texture whose every preview costs more than 15% of it (JPEG headers): the top level
// ships alone, and the report says why.
TEST(TextureLevels, TinyTexturesShipTheirTopLevelAlone) {
  TextureLevelOptions o;
  o.base_size = 32;
  auto l = make_texture_levels(ramp(128, 128), o);
  ASSERT_TRUE(l.ok());
  ASSERT_EQ(l->levels.size(), 1u);
  EXPECT_EQ(l->levels[0].width, 128);
  ASSERT_FALSE(l->dropped.empty());
  EXPECT_NE(l->dropped.back().why.find("only one"), std::string::npos) << l->dropped.back().why;
}

TEST(TextureLevels, RejectsNonPowerOfTwo) {
  auto r = make_texture_levels(ramp(300, 256), {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("ramp"), std::string::npos);
  EXPECT_NE(r.status().message().find("power of two"), std::string::npos);
}

// Quality is settable and does what it says: lower quality, fewer bytes.
TEST(TextureLevels, QualityControlsSize) {
  TextureLevelOptions lo, hi;
  lo.jpeg_quality = 30;
  hi.jpeg_quality = 95;
  auto a = make_texture_levels(ramp(256, 256), lo), b = make_texture_levels(ramp(256, 256), hi);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_LT(a->levels.back().encoded.size(), b->levels.back().encoded.size());
  // Deterministic.
  EXPECT_EQ(make_texture_levels(ramp(256, 256), lo)->levels.back().encoded,
            a->levels.back().encoded);
}

// Downsampling averages light, not sRGB codes: black and white texels make sRGB 188 (linear
// 0.5), not 128.
TEST(TextureLevels, DownsamplesInLinearLight) {
  Image checker;
  checker.width = checker.height = 2;
  checker.rgba = {0, 0, 0, 255, 255, 255, 255, 255, 255, 255, 255, 255, 0, 0, 0, 255};
  Image half = downsample_half(checker);
  ASSERT_EQ(half.width, 1);
  EXPECT_NEAR(half.rgba[0], 188, 1);
  EXPECT_EQ(half.rgba[3], 255);
}

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// The atlas's channels move with the base colour, so every level carries each map at the level's
// size (a client swaps them together), and the byte bound counts them all.
TEST(TextureLevels, ChannelsRideEveryLevelAtItsSize) {
  Image base = ramp(256, 256), normal = ramp(256, 256), orm = ramp(256, 256);
  TextureLevelOptions o;
  o.base_size = 16;
  auto levels = make_texture_levels(base, o,
                                    {{"normal", &normal, TexelFilter::kNormal},
                                     {"occlusion_roughness_metallic", &orm, TexelFilter::kData}});
  ASSERT_TRUE(levels.ok()) << levels.status().message();
  uint64_t total = 0, top = 0;
  for (const TextureLevel& l : levels->levels) {
    ASSERT_EQ(l.other_maps.size(), 2u);
    EXPECT_EQ(l.other_maps[0].channel, "normal");
    EXPECT_EQ(l.other_maps[1].channel, "occlusion_roughness_metallic");
    uint64_t bytes = l.encoded.size();
    for (const TextureMap& m : l.other_maps) {
      Image img;
      img.encoded = m.encoded;
      img.mime_type = m.mime_type;
      ASSERT_TRUE(decode_image(img).is_ok());
      EXPECT_EQ(img.width, l.width);
      EXPECT_EQ(img.height, l.height);
      bytes += m.encoded.size();
    }
    total += bytes;
    top = bytes;
  }
  EXPECT_LE(double(total), o.max_pyramid_ratio * double(top));
}

// A channel of another size than the base colour cannot ride its levels: an internal error,
// not a silent mismatch.
TEST(TextureLevels, ChannelOfAnotherSizeIsRefused) {
  Image base = ramp(64, 64), small = ramp(32, 32);
  auto levels = make_texture_levels(base, {}, {{"normal", &small, TexelFilter::kNormal}});
  ASSERT_FALSE(levels.ok());
  EXPECT_NE(levels.status().message().find("normal"), std::string::npos);
}

// Normal maps halve as directions: the mean of two opposite tilts is straight up, unit length
// (averaging the bytes would give a shortened vector that shades darker).
TEST(TextureLevels, NormalFilterRenormalizes) {
  Image img;
  img.width = img.height = 2;
  const double t = std::sqrt(0.5);
  auto byte = [](double v) { return uint8_t(std::lround((v * 0.5 + 0.5) * 255)); };
  for (int i = 0; i < 4; ++i) {
    const double x = i % 2 ? t : -t;
    img.rgba.insert(img.rgba.end(), {byte(x), byte(0), byte(t), 255});
  }
  const Image half = downsample_half(img, TexelFilter::kNormal);
  ASSERT_EQ(half.width, 1);
  EXPECT_NEAR(half.rgba[0], 128, 1);
  EXPECT_NEAR(half.rgba[1], 128, 1);
  EXPECT_EQ(half.rgba[2], 255);
}

// The shared byte bound counts every map a level carries (a kept image's map as much as the
// atlas's) and takes the dearest level between the smallest and the top, never either end: the
// smallest is the first picture, the top is model.glb's texture.
TEST(TextureLevels, DropDearestMiddleLevelCountsKeptMapsAndKeepsTheEnds) {
  auto level = [](int side, size_t atlas, size_t kept) {
    TextureLevel l;
    l.width = l.height = side;
    l.encoded.assign(atlas, 1);
    if (kept > 0) l.kept.push_back({});
    if (kept > 0) l.kept.back().encoded.assign(kept, 2);
    return l;
  };
  TextureLevels levels;
  // 16²: 50 B; 64²: 30 B + a 60 B kept map (the dearest middle one only with it); 256²: 80 B;
  // top 1024²: 1000 B. Together 1.22× the top.
  levels.levels = {level(16, 50, 0), level(64, 30, 60), level(256, 80, 0), level(1024, 1000, 0)};
  EXPECT_NEAR(pyramid_ratio(levels), 1.22, 1e-9);
  const std::optional<size_t> at = drop_dearest_middle_level(levels, 1.15, "the levels");
  ASSERT_TRUE(at.has_value());
  EXPECT_EQ(*at, 1u);
  ASSERT_EQ(levels.levels.size(), 3u);
  EXPECT_EQ(levels.levels[1].width, 256);
  ASSERT_EQ(levels.dropped.size(), 1u);
  EXPECT_EQ(levels.dropped[0].width, 64);
  EXPECT_EQ(levels.dropped[0].bytes, 90u);
  EXPECT_NE(levels.dropped[0].why.find("the levels cost 1.220"), std::string::npos);
  // 1.13× now: within the bound, nothing more goes.
  EXPECT_FALSE(drop_dearest_middle_level(levels, 1.15, "the levels").has_value());
  // Over a tighter bound the 256² goes; with two levels left, neither end is ever dropped.
  EXPECT_EQ(drop_dearest_middle_level(levels, 1.0, "the levels"), std::optional<size_t>(1));
  EXPECT_FALSE(drop_dearest_middle_level(levels, 1.0, "the levels").has_value());
  EXPECT_EQ(levels.levels.size(), 2u);
}

}  // namespace
}  // namespace meshmux
