// The stream package: round trip through the real pipeline (clean → build_progressive → texture
// levels → base .glb → package), determinism, and robustness against corrupted packages.
#include "stream/package.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>

#include "clean/clean.h"
#include "core/file_io.h"
#include "exporters/gltf.h"
#include "image/texture_levels.h"
#include "importers/import.h"
#include "multiplex/stream_plan.h"
#include "simplify/lod.h"
#include "simplify/simplify.h"
#include "stream/deflate.h"
#include "stream/vsplit.h"
#include "test_util.h"

namespace meshmux {
namespace {

Image texture_image(int size) {
  Image img;
  img.name = "generated";
  img.width = img.height = size;
  img.rgba.resize(size_t(size) * size_t(size) * 4);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      uint8_t* p = &img.rgba[(size_t(y) * size_t(size) + size_t(x)) * 4];
      p[0] = uint8_t(x), p[1] = uint8_t(y),
      p[2] = uint8_t(128 + 100 * std::sin(x * 0.1) * std::cos(y * 0.13)), p[3] = 255;
    }
  return img;
}

// Everything a package is made from, built once.
struct Fixture {
  ProgressiveScene ps;
  TextureLevels textures;
  PackageInput input;
  size_t base_level = 0;                             // mesh 0's base level
  std::vector<uint32_t> base_faces;                  // mesh 0's base faces as a client holds them
  std::vector<size_t> step_levels;                   // per mesh step: the level of mesh 0
  std::vector<std::vector<EncodedMeshPart>> layers;  // per mesh layer, as the multiplexer gives
  std::vector<std::vector<uint8_t>> chunks;          // per mesh layer, its deflated payload
};

const Fixture& fixture() {
  static Fixture* f = [] {
    auto* f = new Fixture;
    Scene s;
    Mesh m;
    m.primitives.push_back(testing::uv_sphere(32, 32, 2.0f, Vec3{1, -3, 0.5f}));
    m.primitives.back().material = 0;
    s.meshes.push_back(m);
    s.instances.push_back({0, Mat4::identity(), "sphere"});
    Material mat;
    mat.base_color.image = 0;
    s.materials.push_back(mat);
    s.images.push_back(texture_image(256));
    Scene cleaned = clean(s, {});
    SimplifyOptions so;
    so.ship_whole_below = 0;  // a small scene, streamed anyway
    so.ship_whole_fraction = 0;
    f->ps = build_progressive(cleaned, so);
    TextureLevelOptions to;
    to.base_size = 64;
    to.level_halvings = 1;  // three levels: the steps below use 1 and 2
    to.max_pyramid_ratio = INFINITY;
    auto levels = make_texture_levels(s.images[0], to);
    if (levels.ok()) f->textures = levels.take();
    LodSelection base = select_base(f->ps);
    auto glb = export_glb_bytes(
        materialize(f->ps, base, /*keep_prefix=*/true),
        [] {
          GltfExportOptions o;
          o.draco = false;
          o.tag_meshes = true;
          return o;
        }(),
        nullptr);
    if (glb.ok()) f->input.base_glb = glb.take();
    const ProgressiveMesh& pm = f->ps.meshes[0];
    f->base_level = base.level[0];
    MeshStreamEncoder encoder(pm, package_quantization(pm), 0, f->base_level);
    MeshStreamBase head;
    head.vertices = uint32_t(pm.vertex_count()), head.faces = uint32_t(pm.face_count());
    head.base_vertices = pm.levels[f->base_level].vertex_end;
    head.base_faces = pm.levels[f->base_level].face_end;
    head.bounds = package_bounds(pm);
    head.quantization = package_quantization(pm);
    head.base_primitive_faces = encoder.base_faces();
    f->base_faces = encoder.client().indices;  // as a client decodes them from the base .glb
    head.base_order = encoder.stream_order();
    f->input.meshes = {head};
    f->layers.resize(1);  // layer 0: the base
    f->chunks.resize(1);
    f->input.mesh_layers = &f->layers;
    f->input.mesh_chunks = &f->chunks;
    f->input.textures = &f->textures;
    // The view a conversion measures with by default: the table carries it, the reader checks it.
    f->input.view = package_view(MultiplexOptions{});
    size_t b = base.level[0], full = pm.levels.size() - 1;
    auto mesh_step = [&](size_t level, double d) {
      std::vector<EncodedMeshPart> parts;
      if (level != encoder.level()) {
        auto part = encoder.next(level);
        if (part.ok()) parts.push_back(part.take());
      }
      f->chunks.push_back(mesh_chunk_payload(parts));
      f->layers.push_back(std::move(parts));
      StreamStep st;
      st.kind = StreamStep::kMesh, st.mesh_layer = f->layers.size() - 1, st.distortion = d;
      f->input.steps.push_back(st);
      f->step_levels.push_back(level);
    };
    auto texture_step = [&](size_t level, double d) {
      StreamStep st;
      st.kind = StreamStep::kTexture, st.texture_level = level, st.distortion = d;
      f->input.steps.push_back(st);
    };
    mesh_step(b + (full - b) / 4, 5.5);
    texture_step(1, 4.25);
    mesh_step(b + (full - b) / 2, 3);
    mesh_step(b + (full - b) / 2, 3);  // nothing changes: an empty chunk
    texture_step(2, 1.5);
    mesh_step(full, 0);
    f->input.base_distortion = 7.75;
    // A baseline: texture steps first, mesh steps in their order.
    StreamOrder tf;
    tf.name = "texture-first";
    tf.steps = {1, 4, 0, 2, 3, 5};
    tf.distortion = {6, 5, 4, 3, 2, 0};
    f->input.orders.push_back(tf);
    return f;
  }();
  return *f;
}

Bounds bounds_of(const PackageMesh& m) {
  Bounds b;
  b.min = {m.bounds[0], m.bounds[1], m.bounds[2]};
  b.max = {m.bounds[3], m.bounds[4], m.bounds[5]};
  return b;
}

using PositionFace = std::array<std::array<uint16_t, 3>, 3>;
// Faces as their corners' quantized positions (testing::sorted_faces): comparable across
// vertex numberings.
std::vector<PositionFace> position_faces(
    const std::vector<uint32_t>& indices,
    const std::function<std::array<uint16_t, 3>(uint32_t)>& at) {
  return testing::sorted_faces(indices, at);
}
// A client state's faces / a progressive mesh level's faces, by quantized position.
std::vector<PositionFace> client_faces(const VsplitMesh& m) {
  return position_faces(m.indices, [&](uint32_t v) {
    return std::array<uint16_t, 3>{m.vertices[v].p[0], m.vertices[v].p[1], m.vertices[v].p[2]};
  });
}
std::vector<PositionFace> level_faces(const ProgressiveMesh& pm, size_t level) {
  PositionQuantization q = package_quantization(pm);
  return position_faces(level_indices(pm, level), [&](uint32_t v) {
    QuantizedVertex x = quantize_vertex(pm, q, v);
    return std::array<uint16_t, 3>{x.p[0], x.p[1], x.p[2]};
  });
}
// The base vertices' quantized attributes, in the stream's base order, as the base .glb holds
// them in a package (the pipeline writes it in that order).
std::vector<QuantizedVertex> base_vertices(const ProgressiveMesh& pm,
                                           const std::vector<uint32_t>& order) {
  std::vector<QuantizedVertex> out;
  PositionQuantization q = package_quantization(pm);
  for (uint32_t v : order) out.push_back(quantize_vertex(pm, q, v));
  return out;
}

TEST(Package, FixtureIsStreamable) {
  const Fixture& f = fixture();
  ASSERT_EQ(f.ps.meshes.size(), 1u);
  const ProgressiveMesh& pm = f.ps.meshes[0];
  EXPECT_GT(pm.face_count(), 1500u);
  EXPECT_LT(f.base_level + 10, pm.levels.size()) << "base must be coarser than the full mesh";
  ASSERT_EQ(f.textures.levels.size(), 3u);
  EXPECT_FALSE(f.input.base_glb.empty());
  auto bytes = write_package(f.input);
  ASSERT_TRUE(bytes.ok()) << bytes.status().message();
  const ProgressiveLevel& base = pm.levels[f.base_level];
  std::printf(
      "[ Package  ] %zu vertices, %zu faces, %zu levels; base %u vertices, %u faces, %zu-byte glb; "
      "package %zu bytes\n",
      pm.vertex_count(), pm.face_count(), pm.levels.size(), base.vertex_end, base.face_end,
      f.input.base_glb.size(), bytes->size());
}

TEST(Package, RoundTripDecodesEveryPart) {
  const Fixture& f = fixture();
  const ProgressiveMesh& pm = f.ps.meshes[0];
  auto bytes = write_package(f.input);
  ASSERT_TRUE(bytes.ok()) << bytes.status().message();
  auto pkg = read_package(*bytes);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  EXPECT_EQ(pkg->version, kPackageVersion);
  // Header: the deflated table, the base right after it, stored deflated when smaller.
  uint32_t json_size = uint32_t((*bytes)[8]) | uint32_t((*bytes)[9]) << 8 |
                       uint32_t((*bytes)[10]) << 16 | uint32_t((*bytes)[11]) << 24;
  EXPECT_EQ(pkg->base_offset, 12u + json_size);
  EXPECT_EQ(pkg->base_glb_size, f.input.base_glb.size());
  EXPECT_LE(pkg->base_size, f.input.base_glb.size());
  auto base_glb = package_base_glb(*bytes, *pkg);
  ASSERT_TRUE(base_glb.ok()) << base_glb.status().message();
  EXPECT_EQ(*base_glb, f.input.base_glb);
  // The mesh table.
  ASSERT_EQ(pkg->meshes.size(), 1u);
  const PackageMesh& mesh = pkg->meshes[0];
  const ProgressiveLevel& base = pm.levels[f.base_level];
  EXPECT_EQ(mesh.vertices, pm.vertex_count());
  EXPECT_EQ(mesh.faces, pm.face_count());
  EXPECT_EQ(mesh.base_vertices, base.vertex_end);
  EXPECT_EQ(mesh.base_faces, base.face_end);
  Bounds box = bounds_of(mesh), expect = package_bounds(pm);
  EXPECT_EQ(box.min.x, expect.min.x);
  EXPECT_EQ(box.max.z, expect.max.z);
  EXPECT_EQ(pkg->texture_width, 256);
  EXPECT_EQ(pkg->texture_height, 256);
  // The chunks, in step order; the last chunk ends the file.
  ASSERT_EQ(pkg->chunks.size(), f.input.steps.size());
  EXPECT_EQ(pkg->chunks.back().offset + pkg->chunks.back().size, bytes->size());
  uint32_t v = base.vertex_end, fc = base.face_end;
  size_t mesh_step = 0;
  // The base: its faces decode to the base level; the base .glb's mesh holds the stream's
  // first base_vertices vertices in order, tagged with its package mesh.
  ASSERT_EQ(f.base_faces.size(), size_t(base.face_end) * 3);
  auto client = decode_base(*pkg, 0, base_vertices(pm, f.input.meshes[0].base_order), f.base_faces);
  ASSERT_TRUE(client.ok()) << client.status().message();
  EXPECT_EQ(client_faces(*client), level_faces(pm, f.base_level));
  {
    testing::TempDir dir;
    std::string glb = dir.path() + "/base.glb";
    ASSERT_TRUE(write_file_atomic(glb, f.input.base_glb));
    Warnings w;
    auto scene = import_scene(glb, ImportOptions{}, &w);
    ASSERT_TRUE(scene.ok()) << scene.status().message();
    ASSERT_EQ(scene->meshes.size(), 1u);
    ASSERT_EQ(scene->meshes[0].primitives.size(), 1u);
    const Primitive& prim = scene->meshes[0].primitives[0];
    ASSERT_EQ(prim.positions.size(), base.vertex_end);
    for (uint32_t k = 0; k < base.vertex_end; ++k) {
      ASSERT_EQ(prim.positions[k].x, pm.positions[k].x) << "vertex " << k;
      ASSERT_EQ(prim.positions[k].z, pm.positions[k].z) << "vertex " << k;
    }
    auto text = read_whole_file(glb);
    ASSERT_TRUE(text.ok());
    std::string glb_text(text->begin(), text->end());
    EXPECT_NE(glb_text.find("\"meshmux_mesh\":0"), std::string::npos);
  }
  for (size_t i = 0; i < pkg->chunks.size(); ++i) {
    const PackageChunk& c = pkg->chunks[i];
    const StreamStep& step = f.input.steps[i];
    EXPECT_EQ(c.distortion, step.distortion);
    if (step.kind == StreamStep::kTexture) {
      ASSERT_EQ(c.kind, StreamStep::kTexture);
      const TextureLevel& l = f.textures.levels[step.texture_level];
      EXPECT_EQ(c.width, l.width);
      EXPECT_EQ(c.height, l.height);
      ASSERT_EQ(c.maps.size(), 1u);
      EXPECT_EQ(c.maps[0].channel, "base_color");
      EXPECT_EQ(c.maps[0].mime, l.mime_type);
      EXPECT_EQ(c.maps[0].offset, c.offset);
      ASSERT_EQ(c.size, l.encoded.size());
      EXPECT_TRUE(std::equal(l.encoded.begin(), l.encoded.end(), bytes->begin() + long(c.offset)));
      continue;
    }
    ASSERT_EQ(c.kind, StreamStep::kMesh);
    const ProgressiveLevel& to = pm.levels[f.step_levels[mesh_step++]];
    size_t level = f.step_levels[mesh_step - 1];
    if (level == (mesh_step >= 2 ? f.step_levels[mesh_step - 2] : f.base_level)) {
      EXPECT_TRUE(c.parts.empty()) << "chunk " << i;
      EXPECT_EQ(c.size, 0u);
      continue;
    }
    ASSERT_EQ(c.parts.size(), 1u) << "chunk " << i;
    const PackagePart& p = c.parts[0];
    EXPECT_EQ(p.mesh, 0u);
    EXPECT_EQ(p.vertex_begin, v);
    EXPECT_EQ(p.vertex_end, to.vertex_end);
    EXPECT_EQ(p.face_begin, fc);
    EXPECT_EQ(p.face_end, to.face_end);
    // The chunk is the part's coded bytes.
    EXPECT_EQ(c.size, p.bytes);
    Status d = decode_part(*bytes, *pkg, c, 0, *client);
    ASSERT_TRUE(d.is_ok()) << d.message();
    // What a client holds after the part draws the level, face for face.
    EXPECT_EQ(client_faces(*client), level_faces(pm, level)) << "chunk " << i;
    v = to.vertex_end, fc = to.face_end;
    EXPECT_FALSE(decode_part(*bytes, *pkg, c, 1, *client).is_ok());
    EXPECT_FALSE(decode_part(*bytes, *pkg, c, 0, *client).is_ok()) << "a part applies once";
  }
  EXPECT_EQ(v, pm.vertex_count());
  EXPECT_EQ(fc, pm.face_count());
  EXPECT_EQ(client->vertex_count(), pm.vertex_count());
  // The orders: the stored one first, then the baseline as given.
  EXPECT_EQ(pkg->base_distortion, 7.75);
  ASSERT_EQ(pkg->orders.size(), 2u);
  EXPECT_EQ(pkg->orders[0].name, "rate-distortion");
  EXPECT_EQ(pkg->orders[0].chunks, (std::vector<uint32_t>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(pkg->orders[0].distortion[1], 4.25);
  EXPECT_EQ(pkg->orders[1].name, "texture-first");
  EXPECT_EQ(pkg->orders[1].chunks, f.input.orders[0].steps);
  EXPECT_EQ(pkg->orders[1].distortion, f.input.orders[0].distortion);
  // Texture chunks and decode_part.
  EXPECT_FALSE(decode_part(*bytes, *pkg, pkg->chunks[1], 0, *client).is_ok());
  // Determinism.
  auto again = write_package(f.input);
  ASSERT_TRUE(again.ok());
  EXPECT_EQ(*again, *bytes);
}

// The package `in` gives, read back: its bytes, and each texture chunk with the level it holds.
struct Written {
  std::vector<uint8_t> bytes;
  Package pkg;
  std::vector<std::pair<PackageChunk, size_t>> texture_chunks;
};
std::optional<Written> write_and_read(const PackageInput& in) {
  auto bytes = write_package(in);
  if (!bytes.ok()) {
    ADD_FAILURE() << bytes.status().message();
    return std::nullopt;
  }
  auto pkg = read_package(*bytes);
  if (!pkg.ok()) {
    ADD_FAILURE() << pkg.status().message();
    return std::nullopt;
  }
  Written w{bytes.take(), pkg.take(), {}};
  for (size_t i = 0; i < w.pkg.chunks.size(); ++i)
    if (w.pkg.chunks[i].kind == StreamStep::kTexture)
      w.texture_chunks.push_back({w.pkg.chunks[i], in.steps[i].texture_level});
  return w;
}

// A texture step may carry several maps at one resolution: each is listed with its channel, type
// and bytes, base colour first, and reads back at its own range.
TEST(Package, TextureStepsCarrySeveralMaps) {
  const Fixture& f = fixture();
  TextureLevels levels = f.textures;
  PackageInput in = f.input;
  in.textures = &levels;
  TextureMap normal;
  normal.channel = "normal";
  normal.mime_type = "image/png";
  normal.encoded = {1, 2, 3, 4, 5, 6, 7};  // the reader checks ranges, not pixels
  for (TextureLevel& l : levels.levels) l.other_maps = {normal};
  const std::optional<Written> w = write_and_read(in);
  ASSERT_TRUE(w);
  const std::vector<uint8_t>* bytes = &w->bytes;
  for (const auto& [c, level] : w->texture_chunks) {
    const TextureLevel& l = levels.levels[level];
    ASSERT_EQ(c.maps.size(), 2u);
    EXPECT_EQ(c.maps[0].channel, "base_color");
    EXPECT_EQ(c.maps[0].size, l.encoded.size());
    EXPECT_EQ(c.maps[1].channel, "normal");
    EXPECT_EQ(c.maps[1].mime, "image/png");
    EXPECT_EQ(c.maps[1].offset, c.offset + l.encoded.size());
    EXPECT_EQ(c.size, l.encoded.size() + 7);
    EXPECT_TRUE(std::equal(normal.encoded.begin(), normal.encoded.end(),
                           bytes->begin() + long(c.maps[1].offset)));
  }
  EXPECT_EQ(w->texture_chunks.size(), 2u);
  // A map that names the base colour again, or no known channel, is refused by the writer.
  for (const char* bad : {"base_color", "specular"}) {
    for (TextureLevel& l : levels.levels) l.other_maps[0].channel = bad;
    auto r = write_package(in);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_NE(r.status().message().find("channel"), std::string::npos) << r.status().message();
  }
}

// A texture step carries the kept materials' images at its scale after its maps (a glass
// model's images were in its base at full size): each listed with the image it replaces, its
// size and type, read back at its own range; one named twice or empty is refused.
TEST(Package, TextureStepsCarryKeptImages) {
  const Fixture& f = fixture();
  TextureLevels levels = f.textures;
  PackageInput in = f.input;
  in.textures = &levels;
  for (size_t j = 0; j < levels.levels.size(); ++j) {
    KeptMap k;
    k.image = 3;
    k.width = 10 << j, k.height = 5 << j;
    k.mime_type = "image/jpeg";
    k.encoded.assign(9 + j, uint8_t(j + 1));  // the reader checks ranges, not pixels
    levels.levels[j].kept = {k};
  }
  const std::optional<Written> w = write_and_read(in);
  ASSERT_TRUE(w);
  const std::vector<uint8_t>* bytes = &w->bytes;
  for (const auto& [c, j] : w->texture_chunks) {
    const TextureLevel& l = levels.levels[j];
    ASSERT_EQ(c.kept.size(), 1u);
    EXPECT_EQ(c.kept[0].image, 3);
    EXPECT_EQ(c.kept[0].width, int(10 << j));
    EXPECT_EQ(c.kept[0].height, int(5 << j));
    EXPECT_EQ(c.kept[0].mime, "image/jpeg");
    EXPECT_EQ(c.kept[0].offset, c.offset + l.encoded.size());
    EXPECT_EQ(c.size, l.encoded.size() + 9 + j);
    EXPECT_TRUE(std::equal(l.kept[0].encoded.begin(), l.kept[0].encoded.end(),
                           bytes->begin() + long(c.kept[0].offset)));
  }
  EXPECT_EQ(w->texture_chunks.size(), 2u);
  for (TextureLevel& l : levels.levels) l.kept.push_back(l.kept[0]);
  auto twice = write_package(in);
  ASSERT_FALSE(twice.ok());
  EXPECT_NE(twice.status().message().find("twice"), std::string::npos) << twice.status().message();
  for (TextureLevel& l : levels.levels) l.kept.resize(1), l.kept[0].encoded.clear();
  EXPECT_FALSE(write_package(in).ok());
}

TEST(Package, WriterRejectsInconsistentInput) {
  const Fixture& f = fixture();
  PackageInput in = f.input;
  in.base_glb.clear();
  EXPECT_FALSE(write_package(in).ok());
  in = f.input;
  in.steps[2].mesh_layer = 1;  // a layer already sent
  auto r = write_package(in);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("out of order"), std::string::npos) << r.status().message();
  in = f.input;
  in.textures = nullptr;
  EXPECT_FALSE(write_package(in).ok());  // texture steps without textures
  in = f.input;
  in.mesh_layers = nullptr;
  EXPECT_FALSE(write_package(in).ok());
  // Orders must be permutations of the steps that keep the mesh steps in order.
  in = f.input;
  in.orders[0].steps = {2, 1, 4, 0, 3, 5};  // mesh step 2 before mesh step 0
  r = write_package(in);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("mesh steps out of order"), std::string::npos)
      << r.status().message();
  in.orders[0].steps = {1, 1, 0, 2, 3, 5};
  EXPECT_FALSE(write_package(in).ok());
  in.orders[0].steps = {1, 4, 0, 2, 3};
  EXPECT_FALSE(write_package(in).ok());
  // No textures, no texture steps: "texture": null.
  in = f.input;
  in.textures = nullptr;
  std::vector<StreamStep> mesh_only;
  for (const StreamStep& s : in.steps)
    if (s.kind == StreamStep::kMesh) mesh_only.push_back(s);
  in.steps = mesh_only;
  in.orders.clear();
  auto bytes = write_package(in);
  ASSERT_TRUE(bytes.ok()) << bytes.status().message();
  auto pkg = read_package(*bytes);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  EXPECT_EQ(pkg->texture_width, 0);
  EXPECT_EQ(pkg->chunks.size(), mesh_only.size());
}

// The package with its table replaced by `json` (deflated, as the format stores it; offsets
// count from the table's end, so the data stays where the table says).
std::vector<uint8_t> with_header(const std::vector<uint8_t>& original, const std::string& json,
                                 size_t /*min_size*/) {
  const std::vector<uint8_t> text = deflate_bytes(std::vector<uint8_t>(json.begin(), json.end()));
  const size_t size = text.size();
  uint32_t old = uint32_t(original[8]) | uint32_t(original[9]) << 8 | uint32_t(original[10]) << 16 |
                 uint32_t(original[11]) << 24;
  std::vector<uint8_t> out(12 + size + (original.size() - 12 - old));
  std::copy(original.begin(), original.begin() + 8, out.begin());
  for (int i = 0; i < 4; ++i) out[8 + size_t(i)] = uint8_t(size >> (8 * i));
  std::copy(text.begin(), text.end(), out.begin() + 12);
  std::copy(original.begin() + 12 + long(old), original.end(), out.begin() + 12 + long(size));
  return out;
}

void collect(nlohmann::json& j, std::vector<nlohmann::json*>& numbers,
             std::vector<nlohmann::json*>& all) {
  all.push_back(&j);
  if (j.is_number()) numbers.push_back(&j);
  if (j.is_structured())
    for (auto& e : j) collect(e, numbers, all);
}

// Corrupted packages are rejected with a message or decode cleanly; never a crash or a hang.
TEST(Package, SurvivesThousandCorruptions) {
  const Fixture& f = fixture();
  auto valid = write_package(f.input);
  ASSERT_TRUE(valid.ok()) << valid.status().message();
  const std::vector<uint8_t>& good = *valid;
  uint32_t json_size = uint32_t(good[8]) | uint32_t(good[9]) << 8 | uint32_t(good[10]) << 16 |
                       uint32_t(good[11]) << 24;
  auto inflated = inflate_bytes(good.data() + 12, json_size, kMaxTableBytes);
  ASSERT_TRUE(inflated.ok()) << inflated.status().message();
  nlohmann::json table = nlohmann::json::parse(inflated->begin(), inflated->end());
  std::mt19937_64 rng(20240611);
  auto below = [&](uint64_t n) { return n ? rng() % n : 0; };
  int kinds[6] = {0, 0, 0, 0, 0, 0};
  int rejected_read = 0, rejected_decode = 0, accepted = 0;
  for (int trial = 0; trial < 1000; ++trial) {
    std::vector<uint8_t> bytes = good;
    int kind = int(below(6));
    ++kinds[kind];
    switch (kind) {
      case 0:  // truncation
        bytes.resize(size_t(below(good.size())));
        break;
      case 1:    // byte flips anywhere
      case 2: {  // byte flips inside the JSON
        int n = 1 + int(below(8));
        for (int i = 0; i < n; ++i) {
          size_t at = kind == 1 ? size_t(below(bytes.size())) : 12 + size_t(below(json_size));
          bytes[at] ^= uint8_t(1 + below(255));
        }
        break;
      }
      case 3: {  // JSON length field
        const uint32_t values[] = {0xffffffffu,
                                   0x80000000u,
                                   uint32_t(good.size()),
                                   uint32_t(good.size() - 12),
                                   uint32_t(good.size() - 11),
                                   json_size + 4,
                                   json_size - 4,
                                   json_size + 1,
                                   0,
                                   uint32_t(below(0xffffffffu))};
        uint32_t v = values[below(sizeof values / sizeof values[0])];
        for (int i = 0; i < 4; ++i) bytes[8 + size_t(i)] = uint8_t(v >> (8 * i));
        break;
      }
      case 4: {  // numbers in the table rewritten (offsets, sizes, counts, ranges, bounds)
        nlohmann::json j = table;
        std::vector<nlohmann::json*> numbers, all;
        collect(j, numbers, all);
        int n = 1 + int(below(3));
        for (int i = 0; i < n; ++i) {
          nlohmann::json& x = *numbers[size_t(below(numbers.size()))];
          int64_t old = x.is_number_integer() ? x.get<int64_t>() : 0;
          switch (below(9)) {
            case 0:
              x = 0;
              break;
            case 1:
              x = -1;
              break;
            case 2:
              x = old + 1;
              break;
            case 3:
              x = old - 1;
              break;
            case 4:
              x = old + int64_t(below(2000)) - 1000;
              break;
            case 5:
              x = uint64_t(good.size());
              break;
            case 6:
              x = uint64_t(1) << (28 + below(36));
              break;
            case 7:
              x = 1.5;
              break;
            default:
              x = std::numeric_limits<uint64_t>::max();
              break;
          }
        }
        bytes = with_header(good, j.dump(), below(2) ? json_size : 0);
        break;
      }
      default: {  // values replaced by other types, entries dropped or duplicated
        nlohmann::json j = table;
        std::vector<nlohmann::json*> numbers, all;
        collect(j, numbers, all);
        nlohmann::json& x = *all[1 + size_t(below(all.size() - 1))];
        switch (below(5)) {
          case 0:
            x = nullptr;
            break;
          case 1:
            x = "text";
            break;
          case 2:
            x = nlohmann::json::array();
            break;
          case 3:
            x = nlohmann::json::object();
            break;
          default: {
            auto& chunks = j["chunks"];
            size_t a = size_t(below(chunks.size())), b = size_t(below(chunks.size()));
            std::swap(chunks[a], chunks[b]);
            if (below(2)) {
              nlohmann::json copy = chunks[a];
              chunks.push_back(copy);
            }
          }
        }
        bytes = with_header(good, j.dump(), json_size);
      }
    }
    auto pkg = read_package(bytes);
    if (!pkg.ok()) {
      ++rejected_read;
      ASSERT_EQ(pkg.status().message().rfind("package: ", 0), 0u) << pkg.status().message();
      continue;
    }
    bool all_ok = true;
    std::vector<Result<VsplitMesh>> clients;
    for (size_t m = 0; m < pkg->meshes.size(); ++m) {
      // The base vertices and faces come from the base .glb, which holds at most what the file
      // holds: the fixture's faces where the table still agrees, zeros (degenerate) elsewhere.
      const PackageMesh& pm = pkg->meshes[m];
      if (pm.base_vertices > bytes.size() || pm.base_faces > bytes.size()) {
        clients.push_back(Status::error("too many base vertices", ErrorKind::kInput));
      } else {
        std::vector<uint32_t> faces = m == 0 && f.base_faces.size() == size_t(pm.base_faces) * 3
                                          ? f.base_faces
                                          : std::vector<uint32_t>(size_t(pm.base_faces) * 3, 0);
        clients.push_back(
            decode_base(*pkg, m, std::vector<QuantizedVertex>(pm.base_vertices), faces));
      }
      if (!clients.back().ok()) all_ok = false;
    }
    for (const PackageChunk& c : pkg->chunks) {
      ASSERT_LE(c.offset + c.size, bytes.size());
      for (size_t p = 0; p < c.parts.size(); ++p) {
        const PackagePart& part = c.parts[p];
        if (part.mesh >= clients.size() || !clients[part.mesh].ok()) {
          all_ok = false;
          continue;
        }
        VsplitMesh& client = *clients[part.mesh];
        Status d = decode_part(bytes, *pkg, c, p, client);
        if (!d.is_ok()) {
          all_ok = false;
          ASSERT_EQ(d.message().rfind("package: ", 0), 0u) << d.message();
          clients[part.mesh] = d;  // a client stops at the first bad part
          continue;
        }
        ASSERT_EQ(client.vertex_count(), part.vertex_end);
        ASSERT_EQ(client.face_count(), part.face_end);
        for (uint32_t i : client.indices) ASSERT_LT(i, client.vertex_count());
      }
    }
    ++(all_ok ? accepted : rejected_decode);
  }
  std::printf(
      "[ Package  ] 1000 corruptions (truncate %d, flip %d, flip JSON %d, JSON length %d, numbers "
      "%d, types %d): "
      "%d rejected at read, %d rejected at decode, %d accepted\n",
      kinds[0], kinds[1], kinds[2], kinds[3], kinds[4], kinds[5], rejected_read, rejected_decode,
      accepted);
  EXPECT_EQ(rejected_read + rejected_decode + accepted, 1000);
  EXPECT_GT(rejected_read, 300);
}

// "whole" says the base is the whole model: a package claiming it while mesh chunks follow
// (which need the base's vertex order) is rejected, and the writer refuses to make one.
TEST(Package, WholeBaseAllowsNoMeshChunk) {
  const Fixture& f = fixture();
  auto valid = write_package(f.input);
  ASSERT_TRUE(valid.ok()) << valid.status().message();
  EXPECT_FALSE(read_package(*valid)->base_whole);
  uint32_t json_size = uint32_t((*valid)[8]) | uint32_t((*valid)[9]) << 8 |
                       uint32_t((*valid)[10]) << 16 | uint32_t((*valid)[11]) << 24;
  auto inflated = inflate_bytes(valid->data() + 12, json_size, kMaxTableBytes);
  ASSERT_TRUE(inflated.ok());
  nlohmann::json table = nlohmann::json::parse(inflated->begin(), inflated->end());
  table["base"]["whole"] = true;
  auto r = read_package(with_header(*valid, table.dump(), 0));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("whole model"), std::string::npos) << r.status().message();
  table["base"]["whole"] = "yes";
  r = read_package(with_header(*valid, table.dump(), 0));
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("not a boolean"), std::string::npos);
  PackageInput whole = f.input;
  whole.base_whole = true;
  auto w = write_package(whole);
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.status().message().find("whole model"), std::string::npos) << w.status().message();
}

// The completion (the full mesh single-rate ending the mesh chunks, stream/format.h): written as
// a "complete" chunk whose meshes' bitstreams fill it, read back with each mesh's counts and
// bytes; a mesh chunk after it, bitstreams that do not fill it, or a mesh listed twice are
// refused by name. The reader does not decode the bitstreams (Draco's), so stand-in bytes do.
TEST(Package, CompletionEndsTheMeshChunks) {
  const Fixture& f = fixture();
  std::vector<std::vector<EncodedMeshPart>> layers = f.layers;
  std::vector<std::vector<uint8_t>> chunks = f.chunks;
  const ProgressiveMesh& pm = f.ps.meshes[0];
  CompletionMesh cm;
  cm.mesh = 0, cm.vertices = uint32_t(pm.vertex_count()), cm.faces = uint32_t(pm.face_count());
  cm.data.assign(1000, 0x5a);
  layers.back().clear();
  chunks.back() = cm.data;
  PackageInput in = f.input;
  in.mesh_layers = &layers;
  in.mesh_chunks = &chunks;
  in.completion = {cm};
  auto bytes = write_package(in);
  ASSERT_TRUE(bytes.ok()) << bytes.status().message();
  auto pkg = read_package(*bytes);
  ASSERT_TRUE(pkg.ok()) << pkg.status().message();
  const PackageChunk& last = pkg->chunks.back();
  ASSERT_EQ(last.kind, StreamStep::kComplete);
  EXPECT_EQ(last.size, 1000u);
  ASSERT_EQ(last.parts.size(), 1u);
  EXPECT_EQ(last.parts[0].vertex_end, cm.vertices);
  EXPECT_EQ(last.parts[0].face_end, cm.faces);
  EXPECT_EQ(std::vector<uint8_t>(bytes->begin() + long(last.offset),
                                 bytes->begin() + long(last.offset + last.size)),
            cm.data);
  // The table, edited.
  uint32_t json_size = uint32_t((*bytes)[8]) | uint32_t((*bytes)[9]) << 8 |
                       uint32_t((*bytes)[10]) << 16 | uint32_t((*bytes)[11]) << 24;
  auto inflated = inflate_bytes(bytes->data() + 12, json_size, kMaxTableBytes);
  ASSERT_TRUE(inflated.ok());
  const nlohmann::json table = nlohmann::json::parse(inflated->begin(), inflated->end());
  auto refused = [&](nlohmann::json t, const char* why) {
    auto r = read_package(with_header(*bytes, t.dump(), 0));
    ASSERT_FALSE(r.ok()) << why;
    EXPECT_NE(r.status().message().find(why), std::string::npos) << r.status().message();
  };
  const size_t c = table["chunks"].size() - 1;
  ASSERT_EQ(table["chunks"][c]["kind"], "complete");
  nlohmann::json t = table;
  t["chunks"][0]["kind"] = "complete";  // a completion before mesh chunks
  t["chunks"][0]["meshes"] = {{0, 10, 10, t["chunks"][0]["size"]}};
  refused(t, "after the completion");
  t = table;
  t["chunks"][c]["meshes"][0][3] = 999;
  refused(t, "hold 999 bytes");
  t = table;
  t["chunks"][c]["meshes"] = {{0, 1, 1, 500}, {0, 1, 1, 500}};
  refused(t, "twice");
  // The writer takes a completion only as the last mesh layer, without parts.
  layers.back() = f.layers.back();
  EXPECT_FALSE(write_package(in).ok());
}

TEST(Package, RejectsBadHeadersWithClearMessages) {
  const Fixture& f = fixture();
  auto valid = write_package(f.input);
  ASSERT_TRUE(valid.ok());
  auto message = [](const std::vector<uint8_t>& b) {
    auto r = read_package(b);
    return r.ok() ? std::string("accepted") : r.status().message();
  };
  EXPECT_EQ(message({}), "package: empty file");
  std::vector<uint8_t> eleven(valid->begin(), valid->begin() + 11);
  EXPECT_NE(message(eleven).find("11 bytes"), std::string::npos) << message(eleven);
  std::vector<uint8_t> b = *valid;
  b[0] = 'X';
  EXPECT_NE(message(b).find("magic"), std::string::npos) << message(b);
  b = *valid;
  b[4] = 1;  // version 1 packages (no corner updates) cannot be streamed correctly
  EXPECT_EQ(message(b), "package: version 1 not supported");
  b = *valid;
  b[11] = 0x7f;
  EXPECT_NE(message(b).find("past the end"), std::string::npos) << message(b);
  b = std::vector<uint8_t>(valid->begin(), valid->begin() + 12);  // header only
  EXPECT_NE(message(b).find("past the end"), std::string::npos) << message(b);
  b = *valid;
  b[12] = '[';
  EXPECT_NE(message(b).find("JSON"), std::string::npos) << message(b);
  // A package cut at a chunk boundary no longer holds the chunks after it: rejected as a whole.
  auto pkg = read_package(*valid);
  ASSERT_TRUE(pkg.ok());
  b.assign(valid->begin(), valid->begin() + long(pkg->chunks.back().offset));
  EXPECT_NE(message(b).find("chunk " + std::to_string(pkg->chunks.size() - 1)), std::string::npos)
      << message(b);
}

// decode_part trusts neither the Package nor the bytes it is given.
TEST(Package, DecodeChecksItsArguments) {
  const Fixture& f = fixture();
  auto bytes = write_package(f.input);
  ASSERT_TRUE(bytes.ok());
  auto pkg = read_package(*bytes);
  ASSERT_TRUE(pkg.ok());
  const PackageChunk& good = pkg->chunks[0];
  ASSERT_EQ(good.kind, StreamStep::kMesh);
  const Fixture& fx = fixture();
  auto fresh = [&](const Package& p) {
    auto c = decode_base(p, 0, base_vertices(fx.ps.meshes[0], fx.input.meshes[0].base_order),
                         fx.base_faces);
    EXPECT_TRUE(c.ok()) << c.status().message();
    return c.ok() ? c.take() : VsplitMesh{};
  };
  {
    VsplitMesh client = fresh(*pkg);
    ASSERT_TRUE(decode_part(*bytes, *pkg, good, 0, client).is_ok());
  }
  auto fails = [&](const PackageChunk& c, const Package& p, const std::vector<uint8_t>& b) {
    VsplitMesh client = fresh(*pkg);
    Status r = decode_part(b, p, c, 0, client);
    return !r.is_ok() && r.message().rfind("package: ", 0) == 0;
  };
  PackageChunk c = good;
  c.offset = bytes->size();
  EXPECT_TRUE(fails(c, *pkg, *bytes));
  c = good;
  c.parts[0].vertex_end = 1u << 27;  // far more vertices than the bytes can hold
  EXPECT_TRUE(fails(c, *pkg, *bytes));
  c = good;
  c.parts[0].mesh = 7;
  EXPECT_TRUE(fails(c, *pkg, *bytes));
  c = good;
  c.parts[0].bytes += 1000000;
  EXPECT_TRUE(fails(c, *pkg, *bytes));
  c = good;
  c.parts[0].vertex_begin += 1;  // not where the client is
  EXPECT_TRUE(fails(c, *pkg, *bytes));
  std::vector<uint8_t> cut(bytes->begin(), bytes->begin() + long(good.offset + good.size - 1));
  EXPECT_TRUE(fails(good, *pkg, cut));
  std::vector<uint8_t> flipped = *bytes;
  for (uint64_t i = 0; i < good.size; ++i) flipped[good.offset + i] = 0xff;
  EXPECT_TRUE(fails(good, *pkg, flipped));  // not a zlib stream
}

}  // namespace
}  // namespace meshmux
