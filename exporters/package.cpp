// The stream package (exporters/package.h, DESIGN.md "Package"): writer, reader and part decoder.
//
// Writer: per mesh a MeshStreamEncoder follows the steps. Per mesh step, one part per mesh whose
// level moved on: its new vertices as 20-byte packed vertices through
// meshopt_encodeVertexBuffer, its new faces mapped to the part's level through
// meshopt_encodeIndexBuffer, and the corner updates (faces held before the part whose corners
// the new vertices take over; paper 002's parent mapping evaluated here, where every parent is
// known, instead of on the client, which lacks the parents of vertices yet to come) through
// meshopt_encodeIndexSequence. The encoder decodes its own faces to learn how the codec rotated
// each one, so updates name the corner slots the client really holds. An empty piece is stored
// as zero bytes (no codec header). Texture steps carry the level's file as is. The JSON table's
// length depends on the offsets it holds, so it is built until it fits the space reserved for
// it (which only grows), then padded with spaces to a multiple of 4. Output is a pure function
// of the input.
//
// Reader: untrusted input. The header, the JSON (nesting depth checked before parsing, parsed
// without exceptions) and every field's type and range are checked before anything is exposed:
// ranges inside the file and after the header, base indices and chunks in order without
// overlap, parts inside their mesh, part bytes summing to the chunk size, counts bounded
// (kMaxCount) and plausible for their byte sizes (the codecs cannot shrink data below a fixed
// ratio), orders permutations keeping the mesh chunks' order, so that decoding never allocates
// far beyond the file's size. decode_part repeats the checks it relies on (the Package may not
// come from these bytes) and checks every decoded index and update against the level.
#include "exporters/package.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

namespace meshmux {

namespace {

using Json = nlohmann::json;
using OrderedJson = nlohmann::ordered_json;

constexpr size_t kHeaderBytes = 12;
constexpr uint64_t kMaxCount = uint64_t(1) << 28;  // vertices or faces per mesh
constexpr uint64_t kMaxTextureSide = 65536;
constexpr int kMaxJsonDepth = 32;
// meshopt's vertex codec spends at least 2 bits per byte lane per 16 vertices: encoded bytes
// are never below 1/64 of the raw bytes. The index codec spends at least 1 byte per triangle.
constexpr uint64_t kMaxVertexRatio = 64;

Status fail(const std::string& message) { return Status::error("package: " + message); }

void put_u32(std::vector<uint8_t>& out, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) out[at + size_t(i)] = uint8_t(v >> (8 * i));
}
uint32_t get_u32(const std::vector<uint8_t>& in, size_t at) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= uint32_t(in[at + size_t(i)]) << (8 * i);
  return v;
}

uint16_t quantize16(float x, float lo, float extent) {
  float t = extent > 0 ? (x - lo) / extent : 0;
  if (!(t >= 0)) t = 0;  // also NaN
  if (t > 1) t = 1;
  return uint16_t(std::lround(t * 65535));
}
int8_t quantize8(float x) {
  if (std::isnan(x)) return 0;
  return int8_t(std::lround(std::clamp(x * 127, -127.0f, 127.0f)));
}

uint32_t map_to(const ProgressiveMesh& pm, uint32_t v, uint32_t k) {
  while (v >= k) v = pm.parent[v];
  return v;
}

Status internal(uint32_t mesh, const std::string& what) {
  return Status::error("package: mesh " + std::to_string(mesh) + ": " + what, ErrorKind::kInternal);
}

}  // namespace

MeshStreamEncoder::MeshStreamEncoder(const ProgressiveMesh& pm, const Bounds& bounds, uint32_t mesh,
                                     size_t base_level)
    : pm_(pm), bounds_(bounds), mesh_(mesh), level_(base_level), base_(std::vector<uint8_t>{}) {
  if (pm.levels.empty() || base_level >= pm.levels.size()) {
    base_ = internal(mesh, "base level out of range");
    return;
  }
  const ProgressiveLevel& b = pm.levels[base_level];
  base_ = encode_faces(0, b.face_end, b.vertex_end);
}

// Encodes faces [face_begin, face_end) mapped to the level with `vertex_end` vertices, decodes
// them back and records each face's rotation (any rotation the decoded corners match: when
// several do, the corners are equal and every choice is the same triangle once they split).
Result<std::vector<uint8_t>> MeshStreamEncoder::encode_faces(uint32_t face_begin, uint32_t face_end,
                                                             uint32_t vertex_end) {
  std::vector<uint8_t> out;
  size_t count = size_t(face_end - face_begin) * 3;
  if (count == 0) return out;
  std::vector<uint32_t> mapped(count);
  for (size_t i = 0; i < count; ++i)
    mapped[i] = map_to(pm_, pm_.indices[size_t(face_begin) * 3 + i], vertex_end);
  out.resize(meshopt_encodeIndexBufferBound(count, std::max<size_t>(vertex_end, 1)));
  size_t size = meshopt_encodeIndexBuffer(out.data(), out.size(), mapped.data(), count);
  if (size == 0) return internal(mesh_, "index encoding failed");
  out.resize(size);
  std::vector<uint32_t> decoded(count);
  if (meshopt_decodeIndexBuffer(decoded.data(), count, sizeof(uint32_t), out.data(), size) != 0)
    return internal(mesh_, "index data does not decode");
  rotation_.resize(face_end, 0);
  for (size_t f = 0; f < count / 3; ++f) {
    const uint32_t *d = &decoded[f * 3], *e = &mapped[f * 3];
    int r = 0;
    while (r < 3 && !(d[0] == e[r] && d[1] == e[(r + 1) % 3] && d[2] == e[(r + 2) % 3])) ++r;
    if (r == 3) return internal(mesh_, "index codec changed a face");
    rotation_[face_begin + f] = uint8_t(r);
  }
  return out;
}

Result<EncodedMeshPart> MeshStreamEncoder::next(size_t level) {
  if (!base_.ok()) return base_.status();
  if (level >= pm_.levels.size() || level < level_)
    return internal(mesh_, "level " + std::to_string(level) + " out of order");
  const ProgressiveLevel &from = pm_.levels[level_], &to = pm_.levels[level];
  if (to.vertex_end < from.vertex_end || to.face_end < from.face_end)
    return internal(mesh_, "levels shrink");
  EncodedMeshPart e;
  e.part.mesh = mesh_;
  e.part.vertex_begin = from.vertex_end, e.part.vertex_end = to.vertex_end;
  e.part.face_begin = from.face_end, e.part.face_end = to.face_end;
  size_t n = size_t(to.vertex_end - from.vertex_end);
  if (n > 0) {
    std::vector<uint8_t> packed = pack_vertices(pm_, bounds_, from.vertex_end, to.vertex_end);
    e.vertices.resize(meshopt_encodeVertexBufferBound(n, kPackedVertexBytes));
    size_t size = meshopt_encodeVertexBuffer(e.vertices.data(), e.vertices.size(), packed.data(), n,
                                             kPackedVertexBytes);
    if (size == 0) return internal(mesh_, "vertex encoding failed");
    e.vertices.resize(size);
  }
  // Corners of the faces already held that the new vertices take over.
  std::vector<std::pair<uint32_t, uint32_t>> moves;
  if (n > 0) {
    for (uint32_t f = 0; f < from.face_end; ++f)
      for (uint32_t t = 0; t < 3; ++t) {
        uint32_t w = pm_.indices[size_t(f) * 3 + t];
        if (w < from.vertex_end) continue;
        uint32_t was = map_to(pm_, w, from.vertex_end), now = map_to(pm_, w, to.vertex_end);
        if (was == now) continue;
        uint32_t slot = (t + 3 - rotation_[f]) % 3;
        moves.push_back({f * 3 + slot, now});
      }
    std::sort(moves.begin(), moves.end());
  }
  if (!moves.empty()) {
    std::vector<uint32_t> seq(moves.size() * 2);
    for (size_t i = 0; i < moves.size(); ++i)
      seq[i] = moves[i].first, seq[moves.size() + i] = moves[i].second;
    size_t top = std::max<size_t>(size_t(from.face_end) * 3, to.vertex_end);
    e.updates.resize(meshopt_encodeIndexSequenceBound(seq.size(), top));
    size_t size =
        meshopt_encodeIndexSequence(e.updates.data(), e.updates.size(), seq.data(), seq.size());
    if (size == 0) return internal(mesh_, "update encoding failed");
    e.updates.resize(size);
  }
  auto faces = encode_faces(from.face_end, to.face_end, to.vertex_end);
  if (!faces.ok()) return faces.status();
  e.indices = faces.take();
  e.part.vertex_bytes = e.vertices.size(), e.part.index_bytes = e.indices.size();
  e.part.updates = uint32_t(moves.size()), e.part.update_bytes = e.updates.size();
  level_ = level;
  return e;
}

namespace {

// The writer's own checks on a progressive mesh: what the reader will demand of the package.
Status check_mesh(const ProgressiveMesh& pm, size_t m) {
  std::string where = "mesh " + std::to_string(m) + ": ";
  if (pm.vertex_count() > kMaxCount || pm.face_count() > kMaxCount)
    return fail(where + "more than 2^28 vertices or faces");
  if (pm.parent.size() != pm.vertex_count())
    return fail(where + "parent count differs from the vertex count");
  if (pm.indices.size() % 3) return fail(where + "index count is not a multiple of 3");
  if (pm.levels.empty()) return fail(where + "no levels");
  for (uint32_t i : pm.indices)
    if (i >= pm.vertex_count()) return fail(where + "index " + std::to_string(i) + " out of range");
  for (size_t l = 0; l < pm.levels.size(); ++l)
    if (pm.levels[l].vertex_end > pm.vertex_count() || pm.levels[l].face_end > pm.face_count())
      return fail(where + "level " + std::to_string(l) + " past the mesh's vertices or faces");
  return Status::ok();
}

}  // namespace

Bounds package_bounds(const ProgressiveMesh& pm) {
  Bounds b;
  for (Vec3 p : pm.positions)
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) b.add(p);
  if (b.empty()) b.min = b.max = Vec3{0, 0, 0};
  return b;
}

std::vector<uint8_t> pack_vertices(const ProgressiveMesh& pm, const Bounds& box, uint32_t begin,
                                   uint32_t end) {
  end = uint32_t(std::min<size_t>(end, pm.vertex_count()));
  begin = std::min(begin, end);
  std::vector<uint8_t> out(size_t(end - begin) * kPackedVertexBytes, 0);
  Vec3 ext = box.max - box.min;
  auto put16 = [](uint8_t* p, uint16_t v) { p[0] = uint8_t(v), p[1] = uint8_t(v >> 8); };
  for (uint32_t v = begin; v < end; ++v) {
    uint8_t* q = &out[size_t(v - begin) * kPackedVertexBytes];
    Vec3 p = pm.positions[v];
    put16(q + 0, quantize16(p.x, box.min.x, ext.x));
    put16(q + 2, quantize16(p.y, box.min.y, ext.y));
    put16(q + 4, quantize16(p.z, box.min.z, ext.z));  // q[6..7] stay 0
    Vec3 n = v < pm.normals.size() ? pm.normals[v] : Vec3{0, 0, 1};
    q[8] = uint8_t(quantize8(n.x)), q[9] = uint8_t(quantize8(n.y)),
    q[10] = uint8_t(quantize8(n.z));  // q[11] = 0
    Vec2 t = !pm.uvs.empty() && v < pm.uvs[0].size() ? pm.uvs[0][v] : Vec2{};
    put16(q + 12, quantize16(t.x, 0, 1));
    put16(q + 14, quantize16(t.y, 0, 1));
    uint32_t parent = v < pm.parent.size() ? pm.parent[v] : v;
    for (int i = 0; i < 4; ++i) q[16 + i] = uint8_t(parent >> (8 * i));
  }
  return out;
}

Result<std::vector<uint8_t>> write_package(const PackageInput& in) {
  if (!in.scene) return fail("no progressive scene");
  const ProgressiveScene& ps = *in.scene;
  size_t meshes = ps.meshes.size();
  if (in.base_levels.size() != meshes)
    return fail(std::to_string(in.base_levels.size()) + " base levels for " +
                std::to_string(meshes) + " meshes");
  if (in.base_glb.empty()) return fail("empty base .glb");
  std::vector<Bounds> boxes;
  for (size_t m = 0; m < meshes; ++m) {
    if (Status s = check_mesh(ps.meshes[m], m); !s) return s;
    if (in.base_levels[m] >= ps.meshes[m].levels.size())
      return fail("mesh " + std::to_string(m) + ": base level " +
                  std::to_string(in.base_levels[m]) + " out of range");
    boxes.push_back(package_bounds(ps.meshes[m]));
  }
  if (in.textures && !in.textures->levels.empty()) {
    const TextureLevel& full = in.textures->levels.back();
    if (in.base_texture_level >= in.textures->levels.size())
      return fail("base texture level out of range");
    if (full.width <= 0 || full.height <= 0 || uint64_t(full.width) > kMaxTextureSide ||
        uint64_t(full.height) > kMaxTextureSide)
      return fail("full texture size " + std::to_string(full.width) + "x" +
                  std::to_string(full.height) + " out of range");
  }

  if (!std::isfinite(in.base_distortion)) return fail("base distortion is not finite");

  // Per mesh: the encoder (its state follows the steps) and the base's faces.
  std::vector<MeshStreamEncoder> encoders;
  encoders.reserve(meshes);
  std::vector<std::vector<uint8_t>> base_indices(meshes);
  for (size_t m = 0; m < meshes; ++m) {
    encoders.emplace_back(ps.meshes[m], boxes[m], uint32_t(m), in.base_levels[m]);
    if (!encoders.back().base_indices().ok()) return encoders.back().base_indices().status();
    base_indices[m] = *encoders.back().base_indices();
  }

  // Payloads and table entries, offsets filled in later.
  struct Chunk {
    bool mesh = true;
    double distortion = 0;
    std::vector<PackagePart> parts;
    const TextureLevel* texture = nullptr;
    std::vector<uint8_t> payload;
  };
  std::vector<Chunk> chunks;
  std::vector<size_t> state = in.base_levels;
  for (size_t k = 0; k < in.steps.size(); ++k) {
    const StreamStep& step = in.steps[k];
    std::string where = "step " + std::to_string(k) + ": ";
    if (!std::isfinite(step.distortion)) return fail(where + "distortion is not finite");
    Chunk c;
    c.distortion = step.distortion;
    if (step.kind == StreamStep::kTexture) {
      if (!in.textures || step.texture_level >= in.textures->levels.size())
        return fail(where + "texture level " + std::to_string(step.texture_level) +
                    " out of range");
      const TextureLevel& t = in.textures->levels[step.texture_level];
      if (t.encoded.empty() || t.width <= 0 || t.height <= 0 ||
          uint64_t(t.width) > kMaxTextureSide || uint64_t(t.height) > kMaxTextureSide)
        return fail(where + "texture level " + std::to_string(step.texture_level) +
                    " is empty or has a bad size");
      if (t.mime_type != "image/jpeg" && t.mime_type != "image/png")
        return fail(where + "texture level mime type \"" + t.mime_type +
                    "\" is neither JPEG nor PNG");
      c.mesh = false;
      c.texture = &t;
      c.payload = t.encoded;
    } else {
      if (step.levels.size() != meshes)
        return fail(where + std::to_string(step.levels.size()) + " levels for " +
                    std::to_string(meshes) + " meshes");
      for (size_t m = 0; m < meshes; ++m) {
        const ProgressiveMesh& pm = ps.meshes[m];
        size_t to = step.levels[m];
        if (to == state[m]) continue;
        if (to >= pm.levels.size())
          return fail(where + "mesh " + std::to_string(m) + ": level " + std::to_string(to) +
                      " out of range");
        const ProgressiveLevel &a = pm.levels[state[m]], &b = pm.levels[to];
        if (to < state[m] || b.vertex_end < a.vertex_end || b.face_end < a.face_end)
          return fail(where + "mesh " + std::to_string(m) + ": goes back from level " +
                      std::to_string(state[m]) + " to " + std::to_string(to));
        auto part = encoders[m].next(to);
        if (!part.ok()) return part.status();
        c.parts.push_back(part->part);
        for (const auto* piece : {&part->vertices, &part->indices, &part->updates})
          c.payload.insert(c.payload.end(), piece->begin(), piece->end());
        state[m] = to;
      }
    }
    chunks.push_back(std::move(c));
  }

  // The orders: the stream's own, then the baselines, each checked to be a permutation that
  // keeps the mesh steps in order.
  std::vector<PackageInput::Order> orders;
  {
    PackageInput::Order own;
    own.name = "rate-distortion";
    for (size_t k = 0; k < in.steps.size(); ++k)
      own.steps.push_back(uint32_t(k)), own.distortion.push_back(in.steps[k].distortion);
    orders.push_back(std::move(own));
  }
  for (const PackageInput::Order& o : in.orders) {
    std::string where = "order \"" + o.name + "\": ";
    if (o.name.empty() || o.name == "rate-distortion") return fail(where + "bad name");
    if (o.steps.size() != in.steps.size() || o.distortion.size() != in.steps.size())
      return fail(where + "not one entry per step");
    std::vector<bool> seen(in.steps.size(), false);
    int64_t last_mesh = -1;
    for (size_t i = 0; i < o.steps.size(); ++i) {
      uint32_t k = o.steps[i];
      if (k >= in.steps.size() || seen[k]) return fail(where + "not a permutation of the steps");
      seen[k] = true;
      if (in.steps[k].kind == StreamStep::kMesh) {
        if (int64_t(k) < last_mesh) return fail(where + "mesh steps out of order");
        last_mesh = int64_t(k);
      }
      if (!std::isfinite(o.distortion[i])) return fail(where + "distortion is not finite");
    }
    orders.push_back(o);
  }

  // The table for a given start of the data (12 + reserved JSON length).
  uint64_t base_indices_total = 0;
  for (const auto& b : base_indices) base_indices_total += b.size();
  auto table = [&](uint64_t data_start) {
    OrderedJson j;
    j["version"] = kPackageVersion;
    j["base"] = {{"offset", data_start},
                 {"size", uint64_t(in.base_glb.size())},
                 {"distortion", in.base_distortion}};
    OrderedJson ms = OrderedJson::array();
    uint64_t offset = data_start + in.base_glb.size();
    for (size_t m = 0; m < meshes; ++m) {
      const ProgressiveMesh& pm = ps.meshes[m];
      const ProgressiveLevel& b = pm.levels[in.base_levels[m]];
      const Bounds& box = boxes[m];
      OrderedJson e;
      e["vertices"] = uint64_t(pm.vertex_count()), e["faces"] = uint64_t(pm.face_count());
      e["base_vertices"] = b.vertex_end, e["base_faces"] = b.face_end;
      e["bounds"] = {double(box.min.x), double(box.min.y), double(box.min.z),
                     double(box.max.x), double(box.max.y), double(box.max.z)};
      e["base_indices"] = {{"offset", offset}, {"size", uint64_t(base_indices[m].size())}};
      offset += base_indices[m].size();
      ms.push_back(std::move(e));
    }
    j["meshes"] = std::move(ms);
    if (in.textures && !in.textures->levels.empty())
      j["texture"] = {{"width", in.textures->levels.back().width},
                      {"height", in.textures->levels.back().height}};
    else
      j["texture"] = nullptr;
    OrderedJson cs = OrderedJson::array();
    for (const Chunk& c : chunks) {
      OrderedJson e;
      e["kind"] = c.mesh ? "mesh" : "texture";
      e["offset"] = offset, e["size"] = uint64_t(c.payload.size()), e["distortion"] = c.distortion;
      if (c.mesh) {
        OrderedJson parts = OrderedJson::array();
        for (const PackagePart& p : c.parts)
          parts.push_back({{"mesh", p.mesh},
                           {"vertex_begin", p.vertex_begin},
                           {"vertex_end", p.vertex_end},
                           {"face_begin", p.face_begin},
                           {"face_end", p.face_end},
                           {"vertex_bytes", p.vertex_bytes},
                           {"index_bytes", p.index_bytes},
                           {"updates", p.updates},
                           {"update_bytes", p.update_bytes}});
        e["parts"] = std::move(parts);
      } else {
        e["width"] = c.texture->width, e["height"] = c.texture->height,
        e["mime"] = c.texture->mime_type;
      }
      offset += c.payload.size();
      cs.push_back(std::move(e));
    }
    j["chunks"] = std::move(cs);
    OrderedJson os = OrderedJson::array();
    for (const PackageInput::Order& o : orders)
      os.push_back({{"name", o.name}, {"chunks", o.steps}, {"distortion", o.distortion}});
    j["orders"] = std::move(os);
    return j.dump();
  };
  std::string text;
  uint64_t reserved = 0;
  try {
    for (;;) {
      text = table(kHeaderBytes + reserved);
      if (text.size() <= reserved) break;
      reserved = (text.size() + 3) / 4 * 4;  // grows only: offsets only get longer
    }
  } catch (const std::exception& e) {
    return Status::error(std::string("package: JSON table: ") + e.what(), ErrorKind::kInternal);
  }
  if (reserved > 0xffffffffu) return fail("JSON table too large");
  text.resize(size_t(reserved), ' ');

  uint64_t total = kHeaderBytes + reserved + in.base_glb.size() + base_indices_total;
  for (const Chunk& c : chunks) total += c.payload.size();
  std::vector<uint8_t> out;
  out.reserve(size_t(total));
  out.resize(kHeaderBytes);
  std::memcpy(out.data(), "MMXP", 4);
  put_u32(out, 4, kPackageVersion);
  put_u32(out, 8, uint32_t(reserved));
  out.insert(out.end(), text.begin(), text.end());
  out.insert(out.end(), in.base_glb.begin(), in.base_glb.end());
  for (const auto& b : base_indices) out.insert(out.end(), b.begin(), b.end());
  for (const Chunk& c : chunks) out.insert(out.end(), c.payload.begin(), c.payload.end());
  return out;
}

namespace {

// Field readers: each names what is wrong with `where` ("chunk 3") and the key.
Status get_uint(const Json& obj, const char* key, uint64_t max, uint64_t& out,
                const std::string& where) {
  auto it = obj.find(key);
  if (it == obj.end()) return fail(where + ": missing \"" + key + "\"");
  if (it->is_number_unsigned()) {
    out = it->get<uint64_t>();
  } else if (it->is_number_integer()) {
    int64_t s = it->get<int64_t>();
    if (s < 0) return fail(where + ": \"" + key + "\" is negative");
    out = uint64_t(s);
  } else {
    return fail(where + ": \"" + key + "\" is not an integer");
  }
  if (out > max)
    return fail(where + ": \"" + key + "\" = " + std::to_string(out) + " exceeds " +
                std::to_string(max));
  return Status::ok();
}
Status get_u32(const Json& obj, const char* key, uint64_t max, uint32_t& out,
               const std::string& where) {
  uint64_t v = 0;
  Status s = get_uint(obj, key, max, v, where);
  out = uint32_t(v);
  return s;
}
Status get_finite(const Json& v, double& out, const std::string& what) {
  if (!v.is_number()) return fail(what + " is not a number");
  out = v.get<double>();
  if (!std::isfinite(out)) return fail(what + " is not finite");
  return Status::ok();
}
Status get_side(const Json& obj, const char* key, int& out, const std::string& where) {
  uint64_t v = 0;
  if (Status s = get_uint(obj, key, kMaxTextureSide, v, where); !s) return s;
  if (v == 0) return fail(where + ": \"" + key + "\" is 0");
  out = int(v);
  return Status::ok();
}

// Bracket nesting depth of JSON text, strings skipped; guards the recursive parts of the JSON
// library (copying, destruction) against hostile nesting.
int json_depth(const uint8_t* p, size_t n) {
  int depth = 0, deepest = 0;
  bool in_string = false, escaped = false;
  for (size_t i = 0; i < n; ++i) {
    uint8_t c = p[i];
    if (in_string) {
      if (escaped)
        escaped = false;
      else if (c == '\\')
        escaped = true;
      else if (c == '"')
        in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return deepest;
}

// The checks decode_part shares with the reader: a part's ranges inside its mesh, counts bounded
// and plausible for the bytes that carry them.
Status check_part(const PackagePart& p, const std::vector<PackageMesh>& meshes,
                  const std::string& where) {
  if (p.mesh >= meshes.size())
    return fail(where + ": mesh " + std::to_string(p.mesh) + " out of range");
  const PackageMesh& m = meshes[p.mesh];
  if (m.vertices > kMaxCount || m.faces > kMaxCount)
    return fail(where + ": mesh has more than 2^28 vertices or faces");
  if (p.vertex_begin > p.vertex_end || p.vertex_end > m.vertices)
    return fail(where + ": vertex range [" + std::to_string(p.vertex_begin) + ", " +
                std::to_string(p.vertex_end) + ") outside the mesh's " +
                std::to_string(m.vertices) + " vertices");
  if (p.face_begin > p.face_end || p.face_end > m.faces)
    return fail(where + ": face range [" + std::to_string(p.face_begin) + ", " +
                std::to_string(p.face_end) + ") outside the mesh's " + std::to_string(m.faces) +
                " faces");
  uint64_t nv = p.vertex_end - p.vertex_begin, nf = p.face_end - p.face_begin;
  if ((nv == 0) != (p.vertex_bytes == 0) ||
      nv * kPackedVertexBytes > p.vertex_bytes * kMaxVertexRatio)
    return fail(where + ": " + std::to_string(p.vertex_bytes) + " vertex bytes cannot hold " +
                std::to_string(nv) + " vertices");
  if ((nf == 0) != (p.index_bytes == 0) || nf > p.index_bytes)
    return fail(where + ": " + std::to_string(p.index_bytes) + " index bytes cannot hold " +
                std::to_string(nf) + " faces");
  // Updates move distinct corners of the faces held before the part, one varint byte each at
  // least for the position and the value.
  if (uint64_t(p.updates) > uint64_t(p.face_begin) * 3)
    return fail(where + ": " + std::to_string(p.updates) + " updates for " +
                std::to_string(p.face_begin) + " faces");
  if ((p.updates == 0) != (p.update_bytes == 0) || uint64_t(p.updates) * 2 > p.update_bytes)
    return fail(where + ": " + std::to_string(p.update_bytes) + " update bytes cannot hold " +
                std::to_string(p.updates) + " updates");
  return Status::ok();
}

Status read_part(const Json& j, const std::vector<PackageMesh>& meshes, uint64_t file_size,
                 PackagePart& p, const std::string& where) {
  if (!j.is_object()) return fail(where + " is not an object");
  Status s;
  if (!(s = get_u32(j, "mesh", kMaxCount, p.mesh, where))) return s;
  if (!(s = get_u32(j, "vertex_begin", kMaxCount, p.vertex_begin, where))) return s;
  if (!(s = get_u32(j, "vertex_end", kMaxCount, p.vertex_end, where))) return s;
  if (!(s = get_u32(j, "face_begin", kMaxCount, p.face_begin, where))) return s;
  if (!(s = get_u32(j, "face_end", kMaxCount, p.face_end, where))) return s;
  if (!(s = get_uint(j, "vertex_bytes", file_size, p.vertex_bytes, where))) return s;
  if (!(s = get_uint(j, "index_bytes", file_size, p.index_bytes, where))) return s;
  if (!(s = get_u32(j, "updates", kMaxCount * 3, p.updates, where))) return s;
  if (!(s = get_uint(j, "update_bytes", file_size, p.update_bytes, where))) return s;
  return check_part(p, meshes, where);
}

Status read_chunk(const Json& j, const Package& pkg, uint64_t file_size, PackageChunk& c,
                  const std::string& where) {
  if (!j.is_object()) return fail(where + " is not an object");
  auto kind = j.find("kind");
  if (kind == j.end() || !kind->is_string())
    return fail(where + ": \"kind\" missing or not a string");
  const std::string& k = kind->get_ref<const std::string&>();
  if (k == "mesh")
    c.kind = StreamStep::kMesh;
  else if (k == "texture")
    c.kind = StreamStep::kTexture;
  else
    return fail(where + ": unknown kind");
  Status s;
  if (!(s = get_uint(j, "offset", file_size, c.offset, where))) return s;
  if (!(s = get_uint(j, "size", file_size, c.size, where))) return s;
  if (c.size > file_size - c.offset) return fail(where + ": range past the end of the file");
  auto d = j.find("distortion");
  if (d == j.end()) return fail(where + ": missing \"distortion\"");
  if (!(s = get_finite(*d, c.distortion, where + ": \"distortion\""))) return s;
  if (c.kind == StreamStep::kTexture) {
    if (!(s = get_side(j, "width", c.width, where)) ||
        !(s = get_side(j, "height", c.height, where)))
      return s;
    auto mime = j.find("mime");
    if (mime == j.end() || !mime->is_string())
      return fail(where + ": \"mime\" missing or not a string");
    c.mime = mime->get<std::string>();
    if (c.mime != "image/jpeg" && c.mime != "image/png")
      return fail(where + ": mime type is neither JPEG nor PNG");
    if (c.size == 0) return fail(where + ": empty texture");
    return Status::ok();
  }
  auto parts = j.find("parts");
  if (parts == j.end() || !parts->is_array())
    return fail(where + ": \"parts\" missing or not an array");
  uint64_t sum = 0;
  for (size_t i = 0; i < parts->size(); ++i) {
    PackagePart p;
    if (!(s = read_part((*parts)[i], pkg.meshes, file_size, p,
                        where + " part " + std::to_string(i))))
      return s;
    sum += p.vertex_bytes + p.index_bytes + p.update_bytes;  // each ≤ file size: no overflow
    if (sum > c.size)
      return fail(where + ": parts hold more bytes than the chunk's " + std::to_string(c.size));
    c.parts.push_back(p);
  }
  if (sum != c.size)
    return fail(where + ": parts hold " + std::to_string(sum) + " bytes, the chunk " +
                std::to_string(c.size));
  return Status::ok();
}

}  // namespace

Result<Package> read_package(const std::vector<uint8_t>& bytes) {
  if (bytes.empty()) return fail("empty file");
  if (bytes.size() < kHeaderBytes)
    return fail(std::to_string(bytes.size()) + " bytes, too short for the 12-byte header");
  if (std::memcmp(bytes.data(), "MMXP", 4) != 0)
    return fail("not a meshmux package (magic is not \"MMXP\")");
  Package pkg;
  pkg.version = get_u32(bytes, 4);
  if (pkg.version != kPackageVersion)
    return fail("version " + std::to_string(pkg.version) + " not supported");
  uint64_t file_size = bytes.size(), json_size = get_u32(bytes, 8);
  if (json_size > file_size - kHeaderBytes)
    return fail("JSON table length " + std::to_string(json_size) + " past the end of the file (" +
                std::to_string(file_size) + " bytes)");
  if (json_size == 0 || json_size % 4)
    return fail("JSON table length " + std::to_string(json_size) +
                " is not a positive multiple of 4");
  const uint8_t* text = bytes.data() + kHeaderBytes;
  if (json_depth(text, size_t(json_size)) > kMaxJsonDepth)
    return fail("JSON table nested too deeply");
  Json j = Json::parse(text, text + json_size, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return fail("JSON table does not parse");
  if (!j.is_object()) return fail("JSON table is not an object");
  Status s;
  uint64_t version = 0;
  if (!(s = get_uint(j, "version", 0xffffffffu, version, "table"))) return s;
  if (version != pkg.version)
    return fail("table version " + std::to_string(version) + " differs from the header's");

  uint64_t data_start = kHeaderBytes + json_size;
  auto base = j.find("base");
  if (base == j.end() || !base->is_object()) return fail("\"base\" missing or not an object");
  if (!(s = get_uint(*base, "offset", file_size, pkg.base_offset, "base"))) return s;
  if (!(s = get_uint(*base, "size", file_size, pkg.base_size, "base"))) return s;
  if (pkg.base_offset < data_start) return fail("base: offset inside the header");
  if (pkg.base_size == 0 || pkg.base_size > file_size - pkg.base_offset)
    return fail("base: range empty or past the end of the file");
  auto base_d = base->find("distortion");
  if (base_d == base->end()) return fail("base: missing \"distortion\"");
  if (!(s = get_finite(*base_d, pkg.base_distortion, "base: \"distortion\""))) return s;
  uint64_t end = pkg.base_offset + pkg.base_size;

  auto meshes = j.find("meshes");
  if (meshes == j.end() || !meshes->is_array()) return fail("\"meshes\" missing or not an array");
  for (size_t m = 0; m < meshes->size(); ++m) {
    const Json& e = (*meshes)[m];
    std::string where = "mesh " + std::to_string(m);
    if (!e.is_object()) return fail(where + " is not an object");
    PackageMesh pm;
    if (!(s = get_u32(e, "vertices", kMaxCount, pm.vertices, where)) ||
        !(s = get_u32(e, "faces", kMaxCount, pm.faces, where)) ||
        !(s = get_u32(e, "base_vertices", pm.vertices, pm.base_vertices, where)) ||
        !(s = get_u32(e, "base_faces", pm.faces, pm.base_faces, where)))
      return s;
    auto b = e.find("bounds");
    if (b == e.end() || !b->is_array() || b->size() != 6)
      return fail(where + ": \"bounds\" is not 6 numbers");
    for (size_t i = 0; i < 6; ++i) {
      double v = 0;
      if (!(s = get_finite((*b)[i], v, where + ": bounds[" + std::to_string(i) + "]"))) return s;
      pm.bounds[i] = float(v);
      if (!std::isfinite(pm.bounds[i])) return fail(where + ": bounds out of float range");
    }
    for (int i = 0; i < 3; ++i)
      if (pm.bounds[i] > pm.bounds[i + 3]) return fail(where + ": bounds minimum above maximum");
    auto bi = e.find("base_indices");
    if (bi == e.end() || !bi->is_object())
      return fail(where + ": \"base_indices\" missing or not an object");
    std::string bwhere = where + " base_indices";
    if (!(s = get_uint(*bi, "offset", file_size, pm.base_indices_offset, bwhere)) ||
        !(s = get_uint(*bi, "size", file_size, pm.base_indices_size, bwhere)))
      return s;
    if (pm.base_indices_offset != end)
      return fail(bwhere + ": offset " + std::to_string(pm.base_indices_offset) +
                  " is not where the data before it ends (" + std::to_string(end) + ")");
    if (pm.base_indices_size > file_size - pm.base_indices_offset)
      return fail(bwhere + ": range past the end of the file");
    if ((pm.base_faces == 0) != (pm.base_indices_size == 0) || pm.base_faces > pm.base_indices_size)
      return fail(bwhere + ": " + std::to_string(pm.base_indices_size) + " bytes cannot hold " +
                  std::to_string(pm.base_faces) + " faces");
    end += pm.base_indices_size;
    pkg.meshes.push_back(pm);
  }

  auto texture = j.find("texture");
  if (texture == j.end()) return fail("\"texture\" missing");
  if (!texture->is_null()) {
    if (!texture->is_object()) return fail("\"texture\" is neither null nor an object");
    if (!(s = get_side(*texture, "width", pkg.texture_width, "texture")) ||
        !(s = get_side(*texture, "height", pkg.texture_height, "texture")))
      return s;
  }

  auto chunks = j.find("chunks");
  if (chunks == j.end() || !chunks->is_array()) return fail("\"chunks\" missing or not an array");
  for (size_t i = 0; i < chunks->size(); ++i) {
    std::string where = "chunk " + std::to_string(i);
    PackageChunk c;
    if (!(s = read_chunk((*chunks)[i], pkg, file_size, c, where))) return s;
    if (c.offset < end)
      return fail(where + ": offset " + std::to_string(c.offset) +
                  " overlaps the base or the chunk before");
    if (c.kind == StreamStep::kTexture && pkg.texture_width == 0)
      return fail(where + ": texture chunk in a package without texture");
    end = c.offset + c.size;
    pkg.chunks.push_back(std::move(c));
  }

  auto orders = j.find("orders");
  if (orders == j.end() || !orders->is_array() || orders->empty())
    return fail("\"orders\" missing, not an array or empty");
  const size_t n = pkg.chunks.size();
  for (size_t o = 0; o < orders->size(); ++o) {
    const Json& e = (*orders)[o];
    std::string where = "order " + std::to_string(o);
    if (!e.is_object()) return fail(where + " is not an object");
    PackageOrder po;
    auto name = e.find("name");
    if (name == e.end() || !name->is_string() || name->get_ref<const std::string&>().empty())
      return fail(where + ": \"name\" missing or not a non-empty string");
    po.name = name->get<std::string>();
    auto cs = e.find("chunks");
    auto ds = e.find("distortion");
    if (cs == e.end() || !cs->is_array() || cs->size() != n)
      return fail(where + ": \"chunks\" is not one index per chunk");
    if (ds == e.end() || !ds->is_array() || ds->size() != n)
      return fail(where + ": \"distortion\" is not one number per chunk");
    std::vector<bool> seen(n, false);
    int64_t last_mesh = -1;
    for (size_t i = 0; i < n; ++i) {
      const Json& c = (*cs)[i];
      if (!c.is_number_unsigned() || c.get<uint64_t>() >= n)
        return fail(where + ": chunk index " + std::to_string(i) + " out of range");
      uint32_t k = uint32_t(c.get<uint64_t>());
      if (seen[k]) return fail(where + ": chunk " + std::to_string(k) + " listed twice");
      seen[k] = true;
      if (o == 0 && k != i) return fail(where + ": the first order is not the stored order");
      if (pkg.chunks[k].kind == StreamStep::kMesh) {
        if (int64_t(k) < last_mesh) return fail(where + ": mesh chunks out of order");
        last_mesh = int64_t(k);
      }
      double d = 0;
      if (!(s = get_finite((*ds)[i], d, where + ": distortion " + std::to_string(i)))) return s;
      po.chunks.push_back(k);
      po.distortion.push_back(d);
    }
    pkg.orders.push_back(std::move(po));
  }
  return pkg;
}

Result<DecodedPart> decode_part(const std::vector<uint8_t>& bytes, const Package& package,
                                const PackageChunk& chunk, size_t part) {
  std::string where = "chunk at offset " + std::to_string(chunk.offset);
  const PackageChunk* first = package.chunks.data();
  if (!package.chunks.empty() && !std::less<const PackageChunk*>()(&chunk, first) &&
      std::less<const PackageChunk*>()(&chunk, first + package.chunks.size()))
    where = "chunk " + std::to_string(&chunk - first);
  if (chunk.kind != StreamStep::kMesh) return fail(where + ": not a mesh chunk");
  if (part >= chunk.parts.size())
    return fail(where + ": part " + std::to_string(part) + " out of range");
  uint64_t size = bytes.size();
  if (chunk.offset > size || chunk.size > size - chunk.offset)
    return fail(where + ": range past the end of the file");
  uint64_t offset = chunk.offset, end = chunk.offset + chunk.size;
  for (size_t i = 0; i <= part; ++i) {
    const PackagePart& p = chunk.parts[i];
    if (p.vertex_bytes > end - offset || p.index_bytes > end - offset - p.vertex_bytes ||
        p.update_bytes > end - offset - p.vertex_bytes - p.index_bytes)
      return fail(where + " part " + std::to_string(i) + ": bytes past the end of the chunk");
    if (i < part) offset += p.vertex_bytes + p.index_bytes + p.update_bytes;
  }
  where += " part " + std::to_string(part);
  const PackagePart& p = chunk.parts[part];
  if (Status s = check_part(p, package.meshes, where); !s) return s;

  DecodedPart out;
  const uint8_t* data = bytes.data() + offset;
  size_t nv = p.vertex_end - p.vertex_begin;
  if (nv > 0) {
    out.vertices.resize(nv * kPackedVertexBytes);
    if (meshopt_decodeVertexBuffer(out.vertices.data(), nv, kPackedVertexBytes, data,
                                   size_t(p.vertex_bytes)) != 0)
      return fail(where + ": vertex data does not decode");
  }
  size_t ni = size_t(p.face_end - p.face_begin) * 3;
  if (ni > 0) {
    out.indices.resize(ni);
    if (meshopt_decodeIndexBuffer(out.indices.data(), ni, sizeof(uint32_t), data + p.vertex_bytes,
                                  size_t(p.index_bytes)) != 0)
      return fail(where + ": index data does not decode");
    for (uint32_t i : out.indices)
      if (i >= p.vertex_end)
        return fail(where + ": index " + std::to_string(i) + " out of range (" +
                    std::to_string(p.vertex_end) + " vertices at this level)");
  }
  if (p.updates > 0) {
    std::vector<uint32_t> seq(size_t(p.updates) * 2);
    if (meshopt_decodeIndexSequence(seq.data(), seq.size(), sizeof(uint32_t),
                                    data + p.vertex_bytes + p.index_bytes,
                                    size_t(p.update_bytes)) != 0)
      return fail(where + ": update data does not decode");
    out.update_positions.assign(seq.begin(), seq.begin() + p.updates);
    out.update_values.assign(seq.begin() + p.updates, seq.end());
    uint64_t corners = uint64_t(p.face_begin) * 3;
    for (size_t i = 0; i < p.updates; ++i) {
      if (out.update_positions[i] >= corners ||
          (i > 0 && out.update_positions[i] <= out.update_positions[i - 1]))
        return fail(where + ": update " + std::to_string(i) + ": corner " +
                    std::to_string(out.update_positions[i]) + " out of range or out of order");
      if (out.update_values[i] >= p.vertex_end)
        return fail(where + ": update " + std::to_string(i) + ": vertex " +
                    std::to_string(out.update_values[i]) + " out of range");
    }
  }
  return out;
}

Result<std::vector<uint32_t>> decode_base_indices(const std::vector<uint8_t>& bytes,
                                                  const Package& package, size_t mesh) {
  std::string where = "mesh " + std::to_string(mesh) + " base_indices";
  if (mesh >= package.meshes.size()) return fail(where + ": no such mesh");
  const PackageMesh& m = package.meshes[mesh];
  uint64_t size = bytes.size();
  if (m.base_indices_offset > size || m.base_indices_size > size - m.base_indices_offset)
    return fail(where + ": range past the end of the file");
  if (m.base_faces > kMaxCount || m.base_faces > m.base_indices_size)
    return fail(where + ": too few bytes for " + std::to_string(m.base_faces) + " faces");
  std::vector<uint32_t> out(size_t(m.base_faces) * 3);
  if (!out.empty() && meshopt_decodeIndexBuffer(out.data(), out.size(), sizeof(uint32_t),
                                                bytes.data() + m.base_indices_offset,
                                                size_t(m.base_indices_size)) != 0)
    return fail(where + ": index data does not decode");
  for (uint32_t i : out)
    if (i >= m.base_vertices)
      return fail(where + ": index " + std::to_string(i) + " out of range (" +
                  std::to_string(m.base_vertices) + " base vertices)");
  return out;
}

}  // namespace meshmux
