// The stream package writer (stream/package.h; the format: stream/format.h). It lays out bytes that
// were encoded upstream (the multiplexer's mesh parts, the texture levels); it only deflates
// (zlib, level 9) the JSON table and, when that makes it smaller, the base .glb: on small
// models those were a third of the package (format 11). Offsets in the table count from its
// end. Output is a pure function of the input.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string>

#include "stream/deflate.h"
#include "stream/package.h"

namespace meshmux {

namespace {

using OrderedJson = nlohmann::ordered_json;

Status fail(const std::string& message) {
  return Status::error("package: " + message, ErrorKind::kInternal);
}

void put_u32(std::vector<uint8_t>& out, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) out[at + size_t(i)] = uint8_t(v >> (8 * i));
}

// A chunk's payload and table entry, offsets filled in later.
struct Chunk {
  StreamStep::Kind kind = StreamStep::kMesh;
  double distortion = 0;
  std::vector<PackagePart> parts;
  const TextureLevel* texture = nullptr;
  std::vector<uint8_t> payload;
};

Status check_texture_level(const TextureLevel& t, const std::string& where) {
  if (t.encoded.empty() || t.width <= 0 || t.height <= 0 || uint64_t(t.width) > kMaxTextureSide ||
      uint64_t(t.height) > kMaxTextureSide)
    return fail(where + "texture level " + std::to_string(t.width) + "x" +
                std::to_string(t.height) + " is empty or has a bad size");
  if (!is_map_mime(t.mime_type))
    return fail(where + "texture level mime type \"" + t.mime_type + "\" is not JPEG, PNG or KTX2");
  for (const TextureMap& m : t.other_maps) {
    if (!is_texture_channel(m.channel) || m.channel == kBaseColorChannel)
      return fail(where + "texture level map channel \"" + m.channel +
                  "\" is not a further channel");
    if (m.encoded.empty() || !is_map_mime(m.mime_type))
      return fail(where + "texture level " + m.channel + " map is empty or not JPEG, PNG or KTX2");
  }
  for (size_t i = 0; i < t.kept.size(); ++i) {
    const KeptMap& k = t.kept[i];
    for (size_t b = 0; b < i; ++b)
      if (t.kept[b].image == k.image)
        return fail(where + "texture level kept image " + std::to_string(k.image) + " twice");
    if (k.image < 0 || uint64_t(k.image) >= kMaxKeptImages || k.width <= 0 || k.height <= 0 ||
        uint64_t(k.width) > kMaxTextureSide || uint64_t(k.height) > kMaxTextureSide)
      return fail(where + "texture level kept image " + std::to_string(k.image) +
                  ": bad index or size");
    if (k.encoded.empty() || !is_map_mime(k.mime_type))
      return fail(where + "texture level kept image " + std::to_string(k.image) +
                  " is empty or not JPEG, PNG or KTX2");
  }
  return Status::ok();
}

Status check_input(const PackageInput& in) {
  if (in.base_glb.empty()) return fail("empty base .glb");
  for (size_t m = 0; m < in.meshes.size(); ++m) {
    const MeshStreamBase& b = in.meshes[m];
    if (b.vertices > kMaxStreamElements || b.faces > kMaxStreamElements ||
        b.base_vertices > b.vertices || b.base_faces > b.faces)
      return fail("mesh " + std::to_string(m) + ": counts out of range");
  }
  if (in.textures && !in.textures->levels.empty())
    if (Status s = check_texture_level(in.textures->levels.back(), "full "); !s) return s;
  if (!std::isfinite(in.base_distortion)) return fail("base distortion is not finite");
  return Status::ok();
}

// One chunk per step: a texture level's file as is, or a mesh layer's encoded parts in order.
// Each mesh layer may be used once, in increasing order (refinements only add).
Result<std::vector<Chunk>> build_chunks(const PackageInput& in) {
  std::vector<Chunk> chunks;
  size_t next_layer = 1;
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
      if (Status s = check_texture_level(t, where); !s) return s;
      c.kind = StreamStep::kTexture;
      c.texture = &t;
      c.payload = t.encoded;
      for (const TextureMap& m : t.other_maps)
        c.payload.insert(c.payload.end(), m.encoded.begin(), m.encoded.end());
      for (const KeptMap& m : t.kept)
        c.payload.insert(c.payload.end(), m.encoded.begin(), m.encoded.end());
    } else {
      if (in.base_whole)
        return fail(where + "a mesh layer in a package whose base is the whole model");
      if (!in.mesh_layers || step.mesh_layer >= in.mesh_layers->size() ||
          step.mesh_layer < next_layer)
        return fail(where + "mesh layer " + std::to_string(step.mesh_layer) +
                    " out of range or out of order");
      next_layer = step.mesh_layer + 1;
      if (!in.mesh_chunks || in.mesh_chunks->size() != in.mesh_layers->size())
        return fail(where + "no payload for mesh layer " + std::to_string(step.mesh_layer));
      if (!in.completion.empty() && step.mesh_layer + 1 == in.mesh_layers->size()) {
        c.kind = StreamStep::kComplete;
        uint64_t sum = 0;
        for (const CompletionMesh& cm : in.completion) {
          if (cm.mesh >= in.meshes.size() || cm.data.empty())
            return fail(where + "completion of mesh " + std::to_string(cm.mesh) +
                        " out of range or empty");
          PackagePart p;
          p.mesh = cm.mesh, p.vertex_end = cm.vertices, p.face_end = cm.faces;
          p.bytes = cm.data.size();
          sum += p.bytes;
          c.parts.push_back(p);
        }
        c.payload = (*in.mesh_chunks)[step.mesh_layer];
        if (sum != c.payload.size() || !(*in.mesh_layers)[step.mesh_layer].empty())
          return fail(where + "the completion's payload is not its meshes' bitstreams");
        chunks.push_back(std::move(c));
        continue;
      }
      for (const EncodedMeshPart& part : (*in.mesh_layers)[step.mesh_layer]) {
        if (part.part.mesh >= in.meshes.size())
          return fail(where + "part of mesh " + std::to_string(part.part.mesh) + " out of range");
        c.parts.push_back(part.part);
      }
      c.payload = (*in.mesh_chunks)[step.mesh_layer];
      if (!c.parts.empty() && c.payload.empty()) return fail(where + "empty mesh payload");
    }
    chunks.push_back(std::move(c));
  }
  return chunks;
}

// The stream's own order, then the baselines, each checked to be a permutation that keeps the
// mesh steps in order.
Result<std::vector<StreamOrder>> check_orders(const PackageInput& in) {
  std::vector<StreamOrder> orders;
  StreamOrder own;
  own.name = "rate-distortion";
  for (size_t k = 0; k < in.steps.size(); ++k)
    own.steps.push_back(uint32_t(k)), own.distortion.push_back(in.steps[k].distortion);
  orders.push_back(std::move(own));
  for (const StreamOrder& o : in.orders) {
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
  return orders;
}

// A float as the double of its shortest decimal that reads back as the same float (the JSON
// then holds "0.8", not "0.800000011920929"); readers casting to float get it exactly.
double short_float(float f) {
  char buf[32];
  for (int digits = 6; digits <= 9; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, double(f));
    if (std::strtof(buf, nullptr) == f) break;
  }
  return std::strtod(buf, nullptr);
}

OrderedJson view_json(const PackageInput& in) {
  const PackageView& v = in.view;
  auto f = [](double x) { return short_float(float(x)); };
  OrderedJson j = {{"fov_y_degrees", f(v.fov_y_degrees)},
                   {"fill", f(v.fill)},
                   {"direction", {f(v.direction[0]), f(v.direction[1]), f(v.direction[2])}},
                   {"clip_margin", f(v.clip_margin)},
                   {"ambient", f(v.ambient)},
                   {"diffuse", f(v.diffuse)},
                   {"light_direction",
                    {f(v.light_direction[0]), f(v.light_direction[1]), f(v.light_direction[2])}},
                   {"light_follows_camera", v.light_follows_camera},
                   {"shading", v.physical ? "physical" : "lambert"},
                   {"environment", f(v.environment)},
                   {"light_intensity", f(v.light_intensity)}};
  if (v.display[0] > 0 && v.display[1] > 0) j["display"] = {v.display[0], v.display[1]};
  j["metric"] = v.mse ? "mse" : "ciede2000";
  return j;
}

// 16 when a mesh is a block hierarchy (stream/format.h "Blocks"), else 15: a chain's package
// stays byte for byte what it was.
uint32_t package_version(const PackageInput& in) {
  for (const MeshStreamBase& m : in.meshes)
    if (!m.blocks.empty()) return kBlockPackageVersion;
  return kPackageVersion;
}

OrderedJson blocks_json(const MeshStreamBase& b) {
  OrderedJson blocks = OrderedJson::array();
  for (const StreamBlock& x : b.blocks)
    blocks.push_back({x.level,
                      short_float(float(x.error)),
                      {x.box[0], x.box[1], x.box[2], x.box[3], x.box[4], x.box[5]},
                      x.deps});
  return blocks;
}

OrderedJson parts_json(const Chunk& c) {
  OrderedJson parts = OrderedJson::array();
  for (const PackagePart& p : c.parts)
    if (p.block >= 0)
      parts.push_back({p.mesh, p.vertex_end, p.face_end, p.bytes, p.block});
    else
      parts.push_back({p.mesh, p.vertex_end, p.face_end, p.bytes});
  return parts;
}

// The block index (stream/format.h "Block index"): every mesh's blocks (null for a chain) and
// every mesh chunk's parts, in stored order.
std::string index_json(const PackageInput& in, const std::vector<Chunk>& chunks) {
  OrderedJson j, blocks = OrderedJson::array(), parts = OrderedJson::array();
  for (const MeshStreamBase& b : in.meshes)
    blocks.push_back(b.blocks.empty() ? OrderedJson(nullptr) : blocks_json(b));
  for (const Chunk& c : chunks)
    if (c.kind == StreamStep::kMesh) parts.push_back(parts_json(c));
  j["blocks"] = std::move(blocks);
  j["parts"] = std::move(parts);
  return j.dump();
}

// The JSON table. Offsets count from the end of the table (the data start), so the table does
// not depend on its own compressed length. `base_stored`: the base's bytes as stored;
// `index_stored`: the block index's (a package with blocks: the blocks and the mesh chunks'
// parts are there, not here), else 0.
std::string table_json(const PackageInput& in, const std::vector<Chunk>& chunks,
                       const std::vector<StreamOrder>& orders, uint64_t base_stored,
                       bool base_deflated, uint64_t index_stored) {
  const bool indexed = package_version(in) == kBlockPackageVersion;
  const uint64_t data_start = 0;
  OrderedJson j;
  j["version"] = package_version(in);
  j["view"] = view_json(in);
  j["limits"] = {{"max_elements", kMaxStreamElements},
                 {"max_texture_side", kMaxTextureSide},
                 {"max_json_depth", kMaxJsonDepth}};
  j["base"] = {{"offset", data_start},
               {"size", base_stored},
               {"deflated", base_deflated},
               {"glb_size", uint64_t(in.base_glb.size())},
               {"distortion", in.base_distortion}};
  if (in.base_whole) j["base"]["whole"] = true;
  if (indexed) j["index"] = {{"offset", data_start + base_stored}, {"size", index_stored}};
  OrderedJson ms = OrderedJson::array();
  uint64_t offset = data_start + base_stored + (indexed ? index_stored : 0);
  for (const MeshStreamBase& b : in.meshes) {
    const Bounds& box = b.bounds;
    OrderedJson e;
    e["vertices"] = b.vertices, e["faces"] = b.faces;
    e["base_vertices"] = b.base_vertices, e["base_faces"] = b.base_faces;
    e["bounds"] = {short_float(box.min.x), short_float(box.min.y), short_float(box.min.z),
                   short_float(box.max.x), short_float(box.max.y), short_float(box.max.z)};
    const PositionQuantization& q = b.quantization;
    e["quantization"] = {{"origin", {double(q.origin.x), double(q.origin.y), double(q.origin.z)}},
                         {"step", q.step}};
    if (!b.blocks.empty()) e["blocks"] = b.blocks.size();  // the list: in the index
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
    e["kind"] = c.kind == StreamStep::kMesh       ? "mesh"
                : c.kind == StreamStep::kComplete ? "complete"
                                                  : "texture";
    e["offset"] = offset, e["size"] = uint64_t(c.payload.size()), e["distortion"] = c.distortion;
    if (c.kind == StreamStep::kComplete) {
      OrderedJson meshes = OrderedJson::array();
      for (const PackagePart& p : c.parts)
        meshes.push_back({p.mesh, p.vertex_end, p.face_end, p.bytes});
      e["meshes"] = std::move(meshes);
    } else if (c.kind == StreamStep::kMesh) {
      if (!indexed) e["parts"] = parts_json(c);
    } else {
      e["width"] = c.texture->width, e["height"] = c.texture->height;
      OrderedJson maps = OrderedJson::array();
      maps.push_back({{"channel", kBaseColorChannel},
                      {"mime", c.texture->mime_type},
                      {"size", uint64_t(c.texture->encoded.size())}});
      for (const TextureMap& m : c.texture->other_maps)
        maps.push_back(
            {{"channel", m.channel}, {"mime", m.mime_type}, {"size", uint64_t(m.encoded.size())}});
      e["maps"] = std::move(maps);
      if (!c.texture->kept.empty()) {
        OrderedJson kept = OrderedJson::array();
        for (const KeptMap& k : c.texture->kept)
          kept.push_back({{"image", k.image},
                          {"width", k.width},
                          {"height", k.height},
                          {"mime", k.mime_type},
                          {"size", uint64_t(k.encoded.size())}});
        e["kept"] = std::move(kept);
      }
    }
    offset += c.payload.size();
    cs.push_back(std::move(e));
  }
  j["chunks"] = std::move(cs);
  OrderedJson os = OrderedJson::array();
  for (const StreamOrder& o : orders)
    os.push_back({{"name", o.name}, {"chunks", o.steps}, {"distortion", o.distortion}});
  j["orders"] = std::move(os);
  // "view_table": the distortion of every cell (mesh layers received × texture levels received)
  // from each view of the viewing sphere, so that a client re-plans the order for its camera (Yang,
  // Shen and Kuo, "Progressive coding of 3D textured graphic model via joint mesh-texture
  // optimization" §3: interpolated over the viewing mesh's triangle around the camera direction).
  // Cells row-major (i × texture_layers + j); null where not measured. The k-th mesh chunk of the
  // stored order is mesh layer k + 1, the k-th texture chunk texture level k + 1.
  const ViewTable* vt = in.view_table;
  if (vt && vt->mesh_layers > 1 && vt->texture_layers > 1 && !vt->directions.empty() &&
      vt->cells.size() == size_t(vt->mesh_layers) * size_t(vt->texture_layers)) {
    OrderedJson dirs = OrderedJson::array(), tris = OrderedJson::array(),
                cells = OrderedJson::array();
    for (const Vec3& d : vt->directions)
      dirs.push_back({short_float(d.x), short_float(d.y), short_float(d.z)});
    for (const auto& t : vt->triangles) tris.push_back({t[0], t[1], t[2]});
    for (const std::vector<double>& c : vt->cells) {
      if (c.size() != vt->directions.size()) {
        cells.push_back(nullptr);
        continue;
      }
      OrderedJson values = OrderedJson::array();
      for (double v : c) values.push_back(short_float(float(v)));
      cells.push_back(std::move(values));
    }
    j["view_table"] = {{"directions", std::move(dirs)},
                       {"triangles", std::move(tris)},
                       {"mesh_layers", vt->mesh_layers},
                       {"texture_layers", vt->texture_layers},
                       {"distortion", std::move(cells)}};
    // Each texture level's width, the base's first: a client re-reading the texture axis for a
    // smaller canvas needs the base's, which no chunk carries.
    if (in.textures && in.textures->levels.size() == size_t(vt->texture_layers)) {
      OrderedJson widths = OrderedJson::array();
      for (const TextureLevel& l : in.textures->levels) widths.push_back(l.width);
      j["view_table"]["texture_widths"] = std::move(widths);
    }
  }
  return j.dump();
}

}  // namespace

Result<std::vector<uint8_t>> write_package(const PackageInput& in) {
  if (Status s = check_input(in); !s) return s;
  auto chunks = build_chunks(in);
  if (!chunks.ok()) return chunks.status();
  auto orders = check_orders(in);
  if (!orders.ok()) return orders.status();

  // The base, deflated when that is smaller (a meshopt-coded mesh and the glTF JSON shrink by
  // a third to a half; a JPEG level does not).
  std::vector<uint8_t> deflated_base = deflate_bytes(in.base_glb);
  const bool base_deflated = deflated_base.size() < in.base_glb.size();
  const std::vector<uint8_t>& base = base_deflated ? deflated_base : in.base_glb;
  std::vector<uint8_t> table, index;
  try {
    if (package_version(in) == kBlockPackageVersion) {
      const std::string text = index_json(in, *chunks);
      index = deflate_bytes(std::vector<uint8_t>(text.begin(), text.end()));
    }
    const std::string text =
        table_json(in, *chunks, *orders, base.size(), base_deflated, index.size());
    table = deflate_bytes(std::vector<uint8_t>(text.begin(), text.end()));
  } catch (const std::exception& e) {
    return fail(std::string("JSON table: ") + e.what());
  }
  if (table.size() > 0xffffffffu) return fail("JSON table too large");

  uint64_t total = kPackageHeaderBytes + table.size() + base.size() + index.size();
  for (const Chunk& c : *chunks) total += c.payload.size();
  std::vector<uint8_t> out;
  out.reserve(size_t(total));
  out.resize(kPackageHeaderBytes);
  std::memcpy(out.data(), "MMXP", 4);
  put_u32(out, 4, package_version(in));
  put_u32(out, 8, uint32_t(table.size()));
  out.insert(out.end(), table.begin(), table.end());
  out.insert(out.end(), base.begin(), base.end());
  out.insert(out.end(), index.begin(), index.end());
  for (const Chunk& c : *chunks) out.insert(out.end(), c.payload.begin(), c.payload.end());
  return out;
}

}  // namespace meshmux
