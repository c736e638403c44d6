// stream_plan: the descent's moves become the package's steps and the baselines become
// permutations of the same steps (what lets one package replay every order).
#include "multiplex/stream_plan.h"

#include <gtest/gtest.h>

namespace meshmux {
namespace {

RdPath path(std::vector<std::pair<int, int>> cells) {
  RdPath p;
  p.cells = std::move(cells);
  for (size_t k = 0; k < p.cells.size(); ++k) {
    p.bytes.push_back(k * 100);
    p.distortion.push_back(10.0 / double(k + 1));
  }
  return p;
}

// A 3 × 3 grid (two refinements, two texture levels) as the multiplexer reports it.
MultiplexResult result() {
  MultiplexResult r;
  r.mesh_bytes = {100, 50, 50};
  r.texture_bytes = {10, 40, 160};
  r.layer_levels = {{2, 0}, {5, 1}, {9, 3}};  // per layer, per mesh: its level
  r.rd = path({{0, 0}, {1, 0}, {1, 1}, {2, 1}, {2, 2}});
  r.mesh_first = path({{0, 0}, {1, 0}, {2, 0}, {2, 1}, {2, 2}});
  r.texture_first = path({{0, 0}, {0, 1}, {0, 2}, {1, 2}, {2, 2}});
  r.constant_ratio = path({{0, 0}, {0, 1}, {1, 1}, {2, 1}, {2, 2}});
  return r;
}

TEST(StreamPlan, StepsFollowTheDescentAndBaselinesPermuteThem) {
  auto plan = stream_plan(result());
  ASSERT_TRUE(plan.ok()) << plan.status().message();
  ASSERT_EQ(plan->steps.size(), 4u);
  EXPECT_EQ(plan->base_distortion, 10.0);
  EXPECT_EQ(plan->steps[0].kind, StreamStep::kMesh);
  EXPECT_EQ(plan->steps[0].mesh_layer, 1u);
  EXPECT_EQ(plan->steps[1].kind, StreamStep::kTexture);
  EXPECT_EQ(plan->steps[1].texture_level, 1u);
  EXPECT_EQ(plan->steps[2].mesh_layer, 2u);
  EXPECT_EQ(plan->steps[3].texture_level, 2u);
  EXPECT_DOUBLE_EQ(plan->steps[3].distortion, 2.0);
  ASSERT_EQ(plan->orders.size(), 3u);
  EXPECT_EQ(plan->orders[0].name, "mesh-first");
  EXPECT_EQ(plan->orders[0].steps, (std::vector<uint32_t>{0, 2, 1, 3}));
  EXPECT_EQ(plan->orders[1].name, "texture-first");
  EXPECT_EQ(plan->orders[1].steps, (std::vector<uint32_t>{1, 3, 0, 2}));
  EXPECT_EQ(plan->orders[2].name, "constant-ratio");
  EXPECT_EQ(plan->orders[2].steps, (std::vector<uint32_t>{1, 0, 2, 3}));
  EXPECT_DOUBLE_EQ(plan->orders[1].distortion[0], 5.0);
}

// A path that skips a layer or stops short is a multiplexer bug, reported rather than packaged.
TEST(StreamPlan, RejectsBrokenPaths) {
  MultiplexResult r = result();
  r.rd = path({{0, 0}, {2, 0}, {2, 1}, {2, 2}});
  auto plan = stream_plan(r);
  ASSERT_FALSE(plan.ok());
  EXPECT_NE(plan.status().message().find("not one layer"), std::string::npos);
  r = result();
  r.mesh_first = path({{0, 0}, {1, 0}, {2, 0}, {2, 1}});
  EXPECT_FALSE(stream_plan(r).ok());
  r = result();
  r.rd.cells.clear();
  EXPECT_FALSE(stream_plan(r).ok());
}

// Baselines not computed (empty paths) are left out, the descent alone is planned.
TEST(StreamPlan, MissingBaselinesAreLeftOut) {
  MultiplexResult r = result();
  r.mesh_first = r.texture_first = r.constant_ratio = RdPath{};
  auto plan = stream_plan(r);
  ASSERT_TRUE(plan.ok());
  EXPECT_TRUE(plan->orders.empty());
  EXPECT_EQ(plan->steps.size(), 4u);
}

}  // namespace
}  // namespace meshmux
