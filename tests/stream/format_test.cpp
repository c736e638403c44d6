// stream/format.h and the web client. The constants the client needs (version, limits, channel
// names) are not checked here: the build generates them from the headers
// (scripts/format_constants.mjs → viewers/web/stream_format.js), so there is no copy to drift.
// What is checked is what cannot be generated: world.json's reader, and the material slot the
// client binds each channel to.
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

TEST(Format, WebClientBindsEveryChannelToAMaterialSlot) {
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
