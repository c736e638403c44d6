// meshmux render: the offscreen render the browser test compares the viewer's frames with.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "test_util.h"

namespace meshmux {
namespace {

using testing::run_meshmux;
using testing::TempDir;

// The built-in sample, rendered to a PAM of a non-square size: header and pixel count match
// the size, the model covers part of the image and the background stays transparent.
TEST(RenderCommand, WritesPamOfTheRequestedSize) {
  TempDir dir;
  ASSERT_EQ(run_meshmux({"sample", "-o", dir.file("s.glb"), "-q"}).exit_code, 0);
  auto r = run_meshmux({"render", dir.file("s.glb"), "-o", dir.file("s.pam"), "--size", "96x64"});
  if (r.exit_code == 5) GTEST_SKIP() << "no offscreen renderer here: " << r.err;
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto bytes = testing::read_file(dir.file("s.pam"));
  std::string text(bytes.begin(), bytes.end());
  size_t end = text.find("ENDHDR\n");
  ASSERT_NE(end, std::string::npos);
  EXPECT_NE(text.find("WIDTH 96\nHEIGHT 64\nDEPTH 4"), std::string::npos);
  ASSERT_EQ(bytes.size() - (end + 7), size_t(96 * 64 * 4));
  size_t covered = 0, clear = 0;
  for (size_t i = end + 7 + 3; i < bytes.size(); i += 4) (bytes[i] == 255 ? covered : clear) += 1;
  EXPECT_GT(covered, size_t(96 * 64 / 20));
  EXPECT_GT(clear, size_t(96 * 64 / 20));
  EXPECT_NE(r.err.find("pixels covered"), std::string::npos);
}

// An explicit camera looking away from the model renders nothing; the same camera turned
// towards it renders the model: the camera options are used, not the default framing.
TEST(RenderCommand, UsesTheGivenCamera) {
  TempDir dir;
  ASSERT_EQ(run_meshmux({"sample", "-o", dir.file("s.glb"), "-q"}).exit_code, 0);
  auto away = run_meshmux({"render", dir.file("s.glb"), "-o", dir.file("a.png"), "--size", "32x32",
                           "--eye", "0,0,1000", "--target", "0,0,2000"});
  if (away.exit_code == 5) GTEST_SKIP() << "no offscreen renderer here: " << away.err;
  ASSERT_EQ(away.exit_code, 0) << away.err;
  EXPECT_NE(away.err.find(" 0 pixels covered"), std::string::npos) << away.err;
  auto towards = run_meshmux({"render", dir.file("s.glb"), "-o", dir.file("t.png"), "--size",
                              "32x32", "--eye", "0,0,1000", "--target", "0,0,0", "--fov", "10"});
  ASSERT_EQ(towards.exit_code, 0) << towards.err;
  EXPECT_EQ(towards.err.find(" 0 pixels covered"), std::string::npos) << towards.err;
}

// Usage and input errors: clear messages, the documented exit codes, no output file.
TEST(RenderCommand, RejectsBadArgumentsAndInput) {
  TempDir dir;
  auto missing = run_meshmux({"render", dir.file("nope.glb"), "-o", dir.file("x.png")});
  EXPECT_EQ(missing.exit_code, 2) << missing.err;
  EXPECT_NE(missing.err.find("nope.glb"), std::string::npos) << missing.err;
  EXPECT_EQ(run_meshmux({"render", dir.file("s.glb"), "-o", dir.file("x.png"), "--size", "0x5"})
                .exit_code,
            1);
  EXPECT_EQ(run_meshmux({"render", dir.file("s.glb"), "-o", dir.file("x.jpg")}).exit_code, 1);
  EXPECT_EQ(
      run_meshmux({"render", dir.file("s.glb"), "-o", dir.file("x.png"), "--eye", "1,2"}).exit_code,
      1);
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.png")));
}

}  // namespace
}  // namespace meshmux
