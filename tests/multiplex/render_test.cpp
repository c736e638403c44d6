// Offscreen renderer: determinism, analytic coverage, texture orientation, Lambert shading,
// mipmapped minification, instancing, two-sided lighting. Skips when EGL is unavailable.
#include "multiplex/render.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "test_util.h"

namespace meshmux {
namespace {

// A square of half-size h in the z = 0 plane facing +z, glTF uvs: (0,0) at the top-left corner
// as seen from +z with y up.
Primitive quad(float h = 0.5f) {
  Primitive p;
  p.positions = {{-h, h, 0}, {-h, -h, 0}, {h, -h, 0}, {h, h, 0}};
  p.normals = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
  p.uvs = {{{0, 0}, {0, 1}, {1, 1}, {1, 0}}};
  p.indices = {0, 1, 2, 0, 2, 3};
  return p;
}

Scene single(Primitive p, std::vector<Mat4> worlds = {Mat4{}}) {
  Scene s;
  s.meshes.push_back({"m", {std::move(p)}});
  for (const Mat4& w : worlds) s.instances.push_back({0, w, "i"});
  return s;
}

Camera head_on(float d, float fov = 90) {
  Camera c;
  c.eye = {0, 0, d};
  c.fov_y_degrees = fov;
  return c;
}

// Debugging aid: with MESHMUX_RENDER_DUMP=<folder> set, writes the image as <folder>/<name>.ppm.
void dump(const RenderImage& im, const char* name) {
  const char* folder = std::getenv("MESHMUX_RENDER_DUMP");
  if (!folder) return;
  FILE* f = std::fopen((std::string(folder) + "/" + name + ".ppm").c_str(), "wb");
  if (!f) return;
  std::fprintf(f, "P6 %d %d 255\n", im.width, im.height);
  for (size_t i = 0; i < im.coverage.size(); ++i) std::fwrite(&im.rgba[i * 4], 1, 3, f);
  std::fclose(f);
}

size_t covered(const RenderImage& im) {
  size_t n = 0;
  for (uint8_t c : im.coverage) n += c;
  return n;
}

const uint8_t* pixel(const RenderImage& im, int x, int y) {
  return &im.rgba[(size_t(y) * im.width + x) * 4];
}

// Mean red channel over covered pixels.
double mean_red(const RenderImage& im) {
  double s = 0;
  size_t n = 0;
  for (size_t i = 0; i < im.coverage.size(); ++i)
    if (im.coverage[i]) s += im.rgba[i * 4], ++n;
  return n ? s / double(n) : 0;
}

// Lambert lit from the camera alone (no ambient): a surface facing it shows its texels as stored.
RenderOptions lit_from_camera() {
  RenderOptions o;
  o.ambient = 0;
  o.diffuse = 1;
  o.light_direction = {0, 0, 1};  // from the camera
  return o;
}

Image solid_checker(int size) {  // 1-texel black/white checkerboard
  Image im;
  im.width = im.height = size;
  im.rgba.resize(size_t(size) * size * 4);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      uint8_t v = ((x + y) & 1) ? 255 : 0;
      uint8_t* p = &im.rgba[(size_t(y) * size + x) * 4];
      p[0] = p[1] = p[2] = v;
      p[3] = 255;
    }
  return im;
}

// A UV sphere with slices × stacks quads (2 triangles each), uvs and normals.
Scene sphere(int slices, int stacks) {
  Primitive p;
  const float pi = 3.14159265f;
  for (int j = 0; j <= stacks; ++j)
    for (int i = 0; i <= slices; ++i) {
      float u = float(i) / slices, v = float(j) / stacks;
      float th = u * 2 * pi, ph = v * pi;
      Vec3 n{std::sin(ph) * std::cos(th), std::cos(ph), std::sin(ph) * std::sin(th)};
      p.positions.push_back(n);
      p.normals.push_back(n);
    }
  p.uvs.resize(1);
  for (int j = 0; j <= stacks; ++j)
    for (int i = 0; i <= slices; ++i) p.uvs[0].push_back({float(i) / slices, float(j) / stacks});
  for (int j = 0; j < stacks; ++j)
    for (int i = 0; i < slices; ++i) {
      uint32_t a = uint32_t(j * (slices + 1) + i), b = a + 1, c = a + uint32_t(slices + 1),
               d = c + 1;
      p.indices.insert(p.indices.end(), {a, c, b, b, c, d});
    }
  Scene s = single(std::move(p));
  Material m;
  m.base_color_factor = {0.9f, 0.8f, 0.7f, 1};
  s.materials.push_back(m);
  s.meshes[0].primitives[0].material = 0;
  return s;
}

Image gradient(int size) {
  Image im;
  im.width = im.height = size;
  im.rgba.resize(size_t(size) * size * 4);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      uint8_t* p = &im.rgba[(size_t(y) * size + x) * 4];
      p[0] = uint8_t(x * 255 / (size - 1));
      p[1] = uint8_t(y * 255 / (size - 1));
      p[2] = uint8_t(((x / 8 + y / 8) & 1) * 200);
      p[3] = 255;
    }
  return im;
}

TEST(Render, IdenticalInputsGiveIdenticalImages) {
  MAKE_RENDERER(r, RenderOptions{});
  Camera cam;
  cam.eye = {1.5f, 1.2f, 2.0f};
  int g = r->add_geometry(sphere(64, 32));
  int t = r->add_texture(gradient(128));
  ASSERT_GE(t, 0);
  RenderImage a = r->render(g, t, cam);
  dump(a, "sphere");
  EXPECT_GT(covered(a), size_t(1000));
  // Something else in between must not leak state.
  int g2 = r->add_geometry(single(quad()));
  r->render(g2, -1, head_on(1));
  RenderImage b = r->render(g, t, cam);
  EXPECT_EQ(a.rgba, b.rgba);
  EXPECT_EQ(a.coverage, b.coverage);

  MAKE_RENDERER(r2, RenderOptions{});
  int h = r2->add_geometry(sphere(64, 32));
  int u = r2->add_texture(gradient(128));
  RenderImage c = r2->render(h, u, cam);
  EXPECT_EQ(a.rgba, c.rgba);
  // The first renderer still works after the second was created (separate contexts).
  RenderImage d = r->render(g, t, cam);
  EXPECT_EQ(a.rgba, d.rgba);
}

TEST(Render, HeadOnSquareCoversAnalyticFraction) {
  MAKE_RENDERER(r, RenderOptions{});
  int g = r->add_geometry(single(quad()));
  // Sides of 128, 102.4 and 64 pixels: pixel-centre sampling rounds each edge to a whole
  // pixel, within 2% at these sizes.
  for (float d : {1.0f, 1.25f, 2.0f}) {
    RenderImage im = r->render(g, -1, head_on(d));
    ASSERT_EQ(im.width, 256);
    ASSERT_EQ(im.rgba.size(), size_t(256 * 256 * 4));
    double expected = (0.5 / d) * (0.5 / d);
    double got = double(covered(im)) / (256.0 * 256.0);
    EXPECT_NEAR(got / expected, 1.0, 0.02) << "d=" << d;
    // Background is transparent black; covered pixels are opaque.
    const uint8_t* corner = pixel(im, 0, 0);
    EXPECT_EQ(corner[0] + corner[1] + corner[2] + corner[3], 0);
    EXPECT_EQ(pixel(im, 128, 128)[3], 255);
  }
  // Non-square viewport: the vertical fov is fixed, so the square's pixel size only depends
  // on the height.
  RenderOptions wide;
  wide.width = 320;
  wide.height = 160;
  MAKE_RENDERER(rw, wide);
  RenderImage im = rw->render(rw->add_geometry(single(quad())), -1, head_on(2));
  EXPECT_NEAR(double(covered(im)) / (40.0 * 40.0), 1.0, 0.03);
}

TEST(Render, TextureOrientationMatchesGltf) {
  MAKE_RENDERER(r, lit_from_camera());
  Image im;
  im.width = im.height = 2;
  im.rgba = {255, 0, 0,   255, 0,   255, 0,   255,   // top row: red, green
             0,   0, 255, 255, 255, 255, 255, 255};  // bottom row: blue, white
  int t = r->add_texture(im);
  int g = r->add_geometry(single(quad()));
  RenderImage out = r->render(g, t, head_on(1));  // quad spans pixels 64..192
  const uint8_t* tl = pixel(out, 96, 96);
  const uint8_t* tr = pixel(out, 160, 96);
  const uint8_t* bl = pixel(out, 96, 160);
  const uint8_t* br = pixel(out, 160, 160);
  EXPECT_GT(tl[0], 200);
  EXPECT_LT(tl[1], 50);
  EXPECT_LT(tl[2], 50);
  EXPECT_GT(tr[1], 200);
  EXPECT_LT(tr[0], 50);
  EXPECT_LT(tr[2], 50);
  EXPECT_GT(bl[2], 200);
  EXPECT_LT(bl[0], 50);
  EXPECT_LT(bl[1], 50);
  EXPECT_GT(br[0], 200);
  EXPECT_GT(br[1], 200);
  EXPECT_GT(br[2], 200);

  // The material's factor multiplies the texture; t = -1 uses the factor alone.
  Scene s = single(quad());
  Material m;
  m.base_color_factor = {0.5f, 1, 1, 1};
  s.materials.push_back(m);
  s.meshes[0].primitives[0].material = 0;
  int g2 = r->add_geometry(s);
  EXPECT_NEAR(pixel(r->render(g2, t, head_on(1)), 96, 96)[0], 128, 2);
  RenderImage flat_image = r->render(g2, -1, head_on(1));  // keep the image alive for the pointer
  const uint8_t* flat = pixel(flat_image, 96, 96);
  EXPECT_NEAR(flat[0], 128, 2);
  EXPECT_NEAR(flat[1], 255, 1);
}

// A texture is sampled past its edges as its material's sampler says. meshmux keeps a source
// image as the atlas with its REPEAT sampler (atlas/source_atlas.h): along a quad's edge at
// uv exactly 0, REPEAT blends the top row with the bottom one where a clamp shows the top row
// alone (TextureLinearInterpolationTest's labels). The renderer measures the stream's
// distortion and draws `meshmux render`, so it samples as the viewers do.
TEST(Render, TextureWrapsAsItsSamplerSays) {
  MAKE_RENDERER(r, lit_from_camera());
  Image im;
  im.width = im.height = 2;
  im.rgba = {255, 0, 0,   255, 255, 0, 0,   255,   // top row: red
             0,   0, 255, 255, 0,   0, 255, 255};  // bottom row: blue
  const int g = r->add_geometry(single(quad()));   // the quad spans pixels 64..192
  const RenderImage clamped = r->render(g, r->add_texture(im), head_on(1));
  const RenderImage repeated =
      r->render(g, r->add_texture(im, true, Wrap::kRepeat, Wrap::kRepeat), head_on(1));
  // The quad's top row of pixels (v ≈ 0): red alone clamped, half blue repeated.
  EXPECT_LT(pixel(clamped, 128, 64)[2], 20);
  EXPECT_GT(pixel(repeated, 128, 64)[2], 80);
  // Its middle (v = 0.5, between the rows' centres) is the same either way.
  EXPECT_NEAR(pixel(clamped, 128, 128)[2], pixel(repeated, 128, 128)[2], 1);

  // A scene drawn with its own textures takes each material's sampler.
  Scene s = single(quad());
  s.images.push_back(im);
  Material m;
  m.base_color.image = 0;  // the default sampler repeats
  s.materials.push_back(m);
  s.meshes[0].primitives[0].material = 0;
  const RenderImage own = r->render(r->add_geometry(s, true), -1, head_on(1));
  EXPECT_GT(pixel(own, 128, 64)[2], 80);
  s.materials[0].base_color.sampler.wrap_t = Wrap::kClampToEdge;
  const RenderImage own_clamped = r->render(r->add_geometry(s, true), -1, head_on(1));
  EXPECT_LT(pixel(own_clamped, 128, 64)[2], 20);
}

TEST(Render, LambertFacingBrighterThanGrazing) {
  RenderOptions o;  // ambient 0.35, diffuse 0.65
  o.light_follows_camera = false;
  o.light_direction = {0, 0, 1};
  MAKE_RENDERER(r, o);
  const double pi = 3.14159265358979;
  double angle = 75 * pi / 180;
  double q[4] = {0, std::sin(angle / 2), 0, std::cos(angle / 2)};  // about y
  Mat4 rot = Mat4::rotation(q[0], q[1], q[2], q[3]);
  RenderImage facing = r->render(r->add_geometry(single(quad())), -1, head_on(2));
  RenderImage grazing = r->render(r->add_geometry(single(quad(), {rot})), -1, head_on(2));
  double f = mean_red(facing), gz = mean_red(grazing);
  EXPECT_NEAR(f, 255 * (0.35 + 0.65), 2);
  EXPECT_NEAR(gz, 255 * (0.35 + 0.65 * std::cos(angle)), 2);
  EXPECT_GT(f, gz + 50);
}

TEST(Render, TwoSidedLightingAndMirroredInstances) {
  MAKE_RENDERER(r, RenderOptions{});  // light follows the camera
  int g = r->add_geometry(single(quad()));
  double front = mean_red(r->render(g, -1, head_on(2)));
  double back = mean_red(r->render(g, -1, head_on(-2)));  // seen from behind
  EXPECT_GT(front, 150);
  EXPECT_NEAR(back, front, 1);
  int mirrored = r->add_geometry(single(quad(), {Mat4::scale(-1, 1, 1)}));
  EXPECT_NEAR(mean_red(r->render(mirrored, -1, head_on(2))), front, 1);
  EXPECT_NEAR(mean_red(r->render(mirrored, -1, head_on(-2))), front, 1);
}

TEST(Render, MipmappedCheckerboardAveragesToGreyFarAway) {
  RenderOptions o;
  o.ambient = 1;
  o.diffuse = 0;
  MAKE_RENDERER(r, o);
  // A long ground strip (y = 0) receding from the camera, 1-texel checkerboard over it.
  Primitive p;
  float hw = 4, len = 200;
  p.positions = {{-hw, 0, -len}, {-hw, 0, 0}, {hw, 0, 0}, {hw, 0, -len}};
  p.normals.assign(4, Vec3{0, 1, 0});
  p.uvs = {{{0, 0}, {0, 1}, {1, 1}, {1, 0}}};
  p.indices = {0, 1, 2, 0, 2, 3};
  int g = r->add_geometry(single(p));
  int t = r->add_texture(solid_checker(512));
  Camera cam;
  cam.eye = {0, 0.5f, 1};
  cam.target = {0, 0.3f, -10};
  RenderImage im = r->render(g, t, cam);
  dump(im, "checker");
  int top = -1;
  for (int y = 0; y < im.height && top < 0; ++y)
    for (int x = 0; x < im.width; ++x)
      if (im.coverage[size_t(y) * im.width + x]) {
        top = y;
        break;
      }
  ASSERT_GE(top, 0);
  // The far region: the covered part of the first 16 covered rows, where a pixel spans many
  // texels along v (further down, near one texel per pixel, a 1-texel checkerboard beats with
  // the pixel grid on any renderer).
  double sum = 0, worst = 0;
  size_t n = 0;
  for (int y = top; y < std::min(im.height, top + 16); ++y)
    for (int x = 0; x < im.width; ++x) {
      size_t i = size_t(y) * im.width + x;
      if (!im.coverage[i]) continue;
      sum += im.rgba[i * 4];
      worst = std::max(worst, std::abs(im.rgba[i * 4] - 127.5));
      ++n;
    }
  ASSERT_GT(n, size_t(500));
  EXPECT_NEAR(sum / double(n), 127.5, 20);
  EXPECT_LT(worst, 60) << "aliased: far pixels should be grey, not black or white";
}

// Anisotropic filtering keeps detail across a receding plane that isotropic trilinear
// filtering (mip level chosen by the long axis of the footprint) blurs to grey.
TEST(Render, AnisotropyKeepsDetailAtGrazingAngles) {
  Image stripes;  // 4-texel black/white columns, constant along v
  stripes.width = stripes.height = 512;
  stripes.rgba.resize(512 * 512 * 4);
  for (int y = 0; y < 512; ++y)
    for (int x = 0; x < 512; ++x) {
      uint8_t v = ((x / 4) & 1) ? 255 : 0;
      uint8_t* p = &stripes.rgba[(size_t(y) * 512 + x) * 4];
      p[0] = p[1] = p[2] = v;
      p[3] = 255;
    }
  Primitive p;
  float hw = 4, len = 8;  // square: texel density the same along u and v
  p.positions = {{-hw, 0, -len}, {-hw, 0, 0}, {hw, 0, 0}, {hw, 0, -len}};
  p.normals.assign(4, Vec3{0, 1, 0});
  p.uvs = {{{0, 0}, {0, 1}, {1, 1}, {1, 0}}};
  p.indices = {0, 1, 2, 0, 2, 3};
  Camera cam;
  cam.eye = {0, 0.3f, 1};
  cam.target = {0, 0, -8};
  double contrast[2];
  for (int k = 0; k < 2; ++k) {
    RenderOptions o;
    o.ambient = 1;
    o.diffuse = 0;
    o.anisotropy = k == 0 ? 1 : 16;
    MAKE_RENDERER(r, o);
    RenderImage im = r->render(r->add_geometry(single(p)), r->add_texture(stripes), cam);
    dump(im, k == 0 ? "stripes_iso" : "stripes_aniso");
    // Mean absolute deviation from 127.5 over the middle half of the covered rows.
    int top = -1;
    for (size_t i = 0; i < im.coverage.size() && top < 0; ++i)
      if (im.coverage[i]) top = int(i / size_t(im.width));
    ASSERT_GE(top, 0);
    double dev = 0;
    size_t n = 0;
    for (int y = top + 4; y < top + 24; ++y)
      for (int x = 0; x < im.width; ++x) {
        size_t i = size_t(y) * im.width + x;
        if (im.coverage[i]) dev += std::abs(im.rgba[i * 4] - 127.5), ++n;
      }
    contrast[k] = dev / double(n);
  }
  std::printf("[render] stripe contrast far away: isotropic %.1f, 16x anisotropic %.1f\n",
              contrast[0], contrast[1]);
  EXPECT_GT(contrast[1], contrast[0] + 20);
}

TEST(Render, TwoInstancesDoubleCoverage) {
  MAKE_RENDERER(r, RenderOptions{});
  size_t one = covered(
      r->render(r->add_geometry(single(quad(), {Mat4::translation(-1, 0, 0)})), -1, head_on(5)));
  size_t two = covered(r->render(
      r->add_geometry(single(quad(), {Mat4::translation(-1, 0, 0), Mat4::translation(1, 0, 0)})),
      -1, head_on(5)));
  ASSERT_GT(one, size_t(0));
  EXPECT_NEAR(double(two) / double(one), 2.0, 0.05);
}

TEST(Render, RemovedOrInvalidHandlesDrawNothing) {
  MAKE_RENDERER(r, RenderOptions{});
  int g = r->add_geometry(single(quad()));
  int t = r->add_texture(solid_checker(4));
  EXPECT_GT(covered(r->render(g, t, head_on(1))), size_t(0));
  r->remove_texture(t);
  EXPECT_GT(covered(r->render(g, t, head_on(1))), size_t(0));  // falls back to untextured
  r->remove_geometry(g);
  r->remove_geometry(g);  // twice is harmless
  EXPECT_EQ(covered(r->render(g, -1, head_on(1))), size_t(0));
  EXPECT_EQ(covered(r->render(99, -1, head_on(1))), size_t(0));
  EXPECT_EQ(r->add_texture(Image{}), -1);  // undecoded
  // Missing normals and uvs, out-of-range indices: drawn without crashing.
  Primitive p = quad();
  p.normals.clear();
  p.uvs.clear();
  p.indices.insert(p.indices.end(), {0, 1, 77});
  EXPECT_GT(covered(r->render(r->add_geometry(single(p)), -1, head_on(1))), size_t(0));
}

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// The display's footprint (RenderOptions::display_scale): a 1000² one-texel checker on a square
// that spans 128 image pixels is about eight texels to a pixel, so trilinear filtering shows it
// grey; rendered for a display eight times the image's size, each pixel samples the texture as a
// display pixel would (about one texel: 1000 texels, so that pixel centres do not all fall on
// texel corners, where bilinear filtering gives grey too), so the pixels range from black to
// white: the spread of the image's values is the checker's, not the mip level's grey.
TEST(Render, DisplayScaleSamplesTexturesAsTheDisplayWould) {
  auto spread = [](float scale) {
    RenderOptions o;
    o.ambient = 1, o.diffuse = 0;
    o.display_scale = scale;
    auto r = Renderer::create(o);
    if (!r.ok()) return -1.0;
    const int t = (*r)->add_texture(solid_checker(1000));
    const int g = (*r)->add_geometry(single(quad()));
    const RenderImage im = (*r)->render(g, t, head_on(1));
    double sum = 0, sum2 = 0;
    size_t n = 0;
    for (int y = 80; y < 176; ++y)
      for (int x = 80; x < 176; ++x) {
        const double v = pixel(im, x, y)[0];
        sum += v, sum2 += v * v, ++n;
      }
    const double mean = sum / double(n);
    return std::sqrt(std::max(0.0, sum2 / double(n) - mean * mean));
  };
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  const double own = spread(1), display = spread(8);
  std::printf(
      "spread of the pixel values: %.1f for the image's own pixels, %.1f for the display's\n", own,
      display);
  EXPECT_LT(own, 10) << "the image's own pixels: the mip level's grey";
  EXPECT_GT(display, 30) << "the display's pixels: the checker's black and white";
}

// The same with the multiplexer's settings: physical shading, several texture sets per pass and
// 16× anisotropic filtering asked for, where the checker is minified at the display too (about
// two texels to a display pixel). llvmpipe's anisotropic filter takes its level of detail from
// the image pixel's derivatives (it ignores a bias and explicit gradients), so with a display
// scale the samplers are trilinear with the level biased: the display's footprint shows some of
// the checker, the image pixel's none.
TEST(Render, DisplayScaleHoldsWithAnisotropicFilteringAndSets) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  auto variance = [](float scale) {
    RenderOptions o = physical_shading();
    o.display_scale = scale;
    auto r = Renderer::create(o);
    if (!r.ok()) return -1.0;
    TextureSet set;
    set.base_color = (*r)->add_texture(solid_checker(1000));
    const int g = (*r)->add_geometry(single(quad()));
    const std::vector<RenderImage> ims =
        (*r)->render(g, std::vector<TextureSet>{set, set}, std::vector<Camera>{head_on(1)});
    double sum = 0, sum2 = 0;
    size_t n = 0;
    for (int y = 80; y < 176; ++y)
      for (int x = 80; x < 176; ++x) {
        const double v = pixel(ims[0], x, y)[0];
        sum += v, sum2 += v * v, ++n;
      }
    return sum2 / double(n) - (sum / double(n)) * (sum / double(n));
  };
  const double own = variance(1), display = variance(4.2f);
  std::printf(
      "variance of the pixel values: %.2f for the image's own pixels, %.2f for the "
      "display's\n",
      own, display);
  EXPECT_LT(own, 1);
  EXPECT_GT(display, 8);
}

}  // namespace
}  // namespace meshmux
