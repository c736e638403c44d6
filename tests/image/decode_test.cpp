// Image decoding: JPEG and PNG go through libjpeg-turbo and libpng directly, everything else
// through the OpenImageIO module loaded on first use. The direct decoders must give the pixels
// OpenImageIO gives (it decoded every image before, and still decodes the rest), and must not
// load the module: that is what keeps a meshmux process from binding ~260 libraries.
#include "image/decode.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>
#include <vector>

#include "image/oiio_loader.h"

namespace meshmux {
namespace {

// A w × h test pattern of `channels` channels at 8 or 16 bits: gradients, a hard edge and
// varied alpha, so rounding, channel order and expansion all show.
std::vector<uint16_t> pattern(int w, int h, int channels, int bits) {
  std::vector<uint16_t> v(size_t(w) * size_t(h) * size_t(channels));
  const int top = (1 << bits) - 1;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < channels; ++c) {
        int value = (x * 37 + y * 11 + c * 71) % (top + 1);
        if (x > w / 2 && c == 0) value = top;  // a hard edge in the first channel
        v[(size_t(y) * w + x) * channels + c] = uint16_t(value);
      }
  return v;
}

// Encodes with OpenImageIO's writer for `extension` (as a file would arrive).
std::vector<uint8_t> oiio_encode(const std::string& extension, int w, int h, int channels, int bits,
                                 const std::vector<uint16_t>& values, int quality = 90) {
  std::vector<unsigned char> bytes;
  OIIO::Filesystem::IOVecOutput proxy(bytes);
  auto out = OIIO::ImageOutput::create("image." + extension, &proxy);
  EXPECT_TRUE(out) << extension;
  if (!out) return {};
  OIIO::ImageSpec spec(w, h, channels, bits == 16 ? OIIO::TypeDesc::UINT16 : OIIO::TypeDesc::UINT8);
  spec.attribute("oiio:UnassociatedAlpha", 1);
  spec.attribute("Compression", "jpeg:" + std::to_string(quality));
  EXPECT_TRUE(out->set_ioproxy(&proxy));
  EXPECT_TRUE(out->open("image." + extension, spec)) << out->geterror();
  bool ok;
  if (bits == 16) {
    ok = out->write_image(OIIO::TypeDesc::UINT16, values.data());
  } else {
    std::vector<uint8_t> b(values.begin(), values.end());
    ok = out->write_image(OIIO::TypeDesc::UINT8, b.data());
  }
  EXPECT_TRUE(ok) << out->geterror();
  out->close();
  return std::vector<uint8_t>(bytes.begin(), bytes.end());
}

// What OpenImageIO itself reads from the bytes, expanded to RGBA8 as decode_image expands.
std::vector<uint8_t> oiio_rgba(const std::vector<uint8_t>& bytes, const std::string& extension) {
  OIIO::Filesystem::IOMemReader proxy(bytes.data(), bytes.size());
  auto in = OIIO::ImageInput::create(OIIO::string_view(extension), false, nullptr, nullptr);
  OIIO::ImageSpec config, spec;
  config.attribute("oiio:UnassociatedAlpha", 1);
  in->set_ioproxy(&proxy);
  EXPECT_TRUE(in->open("image." + extension, spec, config)) << in->geterror();
  const int w = in->spec().width, h = in->spec().height, ch = in->spec().nchannels;  // NOLINT
  std::vector<uint8_t> px(size_t(w) * h * ch), rgba(size_t(w) * h * 4);
  EXPECT_TRUE(in->read_image(0, 0, 0, ch, OIIO::TypeDesc::UINT8, px.data()));
  for (size_t i = 0; i < size_t(w) * h; ++i) {
    const uint8_t* s = &px[i * ch];
    uint8_t* d = &rgba[i * 4];
    d[0] = s[0], d[1] = ch >= 3 ? s[1] : s[0], d[2] = ch >= 3 ? s[2] : s[0];
    d[3] = ch == 2 ? s[1] : ch >= 4 ? s[3] : 255;
  }
  return rgba;
}

int max_difference(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  if (a.size() != b.size()) return 256;
  int worst = 0;
  for (size_t i = 0; i < a.size(); ++i) worst = std::max(worst, std::abs(int(a[i]) - int(b[i])));
  return worst;
}

Image from_bytes(const std::string& name, std::vector<uint8_t> bytes) {
  Image img;
  img.name = name;
  img.encoded = std::move(bytes);
  return img;
}

// Every PNG layout a texture arrives in (grey, grey + alpha, RGB, RGBA, 16-bit) decodes to the
// pixels OpenImageIO gives, without loading the module.
TEST(ImageDecode, PngDirectlyAsOpenImageIoReadsIt) {
  struct Case {
    int channels, bits;
  };
  for (Case c : {Case{1, 8}, Case{2, 8}, Case{3, 8}, Case{4, 8}, Case{3, 16}, Case{4, 16}}) {
    const int w = 37, h = 19;  // odd sizes: row padding and strides show
    auto bytes = oiio_encode("png", w, h, c.channels, c.bits, pattern(w, h, c.channels, c.bits));
    Image img = from_bytes("case.png", bytes);
    ASSERT_TRUE(decode_image(img).is_ok()) << c.channels << "/" << c.bits;
    EXPECT_EQ(img.width, w);
    EXPECT_EQ(img.height, h);
    EXPECT_EQ(img.mime_type, "image/png");
    // 16-bit to 8: both round; OpenImageIO's formula may differ from libpng's by one step.
    EXPECT_LE(max_difference(img.rgba, oiio_rgba(bytes, "png")), c.bits == 16 ? 1 : 0)
        << c.channels << " channels, " << c.bits << " bits";
  }
  EXPECT_FALSE(oiio_module_loaded());
}

// Baseline JPEG, colour and grey, decodes to OpenImageIO's pixels (both are libjpeg-turbo with
// its default accurate DCT and smooth upsampling), without loading the module.
TEST(ImageDecode, JpegDirectlyAsOpenImageIoReadsIt) {
  for (int channels : {3, 1}) {
    const int w = 64, h = 40;
    auto bytes = oiio_encode("jpg", w, h, channels, 8, pattern(w, h, channels, 8));
    Image img = from_bytes("case.jpg", bytes);
    ASSERT_TRUE(decode_image(img).is_ok()) << channels;
    EXPECT_EQ(img.width, w);
    EXPECT_EQ(img.mime_type, "image/jpeg");
    EXPECT_LE(max_difference(img.rgba, oiio_rgba(bytes, "jpeg")), 1) << channels << " channels";
  }
  EXPECT_FALSE(oiio_module_loaded());
}

// Formats the direct decoders do not read (TGA has no signature: named by extension) load the
// module and decode through it.
TEST(ImageDecode, OtherFormatsLoadTheOpenImageIoModule) {
  const int w = 9, h = 5;
  auto bytes = oiio_encode("tga", w, h, 4, 8, pattern(w, h, 4, 8));
  Image img = from_bytes("decal.tga", bytes);
  EXPECT_FALSE(oiio_module_loaded());
  Status s = decode_image(img);
  ASSERT_TRUE(s.is_ok()) << s.message();
  EXPECT_TRUE(oiio_module_loaded());
  EXPECT_EQ(img.width, w);
  EXPECT_EQ(max_difference(img.rgba, oiio_rgba(bytes, "targa")), 0);
}

// A JPEG cut in its scan data: libjpeg only warns; the direct decoder refuses it and the verdict
// is OpenImageIO's, as before the direct decoders (pixels and size as OpenImageIO reads them).
TEST(ImageDecode, TruncatedJpegGetsOpenImageIosVerdict) {
  auto jpg = oiio_encode("jpg", 64, 64, 3, 8, pattern(64, 64, 3, 8));
  std::vector<uint8_t> cut(jpg.begin(), jpg.begin() + jpg.size() * 2 / 3);
  Image img = from_bytes("cut.jpg", cut);
  Status s = decode_image(img);
  EXPECT_TRUE(oiio_module_loaded());
  if (s.is_ok()) {
    EXPECT_EQ(img.width, 64);
    EXPECT_EQ(max_difference(img.rgba, oiio_rgba(cut, "jpeg")), 0);
  } else {
    EXPECT_NE(s.message().find("cut.jpg"), std::string::npos) << s.message();
    EXPECT_TRUE(img.rgba.empty());
  }
}

// A damaged PNG or JPEG (truncated in its pixel data, garbage after the signature) is an error
// naming the image, with no pixels left behind: the direct decoder refuses and OpenImageIO's
// verdict is the one reported.
TEST(ImageDecode, DamagedPngAndJpegAreErrorsNamingTheImage) {
  auto png = oiio_encode("png", 32, 32, 3, 8, pattern(32, 32, 3, 8));
  auto jpg = oiio_encode("jpg", 32, 32, 3, 8, pattern(32, 32, 3, 8));
  std::vector<uint8_t> garbage_png(png.begin(), png.begin() + 8);
  garbage_png.resize(200, 0x5A);
  for (auto [name, bytes] : {std::pair<std::string, std::vector<uint8_t>>{
                                 "half.png", {png.begin(), png.begin() + png.size() / 2}},
                             {"garbage.png", garbage_png},
                             {"header.jpg", {jpg.begin(), jpg.begin() + 20}}}) {
    Image img = from_bytes(name, bytes);
    Status s = decode_image(img);
    EXPECT_FALSE(s.is_ok()) << name;
    EXPECT_NE(s.message().find(name), std::string::npos) << s.message();
    EXPECT_TRUE(img.rgba.empty()) << name;
    EXPECT_EQ(img.width, 0) << name;
  }
}

// A header declaring more pixels than the limit is refused before any pixel is allocated, by
// the direct decoders too, and says so.
TEST(ImageDecode, OverLimitPngIsRefusedByItsHeader) {
  auto png = oiio_encode("png", 300, 200, 3, 8, pattern(300, 200, 3, 8));
  Image img = from_bytes("big.png", png);
  // Whether the header alone refused it shows as the OpenImageIO module still unloaded, which
  // only a process where no earlier test loaded it can see (ctest runs each test alone; a run of
  // the whole binary in one process has loaded it for the TGA tests before).
  const bool loaded_before = oiio_module_loaded();
  bool over = false;
  Status s = decode_image(img, 1000, &over);
  EXPECT_FALSE(s.is_ok());
  EXPECT_TRUE(over);
  EXPECT_NE(s.message().find("300x200"), std::string::npos) << s.message();
  if (!loaded_before) EXPECT_FALSE(oiio_module_loaded());
}

}  // namespace
}  // namespace meshmux
