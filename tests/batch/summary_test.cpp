// batch/summary.h in-process: what batch.json says of the run.
#include "batch/summary.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "batch/world.h"
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

// world.json holds every current conversion with a stream, boxed as its report.json says and
// in list order on the grid; a conversion without a stream (model.glb only) is not in it, and
// one whose report has no box is left out with a note rather than placed at a made-up size.
TEST(BatchSummary, WritesTheWorldOfTheStreamedConversions) {
  TempDir dir;
  const std::string outroot = dir.file("out"), state = outroot + "/.meshmux-batch";
  std::filesystem::create_directories(state + "/records");
  BatchSummaryInfo info;
  info.mode = "local";
  info.fingerprint = "f";
  std::vector<BatchItem> items;
  const char* names[] = {"a", "glb_only", "old", "b"};
  for (const char* name : names) {
    BatchItem item;
    item.input = dir.file(std::string("in/") + name + ".glb"), item.name = name;
    item.hash = "0123456789abcdef";
    items.push_back(item);
    BatchRecord rec;
    rec.input = item.input, rec.name = name, rec.hash = item.hash, rec.options = "f";
    rec.status = "ok";
    rec.glb_bytes = 100;
    rec.stream_bytes = std::string(name) == "glb_only" ? 0 : 2000;
    ASSERT_TRUE(write_record(state, rec).is_ok());
    std::filesystem::create_directories(outroot + "/" + name);
    ASSERT_TRUE(write_file_atomic(outroot + "/" + name + "/model.glb", std::string("glb")).is_ok());
    const std::string report =
        std::string(name) == "old" ? "{\"curves\": {}}" : "{\"bounds\": [0, 0, 0, 2, 4, 4]}";
    ASSERT_TRUE(write_file_atomic(outroot + "/" + name + "/report.json", report).is_ok());
  }
  auto counts = write_batch_summary(outroot, state, items, info);
  ASSERT_TRUE(counts.ok()) << counts.status().message();
  EXPECT_EQ(counts->world_packages, 2u);
  EXPECT_EQ(counts->world_placements, 2u);
  ASSERT_EQ(counts->world_notes.size(), 1u);
  EXPECT_NE(counts->world_notes[0].find("old/report.json"), std::string::npos);
  auto text = read_whole_file(outroot + "/world.json");
  ASSERT_TRUE(text.ok());
  auto world = parse_world(std::string(text->begin(), text->end()), "world.json");
  ASSERT_TRUE(world.ok()) << world.status().message();
  ASSERT_EQ(world->packages.size(), 2u);
  EXPECT_EQ(world->packages[0].url, "a/model.mmxp");
  EXPECT_EQ(world->packages[1].url, "b/model.mmxp");
  EXPECT_EQ(world->packages[1].bytes, 2000u);
  EXPECT_EQ(world->packages[0].bounds, (std::array<double, 6>{0, 0, 0, 2, 4, 4}));
  EXPECT_NEAR(world->placements[0].matrix[0], 1.0 / 6.0, 1e-12);  // the box's diagonal is 6
}

}  // namespace
}  // namespace meshmux
