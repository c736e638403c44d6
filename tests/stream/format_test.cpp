// stream/format.h against the web client, which cannot include it: the version it reads and the
// channel names it knows must be the writer's, or a package written today is refused (version)
// or shows a map in the wrong slot (channels) in every browser.
#include "stream/format.h"

#include <gtest/gtest.h>

#include <regex>
#include <string>
#include <vector>

#include "core/file_io.h"
#include "stream/world_format.h"

namespace meshmux {
namespace {

std::string web_file(const std::string& name) {
  auto text = read_whole_file(std::string(MESHMUX_SOURCE_DIR) + "/viewers/web/" + name);
  EXPECT_TRUE(text.ok()) << name;
  return text.ok() ? std::string(text->begin(), text->end()) : std::string();
}

TEST(Format, WebClientReadsThisVersion) {
  const std::string reader = web_file("package_reader.js");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(reader, m, std::regex(R"(PACKAGE_VERSION = (\d+);)")));
  EXPECT_EQ(std::stoul(m[1].str()), kPackageVersion);
}

// world.json's version and limits (stream/world_format.h) against the browser's reader
// (world_plan.js): a world `meshmux batch` writes must be one the browser accepts, and a world
// the browser accepts must be one `meshmux info` accepts.
TEST(Format, WebWorldReaderHasTheSpecsVersionAndLimits) {
  const std::string plan = web_file("world_plan.js");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(plan, m, std::regex(R"(WORLD_VERSION = (\d+);)")));
  EXPECT_EQ(std::stoi(m[1].str()), kWorldVersion);
  ASSERT_TRUE(std::regex_search(
      plan, m,
      std::regex(R"(maxBytes: (\d+) << (\d+), maxPackages: (\d+), maxPlacements: (\d+))")));
  EXPECT_EQ(std::stoull(m[1].str()) << std::stoull(m[2].str()), kWorldMaxBytes);
  EXPECT_EQ(std::stoull(m[3].str()), kWorldMaxPackages);
  EXPECT_EQ(std::stoull(m[4].str()), kWorldMaxPlacements);
  ASSERT_TRUE(std::regex_search(plan, m, std::regex(R"(MAX_COORDINATE = ([0-9e.]+);)")));
  EXPECT_EQ(std::stod(m[1].str()), kWorldMaxCoordinate);
}

TEST(Format, WebClientKnowsTheChannelsInOrder) {
  const std::string reader = web_file("package_reader.js");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(reader, m, std::regex(R"(const CHANNELS = \[([^\]]*)\])")));
  std::vector<std::string> names;
  const std::string list = m[1].str();
  const std::regex quoted(R"('([a-z_]+)')");
  for (auto it = std::sregex_iterator(list.begin(), list.end(), quoted);
       it != std::sregex_iterator(); ++it)
    names.push_back((*it)[1].str());
  ASSERT_EQ(names.size(), kChannelNames.size());
  for (size_t i = 0; i < names.size(); ++i) EXPECT_EQ(names[i], kChannelNames[i]) << i;
  // The client binds every channel to a material slot (viewers/web/materials.js CHANNEL_SLOTS).
  const std::string client = web_file("materials.js");
  for (const char* name : kChannelNames)
    EXPECT_NE(client.find(std::string("  ") + name + ": ["), std::string::npos) << name;
}

TEST(Format, ChannelNamesRoundTrip) {
  for (size_t i = 0; i < kChannelNames.size(); ++i) {
    auto c = parse_channel(kChannelNames[i]);
    ASSERT_TRUE(c.has_value()) << kChannelNames[i];
    EXPECT_STREQ(channel_name(*c), kChannelNames[i]);
  }
  EXPECT_FALSE(parse_channel("albedo").has_value());
  EXPECT_FALSE(is_texture_channel(""));
}

}  // namespace
}  // namespace meshmux
