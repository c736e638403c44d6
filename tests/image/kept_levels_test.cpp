#include "image/kept_levels.h"

#include <gtest/gtest.h>

#include "image/decode.h"
#include "image/encode.h"

namespace meshmux {
namespace {

// One colour, decoded, and its file bytes in `mime`.
Image solid(int w, int h, uint8_t r, uint8_t g, uint8_t b, const std::string& mime) {
  Image img;
  img.name = "solid";
  img.width = w, img.height = h;
  img.rgba.resize(size_t(w) * size_t(h) * 4);
  for (size_t i = 0; i < img.rgba.size(); i += 4)
    img.rgba[i] = r, img.rgba[i + 1] = g, img.rgba[i + 2] = b, img.rgba[i + 3] = 255;
  img.mime_type = mime;
  img.encoded = mime == "image/png" ? encode_png(img).take() : encode_jpeg(img, 90).take();
  return img;
}

// The atlas material (0) samples image 0; a tiled material (1) samples image 1 as base colour
// and image 2 as normal map; a third samples a 4 × 4 image (3). Levels 16², 64² and 256² of the
// atlas (a quarter of the side a step, as the levels ship by default).
struct KeptScene {
  Scene scene;
  TextureLevels levels;
  KeptScene() {
    scene.images = {
        solid(256, 256, 200, 10, 10, "image/jpeg"), solid(200, 100, 20, 180, 30, "image/jpeg"),
        solid(64, 64, 128, 128, 255, "image/png"), solid(4, 4, 250, 250, 0, "image/png")};
    scene.materials.resize(3);
    scene.materials[0].base_color.image = 0;
    scene.materials[1].base_color.image = 1;
    scene.materials[1].normal.image = 2;
    scene.materials[2].base_color.image = 3;
    levels.material = 0;
    for (int side : {16, 64, 256}) {
      TextureLevel l;
      l.width = l.height = side;
      l.mime_type = "image/jpeg";
      l.encoded = {1};
      levels.levels.push_back(l);
    }
  }
};

// The scale rules alone: no byte bound, previews at quality 75.
const TextureLevelOptions kUnbounded = [] {
  TextureLevelOptions o;
  o.max_pyramid_ratio = 1e9;
  o.preview_quality = 75;
  return o;
}();

// Texture-like noise (every pixel its own value, so a JPEG's bytes follow its pixels, as a
// photograph's do), and its JPEG bytes.
Image noise(int w, int h) {
  Image img;
  img.name = "noise";
  img.width = w, img.height = h;
  img.rgba.resize(size_t(w) * size_t(h) * 4);
  uint32_t x = 12345;
  for (size_t i = 0; i < img.rgba.size(); ++i) {
    x = x * 1664525u + 1013904223u;
    img.rgba[i] = (i % 4 == 3) ? 255 : uint8_t(x >> 24);
  }
  img.mime_type = "image/jpeg";
  img.encoded = encode_jpeg(img, 85).take();
  return img;
}

// A scene whose atlas (image 0) has `sides` as its levels (a byte each, so the kept maps are
// what the bound sees) and whose second material samples `kept`.
struct NoiseScene {
  Scene scene;
  TextureLevels levels;
  NoiseScene(std::vector<int> sides, Image kept) {
    scene.images = {solid(sides.back(), sides.back(), 9, 9, 9, "image/jpeg"), std::move(kept)};
    scene.materials.resize(2);
    scene.materials[0].base_color.image = 0;
    scene.materials[1].base_color.image = 1;
    levels.material = 0;
    for (int side : sides) {
      TextureLevel l;
      l.width = l.height = side;
      l.mime_type = "image/jpeg";
      l.encoded = {1};
      levels.levels.push_back(l);
    }
  }
  double ratio() const {
    uint64_t total = 0, top = 0;
    for (const TextureLevel& l : levels.levels) {
      uint64_t n = l.encoded.size();
      for (const KeptMap& k : l.kept) n += k.encoded.size();
      total += n, top = n;
    }
    return double(total) / double(top);
  }
};

const KeptMap* find(const TextureLevel& l, int32_t image) {
  for (const KeptMap& k : l.kept)
    if (k.image == image) return &k;
  return nullptr;
}

// Every image the streamed material does not sample rides with the levels. The streamed
// material is the one the levels name, wherever it sits (it used to be read as materials[0]).
TEST(KeptLevels, ImagesAreThoseTheStreamedMaterialDoesNotSample) {
  KeptScene k;
  EXPECT_EQ(kept_level_images(k.scene, 0), (std::vector<int32_t>{1, 2, 3}));
  EXPECT_EQ(kept_level_images(k.scene, 1), (std::vector<int32_t>{0, 3}));
  EXPECT_EQ(kept_level_images(k.scene, -1), (std::vector<int32_t>{0, 1, 2, 3}));
  k.scene.materials[0].normal.image = 2;  // shared with the atlas material: streamed with it
  EXPECT_EQ(kept_level_images(k.scene, 0), (std::vector<int32_t>{1, 3}));
}

// A kept image is at each level's scale of the finest (16/256, 64/256, 1), never below 4 pixels a
// side; the finest level carries the bytes it came with; each reduced map decodes to its size and
// keeps its colour; an image too small to reduce is in the base's level only.
TEST(KeptLevels, EachLevelCarriesTheImagesAtItsScale) {
  KeptScene k;
  ASSERT_TRUE(add_kept_levels(k.scene, k.levels, kUnbounded).is_ok());
  const std::vector<std::pair<int, int>> sides1 = {{13, 6}, {50, 25}, {200, 100}};
  for (size_t j = 0; j < 3; ++j) {
    const KeptMap* m = find(k.levels.levels[j], 1);
    ASSERT_NE(m, nullptr) << j;
    EXPECT_EQ(std::make_pair(m->width, m->height), sides1[j]) << j;
    EXPECT_EQ(m->mime_type, "image/jpeg");
    Image d;
    d.name = "kept";
    d.encoded = m->encoded;
    ASSERT_TRUE(decode_image(d).is_ok());
    EXPECT_EQ(std::make_pair(d.width, d.height), sides1[j]);
    EXPECT_NEAR(d.rgba[(size_t(d.width) * size_t(d.height / 2) + size_t(d.width / 2)) * 4 + 1], 180,
                6);
  }
  EXPECT_EQ(find(k.levels.levels[2], 1)->encoded, k.scene.images[1].encoded);
  // The normal map stays PNG: 4 × 4, 16 × 16, then its own 64 × 64.
  const std::vector<int> sides2 = {4, 16, 64};
  for (size_t j = 0; j < 3; ++j) {
    const KeptMap* m = find(k.levels.levels[j], 2);
    ASSERT_NE(m, nullptr) << j;
    EXPECT_EQ(m->width, sides2[j]);
    EXPECT_EQ(m->mime_type, "image/png");
  }
  // 4 × 4 at every scale: the base's level carries it as it came, no level after it again.
  ASSERT_NE(find(k.levels.levels[0], 3), nullptr);
  EXPECT_EQ(find(k.levels.levels[0], 3)->encoded, k.scene.images[3].encoded);
  EXPECT_EQ(find(k.levels.levels[1], 3), nullptr);
  EXPECT_EQ(find(k.levels.levels[2], 3), nullptr);
  // The atlas's own image is never a kept map.
  for (const TextureLevel& l : k.levels.levels) EXPECT_EQ(find(l, 0), nullptr);
}

// A scene shown at level j holds, for each kept image, the last map of it up to j.
TEST(KeptLevels, ApplyShowsTheLastMapUpToTheLevel) {
  KeptScene k;
  ASSERT_TRUE(add_kept_levels(k.scene, k.levels, kUnbounded).is_ok());
  Scene s = k.scene;
  apply_kept_level(s, k.levels, 1);
  EXPECT_EQ(s.images[1].width, 50);
  EXPECT_EQ(s.images[1].encoded, find(k.levels.levels[1], 1)->encoded);
  EXPECT_TRUE(s.images[1].rgba.empty());
  EXPECT_EQ(s.images[3].encoded, k.scene.images[3].encoded);  // from level 0
  EXPECT_EQ(s.images[0].encoded, k.scene.images[0].encoded);  // not a kept image
  EXPECT_EQ(s.images[0].width, 256);
}

// An image that has pixels but no JPEG or PNG bytes (made in code, as the glTF importer's
// anisotropy directions re-expressed for the uv-derived tangent frame; or WebP) rides with the
// levels like the others, every map PNG, the finest at its full size. It used to be skipped: the
// base carried it whole (a lamp's 2048² direction map made its 42 kB base 1.58 MB) and the
// exporter PNG-encoded it again for every base the bytes bound tried.
TEST(KeptLevels, PixelsWithoutFileBytesGetPngMapsAtEveryScale) {
  KeptScene k;
  k.scene.images[1].encoded.clear();  // pixels only, as made in code
  k.scene.images[1].mime_type.clear();
  k.scene.images[2].mime_type = "image/webp";  // bytes a level cannot carry as they came
  ASSERT_TRUE(add_kept_levels(k.scene, k.levels, kUnbounded).is_ok());
  const std::vector<std::pair<int, int>> sides1 = {{13, 6}, {50, 25}, {200, 100}};
  const std::vector<std::pair<int, int>> sides2 = {{4, 4}, {16, 16}, {64, 64}};
  for (size_t j = 0; j < 3; ++j)
    for (auto [image, sides] : {std::pair{1, sides1[j]}, std::pair{2, sides2[j]}}) {
      const KeptMap* m = find(k.levels.levels[j], image);
      ASSERT_NE(m, nullptr) << j << " " << image;
      EXPECT_EQ(m->mime_type, "image/png") << j << " " << image;
      Image d;
      d.name = "kept";
      d.encoded = m->encoded;
      ASSERT_TRUE(decode_image(d).is_ok()) << j << " " << image;
      EXPECT_EQ(std::make_pair(d.width, d.height), sides) << j << " " << image;
      const uint8_t green = image == 1 ? 180 : 128;
      EXPECT_NEAR(d.rgba[(size_t(d.width) * size_t(d.height / 2) + size_t(d.width / 2)) * 4 + 1],
                  green, 2)
          << j << " " << image;
    }
  // Made once: the base's scene shows the small map, not the full pixels.
  Scene s = k.scene;
  apply_kept_level(s, k.levels, 0);
  EXPECT_EQ(s.images[1].width, 13);
  EXPECT_EQ(s.images[1].mime_type, "image/png");
  EXPECT_FALSE(s.images[1].encoded.empty());
}

// No levels (an untextured atlas, or no stream): nothing to carry.
TEST(KeptLevels, NoLevelsNoMaps) {
  KeptScene k;
  TextureLevels none;
  none.material = 0;
  ASSERT_TRUE(add_kept_levels(k.scene, none, kUnbounded).is_ok());
  EXPECT_TRUE(none.levels.empty());
}

// The levels' byte bound counts the kept maps: atlas levels a half apart (64, 128, 256) cost
// nothing here, but a 512² kept image at 1/4 and 1/2 of its side adds about a third of its bytes;
// the middle level goes (as it would for the atlas's own maps), and the kept maps are made again
// for the levels left. Before, the bound saw the atlas alone and shipped all three.
TEST(KeptLevels, KeptMapsCountInTheLevelsByteBound) {
  NoiseScene k({64, 128, 256}, noise(512, 512));
  TextureLevelOptions o;  // the default bound, 1.15
  ASSERT_TRUE(add_kept_levels(k.scene, k.levels, o).is_ok());
  ASSERT_EQ(k.levels.levels.size(), 2u);
  EXPECT_EQ(k.levels.levels[0].width, 64);
  EXPECT_EQ(k.levels.levels[1].width, 256);
  ASSERT_EQ(k.levels.dropped.size(), 1u);
  EXPECT_EQ(k.levels.dropped[0].width, 128);
  EXPECT_LE(k.ratio(), o.max_pyramid_ratio);
  const KeptMap* base = find(k.levels.levels[0], 1);
  ASSERT_NE(base, nullptr);
  EXPECT_EQ(base->width, 128);  // 64 / 256 of 512
  EXPECT_EQ(find(k.levels.levels[1], 1)->encoded, k.scene.images[1].encoded);
}

// An atlas of one level (16²: smaller than the base size) gave the kept images no smaller scale,
// so the base held a 1024² image whole. Levels are made below it for them — the atlas resent,
// the image at 1/16 and 1/4 — until the image fits the base size (128).
TEST(KeptLevels, OneAtlasLevelGetsLevelsForTheKeptImages) {
  NoiseScene k({16}, noise(1024, 1024));
  TextureLevelOptions o;
  ASSERT_TRUE(add_kept_levels(k.scene, k.levels, o).is_ok());
  ASSERT_EQ(k.levels.levels.size(), 3u);
  const std::vector<int> sides = {64, 256, 1024};
  for (size_t j = 0; j < 3; ++j) {
    EXPECT_EQ(k.levels.levels[j].width, 16) << j;
    EXPECT_EQ(k.levels.levels[j].encoded, std::vector<uint8_t>{1}) << j;
    const KeptMap* m = find(k.levels.levels[j], 1);
    ASSERT_NE(m, nullptr) << j;
    EXPECT_EQ(m->width, sides[j]) << j;
  }
  EXPECT_LE(k.ratio(), o.max_pyramid_ratio);
}

// A kept image that already fits the base size needs no level of its own: one atlas level
// carries it as it came.
TEST(KeptLevels, OneAtlasLevelAndASmallKeptImageStayOneLevel) {
  NoiseScene k({16}, noise(128, 64));
  ASSERT_TRUE(add_kept_levels(k.scene, k.levels, TextureLevelOptions{}).is_ok());
  ASSERT_EQ(k.levels.levels.size(), 1u);
  EXPECT_EQ(find(k.levels.levels[0], 1)->encoded, k.scene.images[1].encoded);
}

}  // namespace
}  // namespace meshmux
