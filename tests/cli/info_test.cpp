// meshmux info on a world.json: a world is published as a folder of packages; an operator asks
// whether what the world file names is there before serving it.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "core/file_io.h"
#include "test_util.h"

namespace meshmux {
namespace {

using testing::run_meshmux;
using testing::TempDir;

// A world naming two packages: one present at the size it says, one absent and one of the wrong
// size after a partial copy. Each problem gets its own line naming the package, exit 2; with
// both files in place the same world is reported whole, exit 0.
TEST(InfoWorld, ChecksEveryPackageFileBesideTheWorld) {
  TempDir dir;
  const std::string world =
      "{\"meshmux_world\": 1, \"packages\": ["
      "{\"name\": \"a\", \"url\": \"a/model.mmxp\", \"bounds\": [0,0,0,1,1,1], \"bytes\": 5},"
      "{\"name\": \"b b\", \"url\": \"b%20b/model.mmxp\", \"bounds\": [0,0,0,1,1,1], "
      "\"bytes\": 3}],"
      "\"placements\": [{\"package\": 1, \"matrix\": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]}]}";
  ASSERT_TRUE(write_file_atomic(dir.file("world.json"), world).is_ok());
  std::filesystem::create_directories(dir.file("a"));
  ASSERT_TRUE(write_file_atomic(dir.file("a/model.mmxp"), std::string("12")).is_ok());
  auto r = run_meshmux({"info", dir.file("world.json")});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("world.json: packages[0] 'a': a/model.mmxp: 2 bytes, the world says 5"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("packages[1] 'b b': b%20b/model.mmxp: no such file"), std::string::npos)
      << r.err;
  ASSERT_TRUE(write_file_atomic(dir.file("a/model.mmxp"), std::string("12345")).is_ok());
  std::filesystem::create_directories(dir.file("b b"));
  ASSERT_TRUE(write_file_atomic(dir.file("b b/model.mmxp"), std::string("123")).is_ok());
  auto ok = run_meshmux({"info", dir.file("world.json"), "--json"});
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_NE(ok.out.find("\"packages\": 2"), std::string::npos) << ok.out;
  EXPECT_NE(ok.out.find("\"placements\": 1"), std::string::npos) << ok.out;
  EXPECT_NE(ok.out.find("\"problems\": []"), std::string::npos) << ok.out;
}

// A world whose URL leaves its folder is refused as the browser refuses it: one line, exit 2.
TEST(InfoWorld, RefusesAWorldTheBrowserWouldRefuse) {
  TempDir dir;
  ASSERT_TRUE(write_file_atomic(dir.file("w.json"),
                                std::string("{\"meshmux_world\": 1, \"packages\": [{\"url\": "
                                            "\"../x.mmxp\", \"bounds\": [0,0,0,1,1,1]}], "
                                            "\"placements\": []}"))
                  .is_ok());
  auto r = run_meshmux({"info", dir.file("w.json")});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "meshmux: w.json: packages[0].url \"../x.mmxp\" leaves the world's folder\n");
}

}  // namespace
}  // namespace meshmux
