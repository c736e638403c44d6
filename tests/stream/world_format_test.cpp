// stream/world_format.h: world.json written, read back and refused when it would leave its
// folder or place what the player cannot draw; layout files' refusals. (Worlds are built here with
// batch/world.h's grid, as `meshmux batch` builds them.)
#include "stream/world_format.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "batch/world.h"
#include "core/file_io.h"
#include "test_util.h"

namespace meshmux {
namespace {

WorldPackage package(const std::string& name, std::array<double, 6> bounds, uint64_t bytes = 1000) {
  return {name, name + "/model.mmxp", bounds, bytes};
}

// A written world reads back exactly: names with quotes, box coordinates that need 17 digits,
// byte counts past 32 bits (what the player sizes requests by).
TEST(WorldFormat, JsonReadsBackExactly) {
  World w = grid_world({package("Duck", {-1.5, 0, -0.1, 1.5, 2.25, 0.1}, 5'000'000'000ull),
                        package("a\"b", {0.1, 0.2, 0.3, 0.4, 0.5, 0.6}, 7)});
  w.packages[0].head_bytes = 18602;  // known for one, unknown (0, left out) for the other
  auto back = parse_world(world_json(w), "world.json");
  ASSERT_TRUE(back.ok()) << back.status().message();
  ASSERT_EQ(back->packages.size(), 2u);
  EXPECT_EQ(back->packages[1].name, "a\"b");
  EXPECT_EQ(back->packages[0].bytes, 5'000'000'000ull);
  EXPECT_EQ(back->packages[0].head_bytes, 18602u);
  EXPECT_EQ(back->packages[1].head_bytes, 0u);
  for (size_t i = 0; i < 2; ++i) EXPECT_EQ(back->packages[i].bounds, w.packages[i].bounds);
  ASSERT_EQ(back->placements.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(back->placements[i].package, w.placements[i].package);
    EXPECT_EQ(back->placements[i].matrix, w.placements[i].matrix);
  }
  EXPECT_EQ(world_json(*back), world_json(w));
}

// A world is fetched by a browser from the folder it is served from: a URL that leaves it
// (a parent, an absolute path, another origin, a script) would read what the world's author
// never published. Refused by name unless the world is trusted.
TEST(WorldFormat, UrlsStayInsideTheWorldsFolder) {
  for (const char* bad :
       {"../secret.mmxp", "a/../../b.mmxp", "/etc/x.mmxp", "https://e.com/x.mmxp",
        "data:application/octet-stream,x", "javascript:alert(1)", "a\\b.mmxp", "x.mmxp?y",
        "a/%2e%2e/%2e%2e/b", "a/%2E%2e/b", "a/.%2E/b", " //evil.example/x.mmxp", "a/.. ", ""}) {
    World w = grid_world({package("a", {0, 0, 0, 1, 1, 1})});
    w.packages[0].url = bad;
    auto r = parse_world(world_json(w), "world.json");
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.status().message().find("world.json: packages[0].url"), std::string::npos)
        << r.status().message();
  }
  for (const char* good : {"Duck/model.mmxp", "a/b/c.mmxp", "x..y/model.mmxp", "./a.mmxp"})
    EXPECT_TRUE(world_url_is_inside(good)) << good;
  World w = grid_world({package("a", {0, 0, 0, 1, 1, 1})});
  w.packages[0].url = "https://cdn.example.com/a.mmxp";
  WorldLimits trusted;
  trusted.allow_external_urls = true;
  EXPECT_TRUE(parse_world(world_json(w), "world.json", trusted).ok());
}

// Placements the player could not draw: an index past the packages, a matrix of 15 numbers,
// a coordinate past float range, a projective row, a singular (flattening) matrix.
TEST(WorldFormat, RefusesPlacementsThePlayerCannotDraw) {
  const std::string head =
      "{\"meshmux_world\": 1, \"packages\": [{\"url\": \"a/model.mmxp\", \"bounds\": "
      "[0,0,0,1,1,1]}], "
      "\"placements\": [";
  const std::string id = "1,0,0,0, 0,1,0,0, 0,0,1,0, ";
  struct Case {
    std::string placement, says;
  } cases[] = {
      {"{\"package\": 1, \"matrix\": [" + id + "0,0,0,1]}", "placements[0].package"},
      {"{\"package\": 0, \"matrix\": [" + id + "0,0,1]}", "placements[0].matrix is not 16"},
      {"{\"package\": 0, \"matrix\": [" + id + "1e300,0,0,1]}", "not a finite coordinate"},
      {"{\"package\": 0, \"matrix\": [" + id + "0,0,0,2]}", "not affine"},
      {"{\"package\": 0, \"matrix\": [1,0,0,0, 2,0,0,0, 0,0,1,0, 0,0,0,1]}", "singular"},
      {"{\"package\": -1, \"matrix\": [" + id + "0,0,0,1]}", "placements[0].package"},
  };
  for (const Case& c : cases) {
    auto r = parse_world(head + c.placement + "]}", "w.json");
    ASSERT_FALSE(r.ok()) << c.placement;
    EXPECT_EQ(r.status().kind(), ErrorKind::kInput);
    EXPECT_NE(r.status().message().find(c.says), std::string::npos) << r.status().message();
  }
  EXPECT_TRUE(
      parse_world(head + "{\"package\": 0, \"matrix\": [" + id + "0,0,0,1]}]}", "w.json").ok());
}

// Hostile or broken files: empty, not JSON, nested to overflow a recursive parser, another
// version, more packages than the limit, a box inside out. One line each, naming the file.
TEST(WorldFormat, RefusesBrokenFilesWithOneLine) {
  std::string deep(100000, '[');
  WorldLimits small;
  small.max_packages = 1;
  const std::string two =
      "{\"meshmux_world\": 1, \"packages\": [{\"url\": \"a\", \"bounds\": [0,0,0,1,1,1]}, "
      "{\"url\": \"b\", \"bounds\": [0,0,0,1,1,1]}], \"placements\": []}";
  struct Case {
    std::string text, says;
    WorldLimits limits;
  } cases[] = {
      {"", "empty file", {}},
      {"{\"meshmux_world\": 1, \"packages\": [", "not valid JSON", {}},
      {deep, "nested deeper", {}},
      {"{\"meshmux_world\": 2, \"packages\": [], \"placements\": []}", "version 2", {}},
      {"{\"packages\": [], \"placements\": []}", "not a meshmux world", {}},
      {two, "2 packages (at most 1)", small},
      {"{\"meshmux_world\": 1, \"packages\": [{\"url\": \"a\", \"bounds\": [0,0,0,1,-1,1]}], "
       "\"placements\": []}",
       "minimum above its maximum",
       {}},
      // A head longer than its package would have the client ask past the file's end.
      {"{\"meshmux_world\": 1, \"packages\": [{\"url\": \"a\", \"bounds\": [0,0,0,1,1,1], "
       "\"bytes\": 10, \"head_bytes\": 11}], \"placements\": []}",
       "packages[0].head_bytes is more than the package's bytes",
       {}},
      {"{\"meshmux_world\": 1, \"packages\": [{\"url\": \"a\", \"bounds\": [0,0,0,1,1,1], "
       "\"head_bytes\": -1}], \"placements\": []}",
       "packages[0].head_bytes is not a byte count",
       {}},
  };
  for (const Case& c : cases) {
    auto r = parse_world(c.text, "w.json", c.limits);
    ASSERT_FALSE(r.ok()) << c.says;
    EXPECT_EQ(r.status().message().rfind("w.json: ", 0), 0u) << r.status().message();
    EXPECT_NE(r.status().message().find(c.says), std::string::npos) << r.status().message();
    EXPECT_EQ(r.status().message().find('\n'), std::string::npos);
  }
}

}  // namespace
}  // namespace meshmux
