// Catmull-Rom resampling (image/resize.h): the texture levels need power-of-two sides, so a
// source of other sides is resampled up, and must lose none of its detail doing so.
#include "image/resize.h"

#include <gtest/gtest.h>

namespace meshmux {
namespace {

// A hard black/white edge between columns 1 and 2 of a 4-wide image, upsampled to 8: the edge
// stays within one output texel of its place (bilinear spreads it over two), outputs left of it
// stay black and right of it white, and the interpolating cubic reproduces the texels at their
// own centres.
TEST(Resize, UpsamplingKeepsAnEdgeSharp) {
  Image in;
  in.width = 4, in.height = 1;
  for (int x = 0; x < 4; ++x) {
    const uint8_t v = x < 2 ? 0 : 255;
    in.rgba.insert(in.rgba.end(), {v, v, v, 255});
  }
  Image out = resize_cubic(in, 8, 1, false);
  ASSERT_EQ(out.width, 8);
  ASSERT_EQ(out.rgba.size(), 8u * 4);
  EXPECT_EQ(out.rgba[0 * 4], 0);
  EXPECT_LE(out.rgba[2 * 4], 20);   // just left of the edge
  EXPECT_GE(out.rgba[5 * 4], 235);  // just right of it
  EXPECT_EQ(out.rgba[7 * 4], 255);
  for (int x = 0; x < 8; ++x) EXPECT_EQ(out.rgba[size_t(x) * 4 + 3], 255);
}

// The same size is the identity; a constant image stays that constant in linear light.
TEST(Resize, SameSizeIsIdentityAndConstantsStay) {
  Image in;
  in.width = 3, in.height = 2;
  for (int i = 0; i < 6; ++i) in.rgba.insert(in.rgba.end(), {uint8_t(40 * i), 17, 250, 128});
  EXPECT_EQ(resize_cubic(in, 3, 2, true).rgba, in.rgba);
  Image flat;
  flat.width = 5, flat.height = 3;
  for (int i = 0; i < 15; ++i) flat.rgba.insert(flat.rgba.end(), {90, 180, 30, 200});
  Image up = resize_cubic(flat, 8, 4, true);
  for (size_t i = 0; i < up.rgba.size(); i += 4) {
    EXPECT_NEAR(up.rgba[i], 90, 1);
    EXPECT_NEAR(up.rgba[i + 1], 180, 1);
    EXPECT_NEAR(up.rgba[i + 3], 200, 1);
  }
}

TEST(Resize, NextPowerOfTwo) {
  EXPECT_EQ(next_power_of_two(1), 1);
  EXPECT_EQ(next_power_of_two(211), 256);
  EXPECT_EQ(next_power_of_two(256), 256);
  EXPECT_EQ(next_power_of_two(257), 512);
}

}  // namespace
}  // namespace meshmux
