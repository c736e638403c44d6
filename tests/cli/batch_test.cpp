// meshmux batch on inputs made here: the built-in sample, broken copies of it, a slow generated
// mesh. The shared models and Slurm are tests/cli/batch_shared_test.mjs.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <thread>

#include "core/sanitizers.h"
#include "exporters/gltf.h"
#include "stream/package.h"
#include "test_util.h"

namespace meshmux {
namespace {

namespace fs = std::filesystem;
using testing::read_file;
using testing::run_meshmux;
using testing::TempDir;
using testing::write_file;
using testing::write_text;

nlohmann::json read_json(const std::string& path) {
  auto bytes = read_file(path);
  return nlohmann::json::parse(bytes.begin(), bytes.end());
}

// batch.json's entry for an output name.
nlohmann::json entry(const nlohmann::json& doc, const std::string& name) {
  for (const auto& e : doc["inputs"])
    if (e["name"] == name) return e;
  ADD_FAILURE() << "no entry named " << name << " in " << doc.dump(1);
  return {};
}

// The sample scene, and broken copies of it: the cases a content platform sees every day.
struct Uploads {
  TempDir dir;
  std::string good, truncated, garbage, empty, missing, list;
  Uploads() {
    good = dir.file("uploads/good.glb");
    fs::create_directories(dir.file("uploads"));
    EXPECT_EQ(run_meshmux({"sample", "-o", good, "-q"}).exit_code, 0);
    auto bytes = read_file(good);
    truncated = dir.file("uploads/truncated.glb");
    write_file(truncated,
               std::vector<uint8_t>(bytes.begin(), bytes.begin() + long(bytes.size() / 2)));
    garbage = dir.file("uploads/garbage.dae");
    write_text(garbage, "this is not COLLADA \x01\x02\x03");
    empty = dir.file("uploads/empty.gltf");
    write_text(empty, "");
    missing = dir.file("uploads/missing.glb");  // listed, never written
    list = dir.file("list.txt");
    write_text(list, "# uploads of the day\n" + good + "\n" + truncated + "\n\n" + garbage + "\n" +
                         empty + "\n" + missing + "\n" + good + "\n");
  }
};

// Every input of the list ends up in batch.json: the good one converted with a viewer, each
// broken one failed with one line that names the file; exit 2 says some failed.
TEST(Batch, ConvertsGoodInputsAndListsEveryBadOneWithItsError) {
  Uploads u;
  const std::string out = u.dir.file("out");
  auto r = run_meshmux({"batch", u.list, "-o", out, "--jobs", "2"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  const auto doc = read_json(out + "/batch.json");
  ASSERT_EQ(doc["inputs"].size(), 5u) << "a path listed twice counts once";
  EXPECT_EQ(doc["counts"]["ok"], 1);
  EXPECT_EQ(doc["counts"]["failed"], 4);
  const auto good = entry(doc, "good");
  EXPECT_EQ(good["status"], "ok");
  EXPECT_EQ(good["viewer"], "good/index.html");
  EXPECT_GT(good["glb_bytes"].get<uint64_t>(), 0u);
  EXPECT_GT(good["stream_bytes"].get<uint64_t>(), 0u);
  EXPECT_TRUE(fs::is_regular_file(out + "/good/model.glb"));
  EXPECT_TRUE(fs::is_regular_file(out + "/good/index.html"));
  for (const char* name : {"truncated", "garbage", "empty", "missing"}) {
    const auto e = entry(doc, name);
    EXPECT_EQ(e["status"], "failed") << name;
    const std::string error = e["error"];
    EXPECT_FALSE(error.empty()) << name;
    EXPECT_EQ(error.find('\n'), std::string::npos) << name << ": one line: " << error;
    EXPECT_NE(error.find(fs::path(e["input"].get<std::string>()).filename().string()),
              std::string::npos)
        << name << ": the error names the file: " << error;
    EXPECT_FALSE(fs::exists(out + "/" + std::string(name))) << name << ": no partial output";
  }
  // The page lists every input, links the good one's viewer and shows the errors.
  auto page = read_file(out + "/index.html");
  const std::string html(page.begin(), page.end());
  EXPECT_NE(html.find("href=\"good/index.html\""), std::string::npos);
  for (const char* name : {"truncated", "garbage", "empty", "missing"})
    EXPECT_NE(html.find(std::string(name)), std::string::npos) << name;
  EXPECT_NE(html.find("5 inputs"), std::string::npos);
  // world.json places the one streamed model (the failed ones are not in it).
  auto world = read_json(out + "/world.json");
  ASSERT_EQ(world["packages"].size(), 1u) << world.dump(1);
  EXPECT_EQ(world["packages"][0]["url"], "good/model.mmxp");
  EXPECT_EQ(world["packages"][0]["bytes"], good["stream_bytes"]);
  // Its head: the header, the table and the base, where the package's own table says it ends.
  auto package = read_package(read_file(out + "/good/model.mmxp"));
  ASSERT_TRUE(package.ok()) << package.status().message();
  EXPECT_EQ(world["packages"][0]["head_bytes"], package->base_offset + package->base_size);
  EXPECT_EQ(world["placements"].size(), 1u);
}

// --layout: read before anything is converted, so a broken file costs nothing and says what is
// wrong in one line; a good one places a model as often as it names it.
TEST(Batch, LayoutFilePlacesModelsAndABrokenOneFailsFirst) {
  Uploads u;
  const std::string list = u.dir.file("one.txt");
  write_text(list, u.good + "\n");
  const std::string bad = u.dir.file("bad_layout.json"), out_bad = u.dir.file("out_bad");
  write_text(bad, "{\"placements\": [{\"name\": \"good\", \"scale\": 0}]}");
  auto r = run_meshmux({"batch", list, "-o", out_bad, "--layout", bad});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("bad_layout.json: placements[0] is singular"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(out_bad + "/good")) << "nothing converted";
  const std::string layout = u.dir.file("layout.json"), out = u.dir.file("out");
  write_text(layout,
             "{\"placements\": [{\"name\": \"good\"}, {\"name\": \"good\", "
             "\"translation\": [3, 0, 0]}, {\"name\": \"elsewhere\"}]}");
  r = run_meshmux({"batch", list, "-o", out, "--layout", layout});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("\"elsewhere\" is no streamed model of this batch"), std::string::npos)
      << r.err;
  auto world = read_json(out + "/world.json");
  ASSERT_EQ(world["packages"].size(), 1u);
  ASSERT_EQ(world["placements"].size(), 2u);
  EXPECT_EQ(world["placements"][1]["matrix"][12], 3);
}

// A second run converts nothing: the finished input is reused (its files untouched) and the
// ones that failed on their own bytes are not tried again; changing an input converts it again.
TEST(Batch, SecondRunSkipsFinishedInputsAndRedoesChangedOnes) {
  Uploads u;
  const std::string out = u.dir.file("out");
  ASSERT_EQ(run_meshmux({"batch", u.list, "-o", out, "-q"}).exit_code, 2);
  const auto mtime = fs::last_write_time(out + "/good/model.glb");
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  auto again = run_meshmux({"batch", u.list, "-o", out});
  EXPECT_EQ(again.exit_code, 2) << again.err;
  EXPECT_NE(again.err.find("1 to convert, 4 done by an earlier run"), std::string::npos)
      << again.err;
  EXPECT_EQ(fs::last_write_time(out + "/good/model.glb"), mtime);
  auto doc = read_json(out + "/batch.json");
  EXPECT_EQ(doc["counts"]["reused"], 4);
  EXPECT_TRUE(entry(doc, "good")["reused"].get<bool>());
  EXPECT_FALSE(entry(doc, "missing")["reused"].get<bool>()) << "a missing file is looked for again";

  // The truncated upload is replaced by a good one: only it converts.
  fs::copy_file(u.good, u.truncated, fs::copy_options::overwrite_existing);
  auto third = run_meshmux({"batch", u.list, "-o", out});
  EXPECT_NE(third.err.find("2 to convert, 3 done by an earlier run"), std::string::npos)
      << third.err;
  doc = read_json(out + "/batch.json");
  EXPECT_EQ(entry(doc, "truncated")["status"], "ok");
  EXPECT_EQ(fs::last_write_time(out + "/good/model.glb"), mtime);
  // Other convert options are another batch: everything converts again.
  auto other = run_meshmux({"batch", u.list, "-o", out, "--jpeg-quality", "60", "-q"});
  EXPECT_EQ(other.exit_code, 2) << other.err;
  EXPECT_NE(fs::last_write_time(out + "/good/model.glb"), mtime);
  EXPECT_EQ(read_json(out + "/batch.json")["counts"]["reused"], 0);
}

// A conversion over its time limit is killed, reported as timed out, and the rest goes on.
TEST(Batch, ConversionOverItsTimeLimitIsKilledAndReported) {
  TempDir dir;
  // About 960k triangles: over 20 s to convert here, far over the limit of 5 s. --jobs 1 and
  // the largest input first: the quick one (under a second) then runs alone, unhurried.
  Scene s;
  Mesh m;
  m.name = "slow";
  m.primitives.push_back(testing::uv_sphere(600, 800));
  s.meshes.push_back(m);
  s.instances.push_back({0, Mat4::identity(), "slow"});
  GltfExportOptions g;
  g.draco = false;
  Warnings w;
  auto bytes = export_glb_bytes(s, g, &w);
  ASSERT_TRUE(bytes.ok()) << bytes.status().message();
  fs::create_directories(dir.file("in"));
  write_file(dir.file("in/slow.glb"), *bytes);
  ASSERT_EQ(run_meshmux({"sample", "-o", dir.file("in/quick.glb"), "-q"}).exit_code, 0);
  auto r = run_meshmux(
      {"batch", dir.file("in"), "-o", dir.file("out"), "--timeout", "5", "--jobs", "1"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  const auto doc = read_json(dir.file("out/batch.json"));
  const auto slow = entry(doc, "slow");
  EXPECT_EQ(slow["status"], "failed");
  EXPECT_EQ(slow["cause"], "timeout");
  EXPECT_NE(slow["error"].get<std::string>().find("timed out after 5 s"), std::string::npos);
  EXPECT_EQ(entry(doc, "quick")["status"], "ok") << entry(doc, "quick").dump();
  EXPECT_FALSE(fs::exists(dir.file("out/slow")));
  for (const auto& e : fs::directory_iterator(dir.file("out")))
    EXPECT_EQ(e.path().filename().string().find("meshmux-tmp"), std::string::npos) << e.path();
  EXPECT_LT(slow["seconds"].get<double>(), 10) << "the slow conversion was not stopped at 5 s";
}

// A conversion over its memory limit fails alone, with the line that names --max-memory.
TEST(Batch, ConversionOverItsMemoryLimitFailsAlone) {
#if MESHMUX_SANITIZED
  GTEST_SKIP() << "the memory cap is off under AddressSanitizer";
#endif
  Uploads u;
  write_text(u.list, u.good + "\n");
  auto r = run_meshmux({"batch", u.list, "-o", u.dir.file("out"), "--max-memory", "64", "-q"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  const auto e = entry(read_json(u.dir.file("out/batch.json")), "good");
  EXPECT_EQ(e["status"], "failed");
  EXPECT_NE(e["error"].get<std::string>().find("--max-memory"), std::string::npos) << e.dump();
}

// Uploads with one file name in different folders (everyone's "scene.gltf") get distinct
// output folders named after their folders, the same on every run. Listed one by one (a
// list file), files of one name but three formats in one folder are told apart by extension.
TEST(Batch, SameFileNamesInDifferentFoldersGetDistinctOutputs) {
  TempDir dir;
  std::string list;
  for (const char* sub : {"alice", "bob"}) {
    fs::create_directories(dir.file(sub));
    const std::string file = dir.file(std::string(sub) + "/scene.glb");
    ASSERT_EQ(run_meshmux({"sample", "-o", file, "-q"}).exit_code, 0);
    list += file + "\n";
  }
  fs::create_directories(dir.file("carol"));
  ASSERT_EQ(run_meshmux({"sample", "-o", dir.file("carol/x.glb"), "-q"}).exit_code, 0);
  write_text(dir.file("carol/x.gltf"), "{}");
  write_text(dir.file("carol/x.DAE"), "<COLLADA/>");
  list += dir.file("carol/x.glb") + "\n" + dir.file("carol/x.gltf") + "\n" +
          dir.file("carol/x.DAE") + "\n";
  write_text(dir.file("list.txt"), list);
  auto r = run_meshmux({"batch", dir.file("list.txt"), "-o", dir.file("out"), "-q"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_TRUE(fs::is_regular_file(dir.file("out/alice_scene/model.glb")));
  EXPECT_TRUE(fs::is_regular_file(dir.file("out/bob_scene/model.glb")));
  EXPECT_TRUE(fs::is_regular_file(dir.file("out/x-glb/model.glb")));
  const auto doc = read_json(dir.file("out/batch.json"));
  EXPECT_EQ(entry(doc, "x-gltf")["status"], "failed");
  EXPECT_EQ(entry(doc, "x-dae")["status"], "failed");
}

// A walked folder's top-level sub-folders are the uploads, named after themselves; a
// sub-folder holding three model files side by side is one upload that fails with the line
// naming --main. The output folder inside the walked folder is not taken for input on the
// next run.
TEST(Batch, WalkedFolderTakesSubFoldersAsUploads) {
  TempDir dir;
  for (const char* sub : {"alice", "bob"}) {
    fs::create_directories(dir.file(sub));
    ASSERT_EQ(
        run_meshmux({"sample", "-o", dir.file(std::string(sub) + "/scene.glb"), "-q"}).exit_code,
        0);
  }
  fs::create_directories(dir.file("carol"));
  ASSERT_EQ(run_meshmux({"sample", "-o", dir.file("carol/x.glb"), "-q"}).exit_code, 0);
  write_text(dir.file("carol/x.gltf"), "{}");
  auto r = run_meshmux({"batch", dir.path(), "-o", dir.file("out"), "-q", "--no-report"});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_TRUE(fs::is_regular_file(dir.file("out/alice/model.glb")));
  EXPECT_TRUE(fs::is_regular_file(dir.file("out/bob/model.glb")));
  const auto doc = read_json(dir.file("out/batch.json"));
  EXPECT_EQ(entry(doc, "carol")["status"], "failed");
  EXPECT_NE(entry(doc, "carol")["error"].get<std::string>().find("--main"), std::string::npos);
  auto again = run_meshmux({"batch", dir.path(), "-o", dir.file("out"), "--no-report"});
  EXPECT_EQ(again.exit_code, 2) << again.err;
  EXPECT_NE(again.err.find("3 inputs: 0 to convert"), std::string::npos) << again.err;
}

// OUTROOT must be new, empty or an earlier batch's: the summary never lands among a user's
// own files. Bad lists and flags are usage errors.
TEST(Batch, RefusesForeignOutputFoldersAndBadArguments) {
  Uploads u;
  fs::create_directories(u.dir.file("mine"));
  write_text(u.dir.file("mine/notes.txt"), "mine");
  auto r = run_meshmux({"batch", u.list, "-o", u.dir.file("mine")});
  EXPECT_EQ(r.exit_code, 3) << r.err;
  EXPECT_NE(r.err.find("not a meshmux batch output"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(u.dir.file("mine/index.html")));
  EXPECT_EQ(run_meshmux({"batch", u.list}).exit_code, 1);
  EXPECT_EQ(run_meshmux({"batch", u.list, "-o", u.dir.file("o"), "--jobs", "0"}).exit_code, 1);
  EXPECT_EQ(run_meshmux({"batch", u.list, "-o", u.dir.file("o"), "--bogus"}).exit_code, 1);
  auto none = run_meshmux({"batch", u.dir.file("nothing.txt"), "-o", u.dir.file("o")});
  EXPECT_EQ(none.exit_code, 2) << none.err;
  EXPECT_NE(none.err.find("nothing.txt"), std::string::npos) << none.err;
  // A convert option with a bad value stops the batch once, as a usage error.
  write_text(u.list, u.good + "\n" + u.good + "x\n");
  auto bad = run_meshmux({"batch", u.list, "-o", u.dir.file("o2"), "--jpeg-quality", "500", "-q"});
  EXPECT_EQ(bad.exit_code, 1) << bad.err;
  EXPECT_NE(bad.err.find("--jpeg-quality"), std::string::npos) << bad.err;
}

// --slurm where Slurm is not installed (or not running) is exit 5 with a clear line, and no
// conversion runs locally instead.
TEST(Batch, SlurmUnavailableIsAClearError) {
  Uploads u;
  write_text(u.list, u.good + "\n");
  // An empty PATH and a SLURM_CONF that does not exist: sbatch cannot run or cannot reach it.
  auto r = testing::run_program(
      "/usr/bin/env", {"PATH=/nonexistent", "SLURM_CONF=/nonexistent/slurm.conf", MESHMUX_BINARY,
                       "batch", u.list, "-o", u.dir.file("out"), "--slurm"});
  EXPECT_EQ(r.exit_code, 5) << r.err;
  EXPECT_NE(r.err.find("sbatch"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(u.dir.file("out/good")));
}

}  // namespace
}  // namespace meshmux
