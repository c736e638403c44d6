// meshmux render: the offscreen render the browser test compares the viewer's frames with.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "exporters/gltf.h"
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

// A 4x4 image of one colour.
Image solid(uint8_t r, uint8_t g, uint8_t b) {
  Image img;
  img.name = "solid";
  img.width = img.height = 4;
  img.rgba.resize(4 * 4 * 4);
  for (size_t i = 0; i < 16; ++i)
    img.rgba[i * 4] = r, img.rgba[i * 4 + 1] = g, img.rgba[i * 4 + 2] = b,
                 img.rgba[i * 4 + 3] = 255;
  return img;
}

// A multi-material original was once drawn with its first texture on every part, so our own
// comparisons of original and output were wrong. Two quads, a red-textured one on the left and a
// blue-textured one on the right: each shows its own texture.
TEST(RenderCommand, EachPrimitiveShowsItsOwnTexture) {
  Scene s;
  Mesh mesh;
  for (int q = 0; q < 2; ++q) {
    Primitive p;
    float x = q == 0 ? -1.1f : 0.1f;
    p.positions = {{x, -0.5f, 0}, {x + 1, -0.5f, 0}, {x + 1, 0.5f, 0}, {x, 0.5f, 0}};
    p.normals.assign(4, Vec3{0, 0, 1});
    p.uvs = {{{0, 1}, {1, 1}, {1, 0}, {0, 0}}};
    p.indices = {0, 1, 2, 0, 2, 3};
    p.material = q;
    mesh.primitives.push_back(p);
  }
  s.meshes.push_back(mesh);
  s.instances.push_back({0, Mat4::identity(), "quads"});
  for (int q = 0; q < 2; ++q) {
    Material m;
    m.base_color.image = q;
    s.materials.push_back(m);
  }
  s.images = {solid(230, 20, 20), solid(20, 20, 230)};
  GltfExportOptions o;
  o.draco = false;
  auto glb = export_glb_bytes(s, o, nullptr);
  ASSERT_TRUE(glb.ok()) << glb.status().message();
  TempDir dir;
  testing::write_file(dir.file("two.glb"), *glb);
  auto r = run_meshmux({"render", dir.file("two.glb"), "-o", dir.file("two.pam"), "--size", "64x32",
                        "--eye", "0,0,3", "--target", "0,0,0"});
  if (r.exit_code == 5) GTEST_SKIP() << "no offscreen renderer here: " << r.err;
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto bytes = testing::read_file(dir.file("two.pam"));
  std::string text(bytes.begin(), bytes.end());
  size_t start = text.find("ENDHDR\n") + 7;
  size_t red_left = 0, blue_right = 0, wrong = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 64; ++x) {
      const uint8_t* p = &bytes[start + (size_t(y) * 64 + size_t(x)) * 4];
      if (p[3] == 0) continue;
      bool red = p[0] > 2 * p[2], blue = p[2] > 2 * p[0];
      if (x < 30 && red)
        ++red_left;
      else if (x > 33 && blue)
        ++blue_right;
      else if (x < 30 || x > 33)
        ++wrong;
    }
  EXPECT_GT(red_left, 100u);
  EXPECT_GT(blue_right, 100u);
  EXPECT_EQ(wrong, 0u);
}

}  // namespace
}  // namespace meshmux
