// cli/args.h: the one flag table every command parses with.
#include "cli/args.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace meshmux {
namespace {

// Flags are checked against the command that takes them, with one line naming the flag.
TEST(Args, FlagsBelongToTheirCommands) {
  auto ok = parse_args(kConvert, {"in.glb", "-o", "out", "--jpeg-quality", "90", "-q"});
  ASSERT_TRUE(ok.ok()) << ok.status().message();
  EXPECT_EQ(ok->positional, std::vector<std::string>{"in.glb"});
  EXPECT_EQ(ok->text("--output"), "out");
  EXPECT_EQ(ok->whole("--jpeg-quality", 85), 90);
  EXPECT_EQ(ok->whole("--crease", 60), 60);  // not given: the default
  EXPECT_TRUE(ok->has("--quiet"));
  auto foreign = parse_args(kServe, {"dir", "--jpeg-quality", "90"});
  ASSERT_FALSE(foreign.ok());
  EXPECT_EQ(foreign.status().message(), "unknown option --jpeg-quality");
  auto range = parse_args(kConvert, {"in.glb", "--jpeg-quality", "500"});
  ASSERT_FALSE(range.ok());
  EXPECT_EQ(range.status().message(),
            "--jpeg-quality expects a whole number from 1 to 100, got '500'");
  auto missing = parse_args(kServe, {"dir", "--port"});
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().message(), "--port needs a value");
  auto two = parse_args(kInfo, {"a.glb", "b.glb"});
  ASSERT_FALSE(two.ok());
  EXPECT_EQ(two.status().message(), "more than one input given ('a.glb' and 'b.glb')");
}

// A display size is "WxH" whole device pixels (--display, and render's --size): anything else is
// refused rather than read as far as it goes ("1920" alone, a zero side, a sign, a fraction).
TEST(Args, SizesAreWholeWidthTimesHeight) {
  int w = 0, h = 0;
  EXPECT_TRUE(parse_size("1920x1080", &w, &h));
  EXPECT_EQ(w, 1920);
  EXPECT_EQ(h, 1080);
  for (const char* bad : {"1920", "0x5", "x5", "5x", "+5x5", "5x5.5", "-5x5", "5x9000", "5 x5", ""})
    EXPECT_FALSE(parse_size(bad, &w, &h)) << bad;
  EXPECT_TRUE(parse_args(kConvert, {"in", "-o", "out", "--display", "640x360"}).ok());
  EXPECT_FALSE(parse_args(kServe, {"dir", "--display", "640x360"}).ok());
  EXPECT_NE(convert_flags_text().find("--display WxH"), std::string::npos);
}

// One name, two meanings: --max-memory caps a conversion (any positive MB) or, for batch, each
// of its conversions (at least 64 MB).
TEST(Args, SameFlagDifferentRangesPerCommand) {
  EXPECT_TRUE(parse_args(kConvert, {"in", "--max-memory", "4"}).ok());
  EXPECT_FALSE(parse_args(kBatch, {"list", "--max-memory", "4"}).ok());
  EXPECT_TRUE(parse_args(kBatch, {"list", "--max-memory", "64"}).ok());
  for (const char* bad : {"0", "-5", "lots", "", "1.5"})
    EXPECT_FALSE(parse_args(kInfo, {"in", "--max-texels", bad}).ok()) << bad;
}

// batch hands convert's flags to every conversion, in the order given, and keeps its own.
TEST(Args, BatchHandsConvertFlagsOn) {
  auto p = parse_args(kBatch, {"list", "-o", "out", "-j", "3", "--no-draco", "--jpeg-quality", "70",
                               "--allow-outside", "--retry-failed"});
  ASSERT_TRUE(p.ok()) << p.status().message();
  EXPECT_EQ(p->whole("--jobs", 1), 3);
  EXPECT_EQ(p->convert_args(),
            (std::vector<std::string>{"--no-draco", "--jpeg-quality", "70", "--allow-outside"}));
  EXPECT_NE(convert_flags_text().find("--jpeg-quality N"), std::string::npos);
  EXPECT_EQ(convert_flags_text().find("--jobs"), std::string::npos);
}

// Numbers with open ends: a ratio of 0 keeps nothing, a field of view of 180 degrees is none.
TEST(Args, NumberRangesKeepTheirOpenEnds) {
  EXPECT_FALSE(parse_args(kSimplify, {"in", "--ratio", "0"}).ok());
  EXPECT_TRUE(parse_args(kSimplify, {"in", "--ratio", "1"}).ok());
  EXPECT_TRUE(parse_args(kSimplify, {"in", "--error", "0"}).ok());
  EXPECT_FALSE(parse_args(kRender, {"in", "--fov", "180"}).ok());
  EXPECT_TRUE(parse_args(kRender, {"in", "--fov", "179.5"}).ok());
  EXPECT_FALSE(parse_args(kRender, {"in", "--near", "nan"}).ok());
  EXPECT_FALSE(parse_args(kSample, {"extra"}, 0).ok());
}

// A user who asks for help gets it, even beside a mistake.
TEST(Args, HelpWinsOverMistakes) {
  auto p = parse_args(kServe, {"--bogus", "-h", "--port", "x"});
  ASSERT_TRUE(p.ok()) << p.status().message();
  EXPECT_TRUE(p->help);
}

}  // namespace
}  // namespace meshmux
