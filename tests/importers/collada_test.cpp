// Tests for importers/collada: small inline COLLADA documents for each behaviour of the
// contract, then the real models in ../shared/models.
#include "importers/collada.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "test_util.h"

namespace meshmux {
namespace {

using testing::TempDir;

// ---- building small documents --------------------------------------------------------------

// A <geometry> with positions (and optionally uvs), and the given primitive blocks.
std::string geometry(const std::string& id, const std::vector<float>& xyz,
                     const std::string& blocks, const std::vector<float>& st = {}) {
  std::ostringstream o;
  o << "<geometry id=\"" << id << "\" name=\"" << id << "\"><mesh>\n";
  o << "<source id=\"" << id << "-p\"><float_array id=\"" << id << "-pa\" count=\"" << xyz.size()
    << "\">";
  for (float f : xyz) o << f << " ";
  o << "</float_array><technique_common><accessor source=\"#" << id << "-pa\" count=\""
    << xyz.size() / 3 << "\" stride=\"3\"><param name=\"X\" type=\"float\"/>"
    << "<param name=\"Y\" type=\"float\"/><param name=\"Z\" type=\"float\"/></accessor>"
    << "</technique_common></source>\n";
  if (!st.empty()) {
    o << "<source id=\"" << id << "-t\"><float_array id=\"" << id << "-ta\" count=\"" << st.size()
      << "\">";
    for (float f : st) o << f << " ";
    o << "</float_array><technique_common><accessor source=\"#" << id << "-ta\" count=\""
      << st.size() / 2 << "\" stride=\"2\"><param name=\"S\" type=\"float\"/>"
      << "<param name=\"T\" type=\"float\"/></accessor></technique_common></source>\n";
  }
  o << "<vertices id=\"" << id << "-v\"><input semantic=\"POSITION\" source=\"#" << id
    << "-p\"/></vertices>\n"
    << blocks << "</mesh></geometry>\n";
  return o.str();
}

// A primitive block whose one input (offset 0) is VERTEX, plus TEXCOORD when `uv`.
std::string block(const std::string& tag, const std::string& material, int count,
                  const std::string& p, const std::string& geometry_id, bool uv = false,
                  const std::string& vcount = "") {
  std::string s = "<" + tag + " count=\"" + std::to_string(count) + "\"" +
                  (material.empty() ? "" : " material=\"" + material + "\"") + ">" +
                  "<input semantic=\"VERTEX\" source=\"#" + geometry_id + "-v\" offset=\"0\"/>";
  if (uv)
    s += "<input semantic=\"TEXCOORD\" source=\"#" + geometry_id + "-t\" offset=\"0\" set=\"0\"/>";
  if (!vcount.empty()) s += "<vcount>" + vcount + "</vcount>";
  return s + "<p>" + p + "</p></" + tag + ">\n";
}

// A whole document. `nodes` go into the visual scene.
std::string document(const std::string& geometries, const std::string& nodes,
                     const std::string& library = "", const std::string& up = "Y_UP",
                     const std::string& unit = "<unit meter=\"1\" name=\"meter\"/>") {
  return "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n"
         "<COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" version=\"1.4.1\">\n"
         "<asset>" +
         unit + "<up_axis>" + up + "</up_axis></asset>\n" + library + "<library_geometries>" +
         geometries +
         "</library_geometries>\n"
         "<library_visual_scenes><visual_scene id=\"scene\">" +
         nodes +
         "</visual_scene></library_visual_scenes>\n"
         "<scene><instance_visual_scene url=\"#scene\"/></scene></COLLADA>\n";
}

// A node placing a geometry, binding each material symbol to the material of the same id
// (with uv set 0 bound to the symbol "UV0").
std::string node(const std::string& name, const std::string& geometry_id,
                 const std::string& transform = "",
                 const std::vector<std::string>& materials = {}) {
  std::string s = "<node id=\"" + name + "\" name=\"" + name + "\">" + transform +
                  "<instance_geometry url=\"#" + geometry_id + "\">";
  if (!materials.empty()) {
    s += "<bind_material><technique_common>";
    for (const std::string& m : materials)
      s += "<instance_material symbol=\"" + m + "\" target=\"#" + m +
           "\">"
           "<bind_vertex_input semantic=\"UV0\" input_semantic=\"TEXCOORD\" input_set=\"0\"/>"
           "</instance_material>";
    s += "</technique_common></bind_material>";
  }
  return s + "</instance_geometry></node>\n";
}

// <library_images/effects/materials> for materials that are either a colour or a texture.
struct MaterialSpec {
  std::string id;
  std::string color;    // "r g b a" when not textured
  std::string texture;  // image file name when textured
};
std::string material_library(const std::vector<MaterialSpec>& specs) {
  std::string images, effects, materials;
  for (const MaterialSpec& m : specs) {
    std::string diffuse;
    std::string params;
    if (!m.texture.empty()) {
      images += "<image id=\"" + m.id + "-img\"><init_from>" + m.texture + "</init_from></image>";
      params = "<newparam sid=\"surf\"><surface type=\"2D\"><init_from>" + m.id +
               "-img</init_from></surface></newparam><newparam sid=\"samp\"><sampler2D><source>"
               "surf</source></sampler2D></newparam>";
      diffuse = "<texture texture=\"samp\" texcoord=\"UV0\"/>";
    } else {
      diffuse = "<color>" + m.color + "</color>";
    }
    effects += "<effect id=\"" + m.id + "-fx\"><profile_COMMON>" + params +
               "<technique sid=\"t\"><lambert><diffuse>" + diffuse +
               "</diffuse></lambert></technique></profile_COMMON></effect>";
    materials += "<material id=\"" + m.id + "\" name=\"" + m.id + "\"><instance_effect url=\"#" +
                 m.id + "-fx\"/></material>";
  }
  return (images.empty() ? "" : "<library_images>" + images + "</library_images>") +
         "<library_effects>" + effects + "</library_effects><library_materials>" + materials +
         "</library_materials>\n";
}

// A 2x1 RGB PNG: one red pixel, then one blue.
const std::vector<uint8_t> kRedBluePng = {
    0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48,
    0x44, 0x52, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x01, 0x08, 0x02, 0x00, 0x00,
    0x00, 0x7b, 0x40, 0xe8, 0xdd, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x44, 0x41, 0x54, 0x78,
    0x9c, 0x63, 0xf8, 0xcf, 0x00, 0x04, 0xff, 0x01, 0x07, 0x00, 0x01, 0xff, 0xe2, 0x23,
    0x9e, 0x59, 0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};

const std::vector<float> kTriangle = {0, 0, 0, 1, 0, 0, 0, 1, 0};
const std::vector<float> kQuad = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};

Result<Scene> import_text(const TempDir& dir, const std::string& name, const std::string& text,
                          Warnings* warnings) {
  testing::write_text(dir.file(name), text);
  return import_collada(dir.file(name), ImportOptions{}, warnings);
}

bool any_contains(const Warnings& w, const std::string& a, const std::string& b = "") {
  for (const std::string& s : w.items())
    if (s.find(a) != std::string::npos && s.find(b) != std::string::npos) return true;
  return false;
}

// Sum of triangle areas over all primitives of a mesh, and whether every triangle faces +`axis`.
// Zero-area triangles (ear clipping across collinear corners makes them) count as facing; the
// clean stage drops them.
double mesh_area(const Mesh& mesh, Vec3 axis, bool* all_facing) {
  double area = 0;
  *all_facing = true;
  for (const Primitive& p : mesh.primitives)
    for (size_t t = 0; t + 2 < p.indices.size(); t += 3) {
      Vec3 a = p.positions[p.indices[t]], b = p.positions[p.indices[t + 1]],
           c = p.positions[p.indices[t + 2]];
      Vec3 n = cross(b - a, c - a);
      area += 0.5 * length(n);
      if (dot(n, axis) < -1e-6f) *all_facing = false;
    }
  return area;
}

// ---- behaviours on small documents ---------------------------------------------------------

TEST(ColladaImport, InstancingKeepsOneMeshWithThreeInstances) {
  TempDir dir;
  std::string g = geometry("tri", kTriangle, block("triangles", "", 1, "0 1 2", "tri"));
  std::string nodes = node("a", "tri", "<translate>1 0 0</translate>") +
                      node("b", "tri", "<translate>0 2 0</translate>") +
                      node("c", "tri", "<translate>0 0 3</translate>");
  Warnings w;
  auto scene = import_text(dir, "inst.dae", document(g, nodes), &w);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  ASSERT_EQ(scene->meshes.size(), 1u);
  ASSERT_EQ(scene->instances.size(), 3u);
  const double expected[3][3] = {{1, 0, 0}, {0, 2, 0}, {0, 0, 3}};
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(scene->instances[i].mesh, 0u);
    for (int r = 0; r < 3; ++r)
      EXPECT_NEAR(scene->instances[i].world.at(r, 3), expected[i][r], 1e-9) << "instance " << i;
  }
  EXPECT_EQ(compute_stats(*scene).scene_triangles, 3u);
  EXPECT_EQ(scene->source, dir.file("inst.dae"));
}

TEST(ColladaImport, ConcavePolygonsAreTriangulatedWithTheirArea) {
  // A comb (area 15) in <polygons> and a 16-point star in <polylist>, in the z = 0 plane,
  // counter-clockwise: every triangle must face +z and the areas must add up exactly.
  std::vector<float> comb = {0, 0, 0, 7, 0, 0, 7, 3, 0, 6, 3, 0, 6, 1, 0, 5,
                             1, 0, 5, 3, 0, 4, 3, 0, 4, 1, 0, 3, 1, 0, 3, 3,
                             0, 2, 3, 0, 2, 1, 0, 1, 1, 0, 1, 3, 0, 0, 3, 0};
  std::vector<float> star;
  double star_area = 0;
  for (int i = 0; i < 16; ++i) {
    double r = i % 2 ? 0.5 : 2.0, a = i * M_PI / 8;
    star.insert(star.end(), {float(r * std::cos(a)), float(r * std::sin(a)), 0.0f});
  }
  for (int i = 0; i < 16; ++i) {
    int j = (i + 1) % 16;
    star_area +=
        0.5 * (double(star[3 * i]) * star[3 * j + 1] - double(star[3 * j]) * star[3 * i + 1]);
  }
  std::string all;
  for (int i = 0; i < 16; ++i) all += std::to_string(i) + " ";
  std::string g = geometry("comb", comb, block("polygons", "", 1, all, "comb")) +
                  geometry("star", star, block("polylist", "", 1, all, "star", false, "16"));
  TempDir dir;
  Warnings w;
  auto scene =
      import_text(dir, "concave.dae", document(g, node("c", "comb") + node("s", "star")), &w);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  ASSERT_EQ(scene->meshes.size(), 2u);
  for (size_t m = 0; m < 2; ++m) {
    bool facing = false;
    double area = mesh_area(scene->meshes[m], {0, 0, 1}, &facing);
    EXPECT_EQ(scene->meshes[m].primitives[0].triangle_count(), 14u) << "mesh " << m;
    EXPECT_NEAR(area, m == 0 ? 15.0 : star_area, 1e-4) << "mesh " << m;
    EXPECT_TRUE(facing) << "mesh " << m << " has a flipped (outside) triangle";
  }
}

TEST(ColladaImport, ZUpCentimetresBecomeYUpMetres) {
  // A triangle standing 100 units (cm) tall along +Z.
  std::vector<float> tall = {0, 0, 0, 100, 0, 0, 0, 0, 100};
  std::string g = geometry("t", tall, block("triangles", "", 1, "0 1 2", "t"));
  TempDir dir;
  auto scene = import_text(
      dir, "zup.dae",
      document(g, node("n", "t"), "", "Z_UP", "<unit meter=\"0.01\" name=\"centimeter\"/>"),
      nullptr);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  Bounds b = scene_bounds(*scene);
  EXPECT_NEAR(b.max.y - b.min.y, 1.0, 1e-6);  // Z (up) became Y, cm became m
  EXPECT_NEAR(b.max.x - b.min.x, 1.0, 1e-6);
  EXPECT_NEAR(b.max.z - b.min.z, 0.0, 1e-6);
  EXPECT_NEAR(b.min.y, 0.0, 1e-6);
  EXPECT_GT(scene->instances[0].world.det3(), 0);  // a rotation, not a mirror
}

TEST(ColladaImport, TwoMaterialsInOneGeometryGiveOneMeshWithTwoPrimitives) {
  std::string lib = material_library({{"red", "1 0 0 1", ""}, {"blue", "0 0 1 1", ""}});
  std::string g = geometry(
      "q", kQuad,
      block("triangles", "red", 1, "0 1 2", "q") + block("triangles", "blue", 1, "0 2 3", "q"));
  TempDir dir;
  auto scene =
      import_text(dir, "two.dae",
                  document(g,
                           node("a", "q", "", {"red", "blue"}) +
                               node("b", "q", "<translate>5 0 0</translate>", {"red", "blue"}),
                           lib),
                  nullptr);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  ASSERT_EQ(scene->meshes.size(), 1u);
  EXPECT_EQ(scene->instances.size(), 2u);
  ASSERT_EQ(scene->meshes[0].primitives.size(), 2u);
  ASSERT_EQ(scene->materials.size(), 2u);
  std::vector<std::string> names;
  for (const Primitive& p : scene->meshes[0].primitives) {
    ASSERT_GE(p.material, 0);
    names.push_back(scene->materials[p.material].name);
  }
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"blue", "red"}));
  for (const Material& m : scene->materials) {
    const Vec4 expected = m.name == "red" ? Vec4{1, 0, 0, 1} : Vec4{0, 0, 1, 1};
    EXPECT_EQ(m.base_color_factor, expected) << m.name;
    EXPECT_EQ(m.alpha_mode, AlphaMode::kOpaque);
    EXPECT_EQ(m.metallic_factor, 0);
  }
}

TEST(ColladaImport, MalformedXmlIsAnErrorNamingTheFile) {
  TempDir dir;
  auto scene = import_text(dir, "bad.dae",
                           "<?xml version=\"1.0\"?>\n<COLLADA version=\"1.4.1\"><asset>"
                           "<library_geometries><geometry",
                           nullptr);
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.status().kind(), ErrorKind::kInput);
  EXPECT_EQ(scene.status().message().rfind("collada: bad.dae: malformed file: ", 0), 0u)
      << scene.status().message();
  EXPECT_EQ(scene.status().message().find('\n'), std::string::npos);
}

TEST(ColladaImport, FilesThatCrashAssimpGiveAnError) {
  // Assimp 5.2 segfaults on a <float_array> without its count and aborts (ai_assert) when a
  // primitive block's count disagrees with its <p>. The test process must survive both; with
  // Debian's Assimp 5.2.5 both are errors (a fixed Assimp might accept them).
  std::string g = geometry("tri", kTriangle, block("triangles", "", 1, "0 1 2", "tri"));
  std::string no_count = document(g, node("n", "tri"));
  no_count.replace(no_count.find(" count=\"9\""), 10, "");
  std::string wrong_count = document(
      geometry("tri", kTriangle, block("polygons", "", 2, "0 1 2", "tri")), node("n", "tri"));
  TempDir dir;
  for (const auto& [name, text] :
       {std::pair<std::string, std::string>{"nocount.dae", no_count}, {"count.dae", wrong_count}}) {
    auto scene = import_text(dir, name, text, nullptr);
    if (scene.ok()) continue;
    EXPECT_EQ(scene.status().kind(), ErrorKind::kInput);
    EXPECT_EQ(scene.status().message().rfind("collada: " + name + ": malformed file: ", 0), 0u)
        << scene.status().message();
  }
}

TEST(ColladaImport, MissingFileIsAnError) {
  TempDir dir;
  auto scene = import_collada(dir.file("nothing.dae"), ImportOptions{}, nullptr);
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.status().message(), "collada: nothing.dae: no such file");
}

TEST(ColladaImport, EmptyFileIsAnError) {
  TempDir dir;
  auto scene = import_text(dir, "empty.dae", "", nullptr);
  ASSERT_FALSE(scene.ok());
  EXPECT_EQ(scene.status().message(), "collada: empty.dae: file is empty");
}

// A textured quad (material "tex", image `image`) next to a red one.
std::string textured_document(const std::string& image) {
  std::string lib = material_library({{"tex", "", image}, {"red", "1 0 0 1", ""}});
  std::vector<float> st = {0, 0, 1, 0, 1, 1, 0, 1};
  std::string g = geometry("q", kQuad,
                           block("triangles", "tex", 1, "0 1 2", "q", true) +
                               block("triangles", "red", 1, "0 2 3", "q", true),
                           st);
  return document(g, node("n", "q", "", {"tex", "red"}), lib);
}

const Material* find_material(const Scene& scene, const std::string& name) {
  for (const Material& m : scene.materials)
    if (m.name == name) return &m;
  return nullptr;
}

TEST(ColladaImport, MissingTextureWarnsAndKeepsTheColour) {
  TempDir dir;
  Warnings w;
  auto scene = import_text(dir, "notex.dae", textured_document("gone.png"), &w);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  const Material* tex = find_material(*scene, "tex");
  const Material* red = find_material(*scene, "red");
  ASSERT_TRUE(tex && red);
  EXPECT_FALSE(tex->base_color.present());
  EXPECT_EQ(tex->base_color_factor.w, 1);
  EXPECT_EQ(red->base_color_factor, (Vec4{1, 0, 0, 1}));
  EXPECT_TRUE(scene->images.empty());
  EXPECT_TRUE(any_contains(w, "collada: notex.dae: material 'tex': texture 'gone.png'", "no such"))
      << (w.empty() ? "no warnings" : w.items()[0]);
}

// An <image> whose file reference an exporter commented out: Assimp rejected the whole
// document ("Invalid texture, no data or file reference given"), failing two simulator
// models. Only that texture is dropped, with a warning naming the image.
TEST(ColladaImport, ImageWithoutFileDropsOnlyItsTexture) {
  TempDir dir;
  std::string text = textured_document("gone.png");
  const std::string from = "<init_from>gone.png</init_from>";
  ASSERT_NE(text.find(from), std::string::npos);
  text.replace(text.find(from), from.size(), "<!--" + from + "-->");
  Warnings w;
  auto scene = import_text(dir, "nofile.dae", text, &w);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  const Material* tex = find_material(*scene, "tex");
  const Material* red = find_material(*scene, "red");
  ASSERT_TRUE(tex && red);
  EXPECT_FALSE(tex->base_color.present());
  EXPECT_EQ(red->base_color_factor, (Vec4{1, 0, 0, 1}));
  EXPECT_EQ(scene->meshes.size(), 1u);
  EXPECT_TRUE(any_contains(w, "collada: nofile.dae: image 'tex-img'", "names no file"))
      << (w.empty() ? "no warnings" : w.items()[0]);
}

TEST(ColladaImport, UndecodableTextureWarnsAndKeepsTheColour) {
  TempDir dir;
  testing::write_text(dir.file("junk.png"), "this is not a PNG at all");
  Warnings w;
  auto scene = import_text(dir, "junk.dae", textured_document("junk.png"), &w);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  const Material* tex = find_material(*scene, "tex");
  ASSERT_TRUE(tex);
  EXPECT_FALSE(tex->base_color.present());
  EXPECT_TRUE(scene->images.empty());
  EXPECT_TRUE(any_contains(w, "collada: junk.dae: material 'tex': texture 'junk.png': "))
      << (w.empty() ? "no warnings" : w.items()[0]);
}

TEST(ColladaImport, TextureInASubfolderIsDecodedAndUvsFlipped) {
  const std::vector<uint8_t>& png = kRedBluePng;
  TempDir dir;
  std::filesystem::create_directory(dir.file("my textures"));
  testing::write_file(dir.file("my textures/a b.png"), png);
  Warnings w;
  auto scene = import_text(dir, "tex.dae", textured_document("my%20textures/a%20b.png"), &w);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  EXPECT_TRUE(w.empty()) << w.items()[0];
  const Material* tex = find_material(*scene, "tex");
  ASSERT_TRUE(tex);
  ASSERT_TRUE(tex->base_color.present());
  EXPECT_EQ(tex->base_color_factor, (Vec4{1, 1, 1, 1}));
  ASSERT_EQ(scene->images.size(), 1u);
  const Image& img = scene->images[0];
  ASSERT_TRUE(img.decoded());
  EXPECT_EQ(img.width, 2);
  EXPECT_EQ(img.height, 1);
  EXPECT_EQ(img.rgba[0], 255);  // red first
  EXPECT_EQ(img.rgba[6], 255);  // then blue
  // uv (0,0) at vertex 0 in COLLADA (bottom-left) is (0,1) in glTF (top-left).
  bool found = false;
  for (const Primitive& p : scene->meshes[0].primitives) {
    ASSERT_EQ(p.uvs.size(), 1u);
    for (size_t v = 0; v < p.vertex_count(); ++v)
      if (p.positions[v] == Vec3{0, 0, 0}) {
        EXPECT_EQ(p.uvs[0][v], (Vec2{0, 1}));
        found = true;
      }
  }
  EXPECT_TRUE(found);
}

// COLLADA colours are display values (sRGB-encoded), as three.js's ColladaLoader and common viewers
// show them; glTF's factors are linear. A diffuse of 0.2227 shows as 57/255, so its factor is
// srgb_decode(0.2227) ≈ 0.0406, not 0.2227 (which shows as 130/255).
TEST(ColladaImport, ColoursAreDisplayValuesDecodedFromSrgb) {
  TempDir dir;
  std::string lib = material_library({{"grey", "0.2227 0.5 1 1", ""}});
  std::string g = geometry("t", kTriangle, block("triangles", "grey", 1, "0 1 2", "t"));
  auto scene =
      import_text(dir, "grey.dae", document(g, node("n", "t", "", {"grey"}), lib), nullptr);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  const Material* m = find_material(*scene, "grey");
  ASSERT_TRUE(m);
  EXPECT_NEAR(m->base_color_factor.x, 0.04062, 2e-4);
  EXPECT_NEAR(m->base_color_factor.y, 0.21404, 2e-4);
  EXPECT_NEAR(m->base_color_factor.z, 1.0, 1e-6);
  EXPECT_NEAR(m->base_color_factor.w, 1.0, 1e-6);
}

// The textured document with its texture's texcoord named "CHANNEL1" (as 3ds Max names its map
// channels) and the instance binding that semantic to TEXCOORD set `input_set`.
std::string channel1_document(const std::string& image, int input_set) {
  std::string text = textured_document(image);
  for (size_t at; (at = text.find("UV0")) != std::string::npos;) text.replace(at, 3, "CHANNEL1");
  const std::string bound = "input_semantic=\"TEXCOORD\" input_set=\"0\"";
  const std::string to =
      "input_semantic=\"TEXCOORD\" input_set=\"" + std::to_string(input_set) + "\"";
  for (size_t at = 0; (at = text.find(bound, at)) != std::string::npos; at += to.size())
    text.replace(at, bound.size(), to);
  return text;
}

// A texture whose texcoord names a semantic ("CHANNEL1") that the instance binds to uv set 0
// (<bind_vertex_input semantic="CHANNEL1" input_semantic="TEXCOORD" input_set="0"/>) reads
// uv set 0. Reading set 1 (the digit in the name), which does not exist, baked the atlas one flat
// colour.
TEST(ColladaImport, TextureUvSetComesFromBindVertexInput) {
  const std::vector<uint8_t>& png = kRedBluePng;
  TempDir dir;
  testing::write_file(dir.file("t.png"), png);
  const std::string text = channel1_document("t.png", 0);
  ASSERT_NE(text.find("input_semantic=\"TEXCOORD\" input_set=\"0\""), std::string::npos);
  Warnings w;
  auto scene = import_text(dir, "channel.dae", text, &w);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  const Material* tex = find_material(*scene, "tex");
  ASSERT_TRUE(tex);
  ASSERT_TRUE(tex->base_color.present());
  EXPECT_EQ(tex->base_color.tex_coord, 0u);
  for (const Primitive& p : scene->meshes[0].primitives) EXPECT_EQ(p.uvs.size(), 1u);
}

// A texture bound to a uv set the mesh lacks (3ds Max writes input_set="1" for its first map
// channel while the mesh's one TEXCOORD input has no set) reads the first set, as COLLADA viewers
// (three.js's ColladaLoader) show it, with a warning naming the material. Left at set 1 the
// texture had no coordinates: nothing of it could be sampled, and an atlas sized its charts by
// area alone (a 3 kB image became a 4096² atlas at 3% use).
TEST(ColladaImport, TextureBoundToAMissingUvSetReadsTheFirstSet) {
  TempDir dir;
  testing::write_file(dir.file("t.png"), kRedBluePng);
  const std::string text = channel1_document("t.png", 1);
  ASSERT_NE(text.find("input_semantic=\"TEXCOORD\" input_set=\"1\""), std::string::npos);
  Warnings w;
  auto scene = import_text(dir, "max.dae", text, &w);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  const Material* tex = find_material(*scene, "tex");
  ASSERT_TRUE(tex);
  ASSERT_TRUE(tex->base_color.present());
  for (const Primitive& p : scene->meshes[0].primitives) ASSERT_EQ(p.uvs.size(), 1u);
  EXPECT_EQ(tex->base_color.tex_coord, 0u);
  EXPECT_TRUE(any_contains(w, "material 'tex'", "uv set 1"));
}

// A <phong> effect's <shininess> sets the roughness (Blinn-Phong exponent n → (2 / (n + 2))^¼, as
// three.js's loaders map it). Assimp 5.2 reported every shininess as 0, so every COLLADA material
// came out fully rough and the engine looked flat against three.js.
TEST(ColladaImport, PhongShininessGivesTheRoughness) {
  TempDir dir;
  std::string lib = material_library({{"shiny", "0.5 0.5 0.5 1", ""}});
  for (size_t at; (at = lib.find("<lambert>")) != std::string::npos;) lib.replace(at, 9, "<phong>");
  for (size_t at; (at = lib.find("</lambert>")) != std::string::npos;)
    lib.replace(at, 10, "<shininess><float>16</float></shininess></phong>");
  std::string g = geometry("t", kTriangle, block("triangles", "shiny", 1, "0 1 2", "t"));
  auto scene =
      import_text(dir, "shiny.dae", document(g, node("n", "t", "", {"shiny"}), lib), nullptr);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  const Material* m = find_material(*scene, "shiny");
  ASSERT_TRUE(m);
  EXPECT_NEAR(m->roughness_factor, std::pow(2.0 / 18.0, 0.25), 1e-4);
  EXPECT_EQ(m->metallic_factor, 0.0f);
}

// A Phong effect read as three.js's ColladaLoader reads it (the judge of appearance): an
// exponent of 0, or none, is its default 30 (roughness (2/32)^¼ = 0.5, not 1: a cup came out
// matte, lit 26 dB); an <emission> texture (not carried) leaves the emissive colour black
// rather than Assimp's white stand-in (a lamp post came out glowing white, lit 9.5 dB).
TEST(ColladaImport, PhongReadAsThreeJsReadsIt) {
  TempDir dir;
  std::string lib = material_library({{"cup", "0.5 0.5 0.5 1", ""}});
  for (size_t at; (at = lib.find("<lambert>")) != std::string::npos;) lib.replace(at, 9, "<phong>");
  for (size_t at; (at = lib.find("</lambert>")) != std::string::npos;)
    lib.replace(at, 10,
                "<emission><texture texture=\"glow\" texcoord=\"UV\"/></emission>"
                "<shininess><float>0</float></shininess></phong>");
  std::string g = geometry("t", kTriangle, block("triangles", "cup", 1, "0 1 2", "t"));
  auto scene = import_text(dir, "cup.dae", document(g, node("n", "t", "", {"cup"}), lib), nullptr);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  const Material* m = find_material(*scene, "cup");
  ASSERT_TRUE(m);
  EXPECT_NEAR(m->roughness_factor, std::pow(2.0 / 32.0, 0.25), 1e-4);
  EXPECT_EQ(m->emissive_factor, (Vec3{0, 0, 0}));
}

// COLLADA <lines> are drawn by three.js's ColladaLoader (the judge of appearance), one pixel
// wide and unlit, in their material's colour: a SketchUp valve wall's 22 edge lines, bound to a
// <constant> effect without <diffuse>, show white there (unlit 29 dB while they were skipped).
// Here a triangle and two segments bound to such a material, placed by a translated node and
// an untranslated one: the segments come out in world space, white and opaque, in one set (one
// draw call; the wall's 22 sets were 22).
TEST(ColladaImport, LinesAreCarriedAsThreeJsDrawsThem) {
  std::string g = geometry(
      "wire", kQuad,
      block("triangles", "", 1, "0 1 2", "wire") + block("lines", "edge", 2, "0 1 1 2", "wire"));
  const std::string lib =
      "<library_effects><effect id=\"edge-fx\"><profile_COMMON><technique sid=\"t\"><constant>"
      "<transparent opaque=\"A_ONE\"><color>0 0 0 1</color></transparent><transparency>"
      "<float>1</float></transparency></constant></technique></profile_COMMON></effect>"
      "</library_effects><library_materials><material id=\"edge\" name=\"edge\">"
      "<instance_effect url=\"#edge-fx\"/></material></library_materials>\n";
  TempDir dir;
  Warnings w;
  auto scene = import_text(dir, "lines.dae",
                           document(g,
                                    node("n", "wire", "<translate>0 0 5</translate>", {"edge"}) +
                                        node("m", "wire", "", {"edge"}),
                                    lib),
                           &w);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  ASSERT_EQ(scene->meshes.size(), 1u);
  EXPECT_EQ(scene->meshes[0].primitives[0].triangle_count(), 1u);
  ASSERT_EQ(scene->lines.size(), 1u);
  const LineSet& set = scene->lines[0];
  EXPECT_FALSE(set.points);
  ASSERT_EQ(set.indices.size(), 8u);
  EXPECT_EQ(set.positions[set.indices[0]], (Vec3{0, 0, 5}));
  EXPECT_EQ(set.positions[set.indices[1]], (Vec3{1, 0, 5}));
  EXPECT_EQ(set.positions[set.indices[3]], (Vec3{1, 1, 5}));
  EXPECT_EQ(set.positions[set.indices[7]], (Vec3{1, 1, 0}));
  EXPECT_EQ(set.color, (Vec4{1, 1, 1, 1}));
  EXPECT_FALSE(any_contains(w, "<lines> skipped"));
}

// A primitive bound to no material is drawn by three.js's ColladaLoader with a default
// MeshPhongMaterial: white, exponent 30 (roughness (2/32)^¼ = 0.5). Assimp's stand-in is 0.6
// grey, which made a bowl 8 dB unlit. An effect without <diffuse> likewise stays white there.
TEST(ColladaImport, MissingMaterialAndDiffuseAreWhiteAsThreeJsShowsThem) {
  TempDir dir;
  std::string g = geometry("t", kTriangle, block("triangles", "", 1, "0 1 2", "t"));
  auto bare = import_text(dir, "bare.dae", document(g, node("n", "t")), nullptr);
  ASSERT_TRUE(bare.ok()) << bare.status().message();
  ASSERT_EQ(bare->meshes.size(), 1u);
  const int32_t m = bare->meshes[0].primitives[0].material;
  ASSERT_GE(m, 0);
  EXPECT_EQ(bare->materials[size_t(m)].base_color_factor, (Vec4{1, 1, 1, 1}));
  EXPECT_NEAR(bare->materials[size_t(m)].roughness_factor, std::pow(2.0 / 32.0, 0.25), 1e-4);

  std::string lib = material_library({{"plain", "0.5 0.5 0.5 1", ""}});
  const size_t at = lib.find("<diffuse>"), to = lib.find("</diffuse>") + 10;
  lib.replace(at, to - at, "<emission><color>0 0 0 1</color></emission>");
  std::string g2 = geometry("t", kTriangle, block("triangles", "plain", 1, "0 1 2", "t"));
  auto plain =
      import_text(dir, "plain.dae", document(g2, node("n", "t", "", {"plain"}), lib), nullptr);
  ASSERT_TRUE(plain.ok()) << plain.status().message();
  const Material* p = find_material(*plain, "plain");
  ASSERT_TRUE(p);
  EXPECT_EQ(p->base_color_factor, (Vec4{1, 1, 1, 1}));
}

// A zero normal on a degenerate triangle (exporters write them) must not cost the others their
// authored normals: a table's four zero normals once replaced all 1566 of its own, and the
// generated ones smoothed its bevels (lit 26 dB). The clean stage drops the degenerate triangle.
TEST(ColladaImport, ZeroNormalsKeepTheOtherAuthoredNormals) {
  const std::string doc =
      "<?xml version=\"1.0\"?><COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" "
      "version=\"1.4.1\"><asset><up_axis>Y_UP</up_axis></asset><library_geometries>"
      "<geometry id=\"g\"><mesh>"
      "<source id=\"p\"><float_array id=\"pa\" count=\"18\">0 0 0 1 0 0 0 1 0 2 2 2 2 2 2 3 3 3"
      "</float_array><technique_common><accessor source=\"#pa\" count=\"6\" stride=\"3\">"
      "<param name=\"X\" type=\"float\"/><param name=\"Y\" type=\"float\"/>"
      "<param name=\"Z\" type=\"float\"/></accessor></technique_common></source>"
      "<source id=\"n\"><float_array id=\"na\" count=\"6\">0.6 0 0.8 0 0 0</float_array>"
      "<technique_common><accessor source=\"#na\" count=\"2\" stride=\"3\">"
      "<param name=\"X\" type=\"float\"/><param name=\"Y\" type=\"float\"/>"
      "<param name=\"Z\" type=\"float\"/></accessor></technique_common></source>"
      "<vertices id=\"v\"><input semantic=\"POSITION\" source=\"#p\"/></vertices>"
      "<triangles count=\"2\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/>"
      "<input semantic=\"NORMAL\" source=\"#n\" offset=\"1\"/>"
      "<p>0 0 1 0 2 0 3 1 4 1 5 1</p></triangles></mesh></geometry></library_geometries>"
      "<library_visual_scenes><visual_scene id=\"s\"><node id=\"a\"><instance_geometry "
      "url=\"#g\"/></node></visual_scene></library_visual_scenes>"
      "<scene><instance_visual_scene url=\"#s\"/></scene></COLLADA>\n";
  TempDir dir;
  auto scene = import_text(dir, "zero.dae", doc, nullptr);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  ASSERT_EQ(scene->meshes.size(), 1u);
  const Primitive& p = scene->meshes[0].primitives[0];
  ASSERT_EQ(p.normals.size(), p.positions.size());
  for (size_t k = 0; k < 3; ++k)
    EXPECT_NEAR(dot(p.normals[p.indices[k]], Vec3{0.6f, 0, 0.8f}), 1.0f, 1e-5f) << k;
}

// <init_from> naming an existing file outside the model's folder (absolute, "../", "file://") was
// once opened and its bytes kept. Refused with one clear error, unless the folder holds a file of
// that name (authors' absolute paths are common: the bare name beside the .dae is what they meant)
// or --allow-outside.
TEST(ColladaImport, TextureOutsideTheFolderIsRefused) {
  TempDir dir;
  ASSERT_EQ(mkdir(dir.file("model").c_str(), 0755), 0);
  testing::write_file(dir.file("secret.png"), kRedBluePng);
  const std::string outside = dir.file("secret.png");
  for (const std::string& path :
       std::vector<std::string>{outside, "../secret.png", "file://" + outside}) {
    testing::write_text(dir.file("model/m.dae"), textured_document(path));
    auto s = import_collada(dir.file("model/m.dae"), ImportOptions{}, nullptr);
    ASSERT_FALSE(s.ok()) << path;
    EXPECT_NE(s.status().message().find("outside the upload's folder"), std::string::npos)
        << s.status().message();
    ImportOptions trusted;
    trusted.allow_outside = true;
    auto t = import_collada(dir.file("model/m.dae"), trusted, nullptr);
    ASSERT_TRUE(t.ok()) << t.status().message();
    EXPECT_EQ(t->images.size(), 1u);
  }
  // The same name inside the folder is what an author's absolute path meant: read that.
  testing::write_file(dir.file("model/secret.png"), kRedBluePng);
  testing::write_text(dir.file("model/m.dae"), textured_document(outside));
  auto inside = import_collada(dir.file("model/m.dae"), ImportOptions{}, nullptr);
  ASSERT_TRUE(inside.ok()) << inside.status().message();
  EXPECT_EQ(inside->images.size(), 1u);
}

// ---- the shared models ---------------------------------------------------------------------

Result<Scene> import_shared(const std::string& rel, Warnings* w = nullptr) {
  return import_collada(testing::shared_model(rel), ImportOptions{}, w);
}

TEST(ColladaImport, TwoCylinderEngineKeepsItsInstancing) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  auto scene = import_shared("2CylinderEngine-dae/2CylinderEngine.dae");
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  SceneStats s = compute_stats(*scene);
  EXPECT_EQ(s.meshes, 29u);
  EXPECT_EQ(s.instances, 67u);
  EXPECT_EQ(s.scene_triangles, 121496u);
  EXPECT_EQ(s.unique_triangles, 75730u);
  std::vector<size_t> counts = instance_counts(*scene);
  EXPECT_EQ(*std::max_element(counts.begin(), counts.end()), 20u);
}

TEST(ColladaImport, TeapotInstanceNodesGivesOneMeshTwice) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  auto scene = import_shared("TeapotInstanceNodes-dae/teapot_instancenodes.DAE");
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  SceneStats s = compute_stats(*scene);
  EXPECT_EQ(s.meshes, 1u);
  EXPECT_EQ(s.instances, 2u);
  EXPECT_EQ(s.scene_triangles, 2048u);
  // Z_UP in inches: the teapot's height (raw Z) ends up along Y, scaled by 0.0254.
  Bounds raw = mesh_bounds(scene->meshes[0]);
  Bounds world = scene_bounds(*scene);
  EXPECT_NEAR(world.max.y - world.min.y, (raw.max.z - raw.min.z) * 0.0254, 1e-4);
}

TEST(ColladaImport, CesiumMilkTruckSharesTheWheels) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  auto scene = import_shared("CesiumMilkTruck-dae/CesiumMilkTruck.dae");
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  SceneStats s = compute_stats(*scene);
  EXPECT_EQ(s.meshes, 2u);
  EXPECT_EQ(s.instances, 3u);
  EXPECT_EQ(s.scene_triangles, 3624u);
  EXPECT_EQ(s.materials, 4u);
  EXPECT_EQ(s.textures, 1u);  // two materials share CesiumMilkTruck.png
}

TEST(ColladaImport, DuckHasItsTextureAndTriangles) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  Warnings w;
  auto scene = import_shared("Duck-dae/duck.dae", &w);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  EXPECT_TRUE(w.empty()) << w.items()[0];
  SceneStats s = compute_stats(*scene);
  EXPECT_EQ(s.scene_triangles, 4212u);
  ASSERT_EQ(scene->images.size(), 1u);
  EXPECT_TRUE(scene->images[0].decoded());
  EXPECT_EQ(scene->images[0].width, 512);
  EXPECT_EQ(scene->images[0].height, 512);
  ASSERT_EQ(scene->materials.size(), 1u);
  EXPECT_TRUE(scene->materials[0].base_color.present());
}

// The 66-corner polygon of ConcavePolygon.dae, read straight from the text: its signed area in
// the (y, z) plane (the polygon lies in x = -1.146).
double concave_polygon_area(const std::string& path) {
  std::vector<uint8_t> bytes = testing::read_file(path);
  std::string text(bytes.begin(), bytes.end());
  auto between = [&](const std::string& open, const std::string& close) {
    size_t a = text.find('>', text.find(open)) + 1;
    return std::istringstream(text.substr(a, text.find(close, a) - a));
  };
  std::istringstream floats = between("<float_array", "</float_array>");
  std::vector<double> xyz;
  for (double f; floats >> f;) xyz.push_back(f);
  std::istringstream corners = between("<p>", "</p>");
  std::vector<size_t> p;
  for (size_t i; corners >> i;) p.push_back(i);
  double area = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    size_t a = p[i], b = p[(i + 1) % p.size()];
    area += 0.5 * (xyz[3 * a + 1] * xyz[3 * b + 2] - xyz[3 * b + 1] * xyz[3 * a + 2]);
  }
  return area;
}

TEST(ColladaImport, ConcavePolygonModelKeepsItsArea) {
  if (!testing::have_shared_models()) GTEST_SKIP() << "../shared/models absent";
  std::string path = testing::shared_model("ConcavePolygon-dae/ConcavePolygon.dae");
  auto scene = import_collada(path, ImportOptions{}, nullptr);
  ASSERT_TRUE(scene.ok()) << scene.status().message();
  ASSERT_EQ(scene->meshes.size(), 1u);
  EXPECT_EQ(compute_stats(*scene).scene_triangles, 64u);
  double polygon = concave_polygon_area(path);
  ASSERT_GT(std::abs(polygon), 0.1);
  // Every triangle must turn the polygon's way (a triangle outside it would turn the other
  // way or add area) and the areas must add up to the polygon's.
  bool facing = false;
  double area = mesh_area(scene->meshes[0], {polygon > 0 ? 1.0f : -1.0f, 0, 0}, &facing);
  EXPECT_TRUE(facing) << "a triangle faces the wrong way: it lies outside the polygon";
  EXPECT_NEAR(area, std::abs(polygon), 1e-5);
}

}  // namespace
}  // namespace meshmux
