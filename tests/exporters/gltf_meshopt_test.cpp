// The exporter's meshopt mode (GltfExportOptions::meshopt): EXT_meshopt_compression over
// KHR_mesh_quantization, vertex order and every face kept (faces in vertex-cache order),
// dequantization in the node transforms.
// Round trips go through the project's own importer, which decodes both extensions.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "exporters/gltf.h"
#include "importers/gltf.h"
#include "stream/quantize.h"
#include "test_util.h"

namespace meshmux {

// The importer's EXT_meshopt_compression decoder (importers/gltf_meshopt.cpp), which has no
// header of its own: it rewrites a GLB into plain glTF.
Result<bool> decode_meshopt_glb(std::vector<uint8_t>& data, const std::string& file,
                                uint64_t max_decoded);

namespace {

using json = nlohmann::json;
using testing::TempDir;

// ---- scenes built in code ----

// The test sphere, off the origin so the grid's origin matters: 17 × 25 = 425 vertices with
// normals and uvs in [0, 1], 720 triangles.
Primitive sphere() { return testing::uv_sphere(16, 24, 1.5f, {3, -1, 2}); }

// `p` with its vertices renumbered by a fixed permutation and its faces in a scrambled order, so
// that an encoder which reordered vertices or faces for the codec's sake (as meshopt's
// optimizers would) cannot pass by accident.
Primitive scrambled(Primitive p) {
  const size_t n = p.positions.size(), faces = p.triangle_count();
  std::vector<uint32_t> to(n);  // old vertex → new vertex: i·7 mod n (7 coprime with 425)
  for (size_t i = 0; i < n; ++i) to[i] = uint32_t(i * 7 % n);
  Primitive q = p;
  for (size_t i = 0; i < n; ++i) {
    q.positions[to[i]] = p.positions[i];
    q.normals[to[i]] = p.normals[i];
    q.uvs[0][to[i]] = p.uvs[0][i];
  }
  for (size_t f = 0; f < faces; ++f) {
    size_t from = f * 11 % faces;  // 11 coprime with 720
    for (int k = 0; k < 3; ++k) q.indices[f * 3 + size_t(k)] = to[p.indices[from * 3 + size_t(k)]];
  }
  return q;
}

Scene one_mesh_scene(Primitive p, Mat4 world = {}) {
  Scene scene;
  scene.materials.push_back(Material{});
  p.material = 0;
  Mesh mesh;
  mesh.name = "sphere";
  mesh.primitives.push_back(std::move(p));
  scene.meshes.push_back(std::move(mesh));
  scene.instances.push_back({0, world, "sphere"});
  return scene;
}

// The sphere drawn kMinGpuInstances + 1 times with rotation and non-uniform scale (one
// EXT_mesh_gpu_instancing node), plus once with shear (a parent/child node pair): every kind of
// node that can draw a mesh.
Scene instanced_scene() {
  Scene scene = one_mesh_scene(sphere());
  scene.instances.clear();
  for (size_t i = 0; i <= kMinGpuInstances; ++i) {
    double t[3] = {2.0 * i, -0.5 * i, 1.0}, a = 0.4 * i + 0.1;
    double q[4] = {std::sin(a / 2) * 0.6, std::sin(a / 2) * 0.8, 0, std::cos(a / 2)};
    double s[3] = {1 + 0.1 * i, 0.5, 2 - 0.2 * i};
    scene.instances.push_back({0, Mat4::trs(t, q, s), "i" + std::to_string(i)});
  }
  Mat4 shear = Mat4::translation(-3, 2, 0.5);
  shear.at(0, 1) = 0.5;
  shear.at(2, 0) = -0.25;
  scene.instances.push_back({0, shear, "sheared"});
  return scene;
}

GltfExportOptions meshopt_options() {
  GltfExportOptions o;
  o.meshopt = true;
  return o;
}

// ---- reading back ----

std::vector<uint8_t> export_ok(const Scene& scene, const GltfExportOptions& options) {
  auto r = export_glb_bytes(scene, options, nullptr);
  EXPECT_TRUE(r.ok()) << r.status().message();
  return r.ok() ? r.take() : std::vector<uint8_t>{};
}

json glb_json(const std::vector<uint8_t>& bytes) {
  if (bytes.size() < 20) return json();
  uint32_t len = 0;
  std::memcpy(&len, bytes.data() + 12, 4);
  return json::parse(bytes.begin() + 20, bytes.begin() + 20 + len);
}

Scene import_ok(const std::vector<uint8_t>& bytes, const TempDir& dir) {
  std::string path = dir.file("roundtrip.glb");
  testing::write_file(path, bytes);
  Warnings warnings;
  auto r = import_gltf(path, ImportOptions{}, &warnings);
  EXPECT_TRUE(r.ok()) << r.status().message();
  return r.ok() ? r.take() : Scene{};
}

PositionQuantization grid_of(const Primitive& p) {
  Bounds b;
  for (Vec3 v : p.positions) b.add(v);
  return position_quantization(b);
}

// Largest coordinate difference (L∞) between the world positions of `want` under `want_world`
// and those of `got` under `got_world`, vertex for vertex (infinity when the counts differ).
double max_world_error(const Primitive& want, const Mat4& want_world, const Primitive& got,
                       const Mat4& got_world) {
  if (want.positions.size() != got.positions.size()) return INFINITY;
  double worst = 0;
  for (size_t i = 0; i < want.positions.size(); ++i) {
    Vec3 a = want_world.transform_point(want.positions[i]);
    Vec3 b = got_world.transform_point(got.positions[i]);
    for (float d : {a.x - b.x, a.y - b.y, a.z - b.z}) worst = std::max(worst, double(std::abs(d)));
  }
  return worst;
}

// ---- tests ----

TEST(GltfMeshopt, RoundTripKeepsVertexOrderAndFaces) {
  const Primitive src = scrambled(sphere());
  const PositionQuantization grid = grid_of(src);
  TempDir dir;
  Scene back = import_ok(export_ok(one_mesh_scene(src), meshopt_options()), dir);
  ASSERT_EQ(back.meshes.size(), 1u);
  ASSERT_EQ(back.meshes[0].primitives.size(), 1u);
  ASSERT_EQ(back.instances.size(), 1u);
  const Primitive& got = back.meshes[0].primitives[0];
  const Mat4& world = back.instances[0].world;
  ASSERT_EQ(got.positions.size(), src.positions.size());
  EXPECT_LE(max_world_error(src, Mat4{}, got, world), grid.step / 2 + 1e-5);
  ASSERT_EQ(got.normals.size(), src.normals.size());
  ASSERT_EQ(got.uvs.size(), 1u);
  ASSERT_EQ(got.uvs[0].size(), src.uvs[0].size());
  for (size_t i = 0; i < src.positions.size(); ++i) {
    EXPECT_LE(length(got.normals[i] - src.normals[i]), std::sqrt(3.0f) / 127) << i;
    EXPECT_LE(std::abs(got.uvs[0][i].x - src.uvs[0][i].x), 1.0f / 4095) << i;
    EXPECT_LE(std::abs(got.uvs[0][i].y - src.uvs[0][i].y), 1.0f / 4095) << i;
  }
  ASSERT_EQ(got.indices.size(), src.indices.size());
  EXPECT_EQ(testing::sorted_faces(got.indices), testing::sorted_faces(src.indices));
}

// The values are stream/quantize.h's, bit for bit (the stream encoder codes the same integers):
// the POSITION accessor's bounds are the integer bounds on the grid.
TEST(GltfMeshopt, PositionBoundsAreTheGridIntegers) {
  const Primitive src = sphere();
  const PositionQuantization g = grid_of(src);
  json doc = glb_json(export_ok(one_mesh_scene(src), meshopt_options()));
  const json& pos =
      doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"].get<int>()];
  EXPECT_EQ(pos["componentType"], 5123);
  EXPECT_FALSE(pos.value("normalized", false));
  int lo[3] = {1 << 20, 1 << 20, 1 << 20}, hi[3] = {-1, -1, -1};
  for (Vec3 v : src.positions) {
    int q[3] = {quantize_coordinate(v.x, g.origin.x, g.step),
                quantize_coordinate(v.y, g.origin.y, g.step),
                quantize_coordinate(v.z, g.origin.z, g.step)};
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], q[k]), hi[k] = std::max(hi[k], q[k]);
  }
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(pos["min"][k].get<double>(), lo[k]) << k;
    EXPECT_EQ(pos["max"][k].get<double>(), hi[k]) << k;
  }
  EXPECT_EQ(hi[0], int(kPositionMax));  // the sphere is as wide as it is high and deep
}

// The layout EXT_meshopt_compression prescribes: views read a data-less fallback buffer (1)
// and point into the BIN chunk (buffer 0) through the extension; index views carry no
// byteStride of their own; both extensions are required.
TEST(GltfMeshopt, LayoutFollowsTheExtension) {
  json doc = glb_json(export_ok(one_mesh_scene(sphere()), meshopt_options()));
  for (const char* e : {"EXT_meshopt_compression", "KHR_mesh_quantization"}) {
    EXPECT_NE(std::find(doc["extensionsUsed"].begin(), doc["extensionsUsed"].end(), e),
              doc["extensionsUsed"].end())
        << e;
    EXPECT_NE(std::find(doc["extensionsRequired"].begin(), doc["extensionsRequired"].end(), e),
              doc["extensionsRequired"].end())
        << e;
  }
  ASSERT_EQ(doc["buffers"].size(), 2u);
  const json& fallback = doc["buffers"][1];
  EXPECT_FALSE(fallback.contains("uri"));
  EXPECT_EQ(fallback["extensions"]["EXT_meshopt_compression"]["fallback"], true);
  const json& prim = doc["meshes"][0]["primitives"][0];
  size_t compressed = 0;
  for (const json& view : doc["bufferViews"]) {
    if (!view.contains("extensions")) continue;
    ++compressed;
    const json& ext = view["extensions"]["EXT_meshopt_compression"];
    EXPECT_EQ(view["buffer"], 1);
    EXPECT_EQ(ext["buffer"], 0);
    EXPECT_EQ(view["byteLength"].get<size_t>(),
              ext["byteStride"].get<size_t>() * ext["count"].get<size_t>());
    EXPECT_LE(view["byteOffset"].get<size_t>() + view["byteLength"].get<size_t>(),
              fallback["byteLength"].get<size_t>());
    if (ext["mode"] == "TRIANGLES") {
      EXPECT_FALSE(view.contains("byteStride"));
      EXPECT_EQ(ext["byteStride"], 2);  // 425 vertices: unsigned short indices
    } else {
      EXPECT_EQ(ext["mode"], "ATTRIBUTES");
      EXPECT_EQ(view["byteStride"], ext["byteStride"]);
      EXPECT_EQ(ext["byteStride"].get<int>() % 4, 0);
    }
  }
  EXPECT_EQ(compressed, 4u);  // POSITION, NORMAL, TEXCOORD_0, indices
  auto accessor = [&](const char* name) -> const json& {
    return doc["accessors"][prim["attributes"][name].get<int>()];
  };
  EXPECT_EQ(accessor("NORMAL")["componentType"], 5120);
  EXPECT_EQ(accessor("NORMAL")["normalized"], true);
  EXPECT_EQ(accessor("TEXCOORD_0")["componentType"], 5123);
  EXPECT_EQ(accessor("TEXCOORD_0")["normalized"], true);
  EXPECT_EQ(doc["accessors"][prim["indices"].get<int>()]["componentType"], 5123);
}

// Khronos' validator on the file as written. gltf-validator 2.0.0-dev.3.10 (node_modules) does
// not support EXT_meshopt_compression: it reports the extension as unsupported (an info, not an
// error) and cannot read the compressed views, so it checks the JSON, the nodes and the
// KHR_mesh_quantization accessor types only. Those hold no error.
TEST(GltfMeshopt, FileIsValidatorClean) {
  TempDir dir;
  std::string path = dir.file("meshopt.glb");
  testing::write_file(path, export_ok(instanced_scene(), meshopt_options()));
  std::string report;
  int errors = testing::gltf_validator_errors(path, &report);
  ASSERT_GE(errors, 0) << "gltf-validator not installed (run scripts/setup.sh)";
  EXPECT_EQ(errors, 0) << report;
}

// What the validator cannot see in the compressed file, it checks once the views are decoded
// (the importer's own EXT_meshopt_compression decoder rewrites the GLB into plain glTF): the
// integer POSITION bounds against the data, strides, index ranges.
TEST(GltfMeshopt, DecodedFileIsValidatorClean) {
  auto bytes = export_ok(instanced_scene(), meshopt_options());
  auto decoded = decode_meshopt_glb(bytes, "meshopt.glb", uint64_t(1) << 30);
  ASSERT_TRUE(decoded.ok()) << decoded.status().message();
  ASSERT_TRUE(*decoded);
  TempDir dir;
  std::string path = dir.file("decoded.glb");
  testing::write_file(path, bytes);
  std::string report;
  int errors = testing::gltf_validator_errors(path, &report);
  ASSERT_GE(errors, 0) << "gltf-validator not installed (run scripts/setup.sh)";
  EXPECT_EQ(errors, 0) << report;
}

TEST(GltfMeshopt, AtLeastTwiceSmallerThanPlain) {
  Scene scene = one_mesh_scene(sphere());
  GltfExportOptions plain;
  plain.draco = false;
  auto a = export_ok(scene, meshopt_options());
  auto b = export_ok(scene, plain);
  auto draco = export_ok(scene, GltfExportOptions{});  // for the figure only
  std::cout << "sphere, 425 vertices, 720 triangles: meshopt " << a.size() << " bytes, plain "
            << b.size() << " bytes, draco " << draco.size() << " bytes\n";
  EXPECT_GE(b.size(), 2 * a.size());
}

TEST(GltfMeshopt, OutputIsDeterministic) {
  Scene scene = one_mesh_scene(scrambled(sphere()));
  EXPECT_EQ(export_ok(scene, meshopt_options()), export_ok(scene, meshopt_options()));
}

// The dequantization goes into every kind of node that draws the mesh (instanced_scene): the
// EXT_mesh_gpu_instancing TRS and the parent/child pair of a sheared instance. World positions
// after import match the originals.
TEST(GltfMeshopt, InstancedAndShearedWorldPositionsSurvive) {
  Scene scene = instanced_scene();
  auto bytes = export_ok(scene, meshopt_options());
  json doc = glb_json(bytes);
  ASSERT_NE(std::find(doc["extensionsUsed"].begin(), doc["extensionsUsed"].end(),
                      "EXT_mesh_gpu_instancing"),
            doc["extensionsUsed"].end());
  TempDir dir;
  Scene back = import_ok(bytes, dir);
  ASSERT_EQ(back.meshes.size(), 1u);
  ASSERT_EQ(back.instances.size(), scene.instances.size());
  const Primitive& src = scene.meshes[0].primitives[0];
  const Primitive& got = back.meshes[0].primitives[0];
  // A vertex is off by at most half a step per axis (√3/2 steps in all) in mesh space; rotated
  // and scaled (largest scale 2) that bounds each world coordinate; plus float rounding of the
  // instancing attributes at coordinates up to ~15.
  const double tol = std::sqrt(3.0) * grid_of(src).step / 2 * 2 + 1e-4;
  std::vector<bool> matched(back.instances.size(), false);
  for (const Instance& want : scene.instances) {
    bool found = false;
    for (size_t j = 0; j < back.instances.size() && !found; ++j)
      if (!matched[j] && max_world_error(src, want.world, got, back.instances[j].world) <= tol)
        matched[j] = found = true;
    EXPECT_TRUE(found) << want.name;
  }
}

// Each mesh has its own grid: a small and a large mesh in one file (their views follow each
// other in both buffers) come back at their own size, and the decoded file is valid. The
// large one is flat-shaded (no NORMAL written), and an empty primitive is left out (its point
// still counts in the mesh's bounds, hence its grid).
TEST(GltfMeshopt, SeveralMeshesEachKeepTheirOwnGrid) {
  Scene scene = one_mesh_scene(sphere());
  Primitive big = testing::uv_sphere(8, 12, 40, {0, 100, 0});
  big.flat = true;
  Primitive empty;
  empty.positions = {{0, 0, 0}};
  Mesh mesh;
  mesh.primitives = {empty, big};
  scene.meshes.push_back(mesh);
  scene.instances.push_back({1, Mat4::translation(1, 2, 3), "big"});
  auto bytes = export_ok(scene, meshopt_options());
  TempDir dir;
  Scene back = import_ok(bytes, dir);
  ASSERT_EQ(back.meshes.size(), 2u);
  ASSERT_EQ(back.instances.size(), 2u);
  for (size_t m = 0; m < 2; ++m) {
    const Primitive& src = m == 0 ? scene.meshes[0].primitives[0] : big;
    ASSERT_EQ(back.meshes[m].primitives.size(), 1u);
    EXPECT_LE(max_world_error(src, scene.instances[m].world, back.meshes[m].primitives[0],
                              back.instances[m].world),
              position_quantization(mesh_bounds(scene.meshes[m])).step / 2 + 1e-4)
        << m;
  }
  EXPECT_TRUE(back.meshes[1].primitives[0].flat);
  auto decoded = decode_meshopt_glb(bytes, "two.glb", uint64_t(1) << 30);
  ASSERT_TRUE(decoded.ok()) << decoded.status().message();
  std::string path = dir.file("two-decoded.glb");
  testing::write_file(path, bytes);
  std::string report;
  int errors = testing::gltf_validator_errors(path, &report);
  ASSERT_GE(errors, 0) << "gltf-validator not installed (run scripts/setup.sh)";
  EXPECT_EQ(errors, 0) << report;
}

// The package base: several primitives carrying the same vertex arrays (each the whole prefix)
// with different triangles. Their attributes are written once and shared.
TEST(GltfMeshopt, PrimitivesWithTheSameVerticesShareAccessors) {
  Primitive whole = sphere();
  Primitive first = whole, second = whole;
  const size_t half = whole.triangle_count() / 2 * 3;
  first.indices.assign(whole.indices.begin(), whole.indices.begin() + long(half));
  second.indices.assign(whole.indices.begin() + long(half), whole.indices.end());
  Scene scene = one_mesh_scene(first);
  second.material = -1;
  scene.meshes[0].primitives.push_back(second);
  json doc = glb_json(export_ok(scene, meshopt_options()));
  const json& prims = doc["meshes"][0]["primitives"];
  ASSERT_EQ(prims.size(), 2u);
  for (const char* a : {"POSITION", "NORMAL", "TEXCOORD_0"})
    EXPECT_EQ(prims[0]["attributes"][a], prims[1]["attributes"][a]) << a;
  EXPECT_NE(prims[0]["indices"], prims[1]["indices"]);
  EXPECT_EQ(doc["accessors"].size(), 5u);  // 3 shared attributes + 2 index lists
}

// A grid given in the options (the stream's, from the full-resolution mesh) is used as it is,
// not recomputed from the positions the base happens to hold.
TEST(GltfMeshopt, GivenGridIsUsed) {
  GltfExportOptions o = meshopt_options();
  PositionQuantization g;
  g.origin = {-4, -4, -4};
  g.step = 0.001;
  o.position_quantization = {g};
  json doc = glb_json(export_ok(one_mesh_scene(sphere()), o));
  const json& pos =
      doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"].get<int>()];
  // The sphere's lowest x is 3 - 1.5 = 1.5: (1.5 + 4) / 0.001 = 5500 steps.
  EXPECT_EQ(pos["min"][0].get<double>(), 5500);
  const json& m = doc["nodes"][0]["matrix"];
  EXPECT_DOUBLE_EQ(m[0].get<double>(), 0.001);
  EXPECT_DOUBLE_EQ(m[12].get<double>(), -4);
}

// A given grid that does not cover the mesh (a caller's mistake) clamps the coordinates to its
// edge and says so, rather than wrapping them around.
TEST(GltfMeshopt, PositionsOffTheGivenGridAreClampedWithAWarning) {
  GltfExportOptions o = meshopt_options();
  PositionQuantization g;
  g.origin = {0, 0, 0};
  g.step = 1e-4;  // covers [0, 1.64]: the sphere reaches 4.5 in x
  o.position_quantization = {g};
  Warnings warnings;
  auto r = export_glb_bytes(one_mesh_scene(sphere()), o, &warnings);
  ASSERT_TRUE(r.ok()) << r.status().message();
  ASSERT_EQ(warnings.items().size(), 1u);
  EXPECT_NE(warnings.items()[0].find("outside the given quantization grid"), std::string::npos)
      << warnings.items()[0];
  json doc = glb_json(*r);
  const json& pos =
      doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["POSITION"].get<int>()];
  EXPECT_EQ(pos["max"][0].get<double>(), kPositionMax);
  EXPECT_EQ(pos["min"][1].get<double>(), 0);  // y reaches -2.5
}

// A grid step of 0 would divide by zero: the options are refused.
TEST(GltfMeshopt, ZeroGridStepIsAnError) {
  GltfExportOptions o = meshopt_options();
  PositionQuantization g;
  g.step = 0;
  o.position_quantization = {g};
  auto r = export_glb_bytes(one_mesh_scene(sphere()), o, nullptr);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("position_quantization of mesh 0"), std::string::npos)
      << r.status().message();
}

// Texture coordinates outside [0, 1] (tiling) cannot be stored normalized: that set stays float
// and comes back exactly.
TEST(GltfMeshopt, UvsOutsideTheUnitRangeStayFloat) {
  Primitive p = sphere();
  for (Vec2& uv : p.uvs[0]) uv.x *= 3;
  TempDir dir;
  auto bytes = export_ok(one_mesh_scene(p), meshopt_options());
  json doc = glb_json(bytes);
  const json& uv =
      doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"].get<int>()];
  EXPECT_EQ(uv["componentType"], 5126);
  Scene back = import_ok(bytes, dir);
  ASSERT_EQ(back.meshes.size(), 1u);
  const Primitive& got = back.meshes[0].primitives[0];
  ASSERT_EQ(got.uvs.size(), 1u);
  EXPECT_TRUE(got.uvs[0] == p.uvs[0]);
}

// Vertex colours are written as normalized unsigned bytes (core glTF) and read back within
// half a step.
TEST(GltfMeshopt, VertexColorsAreUnsignedBytes) {
  Primitive p = sphere();
  for (size_t i = 0; i < p.positions.size(); ++i)
    p.colors.push_back({float(i % 17) / 16, 0.25f, 1, 0.5f});
  TempDir dir;
  auto bytes = export_ok(one_mesh_scene(p), meshopt_options());
  json doc = glb_json(bytes);
  const json& c =
      doc["accessors"][doc["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"].get<int>()];
  EXPECT_EQ(c["componentType"], 5121);
  EXPECT_EQ(c["type"], "VEC4");
  EXPECT_EQ(c["normalized"], true);
  Scene back = import_ok(bytes, dir);
  ASSERT_EQ(back.meshes.size(), 1u);
  const Primitive& got = back.meshes[0].primitives[0];
  ASSERT_EQ(got.colors.size(), p.colors.size());
  for (size_t i = 0; i < p.colors.size(); ++i)
    EXPECT_LE(std::abs(got.colors[i].x - p.colors[i].x), 0.5f / 255 + 1e-6f) << i;
}

// More than 65535 vertices: unsigned int indices (index stride 4), order still kept.
TEST(GltfMeshopt, LargeMeshUsesUnsignedIntIndices) {
  Primitive p;
  const uint32_t n = 260;  // 67,600 vertices
  for (uint32_t y = 0; y < n; ++y)
    for (uint32_t x = 0; x < n; ++x)
      p.positions.push_back({float(x), float(y), std::sin(0.1f * x) * std::cos(0.1f * y)});
  for (uint32_t y = 0; y + 1 < n; ++y)
    for (uint32_t x = 0; x + 1 < n; ++x) {
      uint32_t a = y * n + x;
      for (uint32_t k : {a, a + 1, a + n + 1, a, a + n + 1, a + n}) p.indices.push_back(k);
    }
  TempDir dir;
  auto bytes = export_ok(one_mesh_scene(p), meshopt_options());
  json doc = glb_json(bytes);
  const json& idx = doc["accessors"][doc["meshes"][0]["primitives"][0]["indices"].get<int>()];
  EXPECT_EQ(idx["componentType"], 5125);
  Scene back = import_ok(bytes, dir);
  ASSERT_EQ(back.meshes.size(), 1u);
  const Primitive& got = back.meshes[0].primitives[0];
  ASSERT_EQ(got.indices.size(), p.indices.size());
  EXPECT_EQ(testing::sorted_faces(got.indices), testing::sorted_faces(p.indices));
  EXPECT_LE(max_world_error(p, Mat4{}, got, back.instances[0].world), grid_of(p).step / 2 + 1e-3);
}

}  // namespace
}  // namespace meshmux
