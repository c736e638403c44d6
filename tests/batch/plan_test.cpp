// batch/plan.h in-process: output names and the records that make a batch resumable.
#include "batch/plan.h"

#include <gtest/gtest.h>

#include <cctype>
#include <filesystem>
#include <string>
#include <vector>

#include "test_util.h"

namespace meshmux {
namespace {

using testing::TempDir;
using testing::write_text;

// Uploads from a model database often share a file name (every Fox is Fox.gltf): the folders
// above tell them apart, then the extension, then a counter; the same list gives the same names.
TEST(BatchNames, ClashesArePrefixedByTheirFolders) {
  const std::vector<std::string> inputs = {"/m/Fox/glTF/Fox.gltf", "/m/Fox/glTF-Binary/Fox.glb",
                                           "/m/Duck/duck.dae",     "/m/a/model.gltf",
                                           "/m/a/model.glb",       "/m/b c/Weird name!.zip"};
  const std::vector<std::string> names = batch_names(inputs);
  ASSERT_EQ(names.size(), inputs.size());
  EXPECT_EQ(names[2], "duck");
  EXPECT_NE(names[0], names[1]);
  EXPECT_NE(names[0].find("Fox"), std::string::npos);
  EXPECT_NE(names[3], names[4]);
  for (const std::string& n : names) {
    EXPECT_FALSE(n.empty());
    EXPECT_EQ(
        n.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_"),
        std::string::npos)
        << n;
  }
  EXPECT_EQ(batch_names(inputs), names);
}

// Two inputs whose names differ only in letter case would share a folder on a
// case-insensitive file system.
TEST(BatchNames, CaseOnlyClashesAreSeparated) {
  const std::vector<std::string> names = batch_names({"/x/Model.glb", "/y/model.glb"});
  ASSERT_EQ(names.size(), 2u);
  EXPECT_NE(names[0], names[1]);
}

// An upload named like OUTROOT's own entries (viewer/ holds world.html's library, index.html
// the summary) would overwrite them or be overwritten: it gets another name.
TEST(BatchNames, OutrootsOwnNamesAreNotGiven) {
  EXPECT_EQ(batch_names({"/x/viewer.glb", "/z/a.glb"}),
            (std::vector<std::string>{"viewer-model", "a"}));
  for (std::string name : batch_names({"/x/viewer.glb", "/y/Viewer.gltf"})) {
    for (char& c : name) c = char(std::tolower(static_cast<unsigned char>(c)));
    EXPECT_NE(name, "viewer");
  }
}

BatchRecord finished(const std::string& status, const std::string& cause) {
  BatchRecord r;
  r.input = "/in/a.glb", r.name = "a", r.hash = "0123456789abcdef", r.options = "opts";
  r.status = status, r.cause = cause;
  return r;
}

// A record survives a round trip through its file, and decides resumption: converted with its
// model.glb present, or failed on its own bytes, is final; a different input, other options, a
// missing output or a timeout is converted again.
TEST(BatchRecords, RecordsDecideWhatIsConvertedAgain) {
  TempDir dir;
  const std::string state = dir.file("state"), outroot = dir.file("out");
  std::filesystem::create_directories(state + "/records");
  BatchRecord ok = finished("ok", "");
  ok.seconds = 1.5, ok.glb_bytes = 1234, ok.warnings = 2, ok.first_warning = "w";
  ASSERT_TRUE(write_record(state, ok));
  auto back = read_record(state, "a");
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(back->hash, ok.hash);
  EXPECT_EQ(back->glb_bytes, 1234u);
  EXPECT_EQ(back->first_warning, "w");
  EXPECT_FALSE(read_record(state, "b").has_value());

  BatchItem item;
  item.input = ok.input, item.name = "a", item.hash = ok.hash;
  EXPECT_FALSE(record_is_final(ok, item, "opts", outroot, false));  // no model.glb yet
  std::filesystem::create_directories(outroot + "/a");
  EXPECT_FALSE(record_is_final(ok, item, "opts", outroot, false));  // a folder is not enough
  write_text(outroot + "/a/model.glb", "glTF");
  EXPECT_TRUE(record_is_final(ok, item, "opts", outroot, false));
  EXPECT_FALSE(record_is_final(ok, item, "other opts", outroot, false));
  BatchItem changed = item;
  changed.hash = "fedcba9876543210";
  EXPECT_FALSE(record_is_final(ok, changed, "opts", outroot, false));

  const BatchRecord bad_input = finished("failed", "input");
  EXPECT_TRUE(record_is_final(bad_input, item, "opts", outroot, false));
  EXPECT_FALSE(record_is_final(bad_input, item, "opts", outroot, /*retry_failed=*/true));
  for (const char* cause : {"timeout", "memory", "crash", "internal"})
    EXPECT_FALSE(record_is_final(finished("failed", cause), item, "opts", outroot, false)) << cause;
}

}  // namespace
}  // namespace meshmux
