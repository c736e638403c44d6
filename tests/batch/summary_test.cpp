// batch/summary.h in-process: what batch.json says of the run.
#include "batch/summary.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "core/file_io.h"
#include "test_util.h"

namespace meshmux {
namespace {

using testing::TempDir;

// batch.json names the meshmux that wrote it (a summary written by a library built without
// the project's version once said "0.0.0"), and counts an input without a record as not
// converted, with the reason given.
TEST(BatchSummary, NamesTheVersionAndCountsMissingRecords) {
  TempDir dir;
  const std::string outroot = dir.file("out"), state = outroot + "/.meshmux-batch";
  std::filesystem::create_directories(state + "/records");
  BatchItem item;
  item.input = dir.file("in/a.glb"), item.name = "a", item.hash = "0123456789abcdef";
  BatchSummaryInfo info;
  info.mode = "local";
  info.missing_default = "not converted (interrupted)";
  auto counts = write_batch_summary(outroot, state, {item}, info);
  ASSERT_TRUE(counts.ok()) << counts.status().message();
  EXPECT_EQ(counts->inputs, 1u);
  EXPECT_EQ(counts->not_converted, 1u);
  auto text = read_whole_file(outroot + "/batch.json");
  ASSERT_TRUE(text.ok());
  const auto doc = nlohmann::json::parse(text->begin(), text->end());
  EXPECT_EQ(doc["meshmux"], MESHMUX_VERSION);
  EXPECT_NE(doc["meshmux"], "0.0.0");
  EXPECT_TRUE(std::filesystem::exists(outroot + "/index.html"));
}

}  // namespace
}  // namespace meshmux
