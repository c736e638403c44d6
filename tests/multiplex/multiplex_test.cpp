#include "multiplex/multiplex.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>

#include "image/encode.h"
#include "importers/import.h"
#include "pipeline/convert.h"
#include "stream/package.h"
#include "test_util.h"

namespace meshmux {
namespace {

// One UV sphere of rings × segments, placed once, its primitive drawn with `material`.
Scene sphere(int rings, int segments, int32_t material = -1) {
  Scene scene;
  scene.meshes.emplace_back();
  scene.meshes[0].primitives.push_back(testing::uv_sphere(rings, segments));
  scene.meshes[0].primitives[0].material = material;
  scene.instances.push_back({0, Mat4::identity(), "sphere"});
  return scene;
}

// The scene converted with options a and b; their multiplexer results into *x and *y.
void multiplex_both(const Scene& scene, const ConvertOptions& a, const ConvertOptions& b,
                    MultiplexResult* x, MultiplexResult* y) {
  Warnings warnings;
  auto ra = convert(scene, a, &warnings, nullptr);
  auto rb = convert(scene, b, &warnings, nullptr);
  ASSERT_TRUE(ra.ok()) << ra.status().message();
  ASSERT_TRUE(rb.ok()) << rb.status().message();
  ASSERT_TRUE(ra->multiplexed && rb->multiplexed);
  *x = *ra->multiplexed, *y = *rb->multiplexed;
}

// `texture` encoded as an upload's image comes (PNG) and added with a material sampling it as
// its base colour (the scene's first material: sphere(..., 0) draws with it).
void add_texture_material(Scene& scene, Image texture) {
  texture.encoded = encode_png(texture).take();
  texture.mime_type = "image/png";
  scene.materials.emplace_back();
  scene.materials.back().base_color.image = int32_t(scene.images.size());
  scene.images.push_back(std::move(texture));
}

// The scene converted with its order made for a display of w × h device pixels.
Result<ConvertOutputs> convert_for_display(const Scene& scene, int w, int h) {
  ConvertOptions o;
  o.multiplex.display_width = w, o.multiplex.display_height = h;
  Warnings warnings;
  return convert(scene, o, &warnings, nullptr);
}

// The whole conversion (pipeline/convert); the multiplexer's result rides along in its outputs.
// No offscreen OpenGL here: convert() succeeds with a warning and no result (kUnavailable).
Result<MultiplexResult> run(const std::string& model, double* seconds) {
  auto in = import_scene(testing::shared_model(model), {}, nullptr);
  if (!in.ok()) return in.status();
  Warnings warnings;
  auto c = convert(*in, ConvertOptions{}, &warnings, nullptr);
  if (!c.ok()) return c.status();
  if (!c->multiplexed)
    return Status::error(warnings.empty() ? "no multiplex result" : warnings.items().back(),
                         ErrorKind::kUnavailable);
  *seconds = c->multiplexed->seconds_total;
  return c->multiplexed.value();
}

// An untextured scene has one texture level, so its order is forced (the mesh layers in record
// order) and its renders only draw the curve: asked to (forced_view_layers ≥ 0), the
// multiplexer measures it from fewer views on smaller images, with the same order and the same
// stream bytes as the full measurement, and 4 images per cell instead of 10. (Its curve is not
// the full one's: on this sphere, whose coarse levels differ at the silhouette, 128² images
// more than double the area, which is why the option is off by default.) The sphere is over
// 10,000 triangles so that its mesh streams (smaller ones ship whole: a 1 x 1 grid).
TEST(Multiplex, ForcedOrderIsMeasuredCheaply) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  Scene scene = sphere(80, 100);
  ConvertOptions cheap, full;
  // Every split shipped: where the completion goes depends on the measured slopes, which the
  // cheaper measurement gives otherwise (the package's bound is not what this case is about).
  cheap.max_package_ratio = full.max_package_ratio = 0;
  cheap.multiplex.forced_view_layers = 0;
  cheap.multiplex.forced_image_size = 128;
  MultiplexResult x, y;
  ASSERT_NO_FATAL_FAILURE(multiplex_both(scene, cheap, full, &x, &y));
  ASSERT_EQ(x.texture_bytes.size(), 1u);
  ASSERT_GT(x.mesh_bytes.size(), 2u);
  EXPECT_EQ(x.views, 4u);
  EXPECT_EQ(y.views, 10u);
  EXPECT_EQ(x.rd.cells, y.rd.cells);
  EXPECT_EQ(x.layer_chunks, y.layer_chunks);
  // Every cell from every view once, plus the references: 4 images per cell instead of 10.
  EXPECT_EQ(x.renders * 10, y.renders * 4);
  const double area_x = area_under(x.rd), area_y = area_under(y.rd);
  std::printf(
      "sphere: forced order measured with %zu renders of 128^2 (area %.5g), the full "
      "measurement %zu of 256^2 (area %.5g): %.2f%% apart\n",
      x.renders, area_x, y.renders, area_y, 100 * std::fabs(area_x - area_y) / area_y);
}

// Renders on a cut: a smooth sphere's finest levels move its surface by less than a display
// pixel, so no render needs them. With the cut (forced here at 1,000 triangles; by default it
// starts at 1M) the renders draw at most the selection whose error a display pixel stands for:
// fewer triangles, the layers past it share one row of renders (fewer images), the stream's
// bytes untouched; and what the cut draws looks like the full mesh: the full renders measure the
// layer just coarser than the cut at under half a CIEDE2000 unit from the full mesh (mean over
// covered pixels; about 1 is a just-noticeable difference; the silhouette and the shading both
// count), where the coarsest layer is over 1.
TEST(Multiplex, RendersDrawNoFinerThanAPixelCut) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  Scene scene = sphere(100, 200);
  ConvertOptions cut, full;
  cut.max_package_ratio = full.max_package_ratio = 0;  // every split ships in both
  // Looks alike in CIEDE2000 (the MSE the order uses weighs the silhouette's pixel steps).
  cut.multiplex.metric = full.multiplex.metric = DistortionMetric::kCiede2000;
  cut.multiplex.cut_renders_above = 1000;
  full.multiplex.cut_renders_above = UINT64_MAX;
  MultiplexResult x, y;
  ASSERT_NO_FATAL_FAILURE(multiplex_both(scene, cut, full, &x, &y));
  EXPECT_EQ(y.cut_error, 0);
  EXPECT_EQ(y.cut_triangles, y.layer_triangles.back());
  EXPECT_GT(x.cut_error, 0);
  EXPECT_LT(x.cut_triangles, x.layer_triangles.back() / 2);
  EXPECT_LT(x.renders, y.renders);
  EXPECT_EQ(x.layer_chunks, y.layer_chunks);
  // The untextured sphere's order is its layers in turn: row k is step k of the full curve.
  ASSERT_EQ(y.rd.cells.size(), y.layer_triangles.size());
  size_t coarser = 0;  // the last layer no finer than the cut
  while (coarser + 1 < y.layer_triangles.size() &&
         y.layer_triangles[coarser + 1] <= x.cut_triangles)
    ++coarser;
  EXPECT_LT(y.rd.distortion[coarser], 0.5);
  EXPECT_GT(y.rd.distortion[0], 1.0);
  std::printf(
      "sphere: renders on a cut of %llu of %u triangles (error %.2g): %zu images against "
      "%zu; the full renders measure %u triangles at %.3f dE from the full mesh\n",
      (unsigned long long)x.cut_triangles, x.layer_triangles.back(), x.cut_error, x.renders,
      y.renders, y.layer_triangles[coarser], y.rd.distortion[coarser]);
}

// The order is made for a display size: the renders sample textures with a display pixel's
// footprint. A sphere wearing a 1024² checker of one-texel squares (detail only the top level
// holds: the levels below are grey) is framed on 1920×1080 at about one texel per display pixel,
// so its top texture level is plain to see there, while on 640×360 two to four texels fall in
// each pixel and average to the same grey: the top level changes little. The distortion the top
// level removes (the full mesh with the level below it against the reference) is measured larger
// for the large display, and the package's table says which display its order was made for.
// The order follows the display: a sphere wearing a 2048² texture of coarse squares (which the
// level below the top, 512², holds) under a one-texel checker (which only the top level holds)
// is framed at about 3.6 top-level texels per pixel of a 640×360 display, where the checker
// averages away, and at about 1.2 on 1920×1080, where it shows. The top level (1.6 MB) is then
// worth more per byte on the larger display, and the order takes it before the mesh's last
// refinements there, one layer earlier than on the smaller one (measured margins: 22% over
// the next mesh step's gain per byte on 1920×1080, 4% under it on 640×360).
TEST(Multiplex, AFinerTextureLevelComesEarlierForALargerDisplay) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  Scene scene = sphere(150, 300, 0);
  Image texture;
  texture.name = "squares under a checker";
  texture.width = texture.height = 2048;
  for (int y = 0; y < 2048; ++y)
    for (int x = 0; x < 2048; ++x) {
      const bool coarse = ((x / 128) + (y / 128)) % 2;
      const int f = (x + y) % 2 ? 50 : -50;
      texture.rgba.insert(texture.rgba.end(), {uint8_t((coarse ? 190 : 60) + f), uint8_t(128 + f),
                                               uint8_t((coarse ? 60 : 190) + f), 255});
    }
  add_texture_material(scene, std::move(texture));
  // The mesh layers the order sends before the top texture level.
  auto layers_before_top = [&](int w, int h) -> int {
    auto out = convert_for_display(scene, w, h);
    if (!out.ok() || !out->multiplexed) return -1;
    const MultiplexResult& r = *out->multiplexed;
    const int top = int(r.texture_bytes.size()) - 1;
    for (const auto& [i, j] : r.rd.cells)
      if (j == top) return i;
    return -2;
  };
  const int small = layers_before_top(640, 360), large = layers_before_top(1920, 1080);
  ASSERT_GE(small, 0);
  ASSERT_GE(large, 0);
  std::printf("the top texture level after %d mesh layers on 640x360, after %d on 1920x1080\n",
              small, large);
  EXPECT_LT(large, small);
}

TEST(Multiplex, TopTextureLevelMattersMoreOnALargerDisplay) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  Scene scene = sphere(60, 120, 0);
  Image checker;  // one-texel black and white squares: detail only the top level holds
  checker.name = "checker";
  checker.width = checker.height = 1024;
  for (int y = 0; y < 1024; ++y)
    for (int x = 0; x < 1024; ++x) {
      const uint8_t v = (x + y) % 2 ? 255 : 0;
      checker.rgba.insert(checker.rgba.end(), {v, v, v, 255});
    }
  add_texture_material(scene, std::move(checker));
  auto top_level_drop = [&](int w, int h, std::vector<uint8_t>* package) -> double {
    auto out = convert_for_display(scene, w, h);
    if (!out.ok() || !out->multiplexed) return -1;
    const MultiplexResult& r = *out->multiplexed;
    const int n = r.view_table.texture_layers, mm = r.view_table.mesh_layers;
    if (n < 2) return -2;
    const std::vector<double>& cell =
        r.view_table.cells[size_t(mm - 1) * size_t(n) + size_t(n - 2)];
    double sum = 0;
    for (double d : cell) sum += d;
    *package = out->package;
    return cell.empty() ? -3 : sum / double(cell.size());
  };
  std::vector<uint8_t> small_package, large_package;
  const double small = top_level_drop(640, 360, &small_package);
  const double large = top_level_drop(1920, 1080, &large_package);
  ASSERT_GT(small, 0) << "no measurement on 640x360";
  ASSERT_GT(large, 0) << "no measurement on 1920x1080";
  std::printf("top texture level's drop: %.4g on 640x360, %.4g on 1920x1080\n", small, large);
  EXPECT_GT(large, 1.3 * small);
  auto pkg = read_package(small_package);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  EXPECT_EQ(pkg->view.display[0], 640);
  EXPECT_EQ(pkg->view.display[1], 360);
}

class MultiplexSharedModel : public ::testing::TestWithParam<const char*> {};

// The claim of Yang, Shen and Kuo, "Progressive coding of 3D textured graphic model via joint
// mesh-texture optimization", on our data: the steepest-descent order's area under the rendered
// distortion-vs-bytes curve is no larger than mesh-first, texture-first or constant-ratio; and the
// lazy evaluation renders far fewer cells than the whole grid.
TEST_P(MultiplexSharedModel, DescentBeatsEveryBaseline) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  double seconds = 0;
  auto r = run(GetParam(), &seconds);
  if (!r.ok() && r.status().kind() == ErrorKind::kUnavailable) GTEST_SKIP() << r.status().message();
  ASSERT_TRUE(r.ok()) << r.status().message();
  double rd = area_under(r->rd), mf = area_under(r->mesh_first), tf = area_under(r->texture_first),
         cr = area_under(r->constant_ratio);
  EXPECT_LE(rd, mf * (1 + 1e-9));
  EXPECT_LE(rd, tf * (1 + 1e-9));
  EXPECT_LE(rd, cr * (1 + 1e-9));
  EXPECT_EQ(r->rd.cells.back(),
            std::make_pair(int(r->mesh_bytes.size()) - 1, int(r->texture_bytes.size()) - 1));
  EXPECT_LE(r->cells_evaluated, r->cells_total);
  EXPECT_LE(r->cells_descent, 2 * (r->mesh_bytes.size() + r->texture_bytes.size()));
  double best = std::min({mf, tf, cr});
  std::printf(
      "[ rd ] %-42s %zux%zu layers  areas rd %.4g | mesh-first %.4g | texture-first %.4g | "
      "constant %.4g  gain %.1f%%  "
      "views %zu  descent cells %zu, with baselines %zu, of %zu  renders %zu (whole grid %zu)  "
      "%.1f s\n",
      GetParam(), r->mesh_bytes.size(), r->texture_bytes.size(), rd, mf, tf, cr,
      100 * (1 - rd / best), r->views, r->cells_descent, r->cells_evaluated, r->cells_total,
      r->renders, r->cells_total * r->views, seconds);
}

INSTANTIATE_TEST_SUITE_P(Shared, MultiplexSharedModel,
                         ::testing::Values("Duck-dae/duck.dae",
                                           "CesiumMilkTruck-dae/CesiumMilkTruck.dae",
                                           "DamagedHelmet-glb/DamagedHelmet.glb",
                                           "Avocado-gltf/Avocado.gltf",
                                           "SheenChair-gltf/SheenChair.gltf", "Fox-glb/Fox.glb"),
                         [](const auto& info) { return testing::model_test_name(info.param); });

}  // namespace
}  // namespace meshmux
