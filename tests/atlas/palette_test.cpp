#include "atlas/palette.h"

#include <gtest/gtest.h>

#include "atlas/atlas.h"
#include "image/color.h"

namespace meshmux {
namespace {

// A w × h image of distinct opaque texels (a photograph-like main texture).
Image distinct(int w, int h) {
  Image img;
  img.name = "main.png";
  img.width = w;
  img.height = h;
  for (int i = 0; i < w * h; ++i)
    img.rgba.insert(img.rgba.end(), {uint8_t(7 * i), uint8_t(255 - 5 * i), uint8_t(3 * i), 255});
  return img;
}

// A 4 × 4 palette: the left half red, the right half blue (sRGB bytes).
Image palette() {
  Image img;
  img.name = "palette.png";
  img.width = img.height = 4;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x)
      img.rgba.insert(img.rgba.end(), {uint8_t(x < 2 ? 200 : 0), 0, uint8_t(x < 2 ? 0 : 150), 255});
  return img;
}

// A quad at height z with the given uvs per corner.
Primitive quad(float z, std::vector<Vec2> uv, int32_t material) {
  Primitive p;
  p.positions = {{0, 0, z}, {1, 0, z}, {1, 1, z}, {0, 1, z}};
  p.normals.assign(4, {0, 0, 1});
  p.uvs = {std::move(uv)};
  p.indices = {0, 1, 2, 0, 2, 3};
  p.material = material;
  return p;
}

// BoomBoxWithAxes: a body sampling its one 2048² texture over [0, 1]², and axes coloured by
// placing their faces inside the swatches of a 32² palette. The palette's faces each show one
// colour, so they are plain colours and the body's texture stays the atlas as it is; before,
// the second image sent every face through charts, resampling the body's texture (−1 dB unlit,
// 11 s of a 16 s conversion baking 4096²).
Scene body_and_palette_axes() {
  Scene s;
  s.images = {distinct(8, 8), palette()};
  Material body;
  body.base_color.image = 0;
  Material axes;
  axes.base_color.image = 1;
  axes.roughness_factor = 0.7f;
  s.materials = {body, axes};
  Mesh mesh;
  mesh.primitives.push_back(quad(0, {{0, 1}, {1, 1}, {1, 0}, {0, 0}}, 0));
  // The axes: one quad inside the red half, one inside the blue half (inside by a texel's
  // half, so the bilinear footprint stays in the swatch).
  mesh.primitives.push_back(
      quad(1, {{0.15f, 0.2f}, {0.35f, 0.2f}, {0.35f, 0.8f}, {0.15f, 0.8f}}, 1));
  mesh.primitives.back().indices = {0, 1, 2};
  Primitive blue = quad(2, {{0.65f, 0.2f}, {0.85f, 0.2f}, {0.85f, 0.8f}, {0.65f, 0.8f}}, 1);
  blue.indices = {0, 2, 3};
  // The same primitive holds both colours, as the corpus's CoordinateSystem mesh does.
  Primitive& both = mesh.primitives.back();
  const uint32_t base = uint32_t(both.positions.size());
  for (size_t k = 0; k < blue.positions.size(); ++k) {
    both.positions.push_back(blue.positions[k]);
    both.normals.push_back(blue.normals[k]);
    both.uvs[0].push_back(blue.uvs[0][k]);
  }
  for (uint32_t i : blue.indices) both.indices.push_back(base + i);
  s.meshes.push_back(mesh);
  s.instances.push_back({0, Mat4::identity(), ""});
  return s;
}

TEST(Palette, PaletteFacesBecomePlainColoursAndTheMainTextureIsKept) {
  Scene s = body_and_palette_axes();
  size_t replaced = 0;
  std::optional<Scene> plain = palette_as_plain_colors(s, &replaced);
  ASSERT_TRUE(plain.has_value());
  EXPECT_EQ(replaced, 1u);
  const Mesh& m = plain->meshes[0];
  ASSERT_EQ(m.primitives.size(), 3u) << "the body, then the axes split by colour";
  const Material& red = plain->materials[size_t(m.primitives[1].material)];
  const Material& blue = plain->materials[size_t(m.primitives[2].material)];
  EXPECT_FALSE(red.base_color.present());
  EXPECT_FLOAT_EQ(red.base_color_factor.x, srgb_to_linear(200));
  EXPECT_FLOAT_EQ(red.base_color_factor.z, 0);
  EXPECT_FLOAT_EQ(blue.base_color_factor.z, srgb_to_linear(150));
  EXPECT_FLOAT_EQ(red.roughness_factor, 0.7f) << "the other factors stay";
  EXPECT_EQ(m.primitives[1].triangle_count() + m.primitives[2].triangle_count(), 2u);

  AtlasReport rep;
  auto out = build_atlas(s, {}, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  EXPECT_TRUE(rep.reused_source) << "the body's texture is the atlas, texel for texel";
  EXPECT_EQ(rep.palette_materials, 1u);
}

// A face whose footprint crosses two swatches shows a blend (and a real texture shows many
// texels): the material stays textured.
TEST(Palette, FaceAcrossSwatchesStaysTextured) {
  Scene s = body_and_palette_axes();
  s.meshes[0].primitives[1].uvs[0][1] = {0.6f, 0.2f};
  size_t replaced = 7;
  EXPECT_FALSE(palette_as_plain_colors(s, &replaced).has_value());
  EXPECT_EQ(replaced, 0u);
}

}  // namespace
}  // namespace meshmux
