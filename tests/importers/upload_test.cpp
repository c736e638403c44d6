// Tests for importers/upload: an upload is a folder, a .zip or one model file; its root bounds
// every read, and an archive's members are checked before a byte is unpacked. The uploads are
// built here in the layout real ones have (a simulator model database's meshes/ beside
// materials/textures/), and the archives with libzip itself.
#include "importers/upload.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <zip.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

#include "importers/import.h"
#include "test_util.h"
#include "upload_fixtures.h"

namespace meshmux {
namespace {

namespace fs = std::filesystem;
using testing::kPng;
using testing::TempDir;
using testing::textured_dae;
using testing::write_database_model;
using testing::write_zip;
using testing::zip_folder;
using testing::ZipMember;

Result<Scene> import_upload(const Upload& up, Warnings* warnings = nullptr) {
  ImportOptions o;
  o.root = up.root();
  return import_scene(up.model(), o, warnings);
}

bool any_says(const Warnings& w, const std::string& text) {
  return std::any_of(w.items().begin(), w.items().end(),
                     [&](const std::string& s) { return s.find(text) != std::string::npos; });
}

// The class of failure that refused 3 of 16 real models: a .dae in meshes/ reading
// ../materials/textures/. As a folder upload it converts, texture and all.
TEST(Upload, FolderReachesItsSiblingFolders) {
  TempDir dir;
  write_database_model(dir.file("robot"));
  auto up = open_upload(dir.file("robot"), {}, dir.file("scratch"));
  ASSERT_TRUE(up.ok()) << up.status().message();
  EXPECT_EQ(fs::path(up->model()).filename(), "x.dae");
  auto scene = import_upload(*up);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  EXPECT_EQ(scene->images.size(), 1u);
  EXPECT_FALSE(fs::exists(dir.file("scratch"))) << "a folder is read where it is";
}

// The lone .dae keeps its old, narrower root: the read is refused, and the line says how to
// widen it; --root widens it.
TEST(Upload, LoneFileIsBoundByItsFolderUnlessRootWidensIt) {
  TempDir dir;
  write_database_model(dir.file("robot"));
  auto lone = open_upload(dir.file("robot/meshes/x.dae"), {}, dir.file("scratch"));
  ASSERT_TRUE(lone.ok()) << lone.status().message();
  auto refused = import_upload(*lone);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find("outside the upload's folder"), std::string::npos)
      << refused.status().message();
  EXPECT_NE(refused.status().message().find("--root"), std::string::npos);
  UploadOptions wide;
  wide.root = dir.file("robot");
  auto rooted = open_upload(dir.file("robot/meshes/x.dae"), wide, dir.file("scratch"));
  ASSERT_TRUE(rooted.ok()) << rooted.status().message();
  auto scene = import_upload(*rooted);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  EXPECT_EQ(scene->images.size(), 1u);
  // A --root that does not contain the file is refused by name.
  UploadOptions elsewhere;
  elsewhere.root = dir.file("robot/materials");
  auto bad = open_upload(dir.file("robot/meshes/x.dae"), elsewhere, dir.file("scratch"));
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("outside --root"), std::string::npos);
}

// The same upload as a .zip: unpacked into the scratch folder, read there, and the scratch
// folder is gone with the Upload.
TEST(Upload, ZipIsTheSameUploadAsItsFolder) {
  TempDir dir;
  write_database_model(dir.file("robot"));
  zip_folder(dir.file("robot"), dir.file("robot.zip"));
  {
    auto up = open_upload(dir.file("robot.zip"), {}, dir.file("scratch"));
    ASSERT_TRUE(up.ok()) << up.status().message();
    EXPECT_TRUE(up->unpacked());
    EXPECT_EQ(up->display(), "robot.zip:meshes/x.dae");
    auto scene = import_upload(*up);
    ASSERT_TRUE(scene.ok()) << scene.status().message();
    EXPECT_EQ(scene->images.size(), 1u);
    EXPECT_TRUE(fs::exists(dir.file("scratch")));
    struct stat st;
    ASSERT_EQ(stat(dir.file("scratch").c_str(), &st), 0);
    EXPECT_EQ(st.st_mode & 0777, 0700u) << "the unpacked upload is private";
  }
  EXPECT_FALSE(fs::exists(dir.file("scratch")));
}

// Each hostile member is refused by name before anything is written.
TEST(Upload, HostileMembersAreRefusedByName) {
  TempDir dir;
  const std::string dae = textured_dae("x.png");
  const std::vector<std::pair<std::vector<ZipMember>, std::string>> cases = {
      {{{"m.dae", dae}, {"../x.png", "evil"}}, "'../x.png' leaves the archive"},
      {{{"m.dae", dae}, {"a/../../x.png", "evil"}}, "leaves the archive"},
      {{{"m.dae", dae}, {"..\\x.png", "evil"}}, "leaves the archive"},  // Windows separators
      {{{"m.dae", dae}, {"/etc/x.png", "evil"}}, "'/etc/x.png' has an absolute path"},
      {{{"m.dae", dae}, {"C:/x.png", "evil"}}, "has a drive letter"},
      {{{"m.dae", dae}, {"x.png", "/etc/passwd", 0120777}}, "'x.png' is a symbolic link"},
      {{{"m.dae", dae}, {"x.png", "", 0020644}}, "is a device, FIFO or socket"},
      {{{"m.dae", dae}, {"x.png", "", 0010644}}, "is a device, FIFO or socket"},
  };
  for (const auto& [members, expected] : cases) {
    write_zip(dir.file("up.zip"), members);
    auto up = open_upload(dir.file("up.zip"), {}, dir.file("scratch"));
    ASSERT_FALSE(up.ok()) << expected;
    EXPECT_NE(up.status().message().find(expected), std::string::npos) << up.status().message();
    EXPECT_EQ(up.status().message().find('\n'), std::string::npos);
    EXPECT_EQ(up.status().kind(), ErrorKind::kInput);
    EXPECT_FALSE(fs::exists(dir.file("scratch"))) << expected << ": nothing unpacked";
    EXPECT_FALSE(fs::exists(dir.file("x.png"))) << expected;
  }
}

// A zip bomb: 1 GB of zeros deflates to about 1 MB. It is refused in one line (the default
// limit is max(512 MiB, 64 × the archive's size)), before anything is inflated.
TEST(Upload, ZipBombIsOneLineNotAFullDisk) {
  TempDir dir;
  const std::string zeros = dir.file("zeros.bin");
  {
    std::ofstream f(zeros, std::ios::binary);
    f.seekp((std::streamoff(1) << 30) - 1);
    f.put('\0');  // a sparse 1 GiB file: nothing real on disk
  }
  int err = 0;
  zip_t* za = zip_open(dir.file("bomb.zip").c_str(), ZIP_CREATE | ZIP_TRUNCATE, &err);
  ASSERT_TRUE(za);
  ASSERT_GE(zip_file_add(za, "m.dae", zip_source_buffer(za, "<COLLADA/>", 10, 0), 0), 0);
  const zip_int64_t i = zip_file_add(za, "zeros.bin", zip_source_file(za, zeros.c_str(), 0, -1), 0);
  ASSERT_GE(i, 0);
  zip_set_file_compression(za, zip_uint64_t(i), ZIP_CM_DEFLATE, 1);
  ASSERT_EQ(zip_close(za), 0);
  fs::remove(zeros);
  ASSERT_LT(fs::file_size(dir.file("bomb.zip")), uint64_t(8) << 20);

  auto up = open_upload(dir.file("bomb.zip"), {}, dir.file("scratch"));
  ASSERT_FALSE(up.ok());
  EXPECT_NE(up.status().message().find("unpacks to more than"), std::string::npos)
      << up.status().message();
  EXPECT_FALSE(fs::exists(dir.file("scratch")));
}

// The limits apply to what the archive says it holds (here a limit below the sum of the two
// members' sizes) and to its member count, each refused in one line with nothing unpacked.
// (Inflated bytes are counted too, against an archive that understates its sizes.)
TEST(Upload, UnpackedBytesAndMemberCountAreLimited) {
  TempDir dir;
  write_zip(dir.file("big.zip"), {{"m.dae", textured_dae("x.png")}, {"a.bin", std::string(4000, 'a')}});
  UploadOptions o;
  o.max_unpacked_bytes = 3000;
  auto up = open_upload(dir.file("big.zip"), o, dir.file("scratch"));
  ASSERT_FALSE(up.ok());
  EXPECT_NE(up.status().message().find("unpacks to more than 3000 bytes"), std::string::npos)
      << up.status().message();
  EXPECT_FALSE(fs::exists(dir.file("scratch")));
  o.max_unpacked_bytes = 0;
  o.max_members = 1;
  auto many = open_upload(dir.file("big.zip"), o, dir.file("scratch"));
  ASSERT_FALSE(many.ok());
  EXPECT_NE(many.status().message().find("2 members, over the limit of 1"), std::string::npos)
      << many.status().message();
}

// Two model files at the nearest depth: one line listing both and naming --main; --main picks
// one; a deeper model file does not tie with a shallower one; junk (macOS resource forks,
// hidden folders) is never a candidate.
TEST(Upload, TwoModelFilesAtOneDepthNeedMain) {
  TempDir dir;
  fs::create_directories(dir.file("up/meshes"));
  fs::create_directories(dir.file("up/__MACOSX"));
  fs::create_directories(dir.file("up/.git"));
  testing::write_text(dir.file("up/meshes/a.dae"), textured_dae("x.png"));
  testing::write_text(dir.file("up/meshes/B.DAE"), textured_dae("x.png"));
  testing::write_text(dir.file("up/meshes/deeper/c.gltf"), "{}");
  testing::write_text(dir.file("up/__MACOSX/._top.dae"), "junk");
  testing::write_text(dir.file("up/.git/top.glb"), "junk");
  auto tie = open_upload(dir.file("up"), {}, dir.file("scratch"));
  ASSERT_FALSE(tie.ok());
  EXPECT_NE(tie.status().message().find("several model files at the same depth (meshes/B.DAE, "
                                        "meshes/a.dae); name one with --main PATH"),
            std::string::npos)
      << tie.status().message();
  UploadOptions o;
  o.main = "meshes/a.dae";
  auto picked = open_upload(dir.file("up"), o, dir.file("scratch"));
  ASSERT_TRUE(picked.ok()) << picked.status().message();
  EXPECT_EQ(fs::path(picked->model()).filename(), "a.dae");
  o.main = "../../etc/passwd";
  auto outside = open_upload(dir.file("up"), o, dir.file("scratch"));
  ASSERT_FALSE(outside.ok());
  o.main = "meshes/none.dae";
  auto missing = open_upload(dir.file("up"), o, dir.file("scratch"));
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("no such file inside it"), std::string::npos);
  // One file at the top wins over any number below.
  testing::write_text(dir.file("up/top.glb"), "glTF");
  auto top = open_upload(dir.file("up"), {}, dir.file("scratch"));
  ASSERT_TRUE(top.ok()) << top.status().message();
  EXPECT_EQ(fs::path(top->model()).filename(), "top.glb");
}

TEST(Upload, EmptyFolderAndNotAZipSayWhat) {
  TempDir dir;
  fs::create_directories(dir.file("empty"));
  auto none = open_upload(dir.file("empty"), {}, dir.file("scratch"));
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.status().message().find("no .gltf, .glb or .dae file inside it"), std::string::npos);
  testing::write_text(dir.file("fake.zip"), "not an archive at all");
  auto fake = open_upload(dir.file("fake.zip"), {}, dir.file("scratch"));
  ASSERT_FALSE(fake.ok());
  EXPECT_NE(fake.status().message().find("fake.zip: not a readable zip archive"), std::string::npos)
      << fake.status().message();
  auto missing = open_upload(dir.file("nothing"), {}, dir.file("scratch"));
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.status().message().find("no such file or folder"), std::string::npos);
}

// A texture named by a path that does not exist (the author's absolute path, a bare name that
// lives in materials/textures/) is found by its file name when exactly one file in the upload
// has it, with a warning saying where; with two candidates it stays missing (a warning), since
// guessing could pick the wrong picture.
TEST(Upload, MissingTextureIsFoundByItsNameWhenUnique) {
  TempDir dir;
  fs::create_directories(dir.file("up/meshes"));
  fs::create_directories(dir.file("up/materials/textures"));
  testing::write_text(dir.file("up/meshes/m.dae"), textured_dae("C:/Users/me/Desktop/Wood.png"));
  testing::write_file(dir.file("up/materials/textures/wood.png"), kPng);
  auto up = open_upload(dir.file("up"), {}, dir.file("scratch"));
  ASSERT_TRUE(up.ok()) << up.status().message();
  Warnings w;
  auto scene = import_upload(*up, &w);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  EXPECT_EQ(scene->images.size(), 1u);
  EXPECT_TRUE(any_says(w, "materials/textures/wood.png (the only file of that name"))
      << (w.empty() ? "no warnings" : w.items()[0]);

  fs::create_directories(dir.file("up/other"));
  testing::write_file(dir.file("up/other/wood.png"), kPng);
  Warnings w2;
  auto two = import_upload(*up, &w2);
  ASSERT_TRUE(two.ok()) << two.status().message();
  EXPECT_TRUE(two->images.empty());
}

// The same for a .gltf's buffer URI: the author moved the .bin into data/.
TEST(Upload, GltfBufferFoundByNameWhenUnique) {
  TempDir dir;
  fs::create_directories(dir.file("up/data"));
  const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  testing::write_file(dir.file("up/data/tri.bin"),
                      std::vector<uint8_t>(reinterpret_cast<const uint8_t*>(xyz),
                                           reinterpret_cast<const uint8_t*>(xyz) + sizeof xyz));
  testing::write_text(dir.file("up/tri.gltf"), R"({"asset":{"version":"2.0"},
    "buffers":[{"uri":"old/tri.bin","byteLength":36}],
    "bufferViews":[{"buffer":0,"byteLength":36}],
    "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",
                  "min":[0,0,0],"max":[1,1,0]}],
    "meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],
    "nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}],"scene":0})");
  auto up = open_upload(dir.file("up"), {}, dir.file("scratch"));
  ASSERT_TRUE(up.ok()) << up.status().message();
  Warnings w;
  auto scene = import_upload(*up, &w);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  ASSERT_EQ(scene->meshes.size(), 1u);
  EXPECT_TRUE(any_says(w, "data/tri.bin (the only file")) << (w.empty() ? "no warnings" : w.items()[0]);
}

}  // namespace
}  // namespace meshmux
