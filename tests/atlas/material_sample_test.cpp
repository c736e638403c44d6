#include "atlas/material_sample.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>

namespace meshmux {
namespace {

Image image(int w, int h, const std::vector<std::array<uint8_t, 4>>& texels) {
  Image img;
  img.name = "test";
  img.width = w;
  img.height = h;
  for (const auto& t : texels) img.rgba.insert(img.rgba.end(), t.begin(), t.end());
  return img;
}

// 2x2: A B / C D, each channel distinct, all opaque.
const std::array<uint8_t, 4> kA{255, 0, 0, 255}, kB{0, 255, 0, 255}, kC{0, 0, 255, 255},
    kD{255, 255, 255, 255};
Image two_by_two() { return image(2, 2, {kA, kB, kC, kD}); }

void expect_texel(Vec4 got, const std::array<uint8_t, 4>& want) {
  EXPECT_NEAR(got.x, srgb_to_linear(want[0]), 1e-5);
  EXPECT_NEAR(got.y, srgb_to_linear(want[1]), 1e-5);
  EXPECT_NEAR(got.z, srgb_to_linear(want[2]), 1e-5);
  EXPECT_NEAR(got.w, want[3] / 255.0, 1e-5);
}

Sampler sampler(Wrap s, Wrap t) {
  Sampler x;
  x.wrap_s = s;
  x.wrap_t = t;
  return x;
}

TEST(MaterialSample, SrgbDecodeFollowsTheIecCurveAndRoundTrips) {
  EXPECT_EQ(srgb_to_linear(0), 0.0f);
  EXPECT_EQ(srgb_to_linear(255), 1.0f);
  EXPECT_NEAR(srgb_to_linear(128), 0.2158605, 1e-6);
  EXPECT_NEAR(srgb_to_linear(10), 10 / 255.0 / 12.92, 1e-7);  // linear segment
  EXPECT_EQ(linear_to_srgb(0.5f), 188);
  EXPECT_EQ(linear_to_srgb(-1.0f), 0);
  EXPECT_EQ(linear_to_srgb(2.0f), 255);
  for (int v = 0; v < 256; ++v) EXPECT_EQ(linear_to_srgb(srgb_to_linear(uint8_t(v))), v);
}

// The encoder rounds the exact IEC curve, everywhere on [0, 1].
TEST(MaterialSample, SrgbEncodeRoundsTheIecCurve) {
  int mismatches = 0;
  for (int i = 0; i <= 100000; ++i) {
    double v = i / 100000.0;
    double c = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055;
    long want = std::lround(c * 255.0);
    // Skip values within float rounding of a byte boundary.
    if (std::fabs(c * 255.0 - (std::floor(c * 255.0) + 0.5)) < 1e-4) continue;
    mismatches += linear_to_srgb(float(v)) != want;
  }
  EXPECT_EQ(mismatches, 0);
}

TEST(MaterialSample, TexelCentresReturnTheTexel) {
  Image img = two_by_two();
  Sampler s = sampler(Wrap::kClampToEdge, Wrap::kClampToEdge);
  expect_texel(sample_image(img, s, {0.25f, 0.25f}), kA);
  expect_texel(sample_image(img, s, {0.75f, 0.25f}), kB);
  expect_texel(sample_image(img, s, {0.25f, 0.75f}), kC);
  expect_texel(sample_image(img, s, {0.75f, 0.75f}), kD);
}

TEST(MaterialSample, RepeatWrapsOutsideTheUnitSquare) {
  Image img = two_by_two();
  Sampler s = sampler(Wrap::kRepeat, Wrap::kRepeat);
  expect_texel(sample_image(img, s, {1.25f, 0.25f}), kA);
  expect_texel(sample_image(img, s, {-0.25f, 0.25f}), kB);
  expect_texel(sample_image(img, s, {0.25f, -0.25f}), kC);
  expect_texel(sample_image(img, s, {-3.25f, 7.75f}), kD);
}

TEST(MaterialSample, ClampToEdgeHoldsTheBorderTexels) {
  Image img = two_by_two();
  Sampler s = sampler(Wrap::kClampToEdge, Wrap::kClampToEdge);
  expect_texel(sample_image(img, s, {1.75f, 0.25f}), kB);
  expect_texel(sample_image(img, s, {-0.5f, 0.25f}), kA);
  expect_texel(sample_image(img, s, {-5.0f, 9.0f}), kC);
  expect_texel(sample_image(img, s, {1.0f, 1.0f}), kD);  // exactly the edge: the last texel
}

TEST(MaterialSample, MirroredRepeatReflectsAtEachEdge) {
  Image img = two_by_two();
  Sampler s = sampler(Wrap::kMirroredRepeat, Wrap::kMirroredRepeat);
  expect_texel(sample_image(img, s, {1.25f, 0.25f}), kB);   // texel 2 → 1
  expect_texel(sample_image(img, s, {1.75f, 0.25f}), kA);   // texel 3 → 0
  expect_texel(sample_image(img, s, {-0.25f, 0.25f}), kA);  // texel -1 → 0
  expect_texel(sample_image(img, s, {2.25f, 0.25f}), kA);   // texel 4 → 0 (period 2)
  expect_texel(sample_image(img, s, {0.25f, 1.25f}), kC);   // rows mirror too
}

TEST(MaterialSample, WrapModesApplyPerAxis) {
  Image img = two_by_two();
  Sampler s = sampler(Wrap::kRepeat, Wrap::kClampToEdge);
  expect_texel(sample_image(img, s, {1.25f, 1.75f}), kC);  // s wraps to column 0, t clamps to row 1
}

TEST(MaterialSample, BilinearMidpointIsAveragedInLinearLight) {
  Image img = image(2, 1, {{0, 0, 0, 0}, {255, 255, 255, 255}});
  Sampler s = sampler(Wrap::kClampToEdge, Wrap::kClampToEdge);
  Vec4 c = sample_image(img, s, {0.5f, 0.5f});
  EXPECT_NEAR(c.x, 0.5, 1e-6);  // not sRGB 128 (linear 0.216)
  EXPECT_NEAR(c.w, 0.5, 1e-6);
  EXPECT_EQ(linear_to_srgb(c.x), 188);
  // A quarter of the way: 1/4 of white.
  EXPECT_NEAR(sample_image(img, s, {0.375f, 0.5f}).y, 0.25, 1e-6);
}

TEST(MaterialSample, TransformOffsetAndScale) {
  TextureTransform t;
  t.offset[0] = 0.5f;
  t.offset[1] = 0.25f;
  Vec2 a = apply_transform(t, {0.2f, 0.4f});
  EXPECT_NEAR(a.x, 0.7, 1e-6);
  EXPECT_NEAR(a.y, 0.65, 1e-6);
  TextureTransform u;
  u.scale[0] = 2;
  u.scale[1] = 3;
  u.offset[0] = 1;
  Vec2 b = apply_transform(u, {0.2f, 0.4f});  // scale first, then offset
  EXPECT_NEAR(b.x, 1.4, 1e-6);
  EXPECT_NEAR(b.y, 1.2, 1e-6);
}

TEST(MaterialSample, TransformRotationFollowsTheSpecMatrix) {
  TextureTransform t;
  t.rotation = float(M_PI / 2);
  // R = (cos, sin; -sin, cos): (1, 0) → (0, -1), (0, 1) → (1, 0).
  Vec2 a = apply_transform(t, {1, 0});
  EXPECT_NEAR(a.x, 0, 1e-6);
  EXPECT_NEAR(a.y, -1, 1e-6);
  Vec2 b = apply_transform(t, {0, 1});
  EXPECT_NEAR(b.x, 1, 1e-6);
  EXPECT_NEAR(b.y, 0, 1e-6);
}

// The spec's example: offset (0, 1), rotation π/2, scale 0.5 shows the lower-left quadrant.
TEST(MaterialSample, TransformSpecExampleSelectsLowerLeftQuadrant) {
  TextureTransform t;
  t.offset[1] = 1;
  t.rotation = 1.57079632679f;
  t.scale[0] = t.scale[1] = 0.5f;
  for (Vec2 uv : {Vec2{0, 0}, Vec2{1, 0}, Vec2{0, 1}, Vec2{1, 1}, Vec2{0.3f, 0.8f}}) {
    Vec2 r = apply_transform(t, uv);
    EXPECT_GE(r.x, -1e-6);
    EXPECT_LE(r.x, 0.5 + 1e-6);
    EXPECT_GE(r.y, 0.5 - 1e-6);
    EXPECT_LE(r.y, 1 + 1e-6);
  }
  Vec2 c = apply_transform(t, {1, 1});
  EXPECT_NEAR(c.x, 0.5, 1e-6);
  EXPECT_NEAR(c.y, 0.5, 1e-6);
}

Scene textured_scene(const Image& img) {
  Scene s;
  s.images.push_back(img);
  Material m;
  m.base_color.image = 0;
  m.base_color.sampler = sampler(Wrap::kClampToEdge, Wrap::kClampToEdge);
  s.materials.push_back(m);
  return s;
}

TEST(MaterialSample, BaseColorIsFactorTimesVertexColorTimesTexture) {
  Scene s = textured_scene(image(1, 1, {{255, 128, 0, 255}}));
  s.materials[0].base_color_factor = {0.5f, 1, 1, 0.8f};
  Vec4 c = sample_base_color(s, 0, {{0.5f, 0.5f}}, {1, 0.5f, 1, 0.5f});
  EXPECT_NEAR(c.x, 0.5, 1e-6);
  EXPECT_NEAR(c.y, 0.2158605 * 0.5, 1e-6);
  EXPECT_NEAR(c.z, 0, 1e-6);
  EXPECT_NEAR(c.w, 0.4, 1e-6);
}

TEST(MaterialSample, BaseColorUsesTheTransformedUvSetOfTheTextureRef) {
  Scene s = textured_scene(two_by_two());
  s.materials[0].base_color.tex_coord = 1;
  s.materials[0].base_color.transform.offset[0] = 0.5f;
  // Set 1 at (0.25, 0.75) → offset → (0.75, 0.75): D. Set 0 would give C.
  expect_texel(sample_base_color(s, 0, {{0.25f, 0.75f}, {0.25f, 0.75f}}, {1, 1, 1, 1}), kD);
}

TEST(MaterialSample, MissingUvSetSamplesAtTheOrigin) {
  Scene s = textured_scene(two_by_two());
  s.materials[0].base_color.tex_coord = 1;
  // Only set 0 exists (it points at D); the texture reads set 1 → (0, 0) → A under clamping.
  expect_texel(sample_base_color(s, 0, {{0.75f, 0.75f}}, {1, 1, 1, 1}), kA);
}

TEST(MaterialSample, DefaultMaterialIsWhiteTimesVertexColor) {
  Scene s;
  Vec4 c = sample_base_color(s, -1, {}, {1, 1, 1, 1});
  EXPECT_EQ(c, (Vec4{1, 1, 1, 1}));
  Vec4 d = sample_base_color(s, -1, {}, {0.2f, 0.4f, 0.6f, 1});
  EXPECT_EQ(d, (Vec4{0.2f, 0.4f, 0.6f, 1}));
}

TEST(MaterialSample, UndecodedImageCountsAsNoTexture) {
  Image img;
  img.name = "not decoded";
  img.encoded = {1, 2, 3};
  Scene s = textured_scene(img);
  s.materials[0].base_color_factor = {0.1f, 0.2f, 0.3f, 1};
  Vec4 c = sample_base_color(s, 0, {{0.5f, 0.5f}}, {1, 1, 1, 1});
  EXPECT_EQ(c, (Vec4{0.1f, 0.2f, 0.3f, 1}));
}

}  // namespace
}  // namespace meshmux
