// stream/format.h and the web client. The constants the client needs (the package's and
// world.json's versions and limits, channel names) are not checked here: the build generates
// them from the headers (scripts/format_constants.mjs → viewers/web/stream_format.js), so there
// is no copy to drift. What is checked is what cannot be generated: the material slot the client
// binds each channel to.
#include "stream/format.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "core/file_io.h"

namespace meshmux {
namespace {

std::string web_file(const std::string& name) {
  auto text = read_whole_file(std::string(MESHMUX_SOURCE_DIR) + "/viewers/web/" + name);
  EXPECT_TRUE(text.ok()) << name;
  return text.ok() ? std::string(text->begin(), text->end()) : std::string();
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
