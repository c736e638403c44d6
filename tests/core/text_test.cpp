// core/text.h: a world's URLs, a summary page's links and an upload's URIs are escaped by
// url_escape and read back by percent_decode (three copies of the decoder once disagreed on
// nothing but could have): an escaped name decodes to itself, and a malformed escape stays.
#include "core/text.h"

#include <gtest/gtest.h>

namespace meshmux {
namespace {

TEST(Text, PercentDecodeUndoesUrlEscape) {
  for (const std::string name : {"Duck", "a b/c%d", "über-model (2).glb", "100%"})
    EXPECT_EQ(percent_decode(url_escape(name)), name);
  EXPECT_EQ(percent_decode("b%20b/model.mmxp"), "b b/model.mmxp");
  EXPECT_EQ(percent_decode("%2e%2E"), "..");
}

TEST(Text, MalformedEscapesStayAsTheyAre) {
  EXPECT_EQ(percent_decode("100%"), "100%");
  EXPECT_EQ(percent_decode("%4"), "%4");
  EXPECT_EQ(percent_decode("%zz%41"), "%zzA");
}

}  // namespace
}  // namespace meshmux
