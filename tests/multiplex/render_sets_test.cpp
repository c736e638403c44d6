// Renderer::render with several texture sets and cameras (what the multiplexer draws each mesh
// layer with) and the depth pre-pass it uses on textured draws. Skips when EGL is unavailable.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "multiplex/render.h"
#include "test_util.h"

namespace meshmux {
namespace {

// A lat-long sphere of radius r around `centre` with uvs: closed, so every pixel it covers has
// a back face behind its front face (overdraw the pre-pass must resolve exactly).
Primitive sphere(Vec3 centre, float r, int rings = 24, int segments = 48) {
  Primitive p;
  const float pi = 3.14159265f;
  for (int i = 0; i <= rings; ++i)
    for (int j = 0; j <= segments; ++j) {
      const float th = pi * float(i) / float(rings), ph = 2 * pi * float(j) / float(segments);
      const Vec3 n{std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph)};
      p.positions.push_back({centre.x + r * n.x, centre.y + r * n.y, centre.z + r * n.z});
      p.normals.push_back(n);
      if (p.uvs.empty()) p.uvs.emplace_back();
      p.uvs[0].push_back({float(j) / float(segments), float(i) / float(rings)});
    }
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segments; ++j) {
      const uint32_t a = uint32_t(i * (segments + 1) + j), b = a + uint32_t(segments + 1);
      p.indices.insert(p.indices.end(), {a, b, a + 1, a + 1, b, b + 1});
    }
  return p;
}

// A texture of `size`² texels: a checkerboard of `cell`-texel cells in two colours.
Image checker(int size, int cell, std::array<uint8_t, 3> a, std::array<uint8_t, 3> b) {
  Image im;
  im.width = im.height = size;
  im.rgba.resize(size_t(size) * size * 4);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const auto& c = ((x / cell + y / cell) & 1) ? a : b;
      uint8_t* px = &im.rgba[(size_t(y) * size + x) * 4];
      px[0] = c[0], px[1] = c[1], px[2] = c[2], px[3] = 255;
    }
  return im;
}

Camera looking_from(Vec3 eye) {
  Camera c;
  c.eye = eye;
  c.fov_y_degrees = 50;
  return c;
}

// Two spheres, the far one drawn after the near one and overlapping it on screen, plus a
// second instance: the shading pass meets occluded fragments both before and after the
// visible ones.
Scene overlapping_spheres() {
  Scene s;
  s.meshes.push_back({"near", {sphere({0, 0, 0.6f}, 0.5f)}});
  s.meshes.push_back({"far", {sphere({0.3f, 0.2f, -0.6f}, 0.8f)}});
  s.instances.push_back({0, Mat4{}, "near"});
  s.instances.push_back({1, Mat4{}, "far"});
  Mat4 moved;
  moved.at(0, 3) = -0.9;
  s.instances.push_back({0, moved, "near, moved"});
  return s;
}

bool same_pixels(const RenderImage& a, const RenderImage& b) {
  return a.width == b.width && a.height == b.height && a.rgba == b.rgba && a.coverage == b.coverage;
}

size_t covered(const RenderImage& im) {
  size_t n = 0;
  for (uint8_t c : im.coverage) n += c;
  return n;
}

// Why: the multiplexer measures every texture level of a mesh layer from every view in one
// call (with the depth pre-pass) and takes those images for what single renders (without it)
// would give; any difference would change the distortion it orders the stream by.
TEST(RenderSets, EveryImageEqualsItsOwnRender) {
  MAKE_RENDERER(r, physical_shading());
  const int g = r->add_geometry(overlapping_spheres());
  std::vector<TextureSet> sets;
  for (int size : {16, 64, 256}) {
    TextureSet t;
    t.base_color = r->add_texture(checker(size, size / 8, {200, 40, 30}, {30, 60, 220}), true);
    t.orm = r->add_texture(checker(size, size / 4, {255, 90, 0}, {255, 200, 255}), false);
    sets.push_back(t);
  }
  const std::vector<Camera> cameras = {looking_from({0, 0, 3.5f}), looking_from({2.5f, 1, 2}),
                                       looking_from({-1, -2, -3})};
  const std::vector<RenderImage> images = r->render(g, sets, cameras);
  ASSERT_EQ(images.size(), sets.size() * cameras.size());
  for (size_t c = 0; c < cameras.size(); ++c)
    for (size_t k = 0; k < sets.size(); ++k) {
      const RenderImage single = r->render(g, sets[k], cameras[c]);
      EXPECT_GT(covered(single), 2000u) << "camera " << c;
      EXPECT_TRUE(same_pixels(images[c * sets.size() + k], single))
          << "camera " << c << " set " << k;
    }
  // The levels differ, so the comparison above compared different pictures.
  EXPECT_FALSE(same_pixels(images[0], images[2]));
}

// Mean colour of the covered pixels left (x < width / 2) or right of the middle.
std::array<double, 3> mean_colour(const RenderImage& im, bool right) {
  std::array<double, 3> sum{0, 0, 0};
  double n = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = right ? im.width / 2 : 0; x < (right ? im.width : im.width / 2); ++x) {
      const size_t i = size_t(y) * size_t(im.width) + size_t(x);
      if (!im.coverage[i]) continue;
      for (int c = 0; c < 3; ++c) sum[size_t(c)] += im.rgba[i * 4 + size_t(c)];
      ++n;
    }
  for (double& v : sum) v /= std::max(1.0, n);
  return sum;
}

// Why: a material kept beside the atlas (atlas/kept.h) shows its own images, which the texture
// levels bring at each level's scale; drawn with the level's atlas set (as the cells were) it
// showed the atlas through its own uvs, so the multiplexer measured nothing of its images.
TEST(RenderSets, KeptMaterialsDrawTheirOwnImagesThroughTheSet) {
  MAKE_RENDERER(r, RenderOptions{});
  Scene s;
  s.meshes.push_back({"atlas", {sphere({-0.6f, 0, 0}, 0.5f)}});
  s.meshes.push_back({"kept", {sphere({0.6f, 0, 0}, 0.5f)}});
  s.meshes[0].primitives[0].material = 0;
  s.meshes[1].primitives[0].material = 1;
  s.instances.push_back({0, Mat4{}, "atlas"});
  s.instances.push_back({1, Mat4{}, "kept"});
  s.materials.resize(2);
  s.materials[0].base_color.image = 0;
  s.materials[1].base_color.image = 1;
  s.images = {checker(8, 8, {255, 255, 255}, {255, 255, 255}),
              checker(8, 8, {255, 255, 255}, {255, 255, 255})};
  TextureSet level;
  level.base_color = r->add_texture(checker(16, 16, {230, 20, 20}, {230, 20, 20}), true);
  level.kept = {{1, r->add_texture(checker(16, 16, {20, 220, 20}, {20, 220, 20}), true)}};
  const Camera camera = looking_from({0, 0, 4});
  const RenderImage kept =
      r->render(r->add_geometry(s, false, /*streamed_material=*/0), level, camera);
  const auto left = mean_colour(kept, false), right = mean_colour(kept, true);
  EXPECT_GT(left[0], 2 * left[1]) << "the atlas's material shows the level's set";
  EXPECT_GT(right[1], 2 * right[0]) << "the kept material shows its image's handle";
  // Without kept_images every primitive shows the set, as before.
  const RenderImage all = r->render(r->add_geometry(s), level, camera);
  const auto both = mean_colour(all, true);
  EXPECT_GT(both[0], 2 * both[1]);
}

// Why: with the pre-pass (drawn when a call has several sets) each pixel is shaded once, from
// the surface the depth pass found nearest; without it, from the last fragment that passed the
// depth test. Where no faces are coplanar these are the same surface, so the images must be
// the same to the bit (the vertex shader's gl_Position is invariant between the two programs).
TEST(RenderSets, DepthPrepassShowsTheSameNearestSurfaces) {
  RenderOptions with = physical_shading(), without = physical_shading();
  without.depth_prepass = false;
  MAKE_RENDERER(a, with);
  MAKE_RENDERER(b, without);
  const Scene scene = overlapping_spheres();
  const int ga = a->add_geometry(scene), gb = b->add_geometry(scene);
  std::vector<TextureSet> sa, sb;
  for (int size : {32, 128}) {
    const Image tex = checker(size, 8, {250, 250, 240}, {10, 90, 20});
    TextureSet ta, tb;
    ta.base_color = a->add_texture(tex, true);
    tb.base_color = b->add_texture(tex, true);
    sa.push_back(ta), sb.push_back(tb);
  }
  const std::vector<Camera> cameras = {looking_from({0, 0, 3.5f}), looking_from({2.5f, 1, 2}),
                                       looking_from({0.2f, 0.1f, -3})};
  const std::vector<RenderImage> x = a->render(ga, sa, cameras), y = b->render(gb, sb, cameras);
  ASSERT_EQ(x.size(), 6u);
  ASSERT_EQ(y.size(), 6u);
  for (size_t k = 0; k < x.size(); ++k) {
    EXPECT_GT(covered(x[k]), 2000u);
    EXPECT_TRUE(same_pixels(x[k], y[k])) << "image " << k;
  }
}

// Why: an empty list is a caller's edge case, and geometry that does not exist draws nothing
// (as render(g, set, camera) does) rather than failing.
TEST(RenderSets, EmptyListsAndMissingGeometry) {
  MAKE_RENDERER(r, physical_shading());
  const int g = r->add_geometry(overlapping_spheres());
  EXPECT_TRUE(r->render(g, std::vector<TextureSet>{}, {looking_from({0, 0, 3})}).empty());
  EXPECT_TRUE(r->render(g, std::vector<TextureSet>{TextureSet{}}, {}).empty());
  const std::vector<RenderImage> none =
      r->render(g + 7, std::vector<TextureSet>(2), {looking_from({0, 0, 3})});
  ASSERT_EQ(none.size(), 2u);
  for (const RenderImage& im : none) EXPECT_EQ(covered(im), 0u);
}

}  // namespace
}  // namespace meshmux
