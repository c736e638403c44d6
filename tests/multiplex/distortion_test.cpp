#include "multiplex/distortion.h"

#include <gtest/gtest.h>

#include <cmath>

namespace meshmux {
namespace {

// A w×h image of one colour, covered inside the rectangle [x0, x1) × [y0, y1); background
// pixels are (0,0,0,0) as the renderer leaves them.
RenderImage image(int w, int h, uint8_t r, uint8_t g, uint8_t b, int x0, int y0, int x1, int y1) {
  RenderImage im;
  im.width = w;
  im.height = h;
  im.rgba.assign(size_t(w) * h * 4, 0);
  im.coverage.assign(size_t(w) * h, 0);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      size_t p = size_t(y) * w + x;
      im.coverage[p] = 1;
      im.rgba[p * 4 + 0] = r;
      im.rgba[p * 4 + 1] = g;
      im.rgba[p * 4 + 2] = b;
      im.rgba[p * 4 + 3] = 255;
    }
  return im;
}

TEST(Distortion, IdenticalImages) {
  RenderImage a = image(16, 12, 120, 80, 200, 2, 3, 10, 9);
  // Vary the colour a little so not every pixel is the same.
  for (size_t p = 0; p < a.coverage.size(); ++p)
    if (a.coverage[p]) a.rgba[p * 4] = uint8_t(p % 256);
  Distortion d = measure_distortion(a, a);
  EXPECT_EQ(d.pixels, 8u * 6u);
  EXPECT_EQ(d.mse, 0.0);
  EXPECT_TRUE(std::isinf(d.psnr) && d.psnr > 0);
  EXPECT_EQ(d.ciede2000, 0.0);
}

// Pixels covered by neither image are background, whatever bytes they hold.
TEST(Distortion, BackgroundOutsideMasksIgnored) {
  RenderImage a = image(16, 16, 50, 60, 70, 4, 4, 12, 12);
  RenderImage b = a;
  for (size_t p = 0; p < b.coverage.size(); ++p)
    if (!b.coverage[p]) {
      b.rgba[p * 4 + 0] = 255;
      b.rgba[p * 4 + 1] = 17;
      b.rgba[p * 4 + 2] = 99;
    }
  Distortion d = measure_distortion(a, b);
  EXPECT_EQ(d.pixels, 64u);
  EXPECT_EQ(d.mse, 0.0);
  EXPECT_EQ(d.ciede2000, 0.0);
}

// A pixel covered in only one image compares its colour with black.
TEST(Distortion, SilhouetteChangeCountsAgainstBlack) {
  RenderImage a = image(8, 8, 100, 100, 100, 0, 0, 4, 4);  // 16 pixels
  RenderImage b = image(8, 8, 100, 100, 100, 0, 0, 4, 5);  // one more row of 4
  // The uncovered pixels of a hold garbage that must not be used.
  for (size_t p = 0; p < a.coverage.size(); ++p)
    if (!a.coverage[p]) a.rgba[p * 4 + 1] = 100;
  Distortion d = measure_distortion(a, b);
  EXPECT_EQ(d.pixels, 20u);
  // 4 pixels × 3 channels × 100² over 20 × 3.
  EXPECT_NEAR(d.mse, 4.0 * 3 * 100 * 100 / 60.0, 1e-9);
  EXPECT_GT(d.ciede2000, 0.0);
  // Symmetric in which image has the extra pixels.
  Distortion e = measure_distortion(b, a);
  EXPECT_EQ(e.pixels, d.pixels);
  EXPECT_NEAR(e.mse, d.mse, 1e-9);
  EXPECT_NEAR(e.ciede2000, d.ciede2000, 1e-9);
}

TEST(Distortion, UniformShift) {
  RenderImage a = image(10, 10, 100, 150, 30, 1, 1, 9, 9);
  RenderImage b = image(10, 10, 110, 160, 40, 1, 1, 9, 9);
  Distortion d = measure_distortion(a, b);
  EXPECT_EQ(d.pixels, 64u);
  EXPECT_NEAR(d.mse, 100.0, 1e-9);
  EXPECT_NEAR(d.psnr, 28.1308, 1e-3);
  EXPECT_GT(d.ciede2000, 0.0);
  EXPECT_LT(d.ciede2000, 10.0);
}

TEST(Distortion, RedVersusGreenIsLarge) {
  RenderImage a = image(4, 4, 255, 0, 0, 0, 0, 4, 4);
  RenderImage b = image(4, 4, 0, 255, 0, 0, 0, 4, 4);
  Distortion d = measure_distortion(a, b);
  EXPECT_GT(d.ciede2000, 80.0);
}

TEST(Distortion, EmptyUnion) {
  RenderImage a = image(4, 4, 255, 0, 0, 0, 0, 0, 0);
  Distortion d = measure_distortion(a, a);
  EXPECT_EQ(d.pixels, 0u);
  EXPECT_EQ(d.mse, 0.0);
  EXPECT_EQ(d.psnr, 0.0);
  EXPECT_EQ(d.ciede2000, 0.0);
}

TEST(Distortion, SizeMismatch) {
  RenderImage a = image(4, 4, 255, 0, 0, 0, 0, 4, 4);
  RenderImage b = image(4, 5, 255, 0, 0, 0, 0, 4, 4);
  Distortion d = measure_distortion(a, b);
  EXPECT_EQ(d.pixels, 0u);
  EXPECT_TRUE(std::isinf(d.mse));
  EXPECT_TRUE(std::isinf(d.ciede2000));
}

}  // namespace
}  // namespace meshmux
