#include "upload_fixtures.h"

#include <gtest/gtest.h>
#include <zip.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "test_util.h"

namespace meshmux::testing {

namespace fs = std::filesystem;

// A 2×1 RGB PNG (red, blue).
const std::vector<uint8_t> kPng = {
    0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48,
    0x44, 0x52, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x01, 0x08, 0x02, 0x00, 0x00,
    0x00, 0x7b, 0x40, 0xe8, 0xdd, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x44, 0x41, 0x54, 0x78,
    0x9c, 0x63, 0xf8, 0xcf, 0x00, 0x04, 0xff, 0x01, 0x07, 0x00, 0x01, 0xff, 0xe2, 0x23,
    0x9e, 0x59, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};

// A textured quad in COLLADA 1.4.1 whose one image is `image` (as written in <init_from>).
std::string textured_dae(const std::string& image) {
  return R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
 <asset><unit meter="1"/><up_axis>Y_UP</up_axis></asset>
 <library_images><image id="img"><init_from>)" +
         image + R"(</init_from></image></library_images>
 <library_effects><effect id="fx"><profile_COMMON>
  <newparam sid="surf"><surface type="2D"><init_from>img</init_from></surface></newparam>
  <newparam sid="samp"><sampler2D><source>surf</source></sampler2D></newparam>
  <technique sid="common"><lambert><diffuse><texture texture="samp" texcoord="UV"/></diffuse></lambert></technique>
 </profile_COMMON></effect></library_effects>
 <library_materials><material id="mat"><instance_effect url="#fx"/></material></library_materials>
 <library_geometries><geometry id="q"><mesh>
  <source id="p"><float_array id="pa" count="12">0 0 0 1 0 0 1 1 0 0 1 0</float_array>
   <technique_common><accessor source="#pa" count="4" stride="3"><param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/></accessor></technique_common></source>
  <source id="t"><float_array id="ta" count="8">0 0 1 0 1 1 0 1</float_array>
   <technique_common><accessor source="#ta" count="4" stride="2"><param name="S" type="float"/><param name="T" type="float"/></accessor></technique_common></source>
  <vertices id="v"><input semantic="POSITION" source="#p"/></vertices>
  <triangles material="m" count="2"><input semantic="VERTEX" source="#v" offset="0"/><input semantic="TEXCOORD" source="#t" offset="0" set="0"/><p>0 1 2 0 2 3</p></triangles>
 </mesh></geometry></library_geometries>
 <library_visual_scenes><visual_scene id="s"><node id="n"><instance_geometry url="#q"><bind_material><technique_common>
  <instance_material symbol="m" target="#mat"><bind_vertex_input semantic="UV" input_semantic="TEXCOORD" input_set="0"/></instance_material>
 </technique_common></bind_material></instance_geometry></node></visual_scene></library_visual_scenes>
 <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
)";
}

// The standard layout of a simulator's model database: meshes/x.dae names
// ../materials/textures/x.png.
void write_database_model(const std::string& root) {
  fs::create_directories(root + "/meshes");
  fs::create_directories(root + "/materials/textures");
  testing::write_text(root + "/model.config", "<model><name>x</name></model>\n");
  testing::write_text(root + "/meshes/x.dae", textured_dae("../materials/textures/x.png"));
  testing::write_file(root + "/materials/textures/x.png", kPng);
}

// Writes a .zip with libzip; a member named "" is skipped.
void write_zip(const std::string& path, const std::vector<ZipMember>& members) {
  int err = 0;
  zip_t* za = zip_open(path.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &err);
  ASSERT_TRUE(za) << err;
  for (const ZipMember& m : members) {
    char* copy = static_cast<char*>(malloc(m.data.size() + 1));
    memcpy(copy, m.data.data(), m.data.size());
    zip_source_t* src = zip_source_buffer(za, copy, m.data.size(), 1);
    ASSERT_TRUE(src);
    const zip_int64_t i = zip_file_add(za, m.name.c_str(), src, ZIP_FL_ENC_UTF_8);
    ASSERT_GE(i, 0) << m.name << ": " << zip_strerror(za);
    if (m.unix_mode)
      zip_file_set_external_attributes(za, zip_uint64_t(i), 0, ZIP_OPSYS_UNIX, m.unix_mode << 16);
  }
  ASSERT_EQ(zip_close(za), 0);
}

// The same upload as a folder, packed: every regular file under `root`, relative names.
void zip_folder(const std::string& root, const std::string& path) {
  std::vector<ZipMember> members;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.is_regular_file()) {
      auto bytes = testing::read_file(e.path().string());
      members.push_back({fs::relative(e.path(), root).string(),
                         std::string(bytes.begin(), bytes.end())});
    }
  write_zip(path, members);
}

}  // namespace meshmux::testing
