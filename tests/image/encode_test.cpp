// Image encoding: what is stored is what the pixels say, checked with an independent decoder
// (stb_image) as well as our own.
#include "image/encode.h"

#include <gtest/gtest.h>

#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>

#include "image/decode.h"

namespace meshmux {
namespace {

Image grey_glass() {
  Image img;
  img.name = "glass";
  img.width = img.height = 4;
  img.rgba.resize(4 * 4 * 4);
  for (size_t i = 0; i < 16; ++i) {
    img.rgba[i * 4 + 0] = img.rgba[i * 4 + 1] = img.rgba[i * 4 + 2] = 108;
    img.rgba[i * 4 + 3] = 77;
  }
  img.rgba[0] = 200, img.rgba[3] = 255;  // one opaque texel
  return img;
}

// PNG stores straight (unassociated) alpha, and so do our pixels. OpenImageIO's PNG writer once
// divided RGB by alpha (treating ours as premultiplied): grey glass (108, α 77) was stored as
// (255, 255, 255, 77), white glass in every viewer.
TEST(ImageEncode, PngStoresStraightAlpha) {
  Image img = grey_glass();
  auto png = encode_png(img);
  ASSERT_TRUE(png.ok()) << png.status().message();
  int w = 0, h = 0, n = 0;
  unsigned char* px = stbi_load_from_memory(png->data(), int(png->size()), &w, &h, &n, 4);
  ASSERT_NE(px, nullptr);
  ASSERT_EQ(w, 4);
  EXPECT_EQ(px[4 + 0], 108);
  EXPECT_EQ(px[4 + 1], 108);
  EXPECT_EQ(px[4 + 3], 77);
  EXPECT_EQ(px[0], 200);
  stbi_image_free(px);
}

// And the decoder hands straight alpha back: no premultiplication on the way in either.
TEST(ImageDecode, PngWithAlphaDecodesStraight) {
  Image img = grey_glass();
  auto png = encode_png(img);
  ASSERT_TRUE(png.ok()) << png.status().message();
  Image back;
  back.name = "glass.png";
  back.encoded = *png;
  back.mime_type = "image/png";
  ASSERT_TRUE(decode_image(back)) << "decode";
  EXPECT_EQ(back.rgba, img.rgba);
}

// PNGs are deflated with the smaller of two strategies (run-length matching where it pays: a
// baked atlas's flat dilated texels; zlib's default on noisy texels), small ones tried whole,
// large ones on a sample of strips of rows. Whichever is chosen, every texel comes back as it
// was, by an independent decoder.
Image atlas_like(int width, int height, bool noisy) {
  Image img;
  img.name = noisy ? "noise" : "atlas";
  img.width = width;
  img.height = height;
  img.rgba.resize(size_t(img.width) * size_t(img.height) * 4);
  uint32_t state = 12345;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      uint8_t* p = &img.rgba[(size_t(y) * size_t(img.width) + size_t(x)) * 4];
      state = state * 1664525u + 1013904223u;
      const bool chart = noisy || (x > 100 && x < 180 && y > 40 && y < 90);
      p[0] = chart ? uint8_t(state >> 24) : 40;
      p[1] = chart ? uint8_t(state >> 16) : 90;
      p[2] = chart ? uint8_t(x ^ y) : 140;
      p[3] = chart ? uint8_t(128 + (state >> 25)) : 255;
    }
  return img;
}

void expect_lossless_png(const Image& img) {
  auto png = encode_png(img);
  ASSERT_TRUE(png.ok()) << png.status().message();
  int w = 0, h = 0, n = 0;
  unsigned char* px = stbi_load_from_memory(png->data(), int(png->size()), &w, &h, &n, 4);
  ASSERT_NE(px, nullptr);
  ASSERT_EQ(w, img.width);
  ASSERT_EQ(h, img.height);
  EXPECT_EQ(std::vector<uint8_t>(px, px + img.rgba.size()), img.rgba);
  stbi_image_free(px);
}

// 1024 × 600: sampled (600 rows is not a multiple of the 128-row stride: a short last strip).
TEST(ImageEncode, LargePngOfAFlatAtlasIsLossless) {
  const Image img = atlas_like(1024, 600, false);
  expect_lossless_png(img);
  // Runs of one texel compress to almost nothing, whichever strategy took them.
  EXPECT_LT(encode_png(img)->size(), img.rgba.size() / 40);
}

TEST(ImageEncode, LargePngOfNoiseIsLossless) { expect_lossless_png(atlas_like(1024, 600, true)); }

TEST(ImageEncode, SmallPngsTriedWholeAreLossless) {
  expect_lossless_png(atlas_like(300, 200, false));
  expect_lossless_png(atlas_like(300, 200, true));
}

// The image data is deflated in pieces of rows on every core; the pieces depend on the image
// alone, so the bytes must not depend on how many threads there are (1024 × 600 RGBA: three
// pieces, three IDAT chunks).
TEST(ImageEncode, PngBytesAreTheSameWhateverTheThreadCount) {
  const Image img = atlas_like(1024, 600, true);
  auto run = [&](const char* threads) {
    setenv("MESHMUX_THREADS", threads, 1);
    auto png = encode_png(img);
    unsetenv("MESHMUX_THREADS");
    return png.ok() ? png.take() : std::vector<uint8_t>{};
  };
  const std::vector<uint8_t> one = run("1");
  ASSERT_FALSE(one.empty());
  EXPECT_EQ(one, run("2"));
  EXPECT_EQ(one, run("5"));
}

// Each piece is primed with the filtered rows before it, so a match across a piece's border is
// still found. Noise rows repeating with a period of two (no row filter removes them; deflate
// finds each row two rows back), 2048 × 508 RGBA in four pieces: three rows of noise and about
// four rows' worth of match codes (deflate's 258-byte matches cost ~0.75%), 6.8 rows in all;
// unprimed, the first two rows of each later piece are stored as noise again: 12.7 rows.
TEST(ImageEncode, PngPiecesMatchAcrossTheirBorders) {
  Image img = atlas_like(2048, 508, true);
  const size_t row = size_t(img.width) * 4;
  for (int y = 2; y < img.height; ++y)
    std::copy_n(&img.rgba[size_t(y - 2) * row], row, &img.rgba[size_t(y) * row]);
  expect_lossless_png(img);
  EXPECT_LT(encode_png(img)->size(), 8 * row);
}

}  // namespace
}  // namespace meshmux
