// Materials the atlas cannot stand in for stay as they came beside it (atlas/kept.h): a
// clearcoat wicker's relief map (lit 23.9 dB when folded into a constant), a checker minified
// without mipmaps (MorphPrimitivesTest, 21.8 dB when resampled into a chart), anisotropy.
#include "atlas/kept.h"

#include <gtest/gtest.h>

#include <cmath>

#include "atlas/atlas.h"
#include "image/encode.h"

namespace meshmux {
namespace {

Image gradient(int side) {
  Image im;
  im.name = "gradient";
  im.width = im.height = side;
  for (int i = 0; i < side * side; ++i)
    im.rgba.insert(im.rgba.end(), {uint8_t(i % 251), uint8_t(i / side * 7), 90, 255});
  return im;
}

// Two textured quads side by side: material 0 (the one a case changes) and a plain textured
// material 1, each sampling its own 16² image over [0, 1]².
Scene two_quads() {
  Scene s;
  Mesh mesh;
  for (int q = 0; q < 2; ++q) {
    Primitive p;
    const float x = float(q) * 1.5f;
    p.positions = {{x, 0, 0}, {x + 1, 0, 0}, {x + 1, 1, 0}, {x, 1, 0}};
    p.normals.assign(4, Vec3{0, 0, 1});
    p.uvs = {{{0, 0}, {1, 0}, {1, 1}, {0, 1}}};
    p.indices = {0, 1, 2, 0, 2, 3};
    p.material = q;
    mesh.primitives.push_back(p);
    Material m;
    m.name = q == 0 ? "special" : "plain";
    m.base_color.image = q;
    s.materials.push_back(m);
    s.images.push_back(gradient(16));
  }
  s.meshes.push_back(mesh);
  s.instances.push_back({0, Mat4::identity(), ""});
  return s;
}

// The default sampler (trilinear) and no layers: nothing is kept.
TEST(Kept, PlainTexturesAreBaked) {
  EXPECT_EQ(find_kept_materials(two_quads(), 2),
            (std::vector<KeptReason>{KeptReason::kNone, KeptReason::kNone}));
}

// A minification filter without mipmaps (LINEAR or NEAREST) or NEAREST magnification shows the
// source's own texel grid: kept. LINEAR_MIPMAP_LINEAR (9987) is not.
TEST(Kept, SamplersShowingTheTexelGridAreKept) {
  for (auto [min, mag, kept] : {std::tuple{9729, 9729, true}, std::tuple{9728, 0, true},
                                std::tuple{0, 9728, true}, std::tuple{9987, 9729, false}}) {
    Scene s = two_quads();
    s.materials[0].base_color.sampler.min_filter = min;
    s.materials[0].base_color.sampler.mag_filter = mag;
    EXPECT_EQ(find_kept_materials(s, 2)[0], kept ? KeptReason::kTexelGrid : KeptReason::kNone)
        << min << " " << mag;
  }
}

// NEAREST within a mip level shows the texel grid too; a power-of-two image keeps it where the
// atlas reuses the image as it is, but one of other sides must be resampled to powers of two
// for the atlas and the texture levels, and its grid then moves: kept (a 211² palette sampled
// NEAREST_MIPMAP_LINEAR lost 6 dB resampled). Trilinear NPOT images are baked as before.
TEST(Kept, NearestWithinALevelOfANonPowerOfTwoImageIsKept) {
  for (auto [min, side, kept] : {std::tuple{9986, 13, true}, std::tuple{9984, 13, true},
                                 std::tuple{9986, 16, false}, std::tuple{9987, 13, false}}) {
    Scene s = two_quads();
    s.images[0] = gradient(side);
    s.materials[0].base_color.sampler.min_filter = min;
    EXPECT_EQ(find_kept_materials(s, 2)[0], kept ? KeptReason::kTexelGrid : KeptReason::kNone)
        << min << " " << side;
  }
}

// A layer texture (here the clearcoat's normal map), a transmission texture or anisotropy keep
// their material: the atlas carries none of them.
TEST(Kept, LayerTexturesAndAnisotropyAreKept) {
  Scene s = two_quads();
  s.materials[0].clearcoat_factor = 1;
  s.materials[0].layer(LayerSlot::kClearcoatNormal).image = 1;
  EXPECT_EQ(find_kept_materials(s, 2)[0], KeptReason::kLayers);
  s = two_quads();
  s.materials[0].anisotropy_strength = 0.5f;
  EXPECT_EQ(find_kept_materials(s, 2)[0], KeptReason::kLayers);
  s = two_quads();
  s.materials[0].transmission_factor = 1;
  s.materials[0].transmission.image = 1;
  EXPECT_EQ(find_kept_materials(s, 2)[0], KeptReason::kLayers);
}

// The atlas keeps the clearcoat material with its layer texture, after the atlas's material,
// and counts it; the plain quad is baked.
TEST(Kept, AtlasKeepsTheLayeredMaterialWithItsTextures) {
  Scene s = two_quads();
  s.materials[0].clearcoat_factor = 1;
  s.materials[0].layer(LayerSlot::kClearcoatNormal).image = 1;
  s.materials[0].layer(LayerSlot::kClearcoatNormal).scale = 0.5f;
  AtlasReport rep;
  auto out = build_atlas(s, AtlasOptions{}, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  EXPECT_EQ(rep.kept_materials, 1u);
  EXPECT_EQ(rep.layer_materials, 1u);
  ASSERT_EQ(out->materials.size(), 2u);
  const Material& kept = out->materials[1];
  EXPECT_EQ(kept.name, "special");
  const TextureRef& normal = kept.layer(LayerSlot::kClearcoatNormal);
  ASSERT_TRUE(normal.present());
  EXPECT_FLOAT_EQ(normal.scale, 0.5f);
  EXPECT_EQ(out->images[size_t(normal.image)].rgba, s.images[1].rgba);
  EXPECT_EQ(out->images[size_t(kept.base_color.image)].rgba, s.images[0].rgba);
}

// Asked not to keep them (keep_unbakeable off), such materials are baked like the rest: here a
// texel-grid sampler's quad joins the plain one in the one atlas material.
TEST(Kept, KeepUnbakeableOffBakesEverything) {
  Scene s = two_quads();
  s.materials[0].base_color.sampler.min_filter = 9729;
  AtlasOptions bake_all;
  bake_all.keep_unbakeable = false;
  AtlasReport rep;
  auto baked = build_atlas(s, bake_all, &rep, nullptr);
  ASSERT_TRUE(baked.ok());
  EXPECT_EQ(baked->materials.size(), 1u);
  EXPECT_EQ(rep.kept_materials, 0u);
}

// The kept materials' images are coded as the atlas's are: a photograph that came as a PNG is
// re-encoded as JPEG (far smaller), an image with alpha keeps its PNG bytes, and the atlas's
// own images are left to the texture levels.
TEST(Kept, KeptOpaqueImagesAreReencodedAsJpeg) {
  Scene s = two_quads();
  s.materials[0].base_color.sampler.min_filter = 9729;  // kept: texel grid
  Image big = gradient(256);  // a photograph's texture: smooth shading and grain
  big.name = "kept.png";
  uint32_t seed = 99;
  for (size_t i = 0; i < big.rgba.size(); ++i)
    if (i % 4 != 3) {
      seed = seed * 1664525u + 1013904223u;
      const double x = double(i / 4 % 256), y = double(i / 4 / 256);
      big.rgba[i] = uint8_t(120 + 80 * std::sin(x * 0.05 + double(i % 4)) * std::cos(y * 0.03) +
                            double(seed >> 29));
    }
  auto png = encode_png(big);
  ASSERT_TRUE(png.ok());
  big.encoded = png.take();
  big.mime_type = "image/png";
  const size_t png_bytes = big.encoded.size();
  s.images[0] = big;
  AtlasReport rep;
  auto out = build_atlas(s, {}, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_EQ(rep.kept_materials, 1u);
  const int32_t kept_image = out->materials.back().base_color.image;
  Scene scene = *out;
  const size_t saved = encode_kept_images(scene, rep.kept_materials, 85);
  const Image& coded = scene.images[size_t(kept_image)];
  EXPECT_EQ(coded.mime_type, "image/jpeg");
  EXPECT_LT(coded.encoded.size(), png_bytes / 2);
  EXPECT_EQ(saved, png_bytes - coded.encoded.size());
  EXPECT_EQ(scene.images[0].encoded, out->images[0].encoded) << "the atlas's image is untouched";
  // With alpha: kept as it came.
  Scene with_alpha = *out;
  Image& a = with_alpha.images[size_t(kept_image)];
  a.rgba[3] = 10;
  EXPECT_EQ(encode_kept_images(with_alpha, rep.kept_materials, 85), 0u);
  EXPECT_EQ(a.mime_type, "image/png");
}

}  // namespace
}  // namespace meshmux
