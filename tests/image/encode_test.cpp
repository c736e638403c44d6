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

}  // namespace
}  // namespace meshmux
