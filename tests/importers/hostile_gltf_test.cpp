// Hostile glTF uploads: each case is a file a stranger could send to a conversion service,
// generated here; each must be refused with one clear error (or read safely), never crash, never
// read outside the model's folder, never allocate gigabytes.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstring>
#include <nlohmann/json.hpp>

#include "image/encode.h"
#include "importers/gltf.h"
#include "test_util.h"

namespace meshmux {
namespace {

using nlohmann::json;
using testing::TempDir;

// One triangle: positions (36 bytes) and indices (6 bytes) in buffer 0.
std::vector<uint8_t> triangle_bytes() {
  std::vector<uint8_t> b(44, 0);
  const float p[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  std::memcpy(b.data(), p, 36);
  const uint16_t i[3] = {0, 1, 2};
  std::memcpy(b.data() + 36, i, 6);
  return b;
}

json triangle_doc(const std::string& buffer_uri) {
  return {{"asset", {{"version", "2.0"}}},
          {"buffers", {{{"byteLength", 44}, {"uri", buffer_uri}}}},
          {"bufferViews",
           {{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", 36}},
            {{"buffer", 0}, {"byteOffset", 36}, {"byteLength", 6}}}},
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

std::vector<uint8_t> small_png() {
  Image img;
  img.name = "p.png";
  img.width = img.height = 4;
  img.rgba.assign(4 * 4 * 4, 200);
  return *encode_png(img);
}

std::string error_of(const std::string& path, ImportOptions o = {}) {
  auto s = import_gltf(path, o, nullptr);
  return s.ok() ? std::string("(imported)") : s.status().message();
}

// A buffer named "../secret.bin" (also percent-encoded) is outside the model's folder: refused
// by name, its bytes never read. A text file once appeared verbatim in POSITION data.
TEST(HostileGltf, BufferOutsideTheFolderIsRefused) {
  TempDir dir;
  ASSERT_EQ(mkdir(dir.file("model").c_str(), 0755), 0);
  testing::write_file(dir.file("secret.bin"), triangle_bytes());
  for (const std::string uri : {"../secret.bin", "..%2Fsecret.bin"}) {
    testing::write_text(dir.file("model/m.gltf"), triangle_doc(uri).dump());
    std::string e = error_of(dir.file("model/m.gltf"));
    EXPECT_NE(e.find("outside the upload's folder"), std::string::npos) << uri << ": " << e;
    EXPECT_NE(e.find("--allow-outside"), std::string::npos) << e;
  }
  // Trusted local use may read it.
  ImportOptions trusted;
  trusted.allow_outside = true;
  testing::write_text(dir.file("model/m.gltf"), triangle_doc("../secret.bin").dump());
  EXPECT_TRUE(import_gltf(dir.file("model/m.gltf"), trusted, nullptr).ok());
}

// A link inside the folder that points outside it is outside.
TEST(HostileGltf, SymlinkOutOfTheFolderIsRefused) {
  TempDir dir;
  ASSERT_EQ(mkdir(dir.file("model").c_str(), 0755), 0);
  testing::write_file(dir.file("secret.bin"), triangle_bytes());
  ASSERT_EQ(symlink(dir.file("secret.bin").c_str(), dir.file("model/data.bin").c_str()), 0);
  testing::write_text(dir.file("model/m.gltf"), triangle_doc("data.bin").dump());
  EXPECT_NE(error_of(dir.file("model/m.gltf")).find("outside the upload's folder"),
            std::string::npos);
  // The same bytes as a real file inside: read.
  unlink(dir.file("model/data.bin").c_str());
  testing::write_file(dir.file("model/data.bin"), triangle_bytes());
  EXPECT_TRUE(import_gltf(dir.file("model/m.gltf"), {}, nullptr).ok());
}

// An image outside the folder (".." after percent-decoding) is refused as well.
TEST(HostileGltf, ImageOutsideTheFolderIsRefused) {
  TempDir dir;
  ASSERT_EQ(mkdir(dir.file("model").c_str(), 0755), 0);
  testing::write_file(dir.file("model/data.bin"), triangle_bytes());
  testing::write_file(dir.file("outside.png"), small_png());
  json doc = triangle_doc("data.bin");
  doc["images"] = {{{"uri", "..%2Foutside.png"}}};
  doc["textures"] = {{{"source", 0}}};
  doc["materials"] = {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}};
  testing::write_text(dir.file("model/m.gltf"), doc.dump());
  EXPECT_NE(error_of(dir.file("model/m.gltf")).find("outside the upload's folder"),
            std::string::npos);
}

// A FIFO named as a buffer would block forever; /dev/zero would be read until memory runs out.
// Neither is a regular file: neither is read (the test would hang or time out otherwise).
TEST(HostileGltf, FifoAndDeviceAreNotRead) {
  TempDir dir;
  ASSERT_EQ(mkfifo(dir.file("pipe.bin").c_str(), 0644), 0);
  testing::write_text(dir.file("m.gltf"), triangle_doc("pipe.bin").dump());
  EXPECT_NE(error_of(dir.file("m.gltf")), "(imported)");
  ImportOptions trusted;
  trusted.allow_outside = true;
  testing::write_text(dir.file("z.gltf"), triangle_doc("/dev/zero").dump());
  EXPECT_NE(error_of(dir.file("z.gltf"), trusted), "(imported)");
}

// An image whose bufferView runs past its buffer: tinygltf handed over a pointer past the
// buffer (offset 2^31 - 1 crashed; 64 KiB too long copied heap into the output). Refused.
TEST(HostileGltf, ImageBufferViewPastItsBufferIsRefused) {
  TempDir dir;
  std::vector<uint8_t> png = small_png();
  for (json view : {json{{"buffer", 0}, {"byteOffset", 2147483647}, {"byteLength", 64}},
                    json{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", png.size() + 65536}}}) {
    std::vector<uint8_t> bin = triangle_bytes();
    bin.insert(bin.end(), png.begin(), png.end());
    testing::write_file(dir.file("data.bin"), bin);
    json doc = triangle_doc("data.bin");
    doc["buffers"][0]["byteLength"] = bin.size();
    doc["bufferViews"].push_back(view);
    doc["images"] = {{{"bufferView", 2}, {"mimeType", "image/png"}}};
    doc["textures"] = {{{"source", 0}}};
    doc["materials"] = {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}};
    testing::write_text(dir.file("m.gltf"), doc.dump());
    std::string e = error_of(dir.file("m.gltf"));
    EXPECT_NE(e.find("out of bounds"), std::string::npos) << view.dump() << ": " << e;
  }
}

// 15,000 nested arrays in "extras" (31 kB) overflowed the stack of the recursive JSON parser.
TEST(HostileGltf, DeepNestingIsRefusedBeforeParsing) {
  TempDir dir;
  std::string doc = triangle_doc("data.bin").dump();
  doc.pop_back();
  doc += ",\"extras\":" + std::string(15000, '[') + std::string(15000, ']') + "}";
  testing::write_text(dir.file("m.gltf"), doc);
  std::string e = error_of(dir.file("m.gltf"));
  EXPECT_NE(e.find("nested deeper than"), std::string::npos) << e;
}

// 25 nodes each listing the next twice: 2^25 paths, 16.8 M instances and 9.5 GB before. The
// instance limit (from the input's size) stops the expansion and names its option.
TEST(HostileGltf, ExponentialNodeGraphHitsTheInstanceLimit) {
  TempDir dir;
  testing::write_file(dir.file("data.bin"), triangle_bytes());
  json doc = triangle_doc("data.bin");
  doc["nodes"] = json::array();
  for (int i = 0; i < 25; ++i) doc["nodes"].push_back({{"children", {i + 1, i + 1}}});
  doc["nodes"].push_back({{"mesh", 0}});
  testing::write_text(dir.file("m.gltf"), doc.dump());
  std::string e = error_of(dir.file("m.gltf"));
  EXPECT_NE(e.find("--max-instances"), std::string::npos) << e;
}

// An accessor of count 2^28 with no bufferView (legal: zeros) in an 896-byte file allocated
// 3.2 GB before; EXT_mesh_gpu_instancing with count 5 M and no data made 3.4 GB and a 200 MB
// output. Both hit the value budget before allocating.
TEST(HostileGltf, HugeCountsWithoutDataHitTheValueLimit) {
  TempDir dir;
  testing::write_file(dir.file("data.bin"), triangle_bytes());
  json doc = triangle_doc("data.bin");
  doc["accessors"][0].erase("bufferView");
  doc["accessors"][0]["count"] = 1 << 28;
  testing::write_text(dir.file("zeros.gltf"), doc.dump());
  EXPECT_NE(error_of(dir.file("zeros.gltf")).find("--max-elements"), std::string::npos);

  json inst = triangle_doc("data.bin");
  inst["extensionsUsed"] = {"EXT_mesh_gpu_instancing"};
  inst["accessors"].push_back({{"componentType", 5126}, {"count", 5000000}, {"type", "VEC3"}});
  inst["nodes"][0]["extensions"] = {
      {"EXT_mesh_gpu_instancing", {{"attributes", {{"TRANSLATION", 2}}}}}};
  testing::write_text(dir.file("inst.gltf"), inst.dump());
  std::string e = error_of(dir.file("inst.gltf"));
  EXPECT_TRUE(e.find("--max-elements") != std::string::npos ||
              e.find("--max-instances") != std::string::npos)
      << e;
}

// Images no material uses are not read or decoded (three unused entries naming one PNG that
// decodes big cost 9.6 GB); images that are used share the texel budget, named on excess.
TEST(HostileGltf, UnusedImagesAreNotDecodedAndTexelsAreBudgeted) {
  TempDir dir;
  testing::write_file(dir.file("data.bin"), triangle_bytes());
  testing::write_file(dir.file("p.png"), small_png());
  json doc = triangle_doc("data.bin");
  doc["images"] = {{{"uri", "p.png"}}, {{"uri", "p.png"}}, {{"uri", "p.png"}}};
  testing::write_text(dir.file("unused.gltf"), doc.dump());
  auto s = import_gltf(dir.file("unused.gltf"), {}, nullptr);
  ASSERT_TRUE(s.ok()) << s.status().message();
  EXPECT_TRUE(s->images.empty());

  doc["textures"] = {{{"source", 0}}, {{"source", 1}}};
  doc["materials"] = {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}},
                      {{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 1}}}}}}};
  testing::write_text(dir.file("used.gltf"), doc.dump());
  ImportOptions tight;
  tight.max_texels = 20;  // one 4×4 image fits, the second does not
  std::string e = error_of(dir.file("used.gltf"), tight);
  EXPECT_NE(e.find("--max-texels"), std::string::npos) << e;
  auto ok = import_gltf(dir.file("used.gltf"), {}, nullptr);
  ASSERT_TRUE(ok.ok()) << ok.status().message();
  EXPECT_EQ(ok->images.size(), 2u);
}

}  // namespace
}  // namespace meshmux
