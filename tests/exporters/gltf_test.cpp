#include "exporters/gltf.h"

#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "core/file_io.h"
#include "image/encode.h"
#include "image/ktx2_encode.h"
#include "image/psnr.h"
#include "importers/import.h"
#include "test_util.h"

namespace meshmux {
namespace {

using json = nlohmann::json;
using testing::TempDir;

// ---- scenes built in code ----

// A small RGBA checker with partly transparent texels.
Image checker_image(int size = 8, bool opaque = false) {
  Image img;
  img.name = "checker";
  img.width = img.height = size;
  img.rgba.resize(size_t(size) * size * 4);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      uint8_t* p = &img.rgba[(size_t(y) * size + x) * 4];
      bool on = ((x / 2) + (y / 2)) % 2 == 0;
      p[0] = on ? 230 : 20;
      p[1] = uint8_t(x * 30);
      p[2] = uint8_t(y * 30);
      p[3] = opaque ? 255 : (on ? 255 : 128);
    }
  return img;
}

// Unit cube, 24 vertices (normals and uvs per face), 12 triangles.
Mesh cube_mesh(int32_t material) {
  Mesh mesh;
  mesh.name = "cube";
  Primitive p;
  const Vec3 normals[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (const Vec3& n : normals) {
    // Two axes spanning the face, chosen so (u x v) = n.
    Vec3 u = std::abs(n.y) > 0.5f ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    Vec3 v = cross(n, u);
    u = cross(v, n);
    uint32_t base = uint32_t(p.positions.size());
    const float corners[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (const auto& c : corners) {
      Vec3 pos = n * 0.5f + u * (0.5f * c[0]) + v * (0.5f * c[1]);
      p.positions.push_back(pos);
      p.normals.push_back(n);
    }
    p.uvs.resize(1);
    for (const auto& c : corners) p.uvs[0].push_back({0.5f * (c[0] + 1), 0.5f * (1 - c[1])});
    for (uint32_t k : {0u, 1u, 2u, 0u, 2u, 3u}) p.indices.push_back(base + k);
  }
  p.material = material;
  mesh.primitives.push_back(std::move(p));
  return mesh;
}

Scene textured_cube_scene() {
  Scene scene;
  Image img = checker_image();
  auto png = encode_png(img);
  EXPECT_TRUE(png.ok()) << png.status().message();
  if (png.ok()) img.encoded = png.take();
  img.mime_type = "image/png";
  scene.images.push_back(std::move(img));
  Material mat;
  mat.name = "checker";
  mat.base_color.image = 0;
  mat.base_color.sampler.wrap_s = Wrap::kClampToEdge;
  mat.base_color.sampler.mag_filter = 9729;
  mat.metallic_factor = 0;
  scene.materials.push_back(mat);
  scene.meshes.push_back(cube_mesh(0));
  Instance inst;
  inst.mesh = 0;
  inst.name = "cube";
  scene.instances.push_back(inst);
  return scene;
}

// One untextured cube placed `n` times with distinct translation, rotation and scale.
Scene instanced_scene(int n) {
  Scene scene;
  Material mat;
  mat.base_color_factor = {0.8f, 0.2f, 0.1f, 1};
  scene.materials.push_back(mat);
  scene.meshes.push_back(cube_mesh(0));
  for (int i = 0; i < n; ++i) {
    double t[3] = {2.0 * i, 0.5 * i, -1.0 * i};
    double a = 0.3 * i, q[4] = {0, std::sin(a / 2), 0, std::cos(a / 2)};
    double s[3] = {1 + 0.1 * i, 1, 1 + 0.05 * i};
    Instance inst;
    inst.mesh = 0;
    inst.world = Mat4::trs(t, q, s);
    inst.name = "cube." + std::to_string(i);
    scene.instances.push_back(inst);
  }
  return scene;
}

Mat4 shear_matrix() {
  Mat4 m = Mat4::translation(3, -2, 1);
  m.at(0, 1) = 0.5;  // x += 0.5 y
  m.at(2, 0) = 0.25;
  return m;
}

// ---- reading a .glb back ----

struct Glb {
  json doc;
  std::vector<uint8_t> bin;
};

uint32_t u32_at(const std::vector<uint8_t>& b, size_t at) {
  uint32_t v = 0;
  std::memcpy(&v, b.data() + at, 4);
  return v;
}

Glb parse_glb(const std::vector<uint8_t>& bytes) {
  Glb glb;
  EXPECT_GE(bytes.size(), 20u);
  if (bytes.size() < 20) return glb;
  EXPECT_EQ(u32_at(bytes, 0), 0x46546C67u);
  EXPECT_EQ(u32_at(bytes, 4), 2u);
  EXPECT_EQ(u32_at(bytes, 8), bytes.size());
  uint32_t json_len = u32_at(bytes, 12);
  EXPECT_EQ(u32_at(bytes, 16), 0x4E4F534Au);
  EXPECT_EQ(json_len % 4, 0u);
  glb.doc = json::parse(bytes.begin() + 20, bytes.begin() + 20 + json_len);
  size_t at = 20 + json_len;
  if (at + 8 <= bytes.size()) {
    uint32_t bin_len = u32_at(bytes, at);
    EXPECT_EQ(u32_at(bytes, at + 4), 0x004E4942u);
    glb.bin.assign(bytes.begin() + at + 8, bytes.begin() + at + 8 + bin_len);
  }
  return glb;
}

std::vector<uint8_t> export_ok(const Scene& scene, const GltfExportOptions& options = {},
                               Warnings* warnings = nullptr) {
  auto r = export_glb_bytes(scene, options, warnings);
  EXPECT_TRUE(r.ok()) << r.status().message();
  return r.ok() ? r.take() : std::vector<uint8_t>{};
}

// Writes the bytes to a file and runs Khronos' validator on it.
void expect_valid(const std::vector<uint8_t>& bytes, const std::string& name) {
  TempDir dir;
  std::string path = dir.file(name);
  testing::write_file(path, bytes);
  std::string report;
  int errors = testing::gltf_validator_errors(path, &report);
  ASSERT_GE(errors, 0) << "gltf-validator not installed (run scripts/setup.sh)";
  EXPECT_EQ(errors, 0) << report;
}

bool has(const json& arr, const std::string& s) {
  if (!arr.is_array()) return false;
  for (const auto& v : arr)
    if (v == s) return true;
  return false;
}

// ---- tests ----

TEST(GltfExport, TexturedCubeIsValid) {
  auto bytes = export_ok(textured_cube_scene());
  expect_valid(bytes, "cube.glb");
}

TEST(GltfExport, UncompressedTexturedCubeIsValid) {
  GltfExportOptions options;
  options.draco = false;
  auto bytes = export_ok(textured_cube_scene(), options);
  Glb glb = parse_glb(bytes);
  EXPECT_FALSE(glb.doc.contains("extensionsRequired"));
  expect_valid(bytes, "cube-plain.glb");
}

// A source without normals is shown flat-shaded by every glTF viewer (glTF 3.7.2.1); the normals
// clean() generated for our own use must not be exported, or viewers shade it smooth (the fox lost
// 6 dB lit). Both the Draco and the plain paths write no NORMAL; the file stays valid.
TEST(GltfExport, FlatPrimitivesAreWrittenWithoutNormals) {
  Scene s = textured_cube_scene();
  for (Mesh& m : s.meshes)
    for (Primitive& p : m.primitives) {
      ASSERT_FALSE(p.normals.empty());
      p.flat = true;
    }
  for (bool draco : {true, false}) {
    GltfExportOptions options;
    options.draco = draco;
    auto bytes = export_ok(s, options);
    Glb glb = parse_glb(bytes);
    for (const auto& mesh : glb.doc["meshes"])
      for (const auto& prim : mesh["primitives"]) {
        EXPECT_TRUE(prim["attributes"].contains("POSITION"));
        EXPECT_FALSE(prim["attributes"].contains("NORMAL")) << (draco ? "draco" : "plain");
      }
    expect_valid(bytes, draco ? "flat-draco.glb" : "flat-plain.glb");
  }
}

// A scan's one big primitive is written as Draco parts encoded on every core: each part a
// glTF primitive of the mesh with the same material, the file valid, and read back it is the
// whole surface (every triangle, the same bounds).
TEST(GltfExport, BigPrimitiveIsWrittenAsDracoPartsThatReadBackWhole) {
  Scene s;
  Mesh m;
  m.name = "scan";
  m.primitives.push_back(testing::uv_sphere(40, 80));  // 6,240 triangles
  m.primitives[0].material = 0;
  s.meshes.push_back(m);
  s.materials.push_back(Material{});
  s.instances.push_back({0, Mat4::identity(), "scan"});
  GltfExportOptions options;
  options.split_draco_above = 1000;
  const std::vector<uint8_t> bytes = export_ok(s, options);
  const Glb glb = parse_glb(bytes);
  ASSERT_EQ(glb.doc["meshes"].size(), 1u);
  const json& prims = glb.doc["meshes"][0]["primitives"];
  ASSERT_EQ(prims.size(), 7u);
  for (const json& prim : prims) {
    EXPECT_TRUE(prim["extensions"].contains("KHR_draco_mesh_compression"));
    EXPECT_EQ(prim["material"], 0);
  }
  expect_valid(bytes, "parts.glb");
  TempDir dir;
  testing::write_file(dir.file("parts.glb"), bytes);
  Warnings warnings;
  auto back = import_scene(dir.file("parts.glb"), {}, &warnings);
  ASSERT_TRUE(back.ok()) << back.status().message();
  EXPECT_EQ(compute_stats(*back).scene_triangles, 6240u);
  const Bounds a = scene_bounds(s), b = scene_bounds(*back);
  EXPECT_NEAR(a.min.x, b.min.x, 1e-3f);
  EXPECT_NEAR(a.max.y, b.max.y, 1e-3f);
  // The parts share the whole's quantization grid: a vertex on a part's border decodes to the
  // same point in both parts (on grids of their own, the parts' common edges would open hairline
  // cracks), so the parts hold exactly the distinct points the file written whole does.
  options.split_draco_above = 0;
  testing::write_file(dir.file("whole.glb"), export_ok(s, options));
  auto whole = import_scene(dir.file("whole.glb"), {}, &warnings);
  ASSERT_TRUE(whole.ok()) << whole.status().message();
  auto points = [](const Scene& scene) {
    std::set<std::tuple<float, float, float>> out;
    for (const Mesh& mesh : scene.meshes)
      for (const Primitive& p : mesh.primitives)
        for (const Vec3& v : p.positions) out.insert({v.x, v.y, v.z});
    return out;
  };
  EXPECT_EQ(points(*back), points(*whole));
}

// --textures ktx2: the file's images are KTX2 behind KHR_texture_basisu (required: a texture has
// no core source), valid for Khronos' validator, and read back (through three's transcoder, as
// a KTX2 upload is) they are the image they were, within ETC1S's loss. A textured cube with a
// normal map too: colour and data take different modes.
TEST(GltfExport, Ktx2TexturesAreRequiredBasisuImagesThatReadBack) {
  if (!ktx2_encoder_version().ok()) GTEST_SKIP() << ktx2_encoder_version().status().message();
  Scene s = textured_cube_scene();
  // A smooth base colour (ETC1S keeps one chroma per 4x4 block: a texel checker is its worst
  // case, not a texture's).
  Image& colour = s.images[0];
  colour.width = colour.height = 64;
  colour.rgba.assign(64 * 64 * 4, 255);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      uint8_t* p = &colour.rgba[size_t(y * 64 + x) * 4];
      p[0] = uint8_t(40 + 3 * x), p[1] = uint8_t(30 + 2 * y), p[2] = uint8_t(200 - x - y);
    }
  colour.encoded.clear(), colour.mime_type.clear();
  const Image original = colour;
  Image normal = checker_image(16, true);
  normal.name = "normal";
  s.images.push_back(normal);
  s.materials[0].normal.image = 1;
  GltfExportOptions options;
  options.ktx2 = true;
  const std::vector<uint8_t> bytes = export_ok(s, options);
  const Glb glb = parse_glb(bytes);
  EXPECT_TRUE(has(glb.doc["extensionsRequired"], "KHR_texture_basisu"));
  ASSERT_EQ(glb.doc["images"].size(), 2u);
  for (const json& image : glb.doc["images"]) EXPECT_EQ(image["mimeType"], "image/ktx2");
  for (const json& texture : glb.doc["textures"]) {
    EXPECT_FALSE(texture.contains("source"));
    EXPECT_TRUE(texture["extensions"]["KHR_texture_basisu"].contains("source"));
  }
  expect_valid(bytes, "ktx2.glb");
  TempDir dir;
  testing::write_file(dir.file("ktx2.glb"), bytes);
  Warnings warnings;
  auto back = import_scene(dir.file("ktx2.glb"), {}, &warnings);
  ASSERT_TRUE(back.ok()) << back.status().message();
  ASSERT_EQ(back->images.size(), 2u);
  const Image& read = back->images[size_t(back->materials[0].base_color.image)];
  ASSERT_TRUE(read.decoded());
  ASSERT_EQ(read.width, original.width);
  ASSERT_EQ(read.height, original.height);
  const double psnr = psnr_rgb(read, original);
  EXPECT_GT(psnr, 30.0) << "a smooth 64x64 base colour through ETC1S";
}

TEST(GltfExport, EmptySceneIsValid) {
  auto bytes = export_ok(Scene{});
  Glb glb = parse_glb(bytes);
  EXPECT_EQ(glb.doc["asset"]["version"], "2.0");
  EXPECT_EQ(glb.doc["asset"]["generator"], "meshmux");
  expect_valid(bytes, "empty.glb");
}

TEST(GltfExport, TenInstancesUseGpuInstancing) {
  auto bytes = export_ok(instanced_scene(10));
  Glb glb = parse_glb(bytes);
  const json& doc = glb.doc;
  ASSERT_EQ(doc["nodes"].size(), 1u);
  const json& node = doc["nodes"][0];
  ASSERT_TRUE(node["extensions"].contains("EXT_mesh_gpu_instancing"));
  const json& attrs = node["extensions"]["EXT_mesh_gpu_instancing"]["attributes"];
  for (const char* a : {"TRANSLATION", "ROTATION", "SCALE"}) {
    ASSERT_TRUE(attrs.contains(a)) << a;
    EXPECT_EQ(doc["accessors"][attrs[a].get<int>()]["count"], 10) << a;
  }
  EXPECT_TRUE(has(doc["extensionsUsed"], "EXT_mesh_gpu_instancing"));
  EXPECT_FALSE(has(doc["extensionsRequired"], "EXT_mesh_gpu_instancing"));
  expect_valid(bytes, "ten.glb");
}

TEST(GltfExport, TwoInstancesGetSeparateNodes) {
  auto bytes = export_ok(instanced_scene(2));
  Glb glb = parse_glb(bytes);
  const json& doc = glb.doc;
  ASSERT_EQ(doc["nodes"].size(), 2u);
  EXPECT_EQ(doc["scenes"][0]["nodes"], json({0, 1}));
  EXPECT_FALSE(doc["nodes"][0].contains("matrix"));  // identity is left out
  EXPECT_TRUE(doc["nodes"][1].contains("matrix"));
  for (const auto& n : doc["nodes"]) {
    EXPECT_EQ(n["mesh"], 0);
    EXPECT_FALSE(n.contains("extensions"));
  }
  EXPECT_FALSE(has(doc["extensionsUsed"], "EXT_mesh_gpu_instancing"));
  expect_valid(bytes, "two.glb");
}

// glTF forbids a non-TRS node matrix (validator error NODE_MATRIX_NON_TRS), so a sheared
// instance leaves the instanced node and becomes a parent TRS node with a rotated child node
// (SVD split) whose combined transform is the instance's matrix.
TEST(GltfExport, ShearedInstanceFallsBackToOwnNodes) {
  Scene scene = instanced_scene(5);
  scene.instances[2].world = shear_matrix();
  auto bytes = export_ok(scene);
  Glb glb = parse_glb(bytes);
  const json& doc = glb.doc;
  const json& roots = doc["scenes"][0]["nodes"];
  ASSERT_EQ(roots.size(), 2u);
  const json& inst = doc["nodes"][roots[0].get<int>()];
  int count =
      doc["accessors"][inst["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]["TRANSLATION"]
                           .get<int>()]["count"];
  EXPECT_EQ(count, 4);
  const json& parent = doc["nodes"][roots[1].get<int>()];
  EXPECT_FALSE(parent.contains("extensions"));
  EXPECT_FALSE(parent.contains("matrix"));
  ASSERT_EQ(parent["children"].size(), 1u);
  const json& child = doc["nodes"][parent["children"][0].get<int>()];
  EXPECT_EQ(child["mesh"], 0);
  // Parent TRS * child rotation reproduces the sheared matrix.
  auto vec = [](const json& j, const char* key, std::vector<double> def) {
    return j.contains(key) ? j[key].get<std::vector<double>>() : def;
  };
  auto t = vec(parent, "translation", {0, 0, 0}), s = vec(parent, "scale", {1, 1, 1});
  auto q1 = vec(parent, "rotation", {0, 0, 0, 1}), q2 = vec(child, "rotation", {0, 0, 0, 1});
  Mat4 world = Mat4::translation(t[0], t[1], t[2]) * Mat4::rotation(q1[0], q1[1], q1[2], q1[3]) *
               Mat4::scale(s[0], s[1], s[2]) * Mat4::rotation(q2[0], q2[1], q2[2], q2[3]);
  Mat4 want = shear_matrix();
  for (int i = 0; i < 16; ++i) EXPECT_NEAR(world.m[i], want.m[i], 1e-9) << i;
  expect_valid(bytes, "sheared.glb");
}

TEST(GltfExport, LoneShearedInstanceIsValid) {
  Scene scene = instanced_scene(1);
  scene.instances[0].world = shear_matrix();
  auto bytes = export_ok(scene);
  Glb glb = parse_glb(bytes);
  EXPECT_EQ(glb.doc["nodes"].size(), 2u);
  for (const auto& n : glb.doc["nodes"]) EXPECT_FALSE(n.contains("matrix"));
  expect_valid(bytes, "lone-shear.glb");
}

TEST(GltfExport, OutputIsDeterministic) {
  Scene scene = textured_cube_scene();
  Scene more = instanced_scene(6);
  scene.meshes.push_back(more.meshes[0]);
  for (Instance inst : more.instances) {
    inst.mesh = 1;
    scene.instances.push_back(inst);
  }
  scene.meshes[1].primitives[0].material = -1;
  auto a = export_ok(scene);
  auto b = export_ok(scene);
  ASSERT_FALSE(a.empty());
  EXPECT_EQ(a, b);
  expect_valid(a, "mixed.glb");
}

TEST(GltfExport, MissingFolderIsAnOutputError) {
  TempDir dir;
  std::string path = dir.file("no/such/folder/out.glb");
  Status s = export_glb(textured_cube_scene(), path, {}, nullptr);
  EXPECT_FALSE(s.is_ok());
  EXPECT_EQ(s.kind(), ErrorKind::kOutput);
  EXPECT_NE(s.message().find("gltf export"), std::string::npos) << s.message();
  EXPECT_FALSE(std::filesystem::exists(path));
  EXPECT_TRUE(dir.list().empty());
}

TEST(GltfExport, ExportLeavesNoTemporaryFile) {
  TempDir dir;
  std::string path = dir.file("cube.glb");
  Status s = export_glb(textured_cube_scene(), path, {}, nullptr);
  ASSERT_TRUE(s.is_ok()) << s.message();
  EXPECT_EQ(dir.list(), std::vector<std::string>{"cube.glb"});
  EXPECT_EQ(testing::read_file(path), export_ok(textured_cube_scene()));
}

TEST(GltfExport, MaterialFieldsSurvive) {
  Scene scene = textured_cube_scene();
  Material& m = scene.materials[0];
  m.base_color_factor = {0.5f, 0.25f, 1, 0.75f};
  m.alpha_mode = AlphaMode::kMask;
  m.alpha_cutoff = 0.3f;
  m.double_sided = true;
  m.roughness_factor = 0.4f;
  m.emissive_factor = {0.1f, 0.2f, 0.3f};
  m.base_color.transform.offset[0] = 0.5f;
  m.base_color.transform.scale[1] = 2;
  m.occlusion = m.base_color;
  m.occlusion.transform = {};
  m.occlusion.scale = 0.6f;
  Material unlit;
  unlit.name = "flat";
  unlit.unlit = true;
  unlit.alpha_mode = AlphaMode::kBlend;
  scene.materials.push_back(unlit);
  scene.meshes.push_back(cube_mesh(1));
  scene.instances.push_back({1, Mat4::translation(2, 0, 0), "flat"});

  auto bytes = export_ok(scene);
  Glb glb = parse_glb(bytes);
  const json& doc = glb.doc;
  ASSERT_EQ(doc["materials"].size(), 2u);
  const json& j = doc["materials"][0];
  EXPECT_EQ(j["name"], "checker");
  EXPECT_EQ(j["alphaMode"], "MASK");
  EXPECT_FLOAT_EQ(j["alphaCutoff"].get<float>(), 0.3f);
  EXPECT_EQ(j["doubleSided"], true);
  EXPECT_EQ(j["pbrMetallicRoughness"]["baseColorFactor"], json({0.5, 0.25, 1.0, 0.75}));
  EXPECT_FLOAT_EQ(j["pbrMetallicRoughness"]["metallicFactor"].get<float>(), 0.0f);
  EXPECT_FLOAT_EQ(j["pbrMetallicRoughness"]["roughnessFactor"].get<float>(), 0.4f);
  EXPECT_FLOAT_EQ(j["emissiveFactor"][2].get<float>(), 0.3f);
  EXPECT_FLOAT_EQ(j["occlusionTexture"]["strength"].get<float>(), 0.6f);
  const json& base = j["pbrMetallicRoughness"]["baseColorTexture"];
  const json& xf = base["extensions"]["KHR_texture_transform"];
  EXPECT_EQ(xf["offset"], json({0.5, 0.0}));
  EXPECT_EQ(xf["scale"], json({1.0, 2.0}));
  EXPECT_TRUE(has(doc["extensionsUsed"], "KHR_texture_transform"));
  // Same image, same sampler: one texture, one sampler.
  EXPECT_EQ(doc["textures"].size(), 1u);
  EXPECT_EQ(doc["samplers"].size(), 1u);
  EXPECT_EQ(doc["samplers"][0]["wrapS"], 33071);
  EXPECT_EQ(doc["samplers"][0]["magFilter"], 9729);
  const json& flat = doc["materials"][1];
  EXPECT_TRUE(flat["extensions"].contains("KHR_materials_unlit"));
  EXPECT_EQ(flat["alphaMode"], "BLEND");
  EXPECT_FALSE(flat.contains("alphaCutoff"));
  EXPECT_FALSE(flat.contains("doubleSided"));
  EXPECT_TRUE(has(doc["extensionsUsed"], "KHR_materials_unlit"));
  expect_valid(bytes, "materials.glb");
}

// A sheen layer is written as KHR_materials_sheen and read back the same: colour factor, colour
// texture, roughness factor; validator-clean.
TEST(GltfExport, SheenRoundTrips) {
  Scene scene = textured_cube_scene();
  Material& m = scene.materials[0];
  m.sheen_color_factor = {1, 0.5f, 0.25f};
  // Its own image (one no other slot names: the importer reads only images materials use).
  Image sheen_image = scene.images[size_t(m.base_color.image)];
  sheen_image.encoded.clear();
  sheen_image.mime_type.clear();
  sheen_image.name = "sheen";
  scene.images.push_back(sheen_image);
  m.sheen_color = m.base_color;
  m.sheen_color.image = int32_t(scene.images.size() - 1);
  m.sheen_color.transform = {};
  m.sheen_roughness_factor = 0.75f;
  auto bytes = export_ok(scene);
  Glb glb = parse_glb(bytes);
  const json& sheen = glb.doc["materials"][0]["extensions"]["KHR_materials_sheen"];
  EXPECT_EQ(sheen["sheenColorFactor"], json({1.0, 0.5, 0.25}));
  EXPECT_FLOAT_EQ(sheen["sheenRoughnessFactor"].get<float>(), 0.75f);
  EXPECT_TRUE(sheen.contains("sheenColorTexture"));
  EXPECT_TRUE(has(glb.doc["extensionsUsed"], "KHR_materials_sheen"));
  expect_valid(bytes, "sheen.glb");
  TempDir dir;
  testing::write_file(dir.file("sheen.glb"), bytes);
  auto back = import_scene(dir.file("sheen.glb"), {}, nullptr);
  ASSERT_TRUE(back.ok()) << back.status().message();
  EXPECT_EQ(back->materials[0].sheen_color_factor, (Vec3{1, 0.5f, 0.25f}));
  EXPECT_FLOAT_EQ(back->materials[0].sheen_roughness_factor, 0.75f);
  ASSERT_TRUE(back->materials[0].sheen_color.present());
  EXPECT_NE(back->materials[0].sheen_color.image, back->materials[0].base_color.image);
  EXPECT_TRUE(back->images[size_t(back->materials[0].sheen_color.image)].decoded());
}

// Glass round-trips as glass: KHR_materials_transmission, _ior (not at its default) and
// _volume are written, validator-clean, and read back the same.
TEST(GltfExport, GlassRoundTrips) {
  Scene scene = textured_cube_scene();
  Material& m = scene.materials[0];
  m.transmission_factor = 0.9f;
  m.ior = 1.33f;
  m.thickness_factor = 0.25f;
  m.attenuation_distance = 3;
  m.attenuation_color = {1, 0.5f, 0.25f};
  auto bytes = export_ok(scene);
  Glb glb = parse_glb(bytes);
  const json& ext = glb.doc["materials"][0]["extensions"];
  EXPECT_FLOAT_EQ(ext["KHR_materials_transmission"]["transmissionFactor"].get<float>(), 0.9f);
  EXPECT_FLOAT_EQ(ext["KHR_materials_ior"]["ior"].get<float>(), 1.33f);
  EXPECT_FLOAT_EQ(ext["KHR_materials_volume"]["thicknessFactor"].get<float>(), 0.25f);
  for (const char* e : {"KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume"})
    EXPECT_TRUE(has(glb.doc["extensionsUsed"], e)) << e;
  expect_valid(bytes, "glass.glb");
  TempDir dir;
  testing::write_file(dir.file("glass.glb"), bytes);
  auto back = import_scene(dir.file("glass.glb"), {}, nullptr);
  ASSERT_TRUE(back.ok()) << back.status().message();
  const Material& b = back->materials[0];
  EXPECT_FLOAT_EQ(b.transmission_factor, 0.9f);
  EXPECT_FLOAT_EQ(b.ior, 1.33f);
  EXPECT_FLOAT_EQ(b.thickness_factor, 0.25f);
  EXPECT_FLOAT_EQ(b.attenuation_distance, 3);
  EXPECT_EQ(b.attenuation_color, (Vec3{1, 0.5f, 0.25f}));
  EXPECT_EQ(b.alpha_mode, AlphaMode::kOpaque);
}

// The reflection's layers round-trip: clearcoat, specular and iridescence factors are written
// as their extensions (validator-clean) and read back the same.
TEST(GltfExport, ReflectionLayersRoundTrip) {
  Scene scene = textured_cube_scene();
  Material& m = scene.materials[0];
  m.clearcoat_factor = 1;
  m.clearcoat_roughness_factor = 0.1f;
  m.specular_factor = 0.5f;
  m.specular_color_factor = {1, 0.25f, 0.5f};
  m.iridescence_factor = 0.8f;
  m.iridescence_ior = 1.8f;
  m.iridescence_thickness = 700;
  auto bytes = export_ok(scene);
  Glb glb = parse_glb(bytes);
  for (const char* e :
       {"KHR_materials_clearcoat", "KHR_materials_specular", "KHR_materials_iridescence"})
    EXPECT_TRUE(has(glb.doc["extensionsUsed"], e)) << e;
  expect_valid(bytes, "layers.glb");
  TempDir dir;
  testing::write_file(dir.file("layers.glb"), bytes);
  auto back = import_scene(dir.file("layers.glb"), {}, nullptr);
  ASSERT_TRUE(back.ok()) << back.status().message();
  const Material& b = back->materials[0];
  EXPECT_FLOAT_EQ(b.clearcoat_factor, 1);
  EXPECT_FLOAT_EQ(b.clearcoat_roughness_factor, 0.1f);
  EXPECT_FLOAT_EQ(b.specular_factor, 0.5f);
  EXPECT_EQ(b.specular_color_factor, (Vec3{1, 0.25f, 0.5f}));
  EXPECT_FLOAT_EQ(b.iridescence_factor, 0.8f);
  EXPECT_FLOAT_EQ(b.iridescence_ior, 1.8f);
  EXPECT_FLOAT_EQ(b.iridescence_thickness, 700);
}

// The layers' textures and anisotropy round-trip (materials kept beside the atlas carry them,
// atlas/kept.h): each slot is written under its extension's key with its uv set and the
// clearcoat normal map's scale, validator-clean, and read back into the same slot.
TEST(GltfExport, LayerTexturesAndAnisotropyRoundTrip) {
  Scene scene = textured_cube_scene();
  Material& m = scene.materials[0];
  m.clearcoat_factor = 1;
  m.specular_factor = 0.5f;
  m.iridescence_factor = 1;
  m.iridescence_thickness_minimum = 200;
  m.anisotropy_strength = 0.7f;
  m.anisotropy_rotation = 0.25f;
  m.thickness_factor = 0.1f;
  m.transmission_factor = 1;
  m.sheen_color_factor = {1, 1, 1};
  for (size_t k = 0; k < size_t(LayerSlot::kCount); ++k) {
    m.layers[k] = m.base_color;
    m.layers[k].scale = 1;
  }
  m.layer(LayerSlot::kClearcoatNormal).scale = 0.5f;
  m.transmission = m.base_color;
  m.normal = m.base_color;  // anisotropy's tangent space (no TANGENT is written)
  auto bytes = export_ok(scene);
  Glb glb = parse_glb(bytes);
  const json& ext = glb.doc["materials"][0]["extensions"];
  for (const LayerSlotName& slot : kLayerSlots)
    EXPECT_TRUE(ext[slot.extension].contains(slot.key)) << slot.extension << " " << slot.key;
  EXPECT_FLOAT_EQ(ext["KHR_materials_clearcoat"]["clearcoatNormalTexture"]["scale"].get<float>(),
                  0.5f);
  EXPECT_FLOAT_EQ(ext["KHR_materials_anisotropy"]["anisotropyStrength"].get<float>(), 0.7f);
  EXPECT_TRUE(has(glb.doc["extensionsUsed"], "KHR_materials_anisotropy"));
  expect_valid(bytes, "layer_textures.glb");
  TempDir dir;
  testing::write_file(dir.file("layer_textures.glb"), bytes);
  auto back = import_scene(dir.file("layer_textures.glb"), {}, nullptr);
  ASSERT_TRUE(back.ok()) << back.status().message();
  const Material& b = back->materials[0];
  for (size_t k = 0; k < size_t(LayerSlot::kCount); ++k)
    EXPECT_TRUE(b.layers[k].present()) << kLayerSlots[k].key;
  EXPECT_FLOAT_EQ(b.layer(LayerSlot::kClearcoatNormal).scale, 0.5f);
  EXPECT_TRUE(b.transmission.present());
  EXPECT_FLOAT_EQ(b.anisotropy_strength, 0.7f);
  EXPECT_FLOAT_EQ(b.anisotropy_rotation, 0.25f);
  EXPECT_FLOAT_EQ(b.iridescence_thickness_minimum, 200);
}

// Anisotropy without a normal map would need TANGENT, which meshmux does not write: the
// extension is left out, said once, and the file stays valid.
TEST(GltfExport, AnisotropyWithoutNormalMapIsLeftOut) {
  Scene scene = textured_cube_scene();
  scene.materials[0].anisotropy_strength = 0.5f;
  Warnings warnings;
  auto bytes = export_ok(scene, {}, &warnings);
  Glb glb = parse_glb(bytes);
  EXPECT_FALSE(glb.doc["materials"][0].contains("extensions") &&
               glb.doc["materials"][0]["extensions"].contains("KHR_materials_anisotropy"));
  int said = 0;
  for (const std::string& w : warnings.items())
    said += w.find("anisotropy left out") != std::string::npos;
  EXPECT_EQ(said, 1);
  expect_valid(bytes, "anisotropy_no_normal.glb");
}

// Points and lines are written as plain POINTS / LINES primitives under one node, in a
// material of their colour, validator-clean, and read back as they were.
TEST(GltfExport, PointsAndLinesRoundTrip) {
  Scene scene = textured_cube_scene();
  LineSet lines;
  lines.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}};
  lines.indices = {0, 1, 1, 2};
  lines.color = {0, 0, 1, 1};
  scene.lines.push_back(lines);
  LineSet points = lines;
  points.points = true;
  points.indices = {0, 2};
  scene.lines.push_back(points);
  auto bytes = export_ok(scene);
  Glb glb = parse_glb(bytes);
  std::vector<int> modes;
  for (const json& m : glb.doc["meshes"])
    for (const json& p : m["primitives"]) modes.push_back(p.value("mode", 4));
  EXPECT_EQ(std::count(modes.begin(), modes.end(), 1), 1);
  EXPECT_EQ(std::count(modes.begin(), modes.end(), 0), 1);
  expect_valid(bytes, "lines.glb");
  TempDir dir;
  testing::write_file(dir.file("lines.glb"), bytes);
  auto back = import_scene(dir.file("lines.glb"), {}, nullptr);
  ASSERT_TRUE(back.ok()) << back.status().message();
  ASSERT_EQ(back->lines.size(), 2u);
  EXPECT_EQ(back->lines[0].indices, lines.indices);
  EXPECT_EQ(back->lines[0].positions, lines.positions);
  EXPECT_EQ(back->lines[0].color, lines.color);
  EXPECT_TRUE(back->lines[1].points);
}

// An emissive factor beyond 1 (KHR_materials_emissive_strength folded in on import) is
// written back as a factor in [0, 1] and the strength, so it stays valid and as bright.
TEST(GltfExport, EmissiveBeyondOneWritesEmissiveStrength) {
  Scene scene = textured_cube_scene();
  scene.materials[0].emissive_factor = {4, 2, 0};
  auto bytes = export_ok(scene);
  Glb glb = parse_glb(bytes);
  const json& j = glb.doc["materials"][0];
  EXPECT_EQ(j["emissiveFactor"], json({1.0, 0.5, 0.0}));
  EXPECT_FLOAT_EQ(
      j["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"].get<float>(), 4.0f);
  EXPECT_TRUE(has(glb.doc["extensionsUsed"], "KHR_materials_emissive_strength"));
  expect_valid(bytes, "emissive_strength.glb");
}

TEST(GltfExport, UnsupportedImageFormatIsReencodedToPng) {
  Scene scene = textured_cube_scene();
  Image& img = scene.images[0];
  img.mime_type = "image/x-tga";
  img.encoded = {0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 8, 0, 8, 0, 32, 8};  // a TGA header
  Warnings warnings;
  auto bytes = export_ok(scene, {}, &warnings);
  Glb glb = parse_glb(bytes);
  ASSERT_EQ(glb.doc["images"].size(), 1u);
  const json& image = glb.doc["images"][0];
  EXPECT_EQ(image["mimeType"], "image/png");
  const json& view = glb.doc["bufferViews"][image["bufferView"].get<int>()];
  size_t offset = view["byteOffset"], length = view["byteLength"];
  ASSERT_LE(offset + length, glb.bin.size());
  const uint8_t sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  EXPECT_EQ(std::memcmp(glb.bin.data() + offset, sig, 8), 0);
  EXPECT_TRUE(warnings.empty());
  expect_valid(bytes, "tga.glb");
}

TEST(GltfExport, UndecodedImageIsDroppedWithWarning) {
  Scene scene = textured_cube_scene();
  Image& img = scene.images[0];
  img.mime_type = "image/x-tga";
  img.encoded = {0, 0, 2, 0};
  img.width = img.height = 0;
  img.rgba.clear();
  Warnings warnings;
  auto bytes = export_ok(scene, {}, &warnings);
  Glb glb = parse_glb(bytes);
  EXPECT_FALSE(glb.doc.contains("images"));
  EXPECT_FALSE(glb.doc.contains("textures"));
  EXPECT_FALSE(glb.doc["materials"][0]["pbrMetallicRoughness"].contains("baseColorTexture"));
  ASSERT_EQ(warnings.items().size(), 1u);
  EXPECT_EQ(warnings.items()[0], "gltf export: image 0 'checker': cannot embed (not decoded)");
  expect_valid(bytes, "dropped.glb");
}

TEST(GltfExport, DracoDecodedCountMatchesAccessors) {
  Scene scene = textured_cube_scene();
  auto bytes = export_ok(scene);
  Glb glb = parse_glb(bytes);
  const json& doc = glb.doc;
  EXPECT_TRUE(has(doc["extensionsUsed"], "KHR_draco_mesh_compression"));
  EXPECT_TRUE(has(doc["extensionsRequired"], "KHR_draco_mesh_compression"));
  const json& prim = doc["meshes"][0]["primitives"][0];
  const json& ext = prim["extensions"]["KHR_draco_mesh_compression"];
  const json& view = doc["bufferViews"][ext["bufferView"].get<int>()];
  size_t offset = view["byteOffset"], length = view["byteLength"];
  ASSERT_LE(offset + length, glb.bin.size());

  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(glb.bin.data() + offset), length);
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  ASSERT_TRUE(decoded.ok()) << decoded.status().error_msg_string();
  std::unique_ptr<draco::Mesh> mesh = std::move(decoded).value();

  for (const char* name : {"POSITION", "NORMAL", "TEXCOORD_0"}) {
    ASSERT_TRUE(prim["attributes"].contains(name)) << name;
    const json& acc = doc["accessors"][prim["attributes"][name].get<int>()];
    EXPECT_FALSE(acc.contains("bufferView"));
    EXPECT_EQ(acc["count"].get<uint32_t>(), mesh->num_points()) << name;
    EXPECT_NE(mesh->GetAttributeByUniqueId(ext["attributes"][name].get<uint32_t>()), nullptr)
        << name;
  }
  const json& idx = doc["accessors"][prim["indices"].get<int>()];
  EXPECT_EQ(idx["count"].get<uint32_t>(), mesh->num_faces() * 3);
  EXPECT_EQ(mesh->num_faces(), 12u);
  // POSITION min/max are the decoded extremes.
  const json& pos = doc["accessors"][prim["attributes"]["POSITION"].get<int>()];
  const draco::PointAttribute* att =
      mesh->GetAttributeByUniqueId(ext["attributes"]["POSITION"].get<uint32_t>());
  ASSERT_NE(att, nullptr);
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  for (draco::PointIndex p(0); p < mesh->num_points(); ++p) {
    std::array<float, 3> v{};
    ASSERT_TRUE((att->GetValue<float, 3>(att->mapped_index(p), &v)));
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], v[k]), hi[k] = std::max(hi[k], v[k]);
  }
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(pos["min"][k].get<float>(), lo[k]);
    EXPECT_EQ(pos["max"][k].get<float>(), hi[k]);
    EXPECT_NEAR(hi[k], 0.5f, 1e-3);
  }
}

// A scan's triangles can come in no spatial order (here a sphere's, shuffled: a vertex cache
// would miss every vertex); the Draco encoder is then given them in spatial order, which must
// change nothing but their order: the file read back holds the same triangles, each with its
// corners' positions and normals (to the quantization).
TEST(GltfExport, ShuffledTrianglesComeBackTheSame) {
  Primitive p = testing::uv_sphere(30, 60);
  std::vector<std::array<uint32_t, 3>> tris;
  for (size_t t = 0; t < p.indices.size(); t += 3)
    tris.push_back({p.indices[t], p.indices[t + 1], p.indices[t + 2]});
  std::mt19937 rng(3);
  std::shuffle(tris.begin(), tris.end(), rng);
  p.indices.clear();
  for (const auto& t : tris) p.indices.insert(p.indices.end(), t.begin(), t.end());
  Scene scene;
  scene.meshes.push_back(Mesh{});
  scene.meshes[0].primitives.push_back(p);
  scene.instances.push_back({0, Mat4::identity(), "sphere"});
  testing::TempDir dir;
  ASSERT_TRUE(write_file_atomic(dir.file("s.glb"), export_ok(scene)).ok());
  Warnings warnings;
  auto back = import_scene(dir.file("s.glb"), {}, &warnings);
  ASSERT_TRUE(back.ok()) << back.status().message();
  ASSERT_EQ(back->meshes.size(), 1u);
  const Primitive& q = back->meshes[0].primitives.at(0);
  ASSERT_EQ(q.indices.size(), p.indices.size());
  // Each triangle as its corners' positions, numbered by the input's distinct positions (the
  // nearest one: quantization moves a corner by ~1e-4, neighbours are ~0.1 apart), rotated to
  // start at the smallest: the two files' sets must match.
  std::vector<Vec3> unique;
  for (const Vec3& v : p.positions)
    if (std::none_of(unique.begin(), unique.end(), [&](const Vec3& u) { return u == v; }))
      unique.push_back(v);
  auto id = [&](Vec3 v) {
    size_t best = 0;
    for (size_t i = 1; i < unique.size(); ++i)
      if (length(unique[i] - v) < length(unique[best] - v)) best = i;
    return best;
  };
  auto key = [&](const Primitive& m, size_t t) {
    std::array<size_t, 3> c = {id(m.positions[m.indices[t]]), id(m.positions[m.indices[t + 1]]),
                               id(m.positions[m.indices[t + 2]])};
    std::rotate(c.begin(), std::min_element(c.begin(), c.end()), c.end());
    return c;
  };
  std::multiset<std::array<size_t, 3>> in, out;
  for (size_t t = 0; t < p.indices.size(); t += 3) in.insert(key(p, t));
  for (size_t t = 0; t < q.indices.size(); t += 3) out.insert(key(q, t));
  EXPECT_EQ(in, out);
  for (size_t v = 0; v < q.positions.size(); ++v)
    ASSERT_GT(dot(q.normals[v], normalize(q.positions[v])), 0.99f) << "vertex " << v;
}

// More than 65535 vertices: 32-bit indices, in both encodings.
TEST(GltfExport, LargeMeshUsesUnsignedIntIndices) {
  Scene scene;
  Mesh mesh;
  Primitive p;
  const uint32_t n = 300;  // 90,000 vertices
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x) {
      p.positions.push_back({float(x), float(y), std::sin(0.1f * x) * std::cos(0.1f * y)});
      p.normals.push_back({0, 0, 1});
    }
  for (uint32_t y = 0; y + 1 < n; ++y)
    for (uint32_t x = 0; x + 1 < n; ++x) {
      uint32_t a = y * n + x;
      for (uint32_t k : {a, a + 1, a + n + 1, a, a + n + 1, a + n}) p.indices.push_back(k);
    }
  mesh.primitives.push_back(std::move(p));
  scene.meshes.push_back(std::move(mesh));
  scene.instances.push_back({0, Mat4{}, "grid"});
  for (bool draco : {true, false}) {
    GltfExportOptions options;
    options.draco = draco;
    auto bytes = export_ok(scene, options);
    Glb glb = parse_glb(bytes);
    const json& prim = glb.doc["meshes"][0]["primitives"][0];
    const json& idx = glb.doc["accessors"][prim["indices"].get<int>()];
    EXPECT_EQ(idx["componentType"], 5125) << "draco " << draco;
    EXPECT_EQ(idx["count"], 6 * (n - 1) * (n - 1)) << "draco " << draco;
    expect_valid(bytes, draco ? "grid.glb" : "grid-plain.glb");
  }
}

// Inputs a glTF file cannot hold as they are still give a valid file, with warnings: a
// primitive without triangles, a mesh left empty, zero normals, a texture on a uv set the
// primitive lacks, an invalid filter, a projective transform.
TEST(GltfExport, OddInputStillGivesValidFile) {
  Scene scene = textured_cube_scene();
  Primitive& cube = scene.meshes[0].primitives[0];
  cube.normals[0] = {0, 0, 0};
  cube.normals[1] = {NAN, 0, 0};
  scene.materials[0].base_color.tex_coord = 1;
  scene.materials[0].base_color.sampler.min_filter = 1234;
  Primitive empty;
  empty.positions = {{0, 0, 0}};
  scene.meshes[0].primitives.push_back(empty);
  Mesh hollow;
  hollow.name = "hollow";
  hollow.primitives.push_back(empty);
  scene.meshes.push_back(hollow);
  scene.instances.push_back({1, Mat4{}, "hollow"});
  Mat4 projective;
  projective.at(3, 0) = 0.5;
  scene.instances.push_back({0, projective, "projective"});
  for (bool draco : {true, false}) {
    GltfExportOptions options;
    options.draco = draco;
    Warnings warnings;
    auto bytes = export_ok(scene, options, &warnings);
    EXPECT_GE(warnings.items().size(), 6u);
    for (const std::string& w : warnings.items()) EXPECT_EQ(w.rfind("gltf export: ", 0), 0u) << w;
    Glb glb = parse_glb(bytes);
    EXPECT_EQ(glb.doc["meshes"].size(), 1u);
    EXPECT_EQ(glb.doc["meshes"][0]["primitives"].size(), 1u);
    EXPECT_TRUE(glb.doc["meshes"][0]["primitives"][0]["attributes"].contains("TEXCOORD_1"));
    expect_valid(bytes, draco ? "odd.glb" : "odd-plain.glb");
  }
}

TEST(GltfExport, BadOptionsAndScenesAreErrors) {
  GltfExportOptions options;
  options.position_bits = 0;
  auto r = export_glb_bytes(textured_cube_scene(), options, nullptr);
  EXPECT_FALSE(r.ok());
  Scene scene = textured_cube_scene();
  scene.meshes[0].primitives[0].indices[4] = 999;
  r = export_glb_bytes(scene, {}, nullptr);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().message().rfind("gltf export: mesh 0 primitive 0", 0), 0u)
      << r.status().message();
}

TEST(GltfExport, EncodePngDropsAlphaOnlyWhenOpaque) {
  // PNG colour type is byte 25 of the file (IHDR): 2 = RGB, 6 = RGBA.
  auto opaque = encode_png(checker_image(4, true));
  ASSERT_TRUE(opaque.ok()) << opaque.status().message();
  ASSERT_GT(opaque->size(), 26u);
  EXPECT_EQ((*opaque)[25], 2);
  auto alpha = encode_png(checker_image(4, false));
  ASSERT_TRUE(alpha.ok()) << alpha.status().message();
  ASSERT_GT(alpha->size(), 26u);
  EXPECT_EQ((*alpha)[25], 6);
  EXPECT_FALSE(encode_png(Image{}).ok());
}

}  // namespace
}  // namespace meshmux
