// Physically based shading of the offscreen renderer: the closed form at a pixel, the normal map's
// orientation in the GL's derivative frame, emissive, occlusion. The web client draws the same with
// three.js (its browser test compares the two); here the conventions that a mistake would flip are
// pinned. Skips when EGL is unavailable.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "image/color.h"
#include "multiplex/dfg_lut.h"
#include "multiplex/render.h"
#include "test_util.h"

namespace meshmux {
namespace {

// A unit square facing +z, uv (0,0) at its top-left seen from +z (u along +x, v along −y), with
// one material.
Scene quad_scene(const Material& m) {
  Primitive p;
  p.positions = {{-0.5f, 0.5f, 0}, {-0.5f, -0.5f, 0}, {0.5f, -0.5f, 0}, {0.5f, 0.5f, 0}};
  p.normals.assign(4, {0, 0, 1});
  p.uvs = {{{0, 0}, {0, 1}, {1, 1}, {1, 0}}};
  p.indices = {0, 1, 2, 0, 2, 3};
  p.material = 0;
  Scene s;
  s.meshes.push_back({"quad", {p}});
  s.materials.push_back(m);
  s.instances.push_back({0, Mat4{}, "i"});
  return s;
}

Camera head_on() {
  Camera c;
  c.eye = {0, 0, 2};
  c.fov_y_degrees = 45;
  return c;
}

Image solid(int side, uint8_t r, uint8_t g, uint8_t b) {
  Image img;
  img.width = img.height = side;
  for (int i = 0; i < side * side; ++i) img.rgba.insert(img.rgba.end(), {r, g, b, 255});
  return img;
}

const uint8_t* centre(const RenderImage& im) {
  return &im.rgba[(size_t(im.height / 2) * size_t(im.width) + size_t(im.width / 2)) * 4];
}

RenderOptions headlight() {
  RenderOptions o = physical_shading();
  o.light_direction = {0, 0, 1};  // from the camera
  return o;
}

// Head-on (N = V = L) the shading has a closed form: every dot product is 1, the DFG table is
// read at its (roughness, 1) corner. A grey dielectric of roughness 1 under the headlight and
// the uniform environment must come out as that form says, sRGB-encoded.
// The split-sum table is integrated in rows on every core: on one thread every row must still
// be there (it once held only its first row where MESHMUX_THREADS=1, and every package's renders,
// so its order, differed between 1 and 3 threads).
TEST(PhysicalShading, SplitSumTableIsTheSameWhateverTheThreadCount) {
  auto table = [](const char* threads) {
    setenv("MESHMUX_THREADS", threads, 1);
    std::vector<float> lut = dfg_lut(256);
    unsetenv("MESHMUX_THREADS");
    return lut;
  };
  const std::vector<float> one = table("1");
  EXPECT_EQ(one, table("3"));
  // Grazing rows are not empty: the last row's smooth end reflects nearly all.
  EXPECT_GT(one[(size_t(kDfgLutSize - 1) * kDfgLutSize) * 2], 0.5f);
}

TEST(PhysicalShading, DielectricHeadOnMatchesTheClosedForm) {
  const RenderOptions o = headlight();
  MAKE_RENDERER(r, o);
  Material m;
  m.base_color_factor = {0.5f, 0.5f, 0.5f, 1};
  m.metallic_factor = 0;
  m.roughness_factor = 1;
  RenderImage im = r->render(r->add_geometry(quad_scene(m)), -1, head_on());
  const std::vector<float> lut = dfg_lut();
  const size_t last = size_t(kDfgLutSize - 1);
  const double a = lut[(last * kDfgLutSize + last) * 2],
               b = lut[(last * kDfgLutSize + last) * 2 + 1];
  const double pi = 3.14159265358979323846, base = 0.5, f0 = 0.04;
  const double fresnel = std::exp2(-5.55473 - 6.98316);  // at V·H = 1
  const double f = f0 * (1 - fresnel) + fresnel;
  // GGX at N·H = 1 with α = 1: D = 1/π; V = 0.5 / 2.
  const double direct_specular = o.light_intensity * f * (0.25 / pi) * (1 + f0 * (1 / (a + b) - 1));
  const double direct_diffuse = o.light_intensity * base / pi * (1 - f);
  const double ess = a + b, ems = 1 - ess, fss_ess = f0 * a + b, favg = f0 + (1 - f0) / 21;
  const double multi = fss_ess * favg / (1 - ems * favg) * ems;
  const double env =
      o.environment * (fss_ess + multi) + base * (1 - (fss_ess + multi)) * o.environment;
  const double linear = direct_specular + direct_diffuse + env;
  const uint8_t want = linear_to_srgb(float(linear));
  const uint8_t* px = centre(im);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(px[c], want, 2) << "channel " << c;
}

// Emissive light adds to whatever the surface reflects: a black, rough surface glowing green.
TEST(PhysicalShading, EmissiveAdds) {
  MAKE_RENDERER(r, headlight());
  Material m;
  m.base_color_factor = {0, 0, 0, 1};
  m.metallic_factor = 0;
  m.emissive_factor = {0, 1, 0};
  const RenderImage im = r->render(r->add_geometry(quad_scene(m)), -1, head_on());
  const uint8_t* px = centre(im);
  EXPECT_EQ(px[1], 255);
  EXPECT_LT(px[0], 80);
}

// The normal map's axes as glTF and three.js read them: +x leans along +u, +y up the image
// (against +v). A light from one side brightens the surface whose map leans toward it. A
// mirrored frame here would make the multiplexer measure the stream under other lighting than
// the viewer shows.
TEST(PhysicalShading, NormalMapLeansTowardsItsAxes) {
  Material m;
  m.base_color_factor = {0.8f, 0.8f, 0.8f, 1};
  m.metallic_factor = 0;
  m.roughness_factor = 1;
  auto lit = [&](Vec3 light, uint8_t x, uint8_t y) {
    RenderOptions o = physical_shading();
    o.light_follows_camera = false;
    o.light_direction = light;
    o.environment = 0;
    auto rr = Renderer::create(o);
    if (!rr.ok()) return -1.0;
    TextureSet set;
    set.normal = (*rr)->add_texture(solid(4, x, y, 200), false);
    return double(centre((*rr)->render((*rr)->add_geometry(quad_scene(m)), set, head_on()))[0]);
  };
  if (lit({1, 0, 1}, 128, 128) < 0) GTEST_SKIP() << "no offscreen OpenGL";
  // Leaning to +x (+u): brighter under a light from +x than from −x.
  EXPECT_GT(lit({1, 0, 1}, 220, 128), lit({-1, 0, 1}, 220, 128) + 20);
  // Leaning to +y (up the image, world +y here): brighter under a light from above.
  EXPECT_GT(lit({0, 1, 1}, 128, 220), lit({0, -1, 1}, 128, 220) + 20);
  // Flat: the same from both sides.
  EXPECT_NEAR(lit({1, 0, 1}, 128, 128), lit({-1, 0, 1}, 128, 128), 2);
}

// Occlusion (R of the packed map) darkens the environment's light, not the direct light:
// fully occluded and unlit by the headlight's absence, the surface goes black.
TEST(PhysicalShading, OcclusionDarkensTheEnvironmentLight) {
  RenderOptions o = physical_shading();
  o.light_intensity = 0;
  MAKE_RENDERER(r, o);
  Material m;
  m.base_color_factor = {0.8f, 0.8f, 0.8f, 1};
  int g = r->add_geometry(quad_scene(m));
  TextureSet open, occluded;
  open.orm = r->add_texture(solid(4, 255, 255, 0), false);    // roughness 1, dielectric
  occluded.orm = r->add_texture(solid(4, 0, 255, 0), false);  // occlusion 0
  EXPECT_GT(centre(r->render(g, open, head_on()))[0], 150);
  EXPECT_LT(centre(r->render(g, occluded, head_on()))[0], 5);
}

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// A sheen layer adds its lobe and its share of the environment (velvet glows at its rim): a
// black surface with a white sheen is no longer black.
TEST(PhysicalShading, SheenAddsItsLayer) {
  MAKE_RENDERER(r, headlight());
  Material plain;
  plain.base_color_factor = {0, 0, 0, 1};
  plain.metallic_factor = 0;
  Material velvet = plain;
  velvet.sheen_color_factor = {1, 1, 1};
  velvet.sheen_roughness_factor = 0.8f;
  const RenderImage a = r->render(r->add_geometry(quad_scene(plain)), -1, head_on());
  const RenderImage b = r->render(r->add_geometry(quad_scene(velvet)), -1, head_on());
  EXPECT_GT(int(centre(b)[0]), int(centre(a)[0]) + 10);
}

}  // namespace
}  // namespace meshmux
