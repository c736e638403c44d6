// Progress a person can read: one line per step with the elapsed time; on a terminal, a live
// percentage for steps over a second, which logs and pipes never get.
#include <gtest/gtest.h>

#include "exporters/gltf.h"
#include "test_util.h"

namespace meshmux {
namespace {

using testing::run_meshmux;
using testing::run_program;
using testing::TempDir;

// A 200k-triangle sphere: its progressive record takes long enough for several updates (the
// live line is asked for at once with MESHMUX_LIVE_PROGRESS_AFTER=0: a second, the default,
// depends on the machine).
std::string big_sphere(TempDir& dir) {
  Scene s;
  Mesh mesh;
  mesh.primitives.push_back(testing::uv_sphere(225, 450));
  s.meshes.push_back(mesh);
  s.instances.push_back({0, Mat4::identity(), "sphere"});
  GltfExportOptions o;
  o.draco = false;
  auto glb = export_glb_bytes(s, o, nullptr);
  EXPECT_TRUE(glb.ok()) << glb.status().message();
  const std::string path = dir.file("sphere.glb");
  testing::write_file(path, glb.ok() ? *glb : std::vector<uint8_t>{});
  return path;
}

TEST(Progress, LivePercentageOnATerminalOnly) {
  TempDir dir;
  const std::string in = big_sphere(dir);
  // Through a pipe: step lines only, no carriage returns or escapes.
  auto piped = run_meshmux({"simplify", in, "-o", dir.file("a.glb"), "--ratio", "0.2"});
  ASSERT_EQ(piped.exit_code, 0) << piped.err;
  EXPECT_NE(piped.err.find("s] simplifying"), std::string::npos) << piped.err;
  EXPECT_EQ(piped.err.find('\r'), std::string::npos) << piped.err;
  EXPECT_EQ(piped.err.find("\033["), std::string::npos) << piped.err;
  // On a terminal (util-linux's script gives the command a pseudo-terminal): the percentage,
  // on a line the next step line erases.
  auto tty =
      run_program("script", {"-qec",
                             "MESHMUX_LIVE_PROGRESS_AFTER=0 " + std::string(MESHMUX_BINARY) +
                                 " simplify " + in + " -o " + dir.file("b.glb") + " --ratio 0.2",
                             "/dev/null"});
  if (tty.exit_code == 127) GTEST_SKIP() << "util-linux's script is not installed";
  ASSERT_EQ(tty.exit_code, 0) << tty.out << tty.err;
  const std::string& text = tty.out;  // script relays the terminal's output on its stdout
  EXPECT_NE(text.find("%"), std::string::npos) << text;
  EXPECT_NE(text.find("\r\033[K"), std::string::npos) << text;
  // The outputs are the same whatever the progress display.
  EXPECT_EQ(testing::read_file(dir.file("a.glb")), testing::read_file(dir.file("b.glb")));
}

}  // namespace
}  // namespace meshmux
