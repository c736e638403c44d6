// The conversion pipeline as one function: every output from one call, each thing encoded once.
#include "pipeline/convert.h"

#include <draco/compression/decode.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <nlohmann/json.hpp>

#include "image/encode.h"
#include "scene/sample.h"
#include "simplify/memory_fit.h"
#include "stream/mesh_stream.h"
#include "stream/package.h"
#include "test_util.h"

namespace meshmux {
namespace {

// The built-in sample: textured (so there are texture levels), one column instanced many
// times beside unique meshes (so there are mesh layers over several submeshes). Big enough
// that the base is not the whole mesh (48k scene triangles), small enough to convert in 2 s.
Scene sample() { return make_sample_scene(SampleOptions{}); }

// One default conversion of the sample, shared by the tests below (a conversion takes
// seconds), with what the encoders counted while it ran.
struct Converted {
  Result<ConvertOutputs> out = Status::error("not run", ErrorKind::kInternal);
  uint64_t images = 0, parts = 0;  // images and mesh parts encoded during the conversion
};
const Converted& converted() {
  static const Converted c = [] {
    Converted r;
    Scene scene = sample();
    EncodeCounts counts;
    ConvertOptions o;
    o.counts = &counts;
    Warnings warnings;
    r.out = convert(scene, o, &warnings, nullptr);
    r.images = counts.images, r.parts = counts.mesh_parts;
    return r;
  }();
  return c;
}

// The texture levels are encoded once (model.glb, base.glb and the package's base embed levels that
// were encoded for the stream; no atlas encode, no re-encode of level 0), and every mesh part is
// encoded once (the multiplexer's costing encode is what the package holds). Counted at the
// encoders themselves, so a second encode anywhere in the pipeline shows.
TEST(Convert, EachMeshPartAndTextureLevelIsEncodedOnce) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  const auto& out = converted().out;
  ASSERT_TRUE(out.ok()) << out.status().message();
  uint64_t images = converted().images, parts = converted().parts;
  ASSERT_FALSE(out->package.empty()) << out->not_streamed;
  auto pkg = read_package(out->package);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  size_t package_parts = 0, texture_chunks = 0, mesh_chunks = 0;
  for (const PackageChunk& c : pkg->chunks) {
    package_parts += c.parts.size();
    texture_chunks += c.kind == StreamStep::kTexture;
    mesh_chunks += c.kind == StreamStep::kMesh;
  }
  EXPECT_GT(mesh_chunks, 2u) << "the sample must refine in several mesh chunks";
  EXPECT_GT(package_parts, mesh_chunks) << "several submeshes refine per chunk";
  EXPECT_EQ(parts, package_parts) << "mesh parts encoded vs parts in the package";
  ASSERT_GE(out->texture_levels, 2u);  // every other mip level: 512 and 128 high
  EXPECT_EQ(texture_chunks + 1, out->texture_levels) << "level 0 rides in the base";
  // Each level carries the base colour and the atlas's further channels.
  size_t maps = 1;
  for (const PackageChunk& c : pkg->chunks)
    if (c.kind == StreamStep::kTexture) maps = c.maps.size();
  EXPECT_EQ(images, out->texture_levels * maps) << "images encoded vs texture levels × maps";
  EXPECT_EQ(out->mesh_chunks, mesh_chunks);
  EXPECT_EQ(out->texture_chunks, texture_chunks);
}

// Every output of a folder conversion is there, and model.glb alone when asked for one file.
TEST(Convert, FolderOutputsAreAllThereAndSingleFileSkipsTheRest) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  const auto& out = converted().out;
  ASSERT_TRUE(out.ok()) << out.status().message();
  EXPECT_FALSE(out->model_glb.empty());
  EXPECT_FALSE(out->base_glb.empty());
  EXPECT_FALSE(out->package.empty());
  EXPECT_FALSE(out->report_json.empty());
  EXPECT_FALSE(out->rd_svg.empty());
  EXPECT_LT(out->base_glb.size(), out->model_glb.size()) << "the base is the coarse level";
  EXPECT_LT(out->base_triangles, out->output.scene_triangles);
  ConvertOptions single;
  single.stream = false;
  Warnings warnings;
  auto one = convert(sample(), single, &warnings, nullptr);
  ASSERT_TRUE(one.ok()) << one.status().message();
  EXPECT_EQ(one->model_glb, out->model_glb) << "model.glb does not depend on the stream";
  EXPECT_TRUE(one->base_glb.empty());
  EXPECT_TRUE(one->package.empty());
  EXPECT_TRUE(one->report_json.empty());
  EXPECT_EQ(one->texture_levels, 1u) << "without a stream only the top level is built";
}

// The LINES primitives of a .glb's JSON chunk.
size_t line_primitives(const std::vector<uint8_t>& glb) {
  if (glb.size() < 20) return 0;
  uint32_t length = 0;
  std::memcpy(&length, glb.data() + 12, 4);
  auto doc = nlohmann::json::parse(glb.begin() + 20, glb.begin() + 20 + length);
  size_t n = 0;
  for (const auto& m : doc["meshes"])
    for (const auto& p : m["primitives"]) n += p.value("mode", 4) == 1;
  return n;
}

// Points and lines pass every stage (clean, atlas, flattening, the progressive record's
// materialized levels): model.glb and the base carry them whole.
TEST(Convert, LinesReachModelAndBase) {
  Scene scene = sample();
  LineSet lines;
  lines.positions = {{0, 0, 0}, {1, 2, 0}, {2, 0, 1}};
  lines.indices = {0, 1, 1, 2};
  scene.lines.push_back(lines);
  ConvertOptions o;
  o.report = false;  // model.glb and base.glb, no renders
  Warnings warnings;
  auto out = convert(scene, o, &warnings, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  EXPECT_EQ(line_primitives(out->model_glb), 1u);
  ASSERT_FALSE(out->base_glb.empty());
  EXPECT_EQ(line_primitives(out->base_glb), 1u);
}

// One flattening policy for the pipeline and the simplifier: two spheres of two colours (so
// the atlas is built and the pipeline's own flattening runs after it), one placed twice and one
// once (1.5 instances per submesh), are flattened into one mesh under the default 1.75, and kept
// as two instanced meshes when flatten_below_ips says 1.25.
TEST(Convert, FlatteningFollowsTheSimplifyOption) {
  Scene scene;
  for (int k = 0; k < 2; ++k) {
    Mesh mesh;
    mesh.primitives.push_back(testing::uv_sphere(6, 12, 1, {float(4 * k), 0, 0}));
    mesh.primitives.back().material = k;
    scene.meshes.push_back(mesh);
    Material m;
    m.base_color_factor = {float(k), 0.5f, 1.0f - float(k), 1};
    scene.materials.push_back(m);
  }
  scene.instances.push_back({0, Mat4::identity(), "a"});
  scene.instances.push_back({0, Mat4::translation(0, 4, 0), "a2"});
  scene.instances.push_back({1, Mat4::identity(), "b"});
  ConvertOptions o;
  o.stream = false;  // model.glb only
  Warnings warnings;
  auto flattened = convert(scene, o, &warnings, nullptr);
  ASSERT_TRUE(flattened.ok()) << flattened.status().message();
  EXPECT_EQ(flattened->output.instances, 1u);
  o.simplify.flatten_below_ips = 1.25;
  auto kept = convert(scene, o, &warnings, nullptr);
  ASSERT_TRUE(kept.ok()) << kept.status().message();
  EXPECT_EQ(kept->output.instances, 3u);
  EXPECT_EQ(kept->output.meshes, 2u);
}

// One smooth sphere of 39,800 triangles, placed once: streamed (over 10,000 triangles), its
// splits dearer than Draco's single-rate coding, its coarsest level a few dozen triangles.
Scene sphere_scene() {
  Scene scene;
  Mesh mesh;
  mesh.primitives.push_back(testing::uv_sphere(100, 200));
  scene.meshes.push_back(mesh);
  scene.instances.push_back({0, Mat4::identity(), "sphere"});
  return scene;
}

// The first picture's bound is min(256 KiB, max(64 KiB, 0.1× model.glb)): small models get
// the floor, large ones the ceiling, the rest a tenth of their model.glb.
TEST(Convert, FirstPictureBytesFollowTheModelBetweenFloorAndCeiling) {
  ConvertOptions o;
  EXPECT_EQ(first_picture_bytes(100'000, o), 64u * 1024);
  EXPECT_EQ(first_picture_bytes(1'000'000, o), 100'000u);
  EXPECT_EQ(first_picture_bytes(50'000'000, o), 256u * 1024);
  o.base_model_share = 0;
  EXPECT_EQ(first_picture_bytes(50'000'000, o), 0u);  // no bound
}

// The first picture's bound: a base that the stopping rule leaves nearly whole (here a
// stopping error so small that it stops at once, as a CAD model's seams or a game level's
// borders made it stop) would cost about what model.glb costs; the conversion takes the finest
// coarser base within the bound instead (the floor lowered so that a tenth of this small
// model's bytes binds). Without the bound (share 0) the same scene's base is over it, so the
// case does exercise it.
TEST(Convert, BaseGlbStaysWithinTheFirstPictureBytes) {
  const Scene scene = sphere_scene();
  ConvertOptions o;
  o.report = false;  // model.glb and base.glb, no renders
  o.simplify.base_max_error = 1e-9f;
  o.base_min_bytes = 0;
  auto run = [&](double share) {
    o.base_model_share = share;
    Warnings warnings;
    return convert(scene, o, &warnings, nullptr);
  };
  auto unbounded = run(0), bounded = run(0.1);
  ASSERT_TRUE(unbounded.ok()) << unbounded.status().message();
  ASSERT_TRUE(bounded.ok()) << bounded.status().message();
  EXPECT_GT(unbounded->base_glb.size(), unbounded->model_glb.size() / 10);
  EXPECT_LE(bounded->base_glb.size(), bounded->model_glb.size() / 10);
  EXPECT_LT(bounded->base_triangles, unbounded->base_triangles);
  // The finest base that fits, not the coarsest: well over the coarsest sphere's few dozen.
  EXPECT_GT(bounded->base_triangles, 200u);
  EXPECT_EQ(bounded->model_glb, unbounded->model_glb);
}

// When even the coarsest levels are over the bound (here a bound of 1 byte), the base is the
// coarsest the record has, not the stopping rule's: as close to the first picture as it goes.
TEST(Convert, BaseOverTheBoundEvenAtTheCoarsestTakesTheCoarsest) {
  const Scene scene = sphere_scene();
  ConvertOptions o;
  o.report = false;
  o.simplify.base_max_error = 1e-9f;
  o.base_min_bytes = 0, o.base_max_bytes = 1;
  Warnings warnings;
  auto out = convert(scene, o, &warnings, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  o.base_model_share = 0;
  auto unbounded = convert(scene, o, &warnings, nullptr);
  ASSERT_TRUE(unbounded.ok()) << unbounded.status().message();
  EXPECT_LT(out->base_triangles, unbounded->base_triangles / 10);
  EXPECT_LT(out->base_glb.size(), unbounded->base_glb.size() / 4);
}

// The scene converted with the package bounded at 1.1× model.glb, and with no bound (every
// split ships).
std::pair<Result<ConvertOutputs>, Result<ConvertOutputs>> bounded_and_chain(const Scene& scene) {
  ConvertOptions o;
  o.max_package_ratio = 1.1;
  Warnings warnings;
  auto bounded = convert(scene, o, &warnings, nullptr);
  o.max_package_ratio = 0;
  return {std::move(bounded), convert(scene, o, &warnings, nullptr)};
}

// The completion step: a streamed mesh whose splits would take the package over its bound
// (here 1.1x model.glb; the splits of a smooth sphere cost about 1.5x Draco's single-rate) ends
// its mesh chunks in the full mesh sent single-rate: the package stays within the bound,
// report.json says where and what area it cost, and the completion's bitstream decodes to the
// full mesh on the stream's position grid (integers the base's transforms dequantize). Without
// the bound every split ships, over it, and model.glb is the same.
TEST(Convert, PackageOverItsBoundEndsInTheCompletion) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  const Scene scene = sphere_scene();
  auto [bounded, chain] = bounded_and_chain(scene);
  ASSERT_TRUE(bounded.ok()) << bounded.status().message();
  ASSERT_TRUE(chain.ok()) << chain.status().message();
  ASSERT_FALSE(bounded->package.empty()) << bounded->not_streamed;
  EXPECT_EQ(bounded->model_glb, chain->model_glb);
  EXPECT_GT(chain->package.size(), chain->model_glb.size());
  EXPECT_LE(double(bounded->package.size()), 1.1 * double(bounded->model_glb.size()));
  auto report = nlohmann::json::parse(bounded->report_json);
  const auto& c = report["completion"];
  ASSERT_TRUE(c["used"].get<bool>()) << bounded->report_json.substr(0, 600);
  EXPECT_LT(c["after_layer"].get<size_t>() + 1, c["chain_layers"].get<size_t>());
  EXPECT_GT(c["chain_area"].get<double>(), 0);
  EXPECT_FALSE(nlohmann::json::parse(chain->report_json)["completion"]["used"].get<bool>());
  auto pkg = read_package(bounded->package);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  const PackageChunk& last_mesh = [&]() -> const PackageChunk& {
    for (size_t k = pkg->chunks.size(); k-- > 0;)
      if (pkg->chunks[k].kind != StreamStep::kTexture) return pkg->chunks[k];
    return pkg->chunks.back();
  }();
  ASSERT_EQ(last_mesh.kind, StreamStep::kComplete);
  ASSERT_EQ(last_mesh.parts.size(), 1u);
  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(bounded->package.data() + last_mesh.offset),
              last_mesh.size);
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  ASSERT_TRUE(decoded.ok()) << decoded.status().error_msg_string();
  std::unique_ptr<draco::Mesh> full = std::move(decoded).value();
  EXPECT_EQ(full->num_points(), last_mesh.parts[0].vertex_end);
  EXPECT_EQ(full->num_faces(), last_mesh.parts[0].face_end);
  EXPECT_EQ(full->num_faces(), pkg->meshes[0].faces);
  const draco::PointAttribute* position =
      full->GetNamedAttribute(draco::GeometryAttribute::POSITION);
  ASSERT_NE(position, nullptr);
  float top = 0;
  for (draco::PointIndex p(0); p < full->num_points(); ++p) {
    std::array<float, 3> v{};
    ASSERT_TRUE((position->GetValue<float, 3>(position->mapped_index(p), &v)));
    for (float x : v) {
      ASSERT_GE(x, 0.0f);
      ASSERT_LE(x, 16383.0f);
      ASSERT_EQ(x, std::round(x));
      top = std::max(top, x);
    }
  }
  EXPECT_EQ(top, 16383.0f);  // the grid spans the mesh's longest side
}

// The completion's cut is known by bytes before the renders: the mesh layers past it never ship,
// so only the descent over every split (which places the completion and gives the area it cost)
// visits them, lazily; the rows that ship are rendered whole for the per-view table. The sphere
// above, textured (a grid needs texture levels for the descent to leave rows unvisited): fewer
// images than the chain's every row, and past the cut at most the descent's path.
TEST(Convert, CompletionRendersOnlyTheRowsItKeeps) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  Scene scene = sphere_scene();
  Image img;
  img.width = img.height = 512;
  for (int y = 0; y < 512; ++y)
    for (int x = 0; x < 512; ++x)
      img.rgba.insert(img.rgba.end(), {uint8_t(x), uint8_t(y), uint8_t((x ^ y) * 7), 255});
  scene.images.push_back(img);
  scene.materials.emplace_back();
  scene.materials[0].base_color.image = 0;
  scene.meshes[0].primitives[0].material = 0;
  auto [bounded, chain] = bounded_and_chain(scene);
  ASSERT_TRUE(bounded.ok()) << bounded.status().message();
  ASSERT_TRUE(chain.ok()) << chain.status().message();
  const auto b = nlohmann::json::parse(bounded->report_json);
  const auto c = nlohmann::json::parse(chain->report_json);
  ASSERT_TRUE(b["completion"]["used"].get<bool>());
  const size_t views = b["views"].get<size_t>();
  const size_t rows = b["completion"]["chain_layers"].get<size_t>();
  const size_t kept = b["completion"]["after_layer"].get<size_t>() + 2;  // and the full mesh
  const size_t levels = b["texture_level_bytes"].size();           // one (of 0 bytes) untextured
  ASSERT_EQ(c["renders"].get<size_t>(), views * (rows * levels));  // every cell, references in
  // The kept rows whole, and past them at most the descent's path and the other candidate of
  // each of its steps (two cells a step, one step per row and level).
  EXPECT_LE(b["renders"].get<size_t>(), views * (kept * levels + 2 * ((rows - kept) + levels)));
  EXPECT_LT(b["renders"].get<size_t>(), c["renders"].get<size_t>());
}

// The package's bound caps the base: the full mesh single-rate right after the base is the least a
// package holds, so where even that is over the bound (here 1.02× model.glb, with a stopping
// error so small that the base is a few thousand triangles of the sphere: a CAD part's seams or a
// drone's many pieces made such bases), the base gives way by the excess and the package keeps
// the bound; without the bound's retry (a bound so loose it never binds) the same scene's base is
// the larger one and its package over 1.02×.
TEST(Convert, PackageBoundMakesTheBaseGiveWay) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  const Scene scene = sphere_scene();
  ConvertOptions o;
  o.simplify.base_max_error = 2e-4f;
  Warnings warnings;
  o.max_package_ratio = 1.02;
  auto bounded = convert(scene, o, &warnings, nullptr);
  o.max_package_ratio = 100;
  auto loose = convert(scene, o, &warnings, nullptr);
  ASSERT_TRUE(bounded.ok()) << bounded.status().message();
  ASSERT_TRUE(loose.ok()) << loose.status().message();
  ASSERT_FALSE(bounded->package.empty()) << bounded->not_streamed;
  EXPECT_GT(double(loose->base_glb.size() + loose->model_glb.size()),
            1.02 * double(loose->model_glb.size()))
      << "the base alone must break the bound for the case to bind";
  EXPECT_LE(double(bounded->package.size()), 1.02 * double(bounded->model_glb.size()))
      << nlohmann::json::parse(bounded->report_json)["completion"].dump();
  EXPECT_LT(bounded->base_glb.size(), loose->base_glb.size());
  EXPECT_EQ(bounded->model_glb, loose->model_glb);
}

// report.json gives the converted scene's world box, which a world's grid sizes each model by:
// the sample scene's own box (clean keeps positions; the full level is the cleaned scene).
TEST(Convert, ReportGivesTheWorldBoxOfTheScene) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  const auto& out = converted().out;
  ASSERT_TRUE(out.ok()) << out.status().message();
  auto report = nlohmann::json::parse(out->report_json);
  ASSERT_TRUE(report.contains("bounds")) << out->report_json.substr(0, 400);
  const auto& b = report["bounds"];
  ASSERT_EQ(b.size(), 6u);
  const Bounds box = scene_bounds(sample());
  const float expected[6] = {box.min.x, box.min.y, box.min.z, box.max.x, box.max.y, box.max.z};
  for (size_t i = 0; i < 6; ++i)
    EXPECT_NEAR(b[i].get<double>(), expected[i], 1e-5 * (1 + std::abs(expected[i]))) << i;
}

// report.json sets the package, as a viewer receives it (real byte offsets, the stored order),
// against the plain download of model.glb: both start blank, the download shows the model at its
// last byte. The figures come from the outputs themselves.
TEST(Convert, ReportComparesThePackageWithTheDownload) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  const auto& out = converted().out;
  ASSERT_TRUE(out.ok()) << out.status().message();
  auto report = nlohmann::json::parse(out->report_json);
  ASSERT_TRUE(report.contains("download")) << out->report_json.substr(0, 400);
  const auto& d = report["download"];
  EXPECT_EQ(d["model_glb_bytes"].get<uint64_t>(), out->model_glb.size());
  EXPECT_EQ(d["package_bytes"].get<uint64_t>(), out->package.size());
  const auto& curve = d["package_curve"];
  ASSERT_GE(curve.size(), 3u);
  const double empty = report["empty_distortion"].get<double>();
  EXPECT_GT(empty, 0);
  EXPECT_EQ(curve[0][0].get<uint64_t>(), 0u);
  EXPECT_NEAR(curve[0][1].get<double>(), empty, 1e-5 * empty);
  auto pkg = read_package(out->package);
  ASSERT_TRUE(pkg.ok());
  EXPECT_GE(curve[1][0].get<uint64_t>(), pkg->base_offset + pkg->base_size);  // the first picture
  EXPECT_LT(curve[1][1].get<double>(), empty);
  for (size_t k = 1; k < curve.size(); ++k)
    EXPECT_GT(curve[k][0].get<uint64_t>(), curve[k - 1][0].get<uint64_t>());
  const double download = empty * double(out->model_glb.size());  // written with 6 digits
  EXPECT_NEAR(d["download_area"].get<double>(), download, 1e-5 * download);
  EXPECT_EQ(d["stream_beats_download"].get<bool>(),
            d["package_area"].get<double>() < d["download_area"].get<double>());
  EXPECT_NE(out->rd_svg.find("model.glb download"), std::string::npos);
  // The order's curves are costed from the base that ships: every one starts at the package's
  // first picture, and the stored order's points are the package's as received.
  for (const char* c : {"rd", "mesh_first", "texture_first", "constant_ratio"})
    EXPECT_EQ(report["curves"][c][0][0].get<uint64_t>(), curve[1][0].get<uint64_t>()) << c;
  const auto& rd = report["curves"]["rd"];
  ASSERT_EQ(rd.size() + 1, curve.size());
  for (size_t k = 0; k < rd.size(); ++k)
    EXPECT_EQ(rd[k][0].get<uint64_t>(), curve[k + 1][0].get<uint64_t>()) << k;
}

// report.json says which texture levels the stream ships (every one the package holds, with its
// bytes) and which were dropped and why.
TEST(Convert, ReportListsTheTextureLevelsShipped) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  const auto& out = converted().out;
  ASSERT_TRUE(out.ok()) << out.status().message();
  auto report = nlohmann::json::parse(out->report_json);
  ASSERT_TRUE(report.contains("texture_levels"));
  const auto& shipped = report["texture_levels"]["shipped"];
  ASSERT_EQ(shipped.size(), out->texture_levels);
  auto pkg = read_package(out->package);
  ASSERT_TRUE(pkg.ok());
  size_t k = 1;  // level 0 rides in the base
  for (const PackageChunk& c : pkg->chunks) {
    if (c.kind != StreamStep::kTexture) continue;
    ASSERT_LT(k, shipped.size());
    EXPECT_EQ(shipped[k]["width"].get<int>(), c.width);
    EXPECT_EQ(shipped[k]["bytes"].get<uint64_t>(), c.size);
    ++k;
  }
  EXPECT_EQ(k, shipped.size());
  for (const auto& d : report["texture_levels"]["dropped"])
    EXPECT_FALSE(d["why"].get<std::string>().empty());
  // The channels the levels carry, as the package's texture steps list them, and how they move.
  const auto& channels = report["texture_levels"]["channels"];
  ASSERT_FALSE(channels.empty());
  EXPECT_EQ(channels[0], "base_color");
  for (const PackageChunk& c : pkg->chunks)
    if (c.kind == StreamStep::kTexture) {
      ASSERT_EQ(c.maps.size(), channels.size());
      for (size_t i = 0; i < c.maps.size(); ++i) EXPECT_EQ(c.maps[i].channel, channels[i]);
    }
  EXPECT_EQ(report["texture_levels"]["channels_move"], "together");
}

// base.glb is what the stream shows first: the base mesh with texture level 0 (not the full
// atlas), Draco-coded; the package's own base holds the same texture level.
TEST(Convert, BaseGlbIsTheStreamsFirstPicture) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  const auto& out = converted().out;
  ASSERT_TRUE(out.ok()) << out.status().message();
  auto pkg = read_package(out->package);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  testing::TempDir dir;
  testing::write_file(dir.file("base.glb"), out->base_glb);
  auto base_bytes = package_base_glb(out->package, *pkg);
  ASSERT_TRUE(base_bytes.ok()) << base_bytes.status().message();
  const std::vector<uint8_t>& stream_base = *base_bytes;
  testing::write_file(dir.file("stream_base.glb"), stream_base);
  auto info = testing::run_meshmux({"info", dir.file("base.glb"), "--json"});
  auto stream_info = testing::run_meshmux({"info", dir.file("stream_base.glb"), "--json"});
  ASSERT_EQ(info.exit_code, 0) << info.err;
  ASSERT_EQ(stream_info.exit_code, 0) << stream_info.err;
  auto j = nlohmann::json::parse(info.out), k = nlohmann::json::parse(stream_info.out);
  EXPECT_EQ(j["scene_triangles"], out->base_triangles);
  EXPECT_EQ(j["scene_triangles"], k["scene_triangles"]);
  EXPECT_EQ(j["texture_pixels"], k["texture_pixels"]);
  // Level 0: the full texture halved until its larger side is 128 (the sample's 256² texture
  // with a plain-colour block row below it is 256×512, so level 0 is 64×128).
  ASSERT_GT(pkg->texture_width, 0);
  const int shift = std::max(pkg->texture_width, pkg->texture_height) / 128;
  size_t maps = 1;  // base colour and the atlas's further channels, all at the level's size
  for (const PackageChunk& c : pkg->chunks)
    if (c.kind == StreamStep::kTexture) maps = c.maps.size();
  EXPECT_EQ(j["texture_pixels"].get<uint64_t>(),
            uint64_t(pkg->texture_width / shift) * uint64_t(pkg->texture_height / shift) * maps)
      << "texture level 0";
  EXPECT_EQ(std::max(pkg->texture_width, pkg->texture_height) / shift, 128);
  std::string text(out->base_glb.begin(), out->base_glb.end());
  EXPECT_NE(text.find("KHR_draco_mesh_compression"), std::string::npos);
}

}  // namespace
}  // namespace meshmux

namespace meshmux {
namespace {

// A floor whose only material repeats a 6×5 texture 20 times: the atlas keeps it as it came
// (atlas/tiled.h), so the scene's first texture is not a power of two. The texture levels need
// one; the stream then carries the mesh only (a simulator's tiled wall was refused: "256x211 is
// not a power of two in both dimensions").
TEST(Convert, TiledTextureOfAnySizeStreamsWithoutTextureLevels) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  Scene s;
  Mesh mesh;
  Primitive p = testing::uv_sphere(8, 12);
  for (Vec2& t : p.uvs[0]) t = {t.x * 20, t.y * 20};
  p.material = 0;
  mesh.primitives.push_back(p);
  s.meshes.push_back(mesh);
  s.instances.push_back({0, Mat4::identity(), "floor"});
  Material tiles;
  tiles.base_color.image = 0;
  s.materials.push_back(tiles);
  Image im;
  im.width = 6, im.height = 5;
  im.rgba.assign(6 * 5 * 4, 200);
  s.images.push_back(im);
  Warnings warnings;
  auto out = convert(s, ConvertOptions{}, &warnings, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  EXPECT_FALSE(out->package.empty());
  EXPECT_EQ(out->texture_levels, 0u);
  EXPECT_EQ(out->output.draw_calls, 1u);
}

// A photograph-like pattern, decoded and JPEG-coded as an importer gives it.
Image pattern(int side, int seed) {
  Image im;
  im.name = "pattern " + std::to_string(seed);
  im.width = im.height = side;
  im.rgba.resize(size_t(side) * size_t(side) * 4);
  for (int y = 0; y < side; ++y)
    for (int x = 0; x < side; ++x) {
      uint8_t* q = &im.rgba[(size_t(y) * size_t(side) + size_t(x)) * 4];
      q[0] = uint8_t((x * 7 + seed * 40) & 255), q[1] = uint8_t((y * 5) & 255);
      q[2] = uint8_t(((x ^ y) * 3) & 255), q[3] = 255;
    }
  im.mime_type = "image/jpeg";
  im.encoded = encode_jpeg(im, 90).take();
  return im;
}

// A material kept beside the atlas (a texture tiled 20 times) beside one the atlas bakes: its
// image went into the base at full size, so a glass or iridescent model's base was nearly its
// whole model.glb. Now the base holds it at the base level's scale and the finest texture step
// brings it as model.glb has it.
TEST(Convert, KeptImagesComeWithTheTextureLevels) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  Scene s;
  for (int i = 0; i < 2; ++i) {
    Mesh mesh;
    Primitive p = testing::uv_sphere(24, 32, 1, {float(3 * i), 0, 0});
    if (i == 1)
      for (Vec2& t : p.uvs[0]) t = {t.x * 20, t.y * 20};
    p.material = i;
    mesh.primitives.push_back(p);
    s.meshes.push_back(mesh);
    s.instances.push_back({uint32_t(i), Mat4::identity(), "sphere " + std::to_string(i)});
    Material m;
    m.base_color.image = i;
    s.materials.push_back(m);
  }
  s.images = {pattern(1024, 0), pattern(256, 1)};
  Warnings warnings;
  auto out = convert(s, ConvertOptions{}, &warnings, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  ASSERT_GE(out->texture_levels, 2u);
  auto pkg = read_package(out->package);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  int finest = 0;
  for (const PackageChunk& c : pkg->chunks) {
    if (c.kind != StreamStep::kTexture) continue;
    for (const PackageMap& k : c.kept) {
      EXPECT_LT(k.width, 256 * c.width / pkg->texture_width + 2) << "at the level's scale";
      if (c.width == pkg->texture_width) {
        finest = k.width;
        // model.glb's own bytes of the image (the atlas step may have re-encoded it).
        const auto first = out->package.begin() + long(k.offset);
        EXPECT_NE(
            std::search(out->model_glb.begin(), out->model_glb.end(), first, first + long(k.size)),
            out->model_glb.end());
      }
    }
  }
  EXPECT_EQ(finest, 256) << "the finest level carries the image as it came";
  // The base holds the atlas's level 0 and the tiled image at its scale, far under 256².
  testing::TempDir dir;
  testing::write_file(dir.file("base.glb"), out->base_glb);
  testing::write_file(dir.file("model.glb"), out->model_glb);
  auto base = testing::run_meshmux({"info", dir.file("base.glb"), "--json"});
  auto model = testing::run_meshmux({"info", dir.file("model.glb"), "--json"});
  ASSERT_EQ(base.exit_code, 0) << base.err;
  ASSERT_EQ(model.exit_code, 0) << model.err;
  const uint64_t base_texels = nlohmann::json::parse(base.out)["texture_pixels"].get<uint64_t>();
  const uint64_t model_texels = nlohmann::json::parse(model.out)["texture_pixels"].get<uint64_t>();
  EXPECT_LT(base_texels, 256u * 256u);
  EXPECT_GE(model_texels, 256u * 256u) << "model.glb keeps it whole";
}

// A mesh over the block threshold (lowered here: a scan-like bumpy sphere of 36k triangles in
// ~120 blocks) streams as a block hierarchy: a version 17 package whose every part names its
// block, and report.json lists each block part with the mesh layer that ships it, its bytes
// (summing to that layer's), its level and error.
TEST(Convert, BlockMeshReportsItsBlocks) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  ConvertOptions o;
  o.simplify.block_above = 4000, o.simplify.block_positions = 512, o.simplify.block_until = 2000;
  o.max_package_ratio = 0;  // every split sent (small blocks cost more than the bound allows)
  Warnings warnings;
  auto out = convert(testing::bumpy_sphere(96, 192), o, &warnings, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  auto pkg = read_package(out->package);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  EXPECT_EQ(pkg->version, kBlockPackageVersion);
  ASSERT_GT(pkg->meshes[0].blocks.size(), 16u);
  size_t parts = 0;
  for (const PackageChunk& c : pkg->chunks)
    for (const PackagePart& p : c.parts) {
      EXPECT_GE(p.block, 0);
      ++parts;
    }
  const auto report = nlohmann::json::parse(out->report_json);
  ASSERT_TRUE(report.contains("blocks"));
  const auto& blocks = report["blocks"];
  EXPECT_EQ(blocks.size(), parts);
  std::vector<uint64_t> layer_bytes(report["mesh_layer_bytes"].size(), 0);
  size_t layer = 0;
  for (const auto& b : blocks) {
    ASSERT_GE(b["layer"].get<size_t>(), layer);  // in stored order
    layer = b["layer"].get<size_t>();
    ASSERT_LT(layer, layer_bytes.size());
    layer_bytes[layer] += b["bytes"].get<uint64_t>();
    EXPECT_GE(b["error"].get<double>(), 0.0);
  }
  for (size_t k = 1; k < layer_bytes.size(); ++k)
    EXPECT_EQ(layer_bytes[k], report["mesh_layer_bytes"][k].get<uint64_t>()) << "layer " << k;
}

// A memory cap too small for the whole-mesh loop on a mesh (here 30 MB for 36k faces, as 200 MB
// would be for 200k) builds it as blocks and still converts; the default cap keeps it a chain.
TEST(Convert, SmallMemoryCapBuildsBlocks) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  const Scene sphere = testing::bumpy_sphere(96, 192);
  for (uint64_t mb : {uint64_t(2048), uint64_t(30)}) {
    ConvertOptions o;
    o.simplify = fit_simplify_to_memory(o.simplify, mb);
    o.max_package_ratio = 0;  // every split sent (small blocks cost more than the bound allows)
    Warnings warnings;
    auto out = convert(sphere, o, &warnings, nullptr);
    ASSERT_TRUE(out.ok()) << mb << " MB: " << out.status().message();
    auto pkg = read_package(out->package);
    ASSERT_TRUE(pkg.ok()) << pkg.status().message();
    if (mb == 2048) {
      EXPECT_EQ(pkg->version, kPackageVersion);
      EXPECT_TRUE(pkg->meshes[0].blocks.empty());
    } else {
      EXPECT_EQ(pkg->version, kBlockPackageVersion);
      EXPECT_GT(pkg->meshes[0].blocks.size(), 4u) << "blocks of at most 3750 positions";
    }
  }
}

// A block mesh whose parts would pass the package's bound ends them in the completion, as a
// chain does (a sphere's smooth splits cost more than Draco's single-rate): the blocks after it
// are sent by no part, and the package reads back.
TEST(Convert, BlockMeshMayEndInTheCompletion) {
  std::string why;
  if (!testing::renderer_available(&why)) GTEST_SKIP() << why;
  ConvertOptions o;
  o.simplify.block_above = 4000, o.simplify.block_positions = 512, o.simplify.block_until = 2000;
  o.max_package_ratio = 1.2, o.max_block_package_ratio = 1.2;  // the splits pass it
  Warnings warnings;
  Scene scene;
  Mesh mesh;
  mesh.primitives.push_back(testing::uv_sphere(96, 192));
  scene.meshes.push_back(mesh);
  scene.instances.push_back({0, Mat4::identity(), "sphere"});
  auto out = convert(scene, o, &warnings, nullptr);
  ASSERT_TRUE(out.ok()) << out.status().message();
  auto pkg = read_package(out->package);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  EXPECT_EQ(pkg->version, kBlockPackageVersion);
  ASSERT_TRUE(nlohmann::json::parse(out->report_json)["completion"]["used"].get<bool>());
  size_t sent = 0, complete = 0;
  for (const PackageChunk& c : pkg->chunks) {
    complete += c.kind == StreamStep::kComplete;
    if (c.kind == StreamStep::kMesh) sent += c.parts.size();
  }
  EXPECT_EQ(complete, 1u);
  EXPECT_GT(sent, 0u);
  EXPECT_LT(sent, pkg->meshes[0].blocks.size());  // the blocks after the completion: none
}

}  // namespace
}  // namespace meshmux
