// Filling an atlas's empty texels (image/fill_empty.h): the empty space must carry the colours of
// the charts around it (so no mip level averages a chart with black), leave the charts as they
// are, and cost time in proportion to the texels, not to how far the empty space reaches.
#include "image/fill_empty.h"

#include <gtest/gtest.h>

#include <cstdlib>

#include "image/color.h"

namespace meshmux {
namespace {

std::vector<uint8_t> solid(int w, int h, uint8_t r, uint8_t g, uint8_t b, uint8_t a) {
  std::vector<uint8_t> out;
  for (int i = 0; i < w * h; ++i) out.insert(out.end(), {r, g, b, a});
  return out;
}

// One red texel in the corner of an otherwise empty 37 × 23 image (odd sides: the coarser levels
// round up): every empty texel becomes that red, alpha included, however far from it, and the
// filled texel keeps its bytes. A ring-by-ring dilation would need 36 rings to get there.
TEST(FillEmpty, OneTexelFillsTheWholeImage) {
  const int w = 37, h = 23;
  std::vector<uint8_t> rgba = solid(w, h, 0, 0, 0, 0);
  std::vector<uint8_t> filled(size_t(w * h), 0);
  rgba[0] = 200, rgba[1] = 10, rgba[2] = 20, rgba[3] = 255;
  filled[0] = 1;
  fill_empty_texels(w, h, filled, {{&rgba, true}});
  for (int i = 0; i < w * h; ++i) {
    ASSERT_EQ(rgba[size_t(i) * 4 + 0], 200) << "texel " << i;
    ASSERT_EQ(rgba[size_t(i) * 4 + 1], 10) << "texel " << i;
    ASSERT_EQ(rgba[size_t(i) * 4 + 2], 20) << "texel " << i;
    ASSERT_EQ(rgba[size_t(i) * 4 + 3], 255) << "texel " << i;
  }
}

// Two charts, black at the left edge and white at the right edge of a 64 × 8 image: the empty
// texels next to each take that chart's colour, in every layer; filled texels keep their bytes.
TEST(FillEmpty, TexelsNextToAChartTakeItsColour) {
  const int w = 64, h = 8;
  std::vector<uint8_t> colour = solid(w, h, 7, 7, 7, 7), data = colour;
  std::vector<uint8_t> filled(size_t(w * h), 0);
  for (int y = 0; y < h; ++y)
    for (int x : {0, w - 1}) {
      const size_t i = size_t(y * w + x);
      const uint8_t v = x == 0 ? 0 : 255;
      for (int c = 0; c < 3; ++c) colour[i * 4 + size_t(c)] = data[i * 4 + size_t(c)] = v;
      colour[i * 4 + 3] = data[i * 4 + 3] = 255;
      filled[i] = 1;
    }
  fill_empty_texels(w, h, filled, {{&colour, true}, {&data, false}});
  for (const std::vector<uint8_t>* layer : {&colour, &data})
    for (int y = 0; y < h; ++y) {
      const std::vector<uint8_t>& l = *layer;
      EXPECT_EQ(l[size_t(y * w + 0) * 4], 0);
      EXPECT_EQ(l[size_t(y * w + w - 1) * 4], 255);
      EXPECT_EQ(l[size_t(y * w + 1) * 4], 0) << "next to the black chart";
      EXPECT_EQ(l[size_t(y * w + w - 2) * 4], 255) << "next to the white chart";
      EXPECT_EQ(l[size_t(y * w + 1) * 4 + 3], 255) << "alpha of the chart beside it";
    }
}

// A black and a white texel side by side, two empty texels after them: the empty ones take the
// mean of both, in linear light for colour (sRGB 188 is linear 0.5, where a mean of the bytes
// would give 128, visibly darker) and as stored for a data layer (128).
TEST(FillEmpty, ColourIsAveragedInLinearLightDataAsStored) {
  std::vector<uint8_t> colour = {0, 0, 0, 255, 255, 255, 255, 255, 0, 0, 0, 0, 0, 0, 0, 0};
  std::vector<uint8_t> data = colour;
  const std::vector<uint8_t> filled = {1, 1, 0, 0};
  fill_empty_texels(4, 1, filled, {{&colour, true}, {&data, false}});
  for (size_t x : {2u, 3u}) {
    EXPECT_EQ(colour[x * 4], linear_to_srgb(0.5f)) << "texel " << x;
    EXPECT_EQ(colour[x * 4], 188) << "texel " << x;
    EXPECT_EQ(data[x * 4], 128) << "texel " << x;
    EXPECT_EQ(colour[x * 4 + 3], 255) << "texel " << x;
  }
}

// No texel filled: nothing to take a colour from, so the image is left as it was.
TEST(FillEmpty, NothingFilledLeavesTheImage) {
  std::vector<uint8_t> rgba = solid(4, 4, 1, 2, 3, 4);
  const std::vector<uint8_t> before = rgba;
  fill_empty_texels(4, 4, std::vector<uint8_t>(16, 0), {{&rgba, true}});
  EXPECT_EQ(rgba, before);
}

// The same bytes on one thread and on four (rows are split over threads).
TEST(FillEmpty, SameBytesWhateverTheThreadCount) {
  const int w = 300, h = 260;
  std::vector<uint8_t> base = solid(w, h, 0, 0, 0, 0);
  std::vector<uint8_t> filled(size_t(w * h), 0);
  for (int i = 0; i < w * h; i += 97) {
    for (int c = 0; c < 4; ++c) base[size_t(i) * 4 + size_t(c)] = uint8_t((i * (c + 3)) % 251);
    filled[size_t(i)] = 1;
  }
  auto run = [&](const char* threads) {
    setenv("MESHMUX_THREADS", threads, 1);
    std::vector<uint8_t> rgba = base;
    fill_empty_texels(w, h, filled, {{&rgba, true}});
    unsetenv("MESHMUX_THREADS");
    return rgba;
  };
  EXPECT_EQ(run("1"), run("4"));
}

}  // namespace
}  // namespace meshmux
