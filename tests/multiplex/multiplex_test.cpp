#include "multiplex/multiplex.h"

#include <gtest/gtest.h>

#include <chrono>

#include "importers/import.h"
#include "pipeline/convert.h"
#include "test_util.h"

namespace meshmux {
namespace {

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
