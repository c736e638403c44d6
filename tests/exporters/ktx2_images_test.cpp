#include "exporters/ktx2_images.h"

#include <gtest/gtest.h>

namespace meshmux {
namespace {

// Which mode an image takes follows how the materials read it: sRGB colour (ETC1S) wherever
// one reads it as colour, even if another reads it as data; a normal map over data; an image no
// material samples is not encoded at all.
TEST(Ktx2Images, UsesFollowTheMaterialsThatSampleThem) {
  Scene s;
  s.images.resize(6);
  Material a;
  a.base_color.image = 0;
  a.normal.image = 1;
  a.metallic_roughness.image = 2;
  a.occlusion.image = 3;
  Material b;
  b.emissive.image = 3;  // data in a, colour in b: colour
  b.layer(LayerSlot::kClearcoatNormal).image = 4;
  b.layer(LayerSlot::kClearcoat).image = 4;  // a normal map and data: a normal map
  s.materials = {a, b};
  const std::vector<ImageUse> uses = image_uses(s);
  ASSERT_EQ(uses.size(), 6u);
  EXPECT_EQ(uses[0], ImageUse::kColour);
  EXPECT_EQ(uses[1], ImageUse::kNormal);
  EXPECT_EQ(uses[2], ImageUse::kData);
  EXPECT_EQ(uses[3], ImageUse::kColour);
  EXPECT_EQ(uses[4], ImageUse::kNormal);
  EXPECT_EQ(uses[5], ImageUse::kNone);
}

}  // namespace
}  // namespace meshmux
