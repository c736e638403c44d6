// Output safety: a conversion's outputs are one transaction. Each case is what happened to a
// service's output folder before.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/file_io.h"
#include "core/output_transaction.h"
#include "test_util.h"

namespace meshmux {
namespace {

using testing::run_meshmux;
using testing::TempDir;
namespace fs = std::filesystem;

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The sample, converted into DIR/out with the report (package and viewer) or without.
void convert_sample(const TempDir& dir, bool report) {
  ASSERT_EQ(run_meshmux({"sample", "-o", dir.file("s.glb"), "-q"}).exit_code, 0);
  std::vector<std::string> args = {"convert", dir.file("s.glb"), "-o", dir.file("out"), "-q"};
  if (!report) args.push_back("--no-report");
  auto r = run_meshmux(args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
}

// A run killed while writing (here by an 8 kB file-size limit: SIGXFSZ) used to leave a half
// set and had already replaced model.glb. The previous output stays whole, the killed run's
// temporary folder is removed by the next run.
TEST(OutputTransaction, KilledRunLeavesThePreviousOutputAndNextRunCleansUp) {
  TempDir dir;
  convert_sample(dir, /*report=*/false);
  const std::string before = slurp(dir.file("out/model.glb"));
  ASSERT_FALSE(before.empty());
  auto killed = testing::run_program(
      "/bin/sh", {"-c", "ulimit -f 16; exec \"$0\" convert \"$1\" -o \"$2\" -q --no-report",
                  MESHMUX_BINARY, dir.file("s.glb"), dir.file("out")});
  EXPECT_NE(killed.exit_code, 0);
  EXPECT_EQ(slurp(dir.file("out/model.glb")), before);
  size_t temporaries = 0;
  for (const auto& e : fs::directory_iterator(dir.path()))
    temporaries += e.path().filename().string().find(".meshmux-tmp-") != std::string::npos;
  EXPECT_EQ(temporaries, 1u) << "the killed run's temporary folder";
  convert_sample(dir, /*report=*/false);
  for (const auto& e : fs::directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename().string().find(".meshmux-tmp-"), std::string::npos) << e.path();
}

// A batch killed with SIGKILL takes its conversions with it, but under a container's init
// nothing reaps them: they stay zombies, kill(pid, 0) succeeds, and their temporary folders
// were judged live and left in the output forever (seen in CI). A zombie's temporary goes; a
// live process's stays.
TEST(OutputTransaction, ZombiesTemporaryIsCleanedALiveOnesIsKept) {
  TempDir dir;
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) _exit(0);
  // Wait until the child has exited (it is a zombie: not reaped yet).
  for (int i = 0; i < 500; ++i) {
    std::ifstream st("/proc/" + std::to_string(child) + "/stat");
    std::string text((std::istreambuf_iterator<char>(st)), std::istreambuf_iterator<char>());
    if (text.find(") Z ") != std::string::npos) break;
    usleep(10000);
  }
  const std::string out = dir.file("out");
  const std::string zombie = out + ".meshmux-tmp-" + std::to_string(child);
  const std::string live = out + ".meshmux-tmp-" + std::to_string(getpid());
  fs::create_directories(zombie);
  fs::create_directories(live);
  meshmux::clean_stale_temporaries(out);
  EXPECT_FALSE(fs::exists(zombie)) << "a zombie's temporary was judged live";
  EXPECT_TRUE(fs::exists(live)) << "a running process's temporary was removed";
  int status = 0;
  waitpid(child, &status, 0);
}

// Re-converting with --no-report left the old package and viewer beside the new model.glb:
// the folder is replaced as a whole now.
TEST(OutputTransaction, StaleOutputsNeverSurvive) {
  TempDir dir;
  convert_sample(dir, /*report=*/true);
  ASSERT_TRUE(fs::exists(dir.file("out/model.mmxp")));
  ASSERT_TRUE(fs::exists(dir.file("out/index.html")));
  convert_sample(dir, /*report=*/false);
  EXPECT_TRUE(fs::exists(dir.file("out/model.glb")));
  EXPECT_FALSE(fs::exists(dir.file("out/model.mmxp")));
  EXPECT_FALSE(fs::exists(dir.file("out/index.html")));
  EXPECT_FALSE(fs::exists(dir.file("out/viewer")));
}

// `-o` equal to the input silently replaced the source; a folder holding the input would be
// deleted by the swap. Both refused, the input untouched.
TEST(OutputTransaction, OutputThatWouldOverwriteTheInputIsRefused) {
  TempDir dir;
  ASSERT_EQ(run_meshmux({"sample", "-o", dir.file("s.glb"), "-q"}).exit_code, 0);
  const std::string source = slurp(dir.file("s.glb"));
  auto same = run_meshmux({"convert", dir.file("s.glb"), "-o", dir.file("s.glb")});
  EXPECT_EQ(same.exit_code, 3) << same.err;
  EXPECT_NE(same.err.find("is the input itself"), std::string::npos) << same.err;
  EXPECT_EQ(slurp(dir.file("s.glb")), source);
  auto simplify =
      run_meshmux({"simplify", dir.file("s.glb"), "-o", dir.file("./s.glb"), "--ratio", "0.5"});
  EXPECT_EQ(simplify.exit_code, 3) << simplify.err;

  ASSERT_EQ(mkdir(dir.file("out").c_str(), 0755), 0);
  ASSERT_EQ(run_meshmux({"sample", "-o", dir.file("out/model.glb"), "-q"}).exit_code, 0);
  auto inside = run_meshmux({"convert", dir.file("out/model.glb"), "-o", dir.file("out")});
  EXPECT_EQ(inside.exit_code, 3) << inside.err;
  EXPECT_TRUE(fs::exists(dir.file("out/model.glb")));
}

// The folder is replaced as a whole, so a folder with files meshmux did not write is refused
// (`-o ~` must never delete a home folder).
TEST(OutputTransaction, FolderWithForeignFilesIsRefused) {
  TempDir dir;
  ASSERT_EQ(run_meshmux({"sample", "-o", dir.file("s.glb"), "-q"}).exit_code, 0);
  ASSERT_EQ(mkdir(dir.file("out").c_str(), 0755), 0);
  testing::write_text(dir.file("out/notes.txt"), "mine");
  auto r = run_meshmux({"convert", dir.file("s.glb"), "-o", dir.file("out"), "--no-report"});
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("notes.txt"), std::string::npos) << r.err;
  EXPECT_EQ(slurp(dir.file("out/notes.txt")), "mine");
  EXPECT_FALSE(fs::exists(dir.file("out/model.glb")));
}

// A planted "<file>.tmp-<pid>" symlink: the temporary used to be opened through it, writing
// into the link's target. It is replaced by a file of our own; the target is untouched.
TEST(OutputTransaction, PlantedTemporarySymlinkIsNotFollowed) {
  TempDir dir;
  testing::write_text(dir.file("victim"), "precious");
  const std::string out = dir.file("o.bin");
  ASSERT_EQ(symlink(dir.file("victim").c_str(), (out + ".tmp-" + std::to_string(getpid())).c_str()),
            0);
  ASSERT_TRUE(write_file_atomic(out, std::string("new bytes")).is_ok());
  EXPECT_EQ(slurp(dir.file("victim")), "precious");
  EXPECT_EQ(slurp(out), "new bytes");
}

// `info` added the size of an absolute-path image (a system password file's size once): only
// files the importer may read are counted.
TEST(OutputTransaction, InfoCountsOnlyFilesInsideTheFolder) {
  TempDir dir;
  ASSERT_EQ(mkdir(dir.file("m").c_str(), 0755), 0);
  testing::write_text(dir.file("big.bin"), std::string(100000, 'x'));
  const std::string doc =
      R"({"asset":{"version":"2.0"},"images":[{"uri":")" + dir.file("big.bin") + R"("}]})";
  testing::write_text(dir.file("m/m.gltf"), doc);
  auto r = run_meshmux({"info", dir.file("m/m.gltf"), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\"bytes\": " + std::to_string(doc.size())), std::string::npos) << r.out;
  // Relative, it resolves: outside, so the model is refused with one line naming it.
  testing::write_text(dir.file("m/m.gltf"),
                      R"({"asset":{"version":"2.0"},"images":[{"uri":"../big.bin"}]})");
  auto up = run_meshmux({"info", dir.file("m/m.gltf")});
  EXPECT_EQ(up.exit_code, 2);
  EXPECT_NE(up.err.find("outside the upload's folder"), std::string::npos) << up.err;
}

}  // namespace
}  // namespace meshmux
