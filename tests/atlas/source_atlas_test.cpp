#include "atlas/source_atlas.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "atlas/atlas.h"
#include "atlas/material_sample.h"
#include "image/texture_levels.h"

namespace meshmux {
namespace {

// A 4×2 image of distinct opaque texels.
Image strip() {
  Image img;
  img.name = "strip.png";
  img.width = 4;
  img.height = 2;
  for (int i = 0; i < 8; ++i)
    img.rgba.insert(img.rgba.end(), {uint8_t(30 * i), uint8_t(255 - 30 * i), 77, 255});
  return img;
}

// One quad sampling `strip()` through uv set 0 with the given uvs (v in [v0, v0 + 1]).
Scene quad_scene(float v0) {
  Scene s;
  s.images.push_back(strip());
  Material m;
  m.base_color.image = 0;
  s.materials.push_back(m);
  Primitive p;
  p.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  p.normals.assign(4, {0, 0, 1});
  p.uvs = {{{0, v0 + 1}, {1, v0 + 1}, {1, v0}, {0, v0}}};
  p.indices = {0, 1, 2, 0, 2, 3};
  p.material = 0;
  Mesh mesh;
  mesh.primitives.push_back(p);
  s.meshes.push_back(mesh);
  s.instances.push_back({0, Mat4::identity(), ""});
  return s;
}

// The common single-texture-set model (DamagedHelmet): the atlas is the source image itself,
// texel for texel, and the uvs are the source's. Resampling it through charts cost 18 dB of
// unlit PSNR against the original (fidelity harness: 24.7 → 43.8 dB) and doubled its side.
TEST(SourceAtlas, OneTextureInsideTheUnitSquareIsKeptAsIs) {
  Scene s = quad_scene(0);
  AtlasReport rep;
  auto out = build_atlas(s, {}, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  EXPECT_TRUE(rep.built);
  EXPECT_TRUE(rep.reused_source);
  ASSERT_EQ(out->images.size(), 1u);
  EXPECT_EQ(out->images[0].width, 4);
  EXPECT_EQ(out->images[0].height, 2);
  EXPECT_EQ(out->images[0].rgba, strip().rgba);
  ASSERT_EQ(out->meshes.size(), 1u);
  const Primitive& q = out->meshes[0].primitives[0];
  ASSERT_EQ(q.uvs.size(), 1u);
  for (size_t i = 0; i < q.indices.size(); ++i) {
    const Vec3 pos = q.positions[q.indices[i]];
    const Vec2 uv = q.uvs[0][q.indices[i]];
    // The quad's uv is (x, 1 − y) by construction.
    EXPECT_FLOAT_EQ(uv.x, pos.x);
    EXPECT_FLOAT_EQ(uv.y, 1 - pos.y);
  }
}

// DamagedHelmet's uvs lie in [0, 1] × [1, 2] under a repeating sampler: the same texels as
// [0, 1]², so the faces move there and the image is still kept.
TEST(SourceAtlas, RepeatedUnitCellMovesToTheUnitSquare) {
  Scene s = quad_scene(1);
  AtlasReport rep;
  auto out = build_atlas(s, {}, &rep, nullptr);
  ASSERT_TRUE(out.ok());
  EXPECT_TRUE(rep.reused_source);
  const Primitive& q = out->meshes[0].primitives[0];
  for (size_t i = 0; i < q.indices.size(); ++i) {
    const Vec2 uv = q.uvs[0][q.indices[i]];
    EXPECT_GE(uv.y, 0.0f);
    EXPECT_LE(uv.y, 1.0f);
    EXPECT_FLOAT_EQ(uv.y, 1 - q.positions[q.indices[i]].y);
  }
}

// A clamped sampler does not repeat: [1, 2] shows the edge texels, not the image, so the
// source cannot be kept as it is (the charts path bakes what it shows).
TEST(SourceAtlas, ClampedSamplerOutsideTheUnitSquareIsBaked) {
  Scene s = quad_scene(1);
  s.materials[0].base_color.sampler.wrap_t = Wrap::kClampToEdge;
  EXPECT_FALSE(find_source_atlas(s, 4096).has_value());
  AtlasReport rep;
  ASSERT_TRUE(build_atlas(s, {}, &rep, nullptr).ok());
  EXPECT_TRUE(rep.built);
  EXPECT_FALSE(rep.reused_source);
}

// A lightmap whose faces reach a little past the image's edge (v up to 1.014, as a simulator's
// table comes) under a repeating sampler reads across the edge what the original reads when
// the atlas keeps the image and its REPEAT: kept as it is, uvs unchanged. It used to be refused
// and re-baked through charts into a 4096² atlas at 1 % use (15 s). Clamped, it still is baked.
TEST(SourceAtlas, FaceSlightlyPastTheEdgeOfARepeatingImageIsKept) {
  Scene s = quad_scene(0);
  s.meshes[0].primitives[0].uvs[0][0].y = 1.014f;
  s.meshes[0].primitives[0].uvs[0][1].y = 1.014f;
  auto source = find_source_atlas(s, 4096);
  ASSERT_TRUE(source.has_value());
  EXPECT_EQ(source->wrap_t, Wrap::kRepeat);
  AtlasReport rep;
  auto out = build_atlas(s, {}, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  EXPECT_TRUE(rep.reused_source);
  EXPECT_EQ(out->materials[0].base_color.sampler.wrap_t, Wrap::kRepeat);
  const std::vector<Vec2>& in = s.meshes[0].primitives[0].uvs[0];
  const std::vector<Vec2>& uv = out->meshes[0].primitives[0].uvs[0];
  ASSERT_EQ(uv.size(), in.size());
  for (size_t i = 0; i < uv.size(); ++i) {
    EXPECT_NEAR(uv[i].x, in[i].x, 1e-6) << i;
    EXPECT_NEAR(uv[i].y, in[i].y, 1e-6) << i;
  }
  s.materials[0].base_color.sampler.wrap_t = Wrap::kClampToEdge;
  EXPECT_FALSE(find_source_atlas(s, 4096).has_value());
}

// A face spanning two repeats (a tiled floor) needs the texture twice: baked, not kept.
TEST(SourceAtlas, FaceSpanningTwoRepeatsIsBaked) {
  Scene s = quad_scene(0);
  s.meshes[0].primitives[0].uvs[0][1] = {2, 1};
  EXPECT_FALSE(find_source_atlas(s, 4096).has_value());
}

// Two images, vertex colours, or different factors: one image cannot show them.
TEST(SourceAtlas, SecondImageVertexColourOrOtherFactorIsBaked) {
  Scene two = quad_scene(0);
  two.images.push_back(strip());
  Material other = two.materials[0];
  other.base_color.image = 1;
  two.materials.push_back(other);
  two.meshes[0].primitives.push_back(two.meshes[0].primitives[0]);
  two.meshes[0].primitives[1].material = 1;
  EXPECT_FALSE(find_source_atlas(two, 4096).has_value());

  Scene coloured = quad_scene(0);
  coloured.meshes[0].primitives[0].colors.assign(4, {1, 0, 0, 1});
  EXPECT_FALSE(find_source_atlas(coloured, 4096).has_value());

  Scene factors = quad_scene(0);
  factors.materials.push_back(factors.materials[0]);
  factors.materials[1].base_color_factor = {0.5f, 1, 1, 1};
  factors.meshes[0].primitives.push_back(factors.meshes[0].primitives[0]);
  factors.meshes[0].primitives[1].material = 1;
  EXPECT_FALSE(find_source_atlas(factors, 4096).has_value());
}

// A shared factor is folded into the pixels in linear light (sRGB 255 × 0.5 → 188).
TEST(SourceAtlas, SharedFactorIsFoldedIntoThePixels) {
  Scene s = quad_scene(0);
  s.images[0].rgba.assign(s.images[0].rgba.size(), 255);
  s.materials[0].base_color_factor = {0.5f, 1, 1, 0.5f};
  auto source = find_source_atlas(s, 4096);
  ASSERT_TRUE(source.has_value());
  Image atlas = source_atlas_image(s, *source);
  EXPECT_EQ(atlas.rgba[0], 188);
  EXPECT_EQ(atlas.rgba[1], 255);
  EXPECT_EQ(atlas.rgba[3], 128);
}

// A 64×64 image whose left half a textured quad uses, and a plain-coloured triangle (glass or
// trim on a textured vehicle: CesiumMilkTruck-dae went from 25.8 to 42.0 dB unlit when its
// 2048² texture stopped being resampled into a 4096² chart atlas).
Scene half_used_scene() {
  Scene s;
  Image img;
  img.name = "half.png";
  img.width = img.height = 64;
  for (int i = 0; i < 64 * 64; ++i)
    img.rgba.insert(img.rgba.end(), {200, uint8_t(i % 256), 40, 255});
  s.images.push_back(img);
  Material textured;
  textured.base_color.image = 0;
  Material plain;
  plain.base_color_factor = {0.0f, 0.5f, 1.0f, 1.0f};
  s.materials = {textured, plain};
  Primitive q;
  q.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  q.normals.assign(4, {0, 0, 1});
  q.uvs = {{{0, 1}, {0.25f, 1}, {0.25f, 0}, {0, 0}}};
  q.indices = {0, 1, 2, 0, 2, 3};
  q.material = 0;
  Primitive t;
  t.positions = {{2, 0, 0}, {3, 0, 0}, {2, 1, 0}};
  t.normals.assign(3, {0, 0, 1});
  t.indices = {0, 1, 2};
  t.material = 1;
  Mesh mesh;
  mesh.primitives = {q, t};
  s.meshes.push_back(mesh);
  s.instances.push_back({0, Mat4::identity(), ""});
  return s;
}

TEST(SourceAtlas, PlainColoursGetABlockOfUnusedTexels) {
  Scene s = half_used_scene();
  auto source = find_source_atlas(s, 4096);
  ASSERT_TRUE(source.has_value());
  EXPECT_EQ(source->width, 64);
  EXPECT_EQ(source->height, 64);  // room in the image: not extended
  ASSERT_EQ(source->flat_colors.size(), 1u);
  // The quad samples u in [0, 0.25] (texels 0..15) + 8 texels of margin: the block is right of
  // texel 24 and aligned to its side.
  EXPECT_GE(source->flat_x[0], 24);
  EXPECT_EQ(source->flat_x[0] % source->block, 0);
  EXPECT_GE(source->block, 4);
  AtlasReport rep;
  auto out = build_atlas(s, {}, &rep, nullptr);
  ASSERT_TRUE(out.ok());
  EXPECT_TRUE(rep.reused_source);
  EXPECT_EQ(rep.flat_colors, 1u);
  const Image& atlas = out->images[0];
  // The texels the quad uses are the source's.
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 16; ++x)
      for (int c = 0; c < 4; ++c)
        ASSERT_EQ(atlas.rgba[(size_t(y) * 64 + size_t(x)) * 4 + size_t(c)],
                  s.images[0].rgba[(size_t(y) * 64 + size_t(x)) * 4 + size_t(c)]);
  // The triangle's corners sample its colour: (0, 0.5, 1) linear = sRGB (0, 188, 255).
  const Primitive& p = out->meshes[0].primitives[0];
  size_t plain_corners = 0;
  for (size_t i = 0; i < p.indices.size(); ++i) {
    if (p.positions[p.indices[i]].x < 2) continue;
    ++plain_corners;
    const Vec2 uv = p.uvs[0][p.indices[i]];
    const int x = int(uv.x * 64), y = int(uv.y * 64);
    const uint8_t* px = &atlas.rgba[(size_t(y) * 64 + size_t(x)) * 4];
    EXPECT_EQ(px[0], 0);
    EXPECT_EQ(px[1], 188);
    EXPECT_EQ(px[2], 255);
  }
  EXPECT_EQ(plain_corners, 3u);
}

// A texture every texel of which is in use: the plain colours go below it, in a second image
// height (still a power of two), and the source texels stay where they were.
TEST(SourceAtlas, FullTextureGrowsDownwardForPlainColours) {
  Scene s = half_used_scene();
  s.meshes[0].primitives[0].uvs = {{{0, 1}, {1, 1}, {1, 0}, {0, 0}}};
  auto source = find_source_atlas(s, 4096);
  ASSERT_TRUE(source.has_value());
  EXPECT_EQ(source->width, 64);
  EXPECT_EQ(source->height, 128);
  EXPECT_GE(source->flat_y[0], 64);
  EXPECT_GT(source->flat_uv[0].y, 0.5f);
  Image atlas = source_atlas_image(s, *source);
  EXPECT_EQ(atlas.height, 128);
  EXPECT_TRUE(std::equal(s.images[0].rgba.begin(), s.images[0].rgba.end(), atlas.rgba.begin()));
  // No room to grow: baked from charts instead.
  EXPECT_FALSE(find_source_atlas(s, 64).has_value());
}

// The full texture with a half below it: the textured faces keep sampling the image's texels
// (their v scaled into the top half: the quad's corners land on v = 0 and 0.5, not 1, which
// showed the lower half of a label sheet and lost a third of its coverage), the appended rows
// repeat the image's last row (no plain colour bleeds into the image's edge through filtering
// or mip levels), and the plain colour's block sits at the bottom.
TEST(SourceAtlas, AppendedHalfKeepsTheImagesUvsAndEdge) {
  Scene s = half_used_scene();
  s.meshes[0].primitives[0].uvs = {{{0, 1}, {1, 1}, {1, 0}, {0, 0}}};
  s.materials[0].base_color.sampler.wrap_t = Wrap::kClampToEdge;  // repeating: the next test
  AtlasReport rep;
  auto out = build_atlas(s, {}, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_TRUE(rep.reused_source);
  const Image& atlas = out->images[0];
  ASSERT_EQ(atlas.height, 128);
  const Primitive& p = out->meshes[0].primitives[0];
  float hi_v = 0;
  for (size_t i = 0; i < p.indices.size(); ++i)
    if (p.positions[p.indices[i]].x < 2) hi_v = std::max(hi_v, p.uvs[0][p.indices[i]].y);
  EXPECT_FLOAT_EQ(hi_v, 0.5f);
  const size_t row = 64 * 4;
  for (size_t y = 64; y < 72; ++y)
    EXPECT_TRUE(std::equal(atlas.rgba.begin() + std::ptrdiff_t(63 * row),
                           atlas.rgba.begin() + std::ptrdiff_t(64 * row),
                           atlas.rgba.begin() + std::ptrdiff_t(y * row)))
        << "row " << y;
  auto source = find_source_atlas(s, 4096);
  ASSERT_TRUE(source.has_value());
  EXPECT_EQ(source->flat_y[0], 128 - source->block);
}

// A label sheet (TextureLinearInterpolationTest): a 16×16 image whose top row is transparent
// and whose other rows are opaque, sampled over exactly [0, 1]² through the default (REPEAT)
// sampler, beside a plain colour that needs a second image height. Under REPEAT the
// original's bilinear filtering and mip levels blend the quad's top edge with the image's
// bottom rows and its bottom edge with the top rows; an atlas clamped to its edge, its
// appended half the image's last row repeated, showed a solid line along the top edge (a row
// the alpha cutoff dropped in the original) and lost the bottom edge's marks: 27.2 dB unlit,
// 26.1 lit against the original. The atlas must show at the image's edges, at every mip level
// the plain colour's block stays clean to, what the source's sampler shows there; the further
// channels (here emissive, from the same image) likewise.
Scene label_scene() {
  Scene s = half_used_scene();
  Image& img = s.images[0];
  img.width = img.height = 16;
  img.rgba.clear();
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x)
      img.rgba.insert(img.rgba.end(), {uint8_t(16 * x), uint8_t(255 - 16 * y), uint8_t(7 * (x ^ y)),
                                       uint8_t(y == 0 ? 0 : 255)});
  s.materials[0].emissive.image = 0;
  s.materials[0].emissive_factor = {1, 1, 1};
  s.meshes[0].primitives[0].uvs = {{{0, 1}, {1, 1}, {1, 0}, {0, 0}}};
  return s;
}

TEST(SourceAtlas, RepeatingSamplerShowsTheOppositeEdgeAcrossTheImagesEdges) {
  const Scene s = label_scene();
  auto source = find_source_atlas(s, 4096);
  ASSERT_TRUE(source.has_value());
  ASSERT_EQ(source->height, 32);  // the plain colour needs the appended half
  auto out = build_atlas(s, {}, nullptr, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_EQ(out->materials.size(), 1u);
  const Material& m = out->materials[0];
  EXPECT_EQ(m.base_color.sampler.wrap_s, Wrap::kRepeat);
  EXPECT_EQ(m.base_color.sampler.wrap_t, Wrap::kRepeat);
  ASSERT_TRUE(m.emissive.present());
  EXPECT_EQ(m.emissive.sampler.wrap_t, Wrap::kRepeat);
  const Sampler original = s.materials[0].base_color.sampler;
  // Source image and atlas image, level by level (box-filtered halvings), sampled at and just
  // inside the quad's edges (source v, atlas v scaled into the image's part) for every column.
  auto compare = [&](const Image& src0, const Image& atlas0, const Sampler& at, bool rgb_only,
                     float tolerance, const char* what) {
    Image src = src0, atlas = atlas0;
    for (int level = 0; (1 << level) <= source->block; ++level) {
      const double texel = 1.0 / src.height;
      for (double v : {0.0, 0.25 * texel, 0.5 * texel, 1 - 0.5 * texel, 1 - 0.25 * texel, 1.0})
        for (int x = 0; x < src.width; ++x) {
          const float u = float((x + 0.3) / src.width);
          const Vec4 want = sample_image(src, original, {u, float(v)});
          const Vec4 got =
              sample_image(atlas, at, {u, float(v * source->part_height / source->height)});
          for (int c = 0; c < (rgb_only ? 3 : 4); ++c)
            ASSERT_NEAR((&got.x)[c], (&want.x)[c], tolerance)
                << what << " level " << level << " v " << v << " column " << x << " channel " << c;
        }
      src = downsample_half(src);
      atlas = downsample_half(atlas);
    }
  };
  compare(s.images[0], out->images[size_t(m.base_color.image)], m.base_color.sampler, false, 1e-5f,
          "base colour");
  compare(s.images[0], out->images[size_t(m.emissive.image)], m.emissive.sampler, true, 0.01f,
          "emissive");
  // The plain colour's block sits between the rows that continue the image.
  EXPECT_GE(source->flat_y[0], 16 + source->block);
  EXPECT_LE(source->flat_y[0] + source->block, 32 - source->block);
}

// Where the image has room for a plain colour, a repeating axis still samples across the
// image's edges: the block keeps the margin from the textured faces' copies one period away
// too (a quad on the image's top half under REPEAT reads its bottom rows at its top edge).
TEST(SourceAtlas, PlainColourBlockKeepsClearOfTheRepeatedEdge) {
  Scene s = half_used_scene();
  s.meshes[0].primitives[0].uvs = {{{0, 0.5f}, {1, 0.5f}, {1, 0}, {0, 0}}};
  auto source = find_source_atlas(s, 4096);
  ASSERT_TRUE(source.has_value());
  EXPECT_EQ(source->height, 64);
  ASSERT_EQ(source->flat_colors.size(), 1u);
  EXPECT_LE(source->flat_y[0] + source->block, 64 - 8);  // 8 texels: the margin (kMargin)
  // Clamped, the rows at the bottom edge are the original's to give away.
  s.materials[0].base_color.sampler.wrap_t = Wrap::kClampToEdge;
  source = find_source_atlas(s, 4096);
  ASSERT_TRUE(source.has_value());
  EXPECT_EQ(source->flat_y[0] + source->block, 64);
}

// Larger than the atlas may be: baked (and downsized) by the charts path.
TEST(SourceAtlas, OversizeImageIsBaked) {
  Scene s = quad_scene(0);
  EXPECT_FALSE(find_source_atlas(s, 2).has_value());
}

// Sides that are not powers of two (a 211² logo) are resampled up to the next powers of two
// (texture levels halve): the source's uvs stay, every texel keeps at least its density (the
// charts path held it to a quarter: 26.0 dB unlit), and a flat image stays flat.
TEST(SourceAtlas, NonPowerOfTwoImageIsResampledUp) {
  Scene s = quad_scene(0);
  Image& img = s.images[0];
  img.width = 3;
  img.height = 5;
  img.rgba.clear();
  for (int i = 0; i < 15; ++i) img.rgba.insert(img.rgba.end(), {200, 40, 90, 255});
  auto source = find_source_atlas(s, 4096);
  ASSERT_TRUE(source.has_value());
  EXPECT_EQ(source->width, 4);
  EXPECT_EQ(source->height, 8);
  AtlasReport rep;
  auto out = build_atlas(s, {}, &rep, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  EXPECT_TRUE(rep.reused_source);
  const Image& atlas = out->images[0];
  ASSERT_EQ(atlas.width, 4);
  ASSERT_EQ(atlas.height, 8);
  for (size_t i = 0; i < atlas.rgba.size(); i += 4) {
    EXPECT_NEAR(atlas.rgba[i], 200, 1);
    EXPECT_NEAR(atlas.rgba[i + 1], 40, 1);
  }
  EXPECT_EQ(out->meshes[0].primitives[0].uvs, s.meshes[0].primitives[0].uvs);
}

// The atlas's minification filter. Where the atlas is the source's image texel for texel, its
// sampler's mipmapped filter stays: CesiumMan samples NEAREST_MIPMAP_LINEAR, and sampling the
// same texels LINEAR_MIPMAP_LINEAR moved its minified stripes' edges (unlit 25.7 → 35.1 dB
// against the original, BoxTextured 30.1 → 40.9). Resampled texels (a side rounded up to a
// power of two, or charts), disagreeing samplers and unspecified ones get LINEAR_MIPMAP_LINEAR.
int atlas_min_filter(const Scene& s) {
  auto out = build_atlas(s, {}, nullptr, nullptr);
  EXPECT_TRUE(out.ok()) << out.status().message();
  if (!out.ok() || out->materials.empty()) return -1;
  const Material& m = out->materials[0];
  EXPECT_EQ(m.base_color.sampler.mag_filter, 9729);
  return m.base_color.sampler.min_filter;
}

TEST(SourceAtlas, KeptTexelsKeepTheirMipmappedMinFilter) {
  for (int f : {9984, 9985, 9986, 9987}) {
    Scene s = quad_scene(0);
    s.materials[0].base_color.sampler.min_filter = f;
    EXPECT_EQ(atlas_min_filter(s), f);
  }
  Scene unspecified = quad_scene(0);
  EXPECT_EQ(atlas_min_filter(unspecified), 9987);

  // Two materials on the one image whose filters disagree.
  Scene two = quad_scene(0);
  two.materials[0].base_color.sampler.min_filter = 9986;
  two.materials.push_back(two.materials[0]);
  two.materials[1].base_color.sampler.min_filter = 9984;
  two.meshes[0].primitives.push_back(two.meshes[0].primitives[0]);
  two.meshes[0].primitives[1].material = 1;
  ASSERT_TRUE(find_source_atlas(two, 4096).has_value());
  EXPECT_EQ(atlas_min_filter(two), 9987);

  // Sides that are not powers of two would be resampled (other texels): NEAREST within a level
  // then keeps the material as it came, its image and filter (atlas/kept.h); trilinear ones are
  // resampled into the atlas as before.
  Scene npot = quad_scene(0);
  npot.images[0].width = 3;
  npot.images[0].height = 5;
  npot.images[0].rgba.assign(15 * 4, 200);
  npot.materials[0].base_color.sampler.min_filter = 9986;
  auto kept = build_atlas(npot, {}, nullptr, nullptr);
  ASSERT_TRUE(kept.ok()) << kept.status().message();
  ASSERT_EQ(kept->materials.size(), 1u);
  EXPECT_EQ(kept->materials[0].base_color.sampler.min_filter, 9986);
  EXPECT_EQ(kept->images[size_t(kept->materials[0].base_color.image)].width, 3);
  npot.materials[0].base_color.sampler.min_filter = 9987;
  EXPECT_EQ(atlas_min_filter(npot), 9987);

  // Baked into charts (a clamped sampler outside the unit square): trilinear.
  Scene charts = quad_scene(1);
  charts.materials[0].base_color.sampler.wrap_t = Wrap::kClampToEdge;
  charts.materials[0].base_color.sampler.min_filter = 9986;
  ASSERT_FALSE(find_source_atlas(charts, 4096).has_value());
  EXPECT_EQ(atlas_min_filter(charts), 9987);
}

}  // namespace
}  // namespace meshmux
