// Uploads on the command line: `meshmux convert UPLOAD` and `meshmux batch` take a folder, a
// .zip or one model file. What users upload is laid out like a simulator's model database
// (meshes/x.dae reading ../materials/textures/x.png), so that is the case built here.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "test_util.h"
#include "upload_fixtures.h"

namespace meshmux {
namespace {

namespace fs = std::filesystem;
using testing::run_meshmux;
using testing::TempDir;

// The folder and the same folder zipped give the same model.glb, texture included; the lone
// .dae is refused with a line naming --root, and --root converts it.
TEST(UploadCommand, FolderZipAndRootGiveTheSameModel) {
  TempDir dir;
  testing::write_database_model(dir.file("robot"));
  testing::zip_folder(dir.file("robot"), dir.file("robot.zip"));
  auto folder = run_meshmux({"convert", dir.file("robot"), "-o", dir.file("a.glb"), "-q"});
  ASSERT_EQ(folder.exit_code, 0) << folder.err;
  auto zip = run_meshmux({"convert", dir.file("robot.zip"), "-o", dir.file("b.glb"), "-q"});
  ASSERT_EQ(zip.exit_code, 0) << zip.err;
  EXPECT_EQ(testing::read_file(dir.file("a.glb")), testing::read_file(dir.file("b.glb")));
  auto info = run_meshmux({"info", dir.file("a.glb"), "--json"});
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_EQ(nlohmann::json::parse(info.out)["textures"], 1) << info.out;

  auto lone = run_meshmux({"convert", dir.file("robot/meshes/x.dae"), "-o", dir.file("c.glb")});
  EXPECT_EQ(lone.exit_code, 2) << lone.err;
  EXPECT_NE(lone.err.find("outside the upload's folder"), std::string::npos) << lone.err;
  EXPECT_NE(lone.err.find("--root DIR"), std::string::npos) << lone.err;
  EXPECT_FALSE(fs::exists(dir.file("c.glb")));
  auto rooted = run_meshmux({"convert", dir.file("robot/meshes/x.dae"), "--root",
                             dir.file("robot"), "-o", dir.file("c.glb"), "-q"});
  ASSERT_EQ(rooted.exit_code, 0) << rooted.err;
  EXPECT_EQ(testing::read_file(dir.file("a.glb")), testing::read_file(dir.file("c.glb")));
  // Nothing unpacked is left beside the outputs.
  for (const std::string& name : dir.list())
    EXPECT_EQ(name.find("meshmux-upload"), std::string::npos) << name;
}

// A hostile archive ends with one line naming the member, exit 2, and no output at all.
TEST(UploadCommand, ZipSlipIsOneLineAndNoOutput) {
  TempDir dir;
  testing::write_zip(dir.file("evil.zip"), {{"m.dae", testing::textured_dae("x.png")},
                                            {"../../escaped.png", "evil"}});
  auto r = run_meshmux({"convert", dir.file("evil.zip"), "-o", dir.file("out")});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("evil.zip: member '../../escaped.png' leaves the archive"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  EXPECT_EQ(dir.list(), (std::vector<std::string>{"evil.zip"}));
  EXPECT_FALSE(fs::exists(dir.path() + "/../escaped.png"));
}

// Two model files at one depth: the line lists them and names --main, which picks one.
TEST(UploadCommand, MainPicksAmongModelFiles) {
  TempDir dir;
  testing::write_database_model(dir.file("robot"));
  testing::write_text(dir.file("robot/meshes/y.dae"), testing::textured_dae("../materials/textures/x.png"));
  auto tie = run_meshmux({"info", dir.file("robot")});
  EXPECT_EQ(tie.exit_code, 2) << tie.err;
  EXPECT_NE(tie.err.find("meshes/x.dae, meshes/y.dae"), std::string::npos) << tie.err;
  EXPECT_NE(tie.err.find("--main PATH"), std::string::npos) << tie.err;
  auto picked = run_meshmux({"info", dir.file("robot"), "--main", "meshes/y.dae"});
  EXPECT_EQ(picked.exit_code, 0) << picked.err;
  EXPECT_NE(picked.out.find("meshes/y.dae"), std::string::npos) << picked.out;
}

// A folder given to batch: its sub-folders and zips are the uploads (each named after
// itself), and a sub-folder with two model files fails alone with the --main line.
TEST(UploadCommand, BatchTakesFoldersAndZipsAsUploads) {
  TempDir dir;
  testing::write_database_model(dir.file("uploads/robot"));
  testing::write_database_model(dir.file("staging/crate"));
  testing::zip_folder(dir.file("staging/crate"), dir.file("uploads/crate.zip"));
  testing::write_database_model(dir.file("uploads/twins"));
  testing::write_text(dir.file("uploads/twins/meshes/y.dae"), testing::textured_dae("x.png"));
  testing::write_text(dir.file("uploads/README.txt"), "not an upload");
  auto r = run_meshmux({"batch", dir.file("uploads"), "-o", dir.file("out"), "-q", "--no-report"});
  EXPECT_EQ(r.exit_code, 2) << r.err;  // one input failed
  EXPECT_TRUE(fs::is_regular_file(dir.file("out/robot/model.glb")));
  EXPECT_TRUE(fs::is_regular_file(dir.file("out/crate/model.glb")));
  auto bytes = testing::read_file(dir.file("out/batch.json"));
  auto doc = nlohmann::json::parse(bytes.begin(), bytes.end());
  ASSERT_EQ(doc["inputs"].size(), 3u) << doc.dump(1);
  for (const auto& e : doc["inputs"]) {
    if (e["name"] == "twins") {
      EXPECT_EQ(e["status"], "failed");
      EXPECT_NE(e["error"].get<std::string>().find("--main"), std::string::npos) << e.dump();
    } else {
      EXPECT_EQ(e["status"], "ok") << e.dump();
    }
  }
}

}  // namespace
}  // namespace meshmux
