#include "importers/gltf.h"

#include <gtest/gtest.h>

#include <cstring>
#include <nlohmann/json.hpp>

#include "core/process.h"
#include "image/encode.h"
#include "test_util.h"
#include "upload_fixtures.h"

namespace meshmux {
namespace {

using nlohmann::json;
using testing::TempDir;

std::string base64(const std::vector<uint8_t>& in) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    uint32_t v = uint32_t(in[i]) << 16 | uint32_t(in[i + 1]) << 8 | in[i + 2];
    out += {t[v >> 18], t[(v >> 12) & 63], t[(v >> 6) & 63], t[v & 63]};
  }
  if (i + 1 == in.size()) {
    uint32_t v = uint32_t(in[i]) << 16;
    out += {t[v >> 18], t[(v >> 12) & 63], '=', '='};
  } else if (i + 2 == in.size()) {
    uint32_t v = uint32_t(in[i]) << 16 | uint32_t(in[i + 1]) << 8;
    out += {t[v >> 18], t[(v >> 12) & 63], t[(v >> 6) & 63], '='};
  }
  return out;
}

// Appends plain values to a byte blob, returning the offset they start at.
struct Blob {
  std::vector<uint8_t> bytes;
  template <class T>
  size_t add(std::initializer_list<T> values) {
    while (bytes.size() % 4) bytes.push_back(0);
    size_t at = bytes.size();
    for (T v : values) {
      uint8_t b[sizeof(T)];
      std::memcpy(b, &v, sizeof(T));
      bytes.insert(bytes.end(), b, b + sizeof(T));
    }
    return at;
  }
};

// A .gltf with one data-URI buffer holding `blob`.
std::string write_gltf(const TempDir& dir, const std::string& name, json doc, const Blob& blob) {
  doc["asset"] = {{"version", "2.0"}};
  doc["buffers"] =
      json::array({{{"byteLength", blob.bytes.size()},
                    {"uri", "data:application/octet-stream;base64," + base64(blob.bytes)}}});
  std::string path = dir.file(name);
  testing::write_text(path, doc.dump());
  return path;
}

// One triangle: positions at offset 0 (36 bytes), indices at 36 (6 bytes).
// A 1x1 red PNG, inlined as a data URI (one made by the exporter's encoder would pull in
// another module).
const std::vector<uint8_t> kRedPixelPng = {
    0x89, 0x50, 0x4E, 0x47, 0x0D, 0x0A, 0x1A, 0x0A, 0x00, 0x00, 0x00, 0x0D, 0x49, 0x48,
    0x44, 0x52, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x01, 0x08, 0x02, 0x00, 0x00,
    0x00, 0x90, 0x77, 0x53, 0xDE, 0x00, 0x00, 0x00, 0x0C, 0x49, 0x44, 0x41, 0x54, 0x08,
    0xD7, 0x63, 0xF8, 0xCF, 0xC0, 0x00, 0x00, 0x03, 0x01, 0x01, 0x00, 0x18, 0xDD, 0x8D,
    0xB0, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4E, 0x44, 0xAE, 0x42, 0x60, 0x82};

json triangle_doc(const Blob& blob, size_t pos_at, size_t idx_at) {
  return {{"bufferViews",
           {{{"buffer", 0}, {"byteOffset", pos_at}, {"byteLength", 36}},
            {{"buffer", 0}, {"byteOffset", idx_at}, {"byteLength", 6}}}},
          {"accessors",
           {{{"bufferView", 0},
             {"componentType", 5126},
             {"count", 3},
             {"type", "VEC3"},
             {"min", {0, 0, 0}},
             {"max", {1, 1, 0}}},
            {{"bufferView", 1}, {"componentType", 5123}, {"count", 3}, {"type", "SCALAR"}}}},
          {"meshes", {{{"primitives", {{{"attributes", {{"POSITION", 0}}}, {"indices", 1}}}}}}},
          {"nodes", {{{"mesh", 0}}}},
          {"scenes", {{{"nodes", {0}}}}},
          {"scene", 0}};
}

Blob triangle_blob(size_t* pos_at, size_t* idx_at) {
  Blob b;
  *pos_at = b.add<float>({0, 0, 0, 1, 0, 0, 0, 1, 0});
  *idx_at = b.add<uint16_t>({0, 1, 2});
  return b;
}

// The simplest valid file: the baseline every other case varies.
TEST(GltfImport, ReadsOneTriangle) {
  TempDir dir;
  size_t p, i;
  Blob b = triangle_blob(&p, &i);
  std::string path = write_gltf(dir, "tri.gltf", triangle_doc(b, p, i), b);
  Warnings w;
  auto s = import_gltf(path, {}, &w);
  ASSERT_TRUE(s.ok()) << s.status().message();
  ASSERT_EQ(s->meshes.size(), 1u);
  ASSERT_EQ(s->instances.size(), 1u);
  const Primitive& prim = s->meshes[0].primitives[0];
  EXPECT_EQ(prim.indices, (std::vector<uint32_t>{0, 1, 2}));
  EXPECT_FLOAT_EQ(prim.positions[1].x, 1);
}

// Interleaved vertex data (byteStride) with normalized unsigned-byte colours and
// unsigned-short uvs: exporters like this layout and it must decode exactly.
TEST(GltfImport, ReadsInterleavedNormalizedAttributes) {
  TempDir dir;
  Blob b;
  // Per vertex: float3 position (12) + ushort2 uv (4) + ubyte4 colour (4) = 20 bytes.
  std::vector<uint8_t> v;
  auto put = [&](const void* d, size_t n) {
    v.insert(v.end(), static_cast<const uint8_t*>(d), static_cast<const uint8_t*>(d) + n);
  };
  for (int k = 0; k < 3; ++k) {
    float pos[3] = {float(k == 1), float(k == 2), 0};
    uint16_t uv[2] = {uint16_t(k == 1 ? 65535 : 0), uint16_t(k == 2 ? 32768 : 0)};
    uint8_t col[4] = {255, uint8_t(k * 100), 0, 255};
    put(pos, 12), put(uv, 4), put(col, 4);
  }
  b.bytes = v;
  json doc = {
      {"bufferViews", {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 60}, {"byteStride", 20}}}},
      {"accessors",
       {{{"bufferView", 0},
         {"byteOffset", 0},
         {"componentType", 5126},
         {"count", 3},
         {"type", "VEC3"},
         {"min", {0, 0, 0}},
         {"max", {1, 1, 0}}},
        {{"bufferView", 0},
         {"byteOffset", 12},
         {"componentType", 5123},
         {"normalized", true},
         {"count", 3},
         {"type", "VEC2"}},
        {{"bufferView", 0},
         {"byteOffset", 16},
         {"componentType", 5121},
         {"normalized", true},
         {"count", 3},
         {"type", "VEC4"}}}},
      {"meshes",
       {{{"primitives",
          {{{"attributes", {{"POSITION", 0}, {"TEXCOORD_0", 1}, {"COLOR_0", 2}}}}}}}}},
      {"nodes", {{{"mesh", 0}}}}};
  std::string path = write_gltf(dir, "interleaved.gltf", doc, b);
  auto s = import_gltf(path, {}, nullptr);
  ASSERT_TRUE(s.ok()) << s.status().message();
  const Primitive& prim = s->meshes[0].primitives[0];
  ASSERT_EQ(prim.vertex_count(), 3u);
  EXPECT_FLOAT_EQ(prim.positions[2].y, 1);
  EXPECT_FLOAT_EQ(prim.uvs[0][1].x, 1.0f);
  EXPECT_NEAR(prim.uvs[0][2].y, 32768 / 65535.0f, 1e-6);
  EXPECT_NEAR(prim.colors[1].y, 100 / 255.0f, 1e-6);
  // No indices: vertices are taken in order.
  EXPECT_EQ(prim.indices, (std::vector<uint32_t>{0, 1, 2}));
}

// Sparse accessors substitute a few elements; morph-target-free files use them too.
TEST(GltfImport, AppliesSparseSubstitution) {
  TempDir dir;
  size_t p, i;
  Blob b = triangle_blob(&p, &i);
  size_t sp_idx = b.add<uint16_t>({2, 0});
  size_t sp_val = b.add<float>({5, 6, 7});
  json doc = triangle_doc(b, p, i);
  doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", sp_idx}, {"byteLength", 2}});
  doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", sp_val}, {"byteLength", 12}});
  doc["accessors"][0]["sparse"] = {{"count", 1},
                                   {"indices", {{"bufferView", 2}, {"componentType", 5123}}},
                                   {"values", {{"bufferView", 3}}}};
  doc["accessors"][0]["max"] = {5, 6, 7};
  std::string path = write_gltf(dir, "sparse.gltf", doc, b);
  auto s = import_gltf(path, {}, nullptr);
  ASSERT_TRUE(s.ok()) << s.status().message();
  Vec3 v = s->meshes[0].primitives[0].positions[2];
  EXPECT_EQ(v, (Vec3{5, 6, 7}));
}

// A mesh referenced by two nodes stays one mesh; transforms compose down the hierarchy.
TEST(GltfImport, SharedMeshStaysSharedAndTransformsCompose) {
  TempDir dir;
  size_t p, i;
  Blob b = triangle_blob(&p, &i);
  json doc = triangle_doc(b, p, i);
  doc["nodes"] = {{{"children", {1, 2}}, {"translation", {10, 0, 0}}},
                  {{"mesh", 0}, {"scale", {2, 2, 2}}},
                  {{"mesh", 0}, {"translation", {0, 5, 0}}}};
  std::string path = write_gltf(dir, "shared.gltf", doc, b);
  auto s = import_gltf(path, {}, nullptr);
  ASSERT_TRUE(s.ok()) << s.status().message();
  EXPECT_EQ(s->meshes.size(), 1u);
  ASSERT_EQ(s->instances.size(), 2u);
  Vec3 a = s->instances[0].world.transform_point({1, 0, 0});
  Vec3 c = s->instances[1].world.transform_point({1, 0, 0});
  EXPECT_EQ(a, (Vec3{12, 0, 0}));
  EXPECT_EQ(c, (Vec3{11, 5, 0}));
}

// EXT_mesh_gpu_instancing: one node, many instances.
TEST(GltfImport, ExpandsGpuInstancing) {
  TempDir dir;
  size_t p, i;
  Blob b = triangle_blob(&p, &i);
  size_t t = b.add<float>({0, 0, 0, 3, 0, 0, 6, 0, 0});
  json doc = triangle_doc(b, p, i);
  doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", t}, {"byteLength", 36}});
  doc["accessors"].push_back(
      {{"bufferView", 2}, {"componentType", 5126}, {"count", 3}, {"type", "VEC3"}});
  doc["nodes"][0]["extensions"] = {
      {"EXT_mesh_gpu_instancing", {{"attributes", {{"TRANSLATION", 2}}}}}};
  doc["extensionsUsed"] = {"EXT_mesh_gpu_instancing"};
  std::string path = write_gltf(dir, "inst.gltf", doc, b);
  auto s = import_gltf(path, {}, nullptr);
  ASSERT_TRUE(s.ok()) << s.status().message();
  ASSERT_EQ(s->instances.size(), 3u);
  EXPECT_EQ(s->instances[2].world.transform_point({0, 0, 0}), (Vec3{6, 0, 0}));
}

// KHR_mesh_quantization: integer positions (here int16, not normalized) and byte normals
// (normalized) are legal and must come out as the floats they stand for.
TEST(GltfImport, ReadsQuantizedAttributes) {
  TempDir dir;
  Blob b;
  size_t p = b.add<int16_t>({0, 0, 0, 0, 1000, 0, 0, 0, 0, 1000, 0, 0});  // VEC3 padded to 8 bytes
  size_t n = b.add<int8_t>({0, 0, 127, 0, 0, 0, 127, 0, 0, 0, 127, 0});
  size_t i = b.add<uint16_t>({0, 1, 2});
  json doc = {
      {"extensionsUsed", {"KHR_mesh_quantization"}},
      {"extensionsRequired", {"KHR_mesh_quantization"}},
      {"bufferViews",
       {{{"buffer", 0}, {"byteOffset", p}, {"byteLength", 24}, {"byteStride", 8}},
        {{"buffer", 0}, {"byteOffset", n}, {"byteLength", 12}, {"byteStride", 4}},
        {{"buffer", 0}, {"byteOffset", i}, {"byteLength", 6}}}},
      {"accessors",
       {{{"bufferView", 0},
         {"componentType", 5122},
         {"count", 3},
         {"type", "VEC3"},
         {"min", {0, 0, 0}},
         {"max", {1000, 1000, 0}}},
        {{"bufferView", 1},
         {"componentType", 5120},
         {"normalized", true},
         {"count", 3},
         {"type", "VEC3"}},
        {{"bufferView", 2}, {"componentType", 5123}, {"count", 3}, {"type", "SCALAR"}}}},
      {"meshes",
       {{{"primitives", {{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}}}, {"indices", 2}}}}}}},
      {"nodes", {{{"mesh", 0}, {"scale", {0.001, 0.001, 0.001}}}}}};
  std::string path = write_gltf(dir, "quant.gltf", doc, b);
  auto s = import_gltf(path, {}, nullptr);
  ASSERT_TRUE(s.ok()) << s.status().message();
  const Primitive& prim = s->meshes[0].primitives[0];
  EXPECT_EQ(prim.positions[1], (Vec3{1000, 0, 0}));
  EXPECT_EQ(prim.normals[2], (Vec3{0, 0, 1}));
  Vec3 world = s->instances[0].world.transform_point(prim.positions[2]);
  EXPECT_NEAR(world.y, 1.0f, 1e-6);
}

// Points and lines are carried beside the triangles (MeshPrimitiveModes lost two thirds of its
// coverage, IoU 0.66, when they were skipped): a LINE_STRIP and a LINE_LOOP over the
// triangle's three vertices, and POINTS, placed by their node (here moved 5 along x), in their
// material's colour; the triangle stays a mesh.
TEST(GltfImport, PointsAndLinesAreCarried) {
  TempDir dir;
  size_t p, i;
  Blob b = triangle_blob(&p, &i);
  json doc = triangle_doc(b, p, i);
  auto& prims = doc["meshes"][0]["primitives"];
  prims.push_back({{"attributes", {{"POSITION", 0}}}, {"mode", 3}, {"material", 0}});
  prims.push_back({{"attributes", {{"POSITION", 0}}}, {"mode", 2}});
  prims.push_back({{"attributes", {{"POSITION", 0}}}, {"mode", 0}});
  doc["materials"] = {{{"pbrMetallicRoughness", {{"baseColorFactor", {1, 0, 0, 1}}}}}};
  doc["nodes"][0]["translation"] = {5, 0, 0};
  auto s = import_gltf(write_gltf(dir, "lines.gltf", doc, b), {}, nullptr);
  ASSERT_TRUE(s.ok()) << s.status().message();
  ASSERT_EQ(s->meshes.size(), 1u);
  ASSERT_EQ(s->lines.size(), 3u);
  const LineSet& strip = s->lines[0];
  EXPECT_FALSE(strip.points);
  EXPECT_EQ(strip.indices, (std::vector<uint32_t>{0, 1, 1, 2}));
  EXPECT_EQ(strip.positions[1], (Vec3{6, 0, 0}));
  EXPECT_EQ(strip.color, (Vec4{1, 0, 0, 1}));
  EXPECT_EQ(s->lines[1].indices, (std::vector<uint32_t>{0, 1, 1, 2, 2, 0}));
  EXPECT_TRUE(s->lines[2].points);
  EXPECT_EQ(s->lines[2].indices, (std::vector<uint32_t>{0, 1, 2}));
}

// Triangle strips are unrolled with alternating winding so every face keeps its front.
TEST(GltfImport, UnrollsTriangleStrips) {
  TempDir dir;
  Blob b;
  size_t p = b.add<float>({0, 0, 0, 0, 1, 0, 1, 0, 0, 1, 1, 0});
  json doc = {{"bufferViews", {{{"buffer", 0}, {"byteOffset", p}, {"byteLength", 48}}}},
              {"accessors",
               {{{"bufferView", 0},
                 {"componentType", 5126},
                 {"count", 4},
                 {"type", "VEC3"},
                 {"min", {0, 0, 0}},
                 {"max", {1, 1, 0}}}}},
              {"meshes", {{{"primitives", {{{"attributes", {{"POSITION", 0}}}, {"mode", 5}}}}}}},
              {"nodes", {{{"mesh", 0}}}}};
  std::string path = write_gltf(dir, "strip.gltf", doc, b);
  auto s = import_gltf(path, {}, nullptr);
  ASSERT_TRUE(s.ok()) << s.status().message();
  EXPECT_EQ(s->meshes[0].primitives[0].indices, (std::vector<uint32_t>{0, 1, 2, 2, 1, 3}));
}

// The layers' textures are carried as they came (the atlas keeps such a material beside it,
// atlas/kept.h): folding them into their factors lost a glass's pattern (a hurricane glass lit
// 13.8 dB) and a wicker's clearcoat relief (lit 23.9 dB). Each keeps its uv set, its transform
// and, for the clearcoat's normal map, its scale; the factors stay glTF's.
TEST(GltfImport, LayerTexturesAreCarried) {
  TempDir dir;
  size_t p, i;
  Blob b = triangle_blob(&p, &i);
  json doc = triangle_doc(b, p, i);
  doc["images"] = {{{"uri", "data:image/png;base64," + base64(kRedPixelPng)}},
                   {{"uri", "data:image/png;base64," + base64(testing::kPng)}}};
  doc["textures"] = {{{"source", 0}}, {{"source", 1}}};
  doc["extensionsUsed"] = {"KHR_materials_transmission", "KHR_materials_volume",
                           "KHR_materials_clearcoat", "KHR_materials_anisotropy",
                           "KHR_texture_transform"};
  json moved = {{"index", 1},
                {"texCoord", 1},
                {"extensions", {{"KHR_texture_transform", {{"offset", {0.5, 0}}}}}}};
  doc["materials"] = {
      {{"extensions",
        {{"KHR_materials_transmission",
          {{"transmissionFactor", 0.8}, {"transmissionTexture", {{"index", 0}}}}},
         {"KHR_materials_volume", {{"thicknessFactor", 2}, {"thicknessTexture", {{"index", 0}}}}},
         {"KHR_materials_clearcoat",
          {{"clearcoatFactor", 1},
           {"clearcoatRoughnessTexture", moved},
           {"clearcoatNormalTexture", {{"index", 1}, {"scale", 0.5}}}}},
         {"KHR_materials_anisotropy",
          {{"anisotropyStrength", 0.6},
           {"anisotropyRotation", 1.5},
           {"anisotropyTexture", {{"index", 1}}}}}}}}};
  doc["meshes"][0]["primitives"][0]["material"] = 0;
  Warnings w;
  auto s = import_gltf(write_gltf(dir, "layers.gltf", doc, b), {}, &w);
  ASSERT_TRUE(s.ok()) << s.status().message();
  const Material& m = s->materials[0];
  EXPECT_FLOAT_EQ(m.transmission_factor, 0.8f);
  EXPECT_FLOAT_EQ(m.thickness_factor, 2.0f);
  EXPECT_TRUE(m.transmission.present());
  EXPECT_TRUE(m.layer(LayerSlot::kThickness).present());
  const TextureRef& rough = m.layer(LayerSlot::kClearcoatRoughness);
  ASSERT_TRUE(rough.present());
  EXPECT_EQ(rough.tex_coord, 1u);
  EXPECT_FLOAT_EQ(rough.transform.offset[0], 0.5f);
  const TextureRef& normal = m.layer(LayerSlot::kClearcoatNormal);
  ASSERT_TRUE(normal.present());
  EXPECT_FLOAT_EQ(normal.scale, 0.5f);
  EXPECT_FALSE(m.layer(LayerSlot::kClearcoat).present());
  EXPECT_FLOAT_EQ(m.anisotropy_strength, 0.6f);
  EXPECT_FLOAT_EQ(m.anisotropy_rotation, 1.5f);
  EXPECT_TRUE(m.layer(LayerSlot::kAnisotropy).present());
  for (const std::string& text : w.items())
    EXPECT_EQ(text.find("not carried"), std::string::npos) << text;
}

// Anisotropy without a normal map: glTF takes its tangent space from TANGENT (not written by
// meshmux) or along a normal texture's uvs, so a flat 1 × 1 normal map stands in (the lit
// AnisotropyStrengthTest fell to 24.3 dB when the extension was left out instead).
TEST(GltfImport, AnisotropyWithoutNormalMapGetsAFlatOne) {
  TempDir dir;
  size_t p, i;
  Blob b = triangle_blob(&p, &i);
  json doc = triangle_doc(b, p, i);
  doc["extensionsUsed"] = {"KHR_materials_anisotropy"};
  doc["materials"] = {
      {{"extensions", {{"KHR_materials_anisotropy", {{"anisotropyStrength", 0.5}}}}}},
      {{"extensions", {{"KHR_materials_anisotropy", {{"anisotropyStrength", 0.2}}}}}}};
  doc["meshes"][0]["primitives"][0]["material"] = 0;
  auto s = import_gltf(write_gltf(dir, "aniso.gltf", doc, b), {}, nullptr);
  ASSERT_TRUE(s.ok()) << s.status().message();
  ASSERT_EQ(s->materials.size(), 2u);
  const TextureRef& n = s->materials[0].normal;
  ASSERT_TRUE(n.present());
  EXPECT_EQ(s->materials[1].normal.image, n.image) << "one flat map for all";
  const Image& flat = s->images[size_t(n.image)];
  EXPECT_EQ(flat.width, 1);
  EXPECT_EQ(flat.rgba, (std::vector<uint8_t>{128, 128, 255, 255}));
}

// Anisotropy's direction is tangent-space, and the bitangent glTF builds from TANGENT (up the
// image) is the mirror of the one viewers derive from the uvs without it (along +v). meshmux
// writes no TANGENT, so a primitive that came with one must get its material's direction
// mirrored: rotation negated, the texture's y (G) flipped. AnisotropyRotationTest's rotated
// highlights turned the other way without it (lit 19.3 dB). A material also drawn without
// TANGENT keeps the direction as it came there, through a mirrored copy for the other.
TEST(GltfImport, AnisotropyDirectionFollowsTheTangentFrameWrittenOut) {
  TempDir dir;
  size_t p, i;
  Blob b = triangle_blob(&p, &i);
  const size_t t = b.add<float>({1, 0, 0, 1, 1, 0, 0, 1, 1, 0, 0, 1});
  json doc = triangle_doc(b, p, i);
  doc["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", t}, {"byteLength", 48}});
  doc["accessors"].push_back(
      {{"bufferView", 2}, {"componentType", 5126}, {"count", 3}, {"type", "VEC4"}});
  json with = doc["meshes"][0];
  with["primitives"][0]["attributes"]["TANGENT"] = 2;
  with["primitives"][0]["material"] = 0;
  doc["meshes"][0]["primitives"][0]["material"] = 0;
  doc["meshes"].push_back(with);
  doc["nodes"].push_back({{"mesh", 1}});
  doc["scenes"][0]["nodes"] = {0, 1};
  doc["images"] = {{{"uri", "data:image/png;base64," + base64(testing::kPng)}}};
  doc["textures"] = {{{"source", 0}}};
  doc["extensionsUsed"] = {"KHR_materials_anisotropy"};
  doc["materials"] = {{{"extensions",
                        {{"KHR_materials_anisotropy",
                          {{"anisotropyStrength", 0.5},
                           {"anisotropyRotation", 0.5},
                           {"anisotropyTexture", {{"index", 0}}}}}}}}};
  auto s = import_gltf(write_gltf(dir, "aniso_tangent.gltf", doc, b), {}, nullptr);
  ASSERT_TRUE(s.ok()) << s.status().message();
  ASSERT_EQ(s->meshes.size(), 2u);
  const Material& plain = s->materials[size_t(s->meshes[0].primitives[0].material)];
  const Material& tangent = s->materials[size_t(s->meshes[1].primitives[0].material)];
  EXPECT_FLOAT_EQ(plain.anisotropy_rotation, 0.5f) << "no TANGENT: the derived frame, as it came";
  EXPECT_FLOAT_EQ(tangent.anisotropy_rotation, -0.5f);
  EXPECT_FLOAT_EQ(tangent.anisotropy_strength, 0.5f);
  const Image& src = s->images[size_t(plain.layer(LayerSlot::kAnisotropy).image)];
  const Image& mirrored = s->images[size_t(tangent.layer(LayerSlot::kAnisotropy).image)];
  ASSERT_TRUE(src.decoded());
  ASSERT_EQ(mirrored.rgba.size(), src.rgba.size());
  for (size_t k = 0; k < src.rgba.size(); ++k)
    EXPECT_EQ(mirrored.rgba[k], k % 4 == 1 ? 255 - src.rgba[k] : src.rgba[k]) << k;
}

// KHR_texture_transform must be carried to the material so the atlas can honour it.
TEST(GltfImport, ReadsTextureTransform) {
  TempDir dir;
  size_t p, i;
  Blob b = triangle_blob(&p, &i);
  json doc = triangle_doc(b, p, i);
  doc["images"] = {{{"uri", "data:image/png;base64," + base64(kRedPixelPng)}}};
  doc["textures"] = {{{"source", 0}}};
  json transform = {{"offset", {0.5, 0.25}}, {"scale", {2, 3}}, {"rotation", 0.5}};
  json info = {{"index", 0}, {"extensions", {{"KHR_texture_transform", transform}}}};
  json material;
  material["pbrMetallicRoughness"]["baseColorTexture"] = info;
  doc["materials"] = json::array({material});
  doc["meshes"][0]["primitives"][0]["material"] = 0;
  doc["extensionsUsed"] = {"KHR_texture_transform"};
  std::string path = write_gltf(dir, "tt.gltf", doc, b);
  Warnings w;
  auto s = import_gltf(path, {}, &w);
  ASSERT_TRUE(s.ok()) << s.status().message();
  const TextureRef& t = s->materials[0].base_color;
  ASSERT_TRUE(t.present());
  EXPECT_FLOAT_EQ(t.transform.offset[0], 0.5f);
  EXPECT_FLOAT_EQ(t.transform.scale[1], 3.0f);
  EXPECT_FLOAT_EQ(t.transform.rotation, 0.5f);
  ASSERT_TRUE(s->images[0].decoded()) << (w.empty() ? "" : w.items()[0]);
  EXPECT_EQ(s->images[0].rgba[0], 255);  // red
}

// Bad input: an accessor reaching past its buffer must be refused with a message naming the
// file, the mesh, the primitive and the accessor.
TEST(GltfImport, AccessorOutOfBoundsIsAnError) {
  TempDir dir;
  size_t p, i;
  Blob b = triangle_blob(&p, &i);
  json doc = triangle_doc(b, p, i);
  doc["accessors"][0]["count"] = 300;
  std::string path = write_gltf(dir, "oob.gltf", doc, b);
  auto s = import_gltf(path, {}, nullptr);
  ASSERT_FALSE(s.ok());
  const std::string& m = s.status().message();
  EXPECT_NE(m.find("oob.gltf"), std::string::npos) << m;
  EXPECT_NE(m.find("mesh 0 primitive 0"), std::string::npos) << m;
  EXPECT_NE(m.find("accessor 0"), std::string::npos) << m;
  EXPECT_NE(m.find("out of bounds"), std::string::npos) << m;
}

TEST(GltfImport, IndexOutOfRangeIsAnError) {
  TempDir dir;
  size_t p, i;
  Blob b;
  p = b.add<float>({0, 0, 0, 1, 0, 0, 0, 1, 0});
  i = b.add<uint16_t>({0, 1, 7});
  std::string path = write_gltf(dir, "badindex.gltf", triangle_doc(b, p, i), b);
  auto s = import_gltf(path, {}, nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().message().find("index 7 out of range"), std::string::npos)
      << s.status().message();
}

TEST(GltfImport, UnknownRequiredExtensionIsAnError) {
  TempDir dir;
  size_t p, i;
  Blob b = triangle_blob(&p, &i);
  json doc = triangle_doc(b, p, i);
  doc["extensionsUsed"] = {"EXT_made_up"};
  doc["extensionsRequired"] = {"EXT_made_up"};
  std::string path = write_gltf(dir, "ext.gltf", doc, b);
  auto s = import_gltf(path, {}, nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().message().find("required extension EXT_made_up is not supported"),
            std::string::npos)
      << s.status().message();
}

// An image whose bytes do not decode: a warning, the material keeps its factor, the import
// succeeds.
TEST(GltfImport, UndecodableImageIsAWarning) {
  TempDir dir;
  size_t p, i;
  Blob b = triangle_blob(&p, &i);
  json doc = triangle_doc(b, p, i);
  testing::write_text(dir.file("broken.png"), "\x89PNG\r\n\x1a\nthis is not a png");
  doc["images"] = {{{"uri", "broken.png"}}};
  doc["textures"] = {{{"source", 0}}};
  json material;
  material["pbrMetallicRoughness"]["baseColorFactor"] = {0.2, 0.4, 0.6, 1};
  material["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 0}};
  doc["materials"] = json::array({material});
  doc["meshes"][0]["primitives"][0]["material"] = 0;
  std::string path = write_gltf(dir, "img.gltf", doc, b);
  Warnings w;
  auto s = import_gltf(path, {}, &w);
  ASSERT_TRUE(s.ok()) << s.status().message();
  ASSERT_FALSE(w.empty());
  EXPECT_NE(w.items()[0].find("broken.png"), std::string::npos) << w.items()[0];
  EXPECT_FALSE(s->materials[0].base_color.present());
  EXPECT_FLOAT_EQ(s->materials[0].base_color_factor.y, 0.4f);
}

TEST(GltfImport, MissingFileIsAnError) {
  auto s = import_gltf("/nonexistent/dir/model.glb", {}, nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().message().find("model.glb: no such file"), std::string::npos)
      << s.status().message();
}

TEST(GltfImport, EmptyFileIsAnError) {
  TempDir dir;
  testing::write_text(dir.file("empty.gltf"), "");
  auto s = import_gltf(dir.file("empty.gltf"), {}, nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().message().find("empty.gltf: file is empty"), std::string::npos)
      << s.status().message();
}

// A .glb cut in half (an interrupted upload) must be refused, not read past its end.
TEST(GltfImport, TruncatedGlbIsAnError) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  auto bytes = testing::read_file(testing::shared_model("DamagedHelmet-glb/DamagedHelmet.glb"));
  ASSERT_GT(bytes.size(), 1000u);
  bytes.resize(bytes.size() / 2);
  TempDir dir;
  testing::write_file(dir.file("half.glb"), bytes);
  auto s = import_gltf(dir.file("half.glb"), {}, nullptr);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.status().message().find("half.glb"), std::string::npos) << s.status().message();
  EXPECT_NE(s.status().message().find("truncated"), std::string::npos) << s.status().message();
}

// Real files: their known instancing counts.
TEST(GltfImport, SharedModelCylinderEngineKeepsInstancing) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  auto s =
      import_gltf(testing::shared_model("2CylinderEngine-glb/2CylinderEngine.glb"), {}, nullptr);
  ASSERT_TRUE(s.ok()) << s.status().message();
  SceneStats st = compute_stats(*s);
  EXPECT_EQ(st.meshes, 29u);
  EXPECT_EQ(st.instances, 67u);
  EXPECT_EQ(st.scene_triangles, 121496u);
  EXPECT_EQ(st.unique_triangles, 75730u);
}

TEST(GltfImport, SharedModelSimpleInstancingHas125Instances) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  auto s = import_gltf(testing::shared_model("SimpleInstancing-gltf/SimpleInstancing.gltf"), {},
                       nullptr);
  ASSERT_TRUE(s.ok()) << s.status().message();
  SceneStats st = compute_stats(*s);
  EXPECT_EQ(st.meshes, 1u);
  EXPECT_EQ(st.instances, 125u);
  EXPECT_EQ(st.scene_triangles, 1500u);
}

TEST(GltfImport, SharedModelHelmetDecodesEmbeddedJpegs) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  auto s = import_gltf(testing::shared_model("DamagedHelmet-glb/DamagedHelmet.glb"), {}, nullptr);
  ASSERT_TRUE(s.ok()) << s.status().message();
  SceneStats st = compute_stats(*s);
  EXPECT_EQ(st.scene_triangles, 15452u);
  EXPECT_EQ(st.textures, 5u);
  EXPECT_EQ(st.texture_pixels, 5u * 2048u * 2048u);
}

// EXT_texture_webp (required, WebP-only textures) was once refused. The texture's WebP source now
// decodes: the duck has its 512² texture and one textured material.
TEST(GltfImport, SharedModelWebpTexturesDecode) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  auto s = import_gltf(testing::shared_model("Duck-webp-gltf/Duck.gltf"), {}, nullptr);
  ASSERT_TRUE(s.ok()) << s.status().message();
  SceneStats st = compute_stats(*s);
  EXPECT_EQ(st.scene_triangles, 4212u);
  ASSERT_EQ(s->materials.size(), 1u);
  ASSERT_TRUE(s->materials[0].base_color.present());
  const Image& img = s->images[size_t(s->materials[0].base_color.image)];
  EXPECT_TRUE(img.decoded());
  EXPECT_EQ(img.mime_type, "image/webp");
  EXPECT_EQ(img.width * img.height, 512 * 512);
}

// gltfpack output (EXT_meshopt_compression + KHR_mesh_quantization) was once refused ("Invalid
// byteLength"). Decoded, it is the same fox as the plain file: same triangles and, to the
// quantization's precision, the same bounds.
TEST(GltfImport, SharedModelMeshoptFoxMatchesThePlainFox) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  Warnings w;
  auto packed = import_gltf(testing::shared_model("Fox-meshopt-glb/Fox.glb"), {}, &w);
  ASSERT_TRUE(packed.ok()) << packed.status().message();
  auto plain = import_gltf(testing::shared_model("Fox-glb/Fox.glb"), {}, nullptr);
  ASSERT_TRUE(plain.ok()) << plain.status().message();
  EXPECT_EQ(compute_stats(*packed).scene_triangles, compute_stats(*plain).scene_triangles);
  Bounds a = scene_bounds(*packed), b = scene_bounds(*plain);
  float tolerance = 0.002f * b.diagonal();
  EXPECT_NEAR(a.min.x, b.min.x, tolerance);
  EXPECT_NEAR(a.min.y, b.min.y, tolerance);
  EXPECT_NEAR(a.max.z, b.max.z, tolerance);
  EXPECT_NEAR(a.max.y, b.max.y, tolerance);
}

// A glTF naming one KTX2 image (t.ktx2) for its only material's base colour: through
// KHR_texture_basisu (required, no core source) or through the texture's core source (the
// corpus's lamp does so).
std::string ktx2_gltf(bool through_extension) {
  const std::string texture = through_extension
                                  ? R"({"extensions": {"KHR_texture_basisu": {"source": 0}}})"
                                  : R"({"source": 0})";
  return std::string(R"({
    "asset": {"version": "2.0"},
    "extensionsUsed": ["KHR_texture_basisu"],)") +
         (through_extension ? R"("extensionsRequired": ["KHR_texture_basisu"],)" : "") + R"(
    "images": [{"uri": "t.ktx2", "mimeType": "image/ktx2"}],
    "textures": [)" +
         texture + R"(],
    "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
    "meshes": [], "nodes": [], "scenes": [{"nodes": []}], "scene": 0})";
}

// A KTX2 texture was once a refusal of the whole model. A damaged one (here cut inside its
// header) now drops that texture alone with one warning naming the file, the image and the
// fault, both ways a glTF names it; the model imports. (No node needed: the header is checked
// first.)
TEST(GltfImport, DamagedKtx2TextureIsDroppedWithOneWarning) {
  TempDir dir;
  std::vector<uint8_t> cut = testing::ktx2_shell();
  cut.resize(76);
  testing::write_file(dir.file("t.ktx2"), cut);
  for (bool through_extension : {true, false}) {
    testing::write_text(dir.file("k.gltf"), ktx2_gltf(through_extension));
    Warnings w;
    auto s = import_gltf(dir.file("k.gltf"), {}, &w);
    ASSERT_TRUE(s.ok()) << s.status().message();
    ASSERT_EQ(w.items().size(), 1u) << through_extension;
    const std::string& m = w.items()[0];
    EXPECT_NE(m.find("k.gltf"), std::string::npos) << m;
    EXPECT_NE(m.find("t.ktx2"), std::string::npos) << m;
    EXPECT_NE(m.find("truncated header"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    EXPECT_FALSE(s->materials[0].base_color.present());
  }
}

// Without node the KTX2 textures cannot be transcoded: one warning saying what to install (not
// one per image), the textures dropped, the model imported.
TEST(GltfImport, Ktx2WithoutNodeIsOneWarning) {
  TempDir dir;
  testing::write_file(dir.file("t.ktx2"), testing::ktx2_shell());
  testing::write_file(dir.file("u.ktx2"), testing::ktx2_shell());
  std::vector<uint8_t> cut = testing::ktx2_shell();  // its own fault is still said by name
  cut.resize(76);
  testing::write_file(dir.file("v.ktx2"), cut);
  testing::write_text(dir.file("k.gltf"), R"({
    "asset": {"version": "2.0"},
    "images": [{"uri": "t.ktx2"}, {"uri": "u.ktx2"}, {"uri": "v.ktx2"}],
    "textures": [{"source": 0}, {"source": 1}, {"source": 2}],
    "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}},
                   "emissiveTexture": {"index": 1}, "normalTexture": {"index": 2}}],
    "meshes": [], "nodes": [], "scenes": [{"nodes": []}], "scene": 0})");
  setenv("MESHMUX_NODE", "/nonexistent/node", 1);
  Warnings w;
  auto s = import_gltf(dir.file("k.gltf"), {}, &w);
  unsetenv("MESHMUX_NODE");
  ASSERT_TRUE(s.ok()) << s.status().message();
  ASSERT_EQ(w.items().size(), 2u);
  EXPECT_NE(w.items()[0].find("2 KTX2 image(s) not decoded"), std::string::npos) << w.items()[0];
  EXPECT_NE(w.items()[0].find("install Node.js"), std::string::npos) << w.items()[0];
  EXPECT_NE(w.items()[1].find("v.ktx2: KTX2: truncated header"), std::string::npos) << w.items()[1];
  EXPECT_FALSE(s->materials[0].base_color.present());
}

// A KHR_texture_basisu texture that also has a core source (a PNG fallback) shows the PNG, and
// the KTX2 is never read (a transcode saved): here it is garbage, and no warning follows.
TEST(GltfImport, Ktx2WithCoreFallbackReadsTheFallback) {
  TempDir dir;
  testing::write_text(dir.file("t.ktx2"), "not a ktx2");
  Image red;
  red.width = red.height = 2;
  red.rgba = {255, 0, 0, 255, 255, 0, 0, 255, 255, 0, 0, 255, 255, 0, 0, 255};
  auto png = encode_png(red);
  ASSERT_TRUE(png.ok());
  testing::write_file(dir.file("t.png"), *png);
  testing::write_text(dir.file("k.gltf"), R"({
    "asset": {"version": "2.0"}, "extensionsUsed": ["KHR_texture_basisu"],
    "images": [{"uri": "t.png"}, {"uri": "t.ktx2"}],
    "textures": [{"source": 0, "extensions": {"KHR_texture_basisu": {"source": 1}}}],
    "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
    "meshes": [], "nodes": [], "scenes": [{"nodes": []}], "scene": 0})");
  Warnings w;
  auto s = import_gltf(dir.file("k.gltf"), {}, &w);
  ASSERT_TRUE(s.ok()) << s.status().message();
  EXPECT_TRUE(w.items().empty()) << w.items()[0];
  ASSERT_TRUE(s->materials[0].base_color.present());
  EXPECT_EQ(s->images[size_t(s->materials[0].base_color.image)].mime_type, "image/png");
}

// The corpus's KTX2 model (UASTC KTX2 as its textures' core sources) was refused; it imports
// with its four 2048² maps decoded, in one transcoder run.
TEST(GltfImport, CorpusKtx2LampImportsWithItsMaps) {
  const std::string lamp = std::string(MESHMUX_SOURCE_DIR) +
                           "/../shared/corpus/AnisotropyBarnLamp-ktx2-gltf/AnisotropyBarnLamp.gltf";
  if (testing::read_file(lamp).empty()) GTEST_SKIP() << "../shared/corpus absent";
  if (find_program("node").empty()) GTEST_SKIP() << "node is not installed (KTX2 needs it)";
  Warnings w;
  auto s = import_gltf(lamp, {}, &w);
  ASSERT_TRUE(s.ok()) << s.status().message();
  for (const std::string& m : w.items()) EXPECT_EQ(m.find("KTX2"), std::string::npos) << m;
  int ktx2 = 0;  // the four maps (the importer may derive more images, e.g. anisotropy's)
  for (const Image& img : s->images) {
    if (img.mime_type != "image/ktx2") continue;
    ++ktx2;
    EXPECT_TRUE(img.decoded()) << img.name;
    EXPECT_EQ(img.width, 2048) << img.name;
  }
  EXPECT_EQ(ktx2, 4);
  EXPECT_TRUE(s->materials[0].base_color.present());
  EXPECT_TRUE(s->materials[0].normal.present());
}

// Material effects that do not survive conversion are said, once per extension with the
// number of materials, not silently dropped (dispersion); those that are carried (sheen,
// clearcoat even where the file lists it as required, anisotropy) are read without a word.
TEST(GltfImport, MaterialExtensionsWarnOncePerExtension) {
  TempDir dir;
  testing::write_text(dir.file("effects.gltf"), R"({
    "asset": {"version": "2.0"},
    "extensionsUsed": ["KHR_materials_sheen", "KHR_materials_clearcoat", "KHR_materials_anisotropy",
                       "KHR_materials_dispersion"],
    "extensionsRequired": ["KHR_materials_clearcoat"],
    "materials": [
      {"extensions": {"KHR_materials_sheen": {"sheenColorFactor": [1, 0, 0]},
                      "KHR_materials_dispersion": {"dispersion": 0.5}}},
      {"extensions": {"KHR_materials_sheen": {"sheenColorFactor": [0, 1, 0]},
                      "KHR_materials_dispersion": {"dispersion": 0.5}}},
      {"extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": 1, "clearcoatRoughnessFactor": 0.2},
                      "KHR_materials_anisotropy": {"anisotropyStrength": 0.5}}}],
    "meshes": [], "nodes": [], "scenes": [{"nodes": []}], "scene": 0})");
  Warnings w;
  auto s = import_gltf(dir.file("effects.gltf"), {}, &w);
  ASSERT_TRUE(s.ok()) << s.status().message();
  int dispersion = 0;
  for (const std::string& m : w.items()) {
    EXPECT_EQ(m.find("KHR_materials_sheen"), std::string::npos) << m;
    EXPECT_EQ(m.find("anisotropy"), std::string::npos) << m;
    EXPECT_EQ(m.find("clearcoat"), std::string::npos) << m;
    dispersion += m.find("KHR_materials_dispersion on 2 material(s)") != std::string::npos;
  }
  EXPECT_EQ(dispersion, 1);
  EXPECT_FLOAT_EQ(s->materials[2].anisotropy_strength, 0.5f);
  EXPECT_EQ(s->materials[0].sheen_color_factor, (Vec3{1, 0, 0}));
  EXPECT_EQ(s->materials[1].sheen_color_factor, (Vec3{0, 1, 0}));
  EXPECT_EQ(s->materials[2].sheen_color_factor, (Vec3{0, 0, 0}));
  EXPECT_FLOAT_EQ(s->materials[2].clearcoat_factor, 1);
  EXPECT_FLOAT_EQ(s->materials[2].clearcoat_roughness_factor, 0.2f);
}

// Morph targets show at their default weights, as a viewer shows the file without animation
// (a model at weight 0.5 came out at its base shape: 14-18 dB). The node's weights win over
// the mesh's.
TEST(GltfImport, MorphTargetsAtTheirDefaultWeights) {
  TempDir dir;
  const float data[18] = {0, 0, 0, 1, 0, 0, 0, 1, 0,   // the base triangle
                          0, 0, 2, 0, 0, 2, 0, 0, 2};  // target 0: +2 along z
  testing::write_file(dir.file("m.bin"),
                      std::vector<uint8_t>(reinterpret_cast<const uint8_t*>(data),
                                           reinterpret_cast<const uint8_t*>(data) + sizeof data));
  const std::string doc = R"({"asset":{"version":"2.0"},
    "buffers":[{"uri":"m.bin","byteLength":72}],
    "bufferViews":[{"buffer":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":36}],
    "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
                 {"bufferView":1,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,2],"max":[0,0,2]}],
    "meshes":[{"weights":[0.25],"primitives":[{"attributes":{"POSITION":0},"targets":[{"POSITION":1}]}]}],
    "nodes":[{"mesh":0 NODE_WEIGHTS}],"scenes":[{"nodes":[0]}],"scene":0})";
  for (const auto& [node_weights, z] :
       {std::pair{"", 0.5f}, std::pair{", \"weights\": [1]", 2.0f}}) {
    std::string text = doc;
    text.replace(text.find("NODE_WEIGHTS"), 12, node_weights);
    testing::write_text(dir.file("m.gltf"), text);
    Warnings w;
    auto s = import_gltf(dir.file("m.gltf"), {}, &w);
    ASSERT_TRUE(s.ok()) << s.status().message();
    ASSERT_EQ(s->meshes.size(), 1u);
    for (const Vec3& p : s->meshes[0].primitives[0].positions)
      EXPECT_FLOAT_EQ(p.z, z) << node_weights;
    EXPECT_TRUE(std::any_of(w.items().begin(), w.items().end(), [](const std::string& m) {
      return m.find("morph targets applied at their default weights") != std::string::npos;
    }));
  }
}

// A skinned mesh shows as its joints stand at rest, not in its bind pose (skinned characters
// came out elsewhere and in another pose: IoU 0.06-0.24), and the skinned node's own transform
// does not apply (glTF 2.0 §3.7.3). Weights are normalised as three.js's loader does.
TEST(GltfImport, SkinIsPosedAsItsJointsStand) {
  TempDir dir;
  struct {
    float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    uint8_t joints[12] = {0, 1, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0};
    float weights[12] = {2, 0, 0, 0, 0.5f, 0.5f, 0, 0, 1, 0, 0, 0};  // vertex 0 sums to 2
    float ibm[32] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1,
                     1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  } data;
  static_assert(sizeof data == 36 + 12 + 48 + 128);
  testing::write_file(dir.file("s.bin"),
                      std::vector<uint8_t>(reinterpret_cast<const uint8_t*>(&data),
                                           reinterpret_cast<const uint8_t*>(&data) + sizeof data));
  testing::write_text(dir.file("s.gltf"), R"({"asset":{"version":"2.0"},
    "buffers":[{"uri":"s.bin","byteLength":224}],
    "bufferViews":[{"buffer":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":12},
                   {"buffer":0,"byteOffset":48,"byteLength":48},{"buffer":0,"byteOffset":96,"byteLength":128}],
    "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
                 {"bufferView":1,"componentType":5121,"count":3,"type":"VEC4"},
                 {"bufferView":2,"componentType":5126,"count":3,"type":"VEC4"},
                 {"bufferView":3,"componentType":5126,"count":2,"type":"MAT4"}],
    "meshes":[{"primitives":[{"attributes":{"POSITION":0,"JOINTS_0":1,"WEIGHTS_0":2}}]}],
    "skins":[{"joints":[1,2],"inverseBindMatrices":3}],
    "nodes":[{"mesh":0,"skin":0,"translation":[100,100,100]},
             {"translation":[1,0,0]},{"translation":[0,2,0]}],
    "scenes":[{"nodes":[0,1,2]}],"scene":0})");
  Warnings w;
  auto s = import_gltf(dir.file("s.gltf"), {}, &w);
  ASSERT_TRUE(s.ok()) << s.status().message();
  ASSERT_EQ(s->meshes.size(), 1u) << "the unposed mesh is not kept beside the posed one";
  ASSERT_EQ(s->instances.size(), 1u);
  EXPECT_TRUE(s->instances[0].world.is_identity());
  const std::vector<Vec3>& p = s->meshes[s->instances[0].mesh].primitives[0].positions;
  EXPECT_EQ(p[0], (Vec3{1, 0, 0}));     // joint 0 alone (weights 2, 0 normalised)
  EXPECT_EQ(p[1], (Vec3{1.5f, 1, 0}));  // half of each: (2,0,0)/2 + (1,2,0)/2
  EXPECT_EQ(p[2], (Vec3{0, 3, 0}));     // joint 1 alone
  EXPECT_TRUE(std::any_of(w.items().begin(), w.items().end(), [](const std::string& m) {
    return m.find("1 skinned mesh node(s) posed as the joints stand at rest") != std::string::npos;
  }));
}

// Glass stays glass: transmission, ior and volume are read as they are, and the base colour's
// alpha is left alone (the old alpha × (1 − transmission) made a fully transmissive lamp shade
// invisible). Emissive strength is folded into the emissive factor. A transmission texture
// naming a texture that does not exist is dropped with a warning naming it.
TEST(GltfImport, TransmissionStaysGlassAndEmissiveStrengthIsFolded) {
  TempDir dir;
  testing::write_text(dir.file("glass.gltf"), R"({
    "asset": {"version": "2.0"},
    "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_emissive_strength",
                       "KHR_materials_ior", "KHR_materials_volume"],
    "extensionsRequired": ["KHR_materials_transmission"],
    "materials": [
      {"pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.6, 0.8]},
       "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1,
                                                     "transmissionTexture": {"index": 0}},
                      "KHR_materials_ior": {"ior": 1.33},
                      "KHR_materials_volume": {"thicknessFactor": 0.1, "attenuationDistance": 2,
                                               "attenuationColor": [1, 0.5, 0.25]}}},
      {"emissiveFactor": [1, 0.5, 0],
       "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4}}},
      {"extensions": {"KHR_materials_transmission": {}}}],
    "meshes": [], "nodes": [], "scenes": [{"nodes": []}], "scene": 0})");
  Warnings w;
  auto s = import_gltf(dir.file("glass.gltf"), {}, &w);
  ASSERT_TRUE(s.ok()) << s.status().message();
  ASSERT_EQ(s->materials.size(), 3u);
  const Material& glass = s->materials[0];
  EXPECT_EQ(glass.alpha_mode, AlphaMode::kOpaque);
  EXPECT_FLOAT_EQ(glass.base_color_factor.w, 0.8f);
  EXPECT_FLOAT_EQ(glass.transmission_factor, 1.0f);
  EXPECT_FLOAT_EQ(glass.ior, 1.33f);
  EXPECT_FLOAT_EQ(glass.thickness_factor, 0.1f);
  EXPECT_FLOAT_EQ(glass.attenuation_distance, 2.0f);
  EXPECT_EQ(glass.attenuation_color, (Vec3{1, 0.5f, 0.25f}));
  EXPECT_FLOAT_EQ(s->materials[1].emissive_factor.x, 4.0f);
  EXPECT_FLOAT_EQ(s->materials[1].emissive_factor.y, 2.0f);
  // transmissionFactor defaults to 0: nothing to see through.
  EXPECT_FALSE(s->materials[2].transmissive());
  EXPECT_EQ(s->materials[2].alpha_mode, AlphaMode::kOpaque);
  EXPECT_FALSE(glass.transmission.present());
  int said = 0;
  for (const std::string& m : w.items()) {
    said += m.find("transmissionTexture: texture 0 does not exist") != std::string::npos;
    EXPECT_EQ(m.find("approximated"), std::string::npos) << m;
  }
  EXPECT_EQ(said, 1);
}

// A primitive without NORMAL is flat-shaded by definition (glTF 3.7.2.1): the importer marks it so,
// and a primitive with normals is not marked.
TEST(GltfImport, SharedModelWithoutNormalsIsMarkedFlat) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  auto fox = import_gltf(testing::shared_model("Fox-glb/Fox.glb"), {}, nullptr);
  ASSERT_TRUE(fox.ok()) << fox.status().message();
  for (const Mesh& m : fox->meshes)
    for (const Primitive& p : m.primitives) {
      EXPECT_TRUE(p.normals.empty());
      EXPECT_TRUE(p.flat);
    }
  auto duck = import_gltf(testing::shared_model("Duck-webp-gltf/Duck.gltf"), {}, nullptr);
  ASSERT_TRUE(duck.ok()) << duck.status().message();
  for (const Mesh& m : duck->meshes)
    for (const Primitive& p : m.primitives) EXPECT_FALSE(p.flat);
}

}  // namespace
}  // namespace meshmux
