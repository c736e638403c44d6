// Tiled textures stay tiled (atlas/tiled.h): a floor whose 4×4 texture repeats 20 times keeps
// its material, texture, sampler and uvs beside the atlas, instead of being baked into one
// blurred copy (a town's grass and a café's floor came out as blotches: 26.8 and 27.8 dB).
#include "atlas/tiled.h"

#include <gtest/gtest.h>

#include "atlas/atlas.h"

namespace meshmux {
namespace {

Image checker(int side) {
  Image im;
  im.name = "tile";
  im.width = im.height = side;
  im.rgba.resize(size_t(side) * side * 4);
  for (int y = 0; y < side; ++y)
    for (int x = 0; x < side; ++x) {
      uint8_t v = ((x + y) & 1) ? 230 : 30;
      uint8_t* px = &im.rgba[(size_t(y) * side + x) * 4];
      px[0] = px[1] = px[2] = v, px[3] = 255;
    }
  return im;
}

// A quad with uvs spanning `periods` periods of material 0, and a plain red quad beside it.
Scene floor_scene(float periods, Wrap wrap) {
  Scene s;
  Mesh mesh;
  for (int q = 0; q < 2; ++q) {
    Primitive p;
    const float x = float(q) * 1.5f;
    p.positions = {{x, 0, 0}, {x + 1, 0, 0}, {x + 1, 1, 0}, {x, 1, 0}};
    p.normals.assign(4, Vec3{0, 0, 1});
    const float t = q == 0 ? periods : 1;
    p.uvs = {{{0, 0}, {t, 0}, {t, t}, {0, t}}};
    p.indices = {0, 1, 2, 0, 2, 3};
    p.material = q;
    mesh.primitives.push_back(p);
  }
  s.meshes.push_back(mesh);
  s.instances.push_back({0, Mat4::identity(), "a"});
  s.instances.push_back({0, Mat4::translation(0, 2, 0), "b"});
  Material tiles;
  tiles.name = "tiles";
  tiles.base_color.image = 0;
  tiles.base_color.sampler.wrap_s = tiles.base_color.sampler.wrap_t = wrap;
  Material red;
  red.name = "red";
  red.base_color_factor = {0.8f, 0.05f, 0.05f, 1};
  s.materials = {tiles, red};
  s.images.push_back(checker(4));
  return s;
}

TEST(Tiled, RepeatOverManyPeriodsIsTiled) {
  EXPECT_EQ(find_tiled_materials(floor_scene(20, Wrap::kRepeat)), (std::vector<char>{1, 0}));
  EXPECT_EQ(find_tiled_materials(floor_scene(20, Wrap::kMirroredRepeat)), (std::vector<char>{1, 0}));
  // Within two periods (a texture nudged past its edge), or clamped: baked as before.
  EXPECT_EQ(find_tiled_materials(floor_scene(1.8f, Wrap::kRepeat)), (std::vector<char>{0, 0}));
  EXPECT_EQ(find_tiled_materials(floor_scene(20, Wrap::kClampToEdge)), (std::vector<char>{0, 0}));
}

// The atlas keeps the tiled floor as it came: its own material after the atlas's, the source
// image (same texels), REPEAT, the original uvs, placed by both instances.
TEST(Tiled, AtlasKeepsTheTiledMaterialBesideTheAtlas) {
  Scene s = floor_scene(20, Wrap::kRepeat);
  AtlasReport rep;
  auto out = build_atlas(s, AtlasOptions{}, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  EXPECT_EQ(rep.tiled_materials, 1u);
  ASSERT_EQ(out->materials.size(), 2u);
  const Material& kept = out->materials[1];
  EXPECT_EQ(kept.name, "tiles");
  EXPECT_EQ(kept.base_color.sampler.wrap_s, Wrap::kRepeat);
  ASSERT_TRUE(kept.base_color.present());
  EXPECT_EQ(out->images[size_t(kept.base_color.image)].rgba, s.images[0].rgba);
  EXPECT_NE(kept.base_color.image, out->materials[0].base_color.image);
  size_t placed = 0;
  for (const Instance& inst : out->instances) {
    const Primitive& p = out->meshes[inst.mesh].primitives[0];
    ASSERT_EQ(out->meshes[inst.mesh].primitives.size(), 1u);
    if (p.material != 1) continue;
    ++placed;
    EXPECT_EQ(p.uvs[0][2], (Vec2{20, 20}));
  }
  EXPECT_EQ(placed, 2u);
  // Off (tiled_periods 0): everything is baked, one material.
  AtlasOptions bake_all;
  bake_all.tiled_periods = 0;
  auto baked = build_atlas(s, bake_all, nullptr, nullptr);
  ASSERT_TRUE(baked.ok());
  EXPECT_EQ(baked->materials.size(), 1u);
}

// A scene where everything is tiled has no atlas at all: the materials are the source's.
TEST(Tiled, AllTiledSceneKeepsItsMaterials) {
  Scene s = floor_scene(20, Wrap::kRepeat);
  s.meshes[0].primitives.pop_back();
  s.materials.pop_back();
  auto out = build_atlas(s, AtlasOptions{}, nullptr, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_EQ(out->materials.size(), 1u);
  EXPECT_EQ(out->materials[0].name, "tiles");
  EXPECT_EQ(out->instances.size(), 2u);
}

}  // namespace
}  // namespace meshmux
