// The stream package reader (stream/package.h; the part decoder: package_decode.cpp). Untrusted
// input: the header, the JSON (nesting depth checked before parsing, parsed without exceptions) and
// every field's type and range are checked before anything is exposed: ranges inside the file and
// after the header, base and chunks in order without overlap, parts inside their mesh,
// part bytes summing to the chunk size, counts bounded (kMaxStreamElements) and plausible for
// their byte sizes (the codecs cannot shrink data below a fixed ratio), orders permutations
// keeping the mesh chunks' order, so that decoding never allocates far beyond the file's size.
// A part's own checks (check_part) are package_decode.cpp's, which decode_part repeats (the
// Package may not come from these bytes).
#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "core/json_depth.h"
#include "stream/deflate.h"
#include "stream/package.h"
#include "stream/vsplit.h"  // part_size_plausible

namespace meshmux {

namespace {

using Json = nlohmann::json;

constexpr uint64_t kMaxCount = kMaxStreamElements;

Status fail(const std::string& message) {
  return Status::error("package: " + message, ErrorKind::kInput);
}

uint32_t get_u32(const std::vector<uint8_t>& in, size_t at) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= uint32_t(in[at + size_t(i)]) << (8 * i);
  return v;
}

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
// Three finite numbers.
Status get_vec3(const Json& obj, const char* key, double out[3], const std::string& where) {
  auto it = obj.find(key);
  if (it == obj.end() || !it->is_array() || it->size() != 3)
    return fail(where + ": \"" + key + "\" is not 3 numbers");
  for (size_t i = 0; i < 3; ++i)
    if (Status s = get_finite((*it)[i], out[i], where + ": " + key); !s) return s;
  return Status::ok();
}

Status get_number(const Json& obj, const char* key, double& out, const std::string& where) {
  auto it = obj.find(key);
  if (it == obj.end()) return fail(where + ": missing \"" + key + "\"");
  return get_finite(*it, out, where + ": \"" + key + "\"");
}

// The table's "view": how the distortion was measured (see format.h).
Status read_view(const Json& j, PackageView& v) {
  auto it = j.find("view");
  if (it == j.end() || !it->is_object()) return fail("\"view\" missing or not an object");
  const Json& e = *it;
  Status s;
  if (!(s = get_number(e, "fov_y_degrees", v.fov_y_degrees, "view")) ||
      !(s = get_number(e, "fill", v.fill, "view")) ||
      !(s = get_number(e, "clip_margin", v.clip_margin, "view")) ||
      !(s = get_number(e, "ambient", v.ambient, "view")) ||
      !(s = get_number(e, "diffuse", v.diffuse, "view")) ||
      !(s = get_vec3(e, "direction", v.direction, "view")) ||
      !(s = get_vec3(e, "light_direction", v.light_direction, "view")))
    return s;
  if (!(v.fov_y_degrees > 0 && v.fov_y_degrees < 180)) return fail("view: fov out of range");
  if (!(v.fill > 0) || !(v.clip_margin > 0)) return fail("view: fill or clip margin not positive");
  auto follows = e.find("light_follows_camera");
  if (follows == e.end() || !follows->is_boolean())
    return fail("view: \"light_follows_camera\" missing or not a boolean");
  v.light_follows_camera = follows->get<bool>();
  // Physically based shading; packages without the fields were shaded Lambert.
  auto shading = e.find("shading");
  if (shading != e.end()) {
    if (!shading->is_string() ||
        (shading->get<std::string>() != "lambert" && shading->get<std::string>() != "physical"))
      return fail("view: \"shading\" must be \"lambert\" or \"physical\"");
    v.physical = shading->get<std::string>() == "physical";
  }
  if (v.physical) {
    if (!(s = get_number(e, "environment", v.environment, "view")) ||
        !(s = get_number(e, "light_intensity", v.light_intensity, "view")))
      return s;
    if (!(v.environment >= 0 && v.environment <= 100) ||
        !(v.light_intensity >= 0 && v.light_intensity <= 1000))
      return fail("view: environment or light intensity out of range");
  }
  // The display the order was made for (optional).
  if (auto d = e.find("display"); d != e.end()) {
    if (!d->is_array() || d->size() != 2 || !(*d)[0].is_number_integer() ||
        !(*d)[1].is_number_integer())
      return fail("view: \"display\" must be two integers");
    const int64_t w = (*d)[0].get<int64_t>(), h = (*d)[1].get<int64_t>();
    if (w < 1 || h < 1 || w > 65536 || h > 65536) return fail("view: display out of range");
    v.display[0] = int(w), v.display[1] = int(h);
  }
  // The distortion's measure (optional: packages before it measured CIEDE2000).
  if (auto m = e.find("metric"); m != e.end()) {
    if (!m->is_string() || (m->get<std::string>() != "mse" && m->get<std::string>() != "ciede2000"))
      return fail("view: \"metric\" must be \"mse\" or \"ciede2000\"");
    v.mse = m->get<std::string>() == "mse";
  }
  return Status::ok();
}

// The table's "limits" must be the ones this reader enforces (a package written for other
// limits is refused, never trusted to raise ours).
Status check_limits(const Json& j) {
  auto it = j.find("limits");
  if (it == j.end() || !it->is_object()) return fail("\"limits\" missing or not an object");
  uint64_t elements = 0, side = 0, depth = 0;
  Status s;
  if (!(s = get_uint(*it, "max_elements", ~uint64_t(0), elements, "limits")) ||
      !(s = get_uint(*it, "max_texture_side", ~uint64_t(0), side, "limits")) ||
      !(s = get_uint(*it, "max_json_depth", ~uint64_t(0), depth, "limits")))
    return s;
  if (elements > kMaxStreamElements || side > kMaxTextureSide || depth > uint64_t(kMaxJsonDepth))
    return fail("limits: beyond what this reader accepts");
  return Status::ok();
}

Status get_side(const Json& obj, const char* key, int& out, const std::string& where) {
  uint64_t v = 0;
  if (Status s = get_uint(obj, key, kMaxTextureSide, v, where); !s) return s;
  if (v == 0) return fail(where + ": \"" + key + "\" is 0");
  out = int(v);
  return Status::ok();
}

// A part is [mesh, vertex_end, face_end, bytes]; it starts where its mesh stands (`held`: per
// mesh the vertices and faces of the base and the parts before it), which it then advances. A
// block mesh's part is [mesh, vertex_end, face_end, bytes, block]: it is block's range, sent
// once (`sent`: per mesh, per block), after the blocks it depends on.
Status read_part(const Json& j, const std::vector<PackageMesh>& meshes, uint64_t file_size,
                 std::vector<std::pair<uint32_t, uint32_t>>& held,
                 std::vector<std::vector<uint8_t>>& sent, PackagePart& p,
                 const std::string& where) {
  const bool blocky = j.is_array() && !j.empty() && j[0].is_number_unsigned() &&
                      j[0].get<uint64_t>() < meshes.size() &&
                      !meshes[j[0].get<uint64_t>()].blocks.empty();
  if (!j.is_array() || j.size() != (blocky ? 5u : 4u))
    return fail(where + (blocky ? " is not [mesh, vertex_end, face_end, bytes, block]"
                                : " is not [mesh, vertex_end, face_end, bytes]"));
  uint64_t v[5];
  // n is coded bytes: within the file.
  const uint64_t max[5] = {kMaxCount, kMaxCount, kMaxCount, file_size, 0xFFFF};
  for (size_t i = 0; i < j.size(); ++i) {
    if (!j[i].is_number_unsigned() && !(j[i].is_number_integer() && j[i].get<int64_t>() >= 0))
      return fail(where + ": entry " + std::to_string(i) + " is not an unsigned integer");
    v[i] = j[i].get<uint64_t>();
    if (v[i] > max[i])
      return fail(where + ": entry " + std::to_string(i) + " = " + std::to_string(v[i]) +
                  " exceeds " + std::to_string(max[i]));
  }
  if (v[0] >= meshes.size() || v[0] >= held.size())
    return fail(where + ": mesh " + std::to_string(v[0]) + " out of range");
  p.mesh = uint32_t(v[0]);
  p.vertex_begin = held[p.mesh].first, p.face_begin = held[p.mesh].second;
  p.vertex_end = uint32_t(v[1]), p.face_end = uint32_t(v[2]), p.bytes = v[3];
  if (blocky) {
    const std::vector<StreamBlock>& blocks = meshes[p.mesh].blocks;
    if (v[4] >= blocks.size())
      return fail(where + ": block " + std::to_string(v[4]) + " of " +
                  std::to_string(blocks.size()));
    const StreamBlock& b = blocks[v[4]];
    p.block = int32_t(v[4]);
    p.vertex_begin = b.vertex_begin, p.face_begin = b.face_begin;
    if (p.vertex_end != b.vertex_end || p.face_end != b.face_end)
      return fail(where + ": block " + std::to_string(v[4]) + " ends at vertex " +
                  std::to_string(b.vertex_end) + ", face " + std::to_string(b.face_end));
    std::vector<uint8_t>& got = sent[p.mesh];
    if (got[v[4]]) return fail(where + ": block " + std::to_string(v[4]) + " sent twice");
    for (uint32_t d : b.deps)
      if (!got[d] && (blocks[d].vertex_end > blocks[d].vertex_begin ||
                      blocks[d].face_end > blocks[d].face_begin))
        return fail(where + ": block " + std::to_string(v[4]) + " before block " +
                    std::to_string(d) + ", which it depends on");
    got[v[4]] = 1;
  }
  if (Status s = check_part(p, meshes, where); !s) return s;
  if (!blocky) held[p.mesh] = {p.vertex_end, p.face_end};
  return Status::ok();
}

// A mesh's "blocks" (stream/format.h "Blocks"): [level, error, box, deps] each, dependencies on
// earlier blocks only (no cycle can be read), the box on the grid and the error finite. Their
// ranges come from the parts (block_ranges).
Status read_blocks(const Json& list, PackageMesh& pm, const std::string& where) {
  if (!list.is_array() || list.empty() || list.size() > 0xFFFF)
    return fail(where + ": \"blocks\" is not an array of 1 to 65535 blocks");
  Status s;
  for (size_t k = 0; k < list.size(); ++k) {
    const Json& e = list[k];
    const std::string bw = where + ": block " + std::to_string(k);
    if (!e.is_array() || e.size() != 4) return fail(bw + " is not [level, error, box, deps]");
    StreamBlock b;
    if (!e[0].is_number_unsigned() || e[0].get<uint64_t>() > 0xFFFF)
      return fail(bw + ": level is not an integer up to 65535");
    b.level = uint32_t(e[0].get<uint64_t>());
    if (!(s = get_finite(e[1], b.error, bw + ": error"))) return s;
    if (!(b.error >= 0)) return fail(bw + ": error is negative");
    const Json& box = e[2];
    if (!box.is_array() || box.size() != 6) return fail(bw + ": box is not 6 integers");
    for (size_t i = 0; i < 6; ++i) {
      if (!box[i].is_number_unsigned() || box[i].get<uint64_t>() > 0xFFFF)
        return fail(bw + ": box is not 6 integers on the position grid");
      b.box[i] = uint16_t(box[i].get<uint64_t>());
    }
    for (int i = 0; i < 3; ++i)
      if (b.box[i] > b.box[i + 3]) return fail(bw + ": box minimum above maximum");
    const Json& deps = e[3];
    if (!deps.is_array()) return fail(bw + ": deps is not an array");
    for (const Json& d : deps) {
      if (!d.is_number_unsigned()) return fail(bw + ": a dependency is not a block index");
      const uint64_t x = d.get<uint64_t>();
      if (x >= list.size())
        return fail(bw + ": depends on block " + std::to_string(x) + ", which is missing");
      if (x >= k)
        return fail(bw + ": depends on block " + std::to_string(x) +
                    ", not an earlier one (a dependency cycle)");
      if (!b.deps.empty() && x <= b.deps.back())
        return fail(bw + ": dependencies not strictly ascending");
      b.deps.push_back(uint32_t(x));
    }
    pm.blocks.push_back(std::move(b));
  }
  return Status::ok();
}

// The blocks' ranges from the parts that name them (stream/format.h "Blocks"): each begins
// where the one before it ends (the first at the base), ends where its part does (or where it
// begins, named by none), the last at the mesh's end unless a completion ends its splits. A pass
// over the table's chunks before they are read (malformed entries are skipped here: the chunks'
// reading names them).
Status block_ranges(const Json& chunks, Package& pkg) {
  std::vector<std::vector<std::pair<uint64_t, uint64_t>>> ends(pkg.meshes.size());
  std::vector<uint8_t> completed(pkg.meshes.size(), 0);  // a completion ends the mesh's splits
  for (size_t m = 0; m < pkg.meshes.size(); ++m)
    ends[m].assign(pkg.meshes[m].blocks.size(), {UINT64_MAX, UINT64_MAX});
  if (chunks.is_array())
    for (const Json& c : chunks) {
      if (!c.is_object()) continue;
      auto meshes = c.find("meshes"), kind = c.find("kind");
      if (kind != c.end() && kind->is_string() && *kind == "complete" && meshes != c.end() &&
          meshes->is_array())
        for (const Json& e : *meshes)
          if (e.is_array() && !e.empty() && e[0].is_number_unsigned() &&
              e[0].get<uint64_t>() < completed.size())
            completed[e[0].get<uint64_t>()] = 1;
      auto parts = c.find("parts");
      if (parts == c.end() || !parts->is_array()) continue;
      for (const Json& p : *parts) {
        if (!p.is_array() || p.size() != 5) continue;
        bool ints = true;
        for (const Json& x : p) ints = ints && x.is_number_unsigned();
        if (!ints) continue;
        const uint64_t m = p[0].get<uint64_t>(), k = p[4].get<uint64_t>();
        if (m < ends.size() && k < ends[m].size() && ends[m][k].first == UINT64_MAX)
          ends[m][k] = {p[1].get<uint64_t>(), p[2].get<uint64_t>()};
      }
    }
  for (size_t m = 0; m < pkg.meshes.size(); ++m) {
    PackageMesh& pm = pkg.meshes[m];
    if (pm.blocks.empty()) continue;
    uint64_t vertex_at = pm.base_vertices, face_at = pm.base_faces;
    for (size_t k = 0; k < pm.blocks.size(); ++k) {
      StreamBlock& b = pm.blocks[k];
      const auto [v, f] = ends[m][k];
      b.vertex_begin = uint32_t(vertex_at), b.face_begin = uint32_t(face_at);
      if (v != UINT64_MAX) {
        if (v < vertex_at || f < face_at || v > pm.vertices || f > pm.faces)
          return fail("mesh " + std::to_string(m) + ": block " + std::to_string(k) +
                      " ends at vertex " + std::to_string(v) + ", face " + std::to_string(f) +
                      ", before it begins or past the mesh");
        vertex_at = v, face_at = f;
      }
      b.vertex_end = uint32_t(vertex_at), b.face_end = uint32_t(face_at);
    }
    if (!completed[m] && (vertex_at != pm.vertices || face_at != pm.faces))
      return fail("mesh " + std::to_string(m) + ": the blocks end at vertex " +
                  std::to_string(vertex_at) + ", face " + std::to_string(face_at) +
                  ", not at the mesh's end");
  }
  return Status::ok();
}

// The completion's "meshes" (stream/format.h "Completion"): [m, points, triangles, bytes], each
// mesh once, bitstreams of at least one byte summing to the chunk's size.
Status read_completion(const Json& j, const std::vector<PackageMesh>& meshes, PackageChunk& c,
                       const std::string& where) {
  auto list = j.find("meshes");
  if (list == j.end() || !list->is_array() || list->empty())
    return fail(where + ": \"meshes\" missing, not an array or empty");
  uint64_t sum = 0;
  std::vector<bool> seen(meshes.size(), false);
  for (size_t i = 0; i < list->size(); ++i) {
    const Json& e = (*list)[i];
    const std::string w = where + " mesh entry " + std::to_string(i);
    if (!e.is_array() || e.size() != 4) return fail(w + " is not [mesh, points, faces, bytes]");
    uint64_t v[4];
    const uint64_t max[4] = {meshes.size() ? meshes.size() - 1 : 0, kMaxCount, kMaxCount, c.size};
    for (size_t k = 0; k < 4; ++k) {
      if (!e[k].is_number_unsigned() && !(e[k].is_number_integer() && e[k].get<int64_t>() >= 0))
        return fail(w + ": entry " + std::to_string(k) + " is not an unsigned integer");
      v[k] = e[k].get<uint64_t>();
      if (v[k] > max[k] || (k == 0 && meshes.empty()))
        return fail(w + ": entry " + std::to_string(k) + " = " + std::to_string(v[k]) +
                    " out of range");
    }
    if (seen[size_t(v[0])]) return fail(w + ": mesh " + std::to_string(v[0]) + " twice");
    seen[size_t(v[0])] = true;
    if (v[3] == 0) return fail(w + ": empty bitstream");
    sum += v[3];
    if (sum > c.size) return fail(where + ": meshes hold more bytes than the chunk's");
    PackagePart p;
    p.mesh = uint32_t(v[0]), p.vertex_end = uint32_t(v[1]), p.face_end = uint32_t(v[2]);
    p.bytes = v[3];
    c.parts.push_back(p);
  }
  if (sum != c.size)
    return fail(where + ": meshes hold " + std::to_string(sum) + " bytes, the chunk " +
                std::to_string(c.size));
  return Status::ok();
}

// A map's "size", placed at `at` inside chunk `c` (then `at` is past it).
Status map_range(const Json& e, const PackageChunk& c, uint64_t& at, PackageMap& m,
                 const std::string& where) {
  if (Status s = get_uint(e, "size", c.size, m.size, where); !s) return s;
  if (m.size == 0) return fail(where + ": empty map");
  if (m.size > c.offset + c.size - at) return fail(where + ": maps hold more than the chunk");
  m.offset = at;
  at += m.size;
  return Status::ok();
}

// A texture chunk's "kept" maps (optional): the kept materials' images at the level's scale,
// their files after the channel maps' from `at` on (advanced past them).
Status read_kept(const Json& j, PackageChunk& c, uint64_t& at, const std::string& where) {
  auto kept = j.find("kept");
  if (kept == j.end()) return Status::ok();
  if (!kept->is_array()) return fail(where + ": \"kept\" is not an array");
  Status s;
  for (size_t i = 0; i < kept->size(); ++i) {
    const Json& e = (*kept)[i];
    std::string kw = where + " kept " + std::to_string(i);
    if (!e.is_object()) return fail(kw + " is not an object");
    auto mime = e.find("mime");
    if (mime == e.end() || !mime->is_string())
      return fail(kw + ": \"mime\" missing or not a string");
    PackageMap m;
    m.mime = mime->get<std::string>();
    if (!is_map_mime(m.mime)) return fail(kw + ": mime type is not JPEG, PNG or KTX2");
    uint64_t image = 0;
    if (!(s = get_uint(e, "image", kMaxKeptImages - 1, image, kw))) return s;
    m.image = int32_t(image);
    for (const PackageMap& before : c.kept)
      if (before.image == m.image) return fail(kw + ": image " + std::to_string(image) + " twice");
    if (!(s = get_side(e, "width", m.width, kw)) || !(s = get_side(e, "height", m.height, kw)))
      return s;
    if (!(s = map_range(e, c, at, m, kw))) return s;
    c.kept.push_back(std::move(m));
  }
  return Status::ok();
}

// `file_size`: the bytes after the data start; offsets are relative to it, and made absolute
// (+ data_start) on the way.
Status read_chunk(const Json& j, const Package& pkg, uint64_t file_size, uint64_t data_start,
                  std::vector<std::pair<uint32_t, uint32_t>>& held,
                  std::vector<std::vector<uint8_t>>& sent, PackageChunk& c,
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
  else if (k == "complete")
    c.kind = StreamStep::kComplete;
  else
    return fail(where + ": unknown kind");
  Status s;
  if (!(s = get_uint(j, "offset", file_size, c.offset, where))) return s;
  if (!(s = get_uint(j, "size", file_size, c.size, where))) return s;
  if (c.size > file_size - c.offset) return fail(where + ": range past the end of the file");
  c.offset += data_start;
  auto d = j.find("distortion");
  if (d == j.end()) return fail(where + ": missing \"distortion\"");
  if (!(s = get_finite(*d, c.distortion, where + ": \"distortion\""))) return s;
  if (c.kind == StreamStep::kTexture) {
    if (!(s = get_side(j, "width", c.width, where)) ||
        !(s = get_side(j, "height", c.height, where)))
      return s;
    auto maps = j.find("maps");
    if (maps == j.end() || !maps->is_array() || maps->empty())
      return fail(where + ": \"maps\" missing, not an array or empty");
    uint64_t at = c.offset;
    for (size_t i = 0; i < maps->size(); ++i) {
      const Json& e = (*maps)[i];
      std::string mw = where + " map " + std::to_string(i);
      if (!e.is_object()) return fail(mw + " is not an object");
      auto channel = e.find("channel"), mime = e.find("mime");
      if (channel == e.end() || !channel->is_string() || mime == e.end() || !mime->is_string())
        return fail(mw + ": \"channel\" or \"mime\" missing or not a string");
      PackageMap m;
      m.channel = channel->get<std::string>(), m.mime = mime->get<std::string>();
      if (!is_texture_channel(m.channel))
        return fail(mw + ": unknown channel \"" + m.channel + "\"");
      if ((i == 0) != (m.channel == kBaseColorChannel))
        return fail(mw + ": base_color must come first, once");
      for (const PackageMap& before : c.maps)
        if (before.channel == m.channel) return fail(mw + ": channel " + m.channel + " twice");
      if (!is_map_mime(m.mime)) return fail(mw + ": mime type is not JPEG, PNG or KTX2");
      if (!(s = map_range(e, c, at, m, mw))) return s;
      c.maps.push_back(std::move(m));
    }
    if (Status k = read_kept(j, c, at, where); !k) return k;
    if (at != c.offset + c.size)
      return fail(where + ": maps hold " + std::to_string(at - c.offset) + " bytes, the chunk " +
                  std::to_string(c.size));
    return Status::ok();
  }
  if (c.kind == StreamStep::kComplete) return read_completion(j, pkg.meshes, c, where);
  auto parts = j.find("parts");
  if (parts == j.end() || !parts->is_array())
    return fail(where + ": \"parts\" missing or not an array");
  uint64_t sum = 0;
  for (size_t i = 0; i < parts->size(); ++i) {
    PackagePart p;
    if (!(s = read_part((*parts)[i], pkg.meshes, file_size, held, sent, p,
                        where + " part " + std::to_string(i))))
      return s;
    sum += p.bytes;  // each ≤ the file size: no overflow
    if (sum > c.size)
      return fail(where + ": parts hold more bytes than the chunk's " + std::to_string(c.size));
    c.parts.push_back(p);
  }
  if (sum != c.size)
    return fail(where + ": parts hold " + std::to_string(sum) + " bytes, the chunk " +
                std::to_string(c.size));
  return Status::ok();
}

// The table's "meshes": counts, bounds and the position grid of each.
Status read_meshes(const Json& j, Package& pkg) {
  Status s;
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
    auto q = e.find("quantization");
    if (q == e.end() || !q->is_object())
      return fail(where + ": \"quantization\" missing or not an object");
    auto origin = q->find("origin");
    if (origin == q->end() || !origin->is_array() || origin->size() != 3)
      return fail(where + ": quantization \"origin\" is not 3 numbers");
    for (size_t i = 0; i < 3; ++i)
      if (!(s = get_finite((*origin)[i], pm.origin[i], where + ": quantization origin"))) return s;
    auto step = q->find("step");
    if (step == q->end()) return fail(where + ": quantization \"step\" missing");
    if (!(s = get_finite(*step, pm.step, where + ": quantization step"))) return s;
    if (!(pm.step > 0)) return fail(where + ": quantization step is not positive");
    if (auto blocks = e.find("blocks"); blocks != e.end()) {
      if (pkg.version < kBlockPackageVersion)
        return fail(where + ": \"blocks\" in a version " + std::to_string(pkg.version) +
                    " package");
      if (!(s = read_blocks(*blocks, pm, where))) return s;
    }
    pkg.meshes.push_back(pm);
  }

  return Status::ok();
}

// The table's "orders": permutations of the chunks that keep the mesh chunks' relative order,
// the first being the stored order.
Status read_orders(const Json& j, Package& pkg) {
  Status s;
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
      if (pkg.chunks[k].kind != StreamStep::kTexture) {  // mesh chunks and the completion
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
  return Status::ok();
}

// The block index (stream/format.h "Block index", a package with blocks, when it has one): read
// from right after the base and put where a package without one holds the same lists (each block
// mesh's "blocks" for its count, each mesh chunk's "parts"), so the table is read as one from there
// on. `end` moves past it.
Status merge_index(const std::vector<uint8_t>& bytes, uint64_t data_start, const Package& pkg,
                   Json& j, uint64_t& end) {
  auto index = j.find("index");
  if (pkg.version != kBlockPackageVersion) {
    if (index != j.end())
      return fail("\"index\" in a version " + std::to_string(pkg.version) + " package");
    return Status::ok();
  }
  if (index == j.end()) return Status::ok();  // the lists in the table itself
  if (!index->is_object()) return fail("\"index\" is not an object");
  Status s;
  uint64_t offset = 0, size = 0;
  const uint64_t data_size = bytes.size() - data_start;
  if (!(s = get_uint(*index, "offset", data_size, offset, "index")) ||
      !(s = get_uint(*index, "size", data_size, size, "index")))
    return s;
  if (data_start + offset != end || size == 0 || size > data_size - offset)
    return fail("index: not right after the base, empty, or past the end of the file");
  auto inflated = inflate_bytes(bytes.data() + data_start + offset, size_t(size), kMaxTableBytes);
  if (!inflated.ok()) return fail("index: " + inflated.status().message());
  const uint8_t* text = inflated->data();
  if (json_depth(text, inflated->size()) > kMaxJsonDepth) return fail("index nested too deeply");
  Json x = Json::parse(text, text + inflated->size(), nullptr, /*allow_exceptions=*/false);
  if (x.is_discarded() || !x.is_object()) return fail("index does not parse as an object");
  auto blocks = x.find("blocks"), parts = x.find("parts");
  auto meshes = j.find("meshes"), chunks = j.find("chunks");
  if (blocks == x.end() || !blocks->is_array() || parts == x.end() || !parts->is_array())
    return fail("index: \"blocks\" or \"parts\" missing or not an array");
  if (meshes == j.end() || !meshes->is_array() || blocks->size() != meshes->size())
    return fail("index: \"blocks\" does not hold one entry per mesh");
  for (size_t i = 0; i < blocks->size(); ++i) {
    Json& mesh = (*meshes)[i];
    auto count = mesh.is_object() ? mesh.find("blocks") : mesh.end();
    const Json& list = (*blocks)[i];
    const bool listed = !list.is_null();
    if (listed != (mesh.is_object() && count != mesh.end()) ||
        (listed && (!count->is_number_unsigned() || !list.is_array() ||
                    count->get<uint64_t>() != list.size())))
      return fail("mesh " + std::to_string(i) +
                  ": its \"blocks\" count and the index's list differ");
    if (listed) *count = list;
  }
  if (chunks == j.end() || !chunks->is_array()) return fail("\"chunks\" missing or not an array");
  size_t next = 0;
  for (Json& c : *chunks) {
    auto kind = c.is_object() ? c.find("kind") : c.end();
    if (!c.is_object() || kind == c.end() || !kind->is_string() || *kind != "mesh") continue;
    if (c.contains("parts")) return fail("index: a mesh chunk carries parts in the table too");
    if (next >= parts->size()) return fail("index: fewer part lists than mesh chunks");
    c["parts"] = (*parts)[next++];
  }
  if (next != parts->size()) return fail("index: more part lists than mesh chunks");
  end = data_start + offset + size;
  return Status::ok();
}

}  // namespace

Result<Package> read_package(const std::vector<uint8_t>& bytes) {
  if (bytes.empty()) return fail("empty file");
  if (bytes.size() < kPackageHeaderBytes)
    return fail(std::to_string(bytes.size()) + " bytes, too short for the 12-byte header");
  if (std::memcmp(bytes.data(), "MMXP", 4) != 0)
    return fail("not a meshmux package (magic is not \"MMXP\")");
  Package pkg;
  pkg.version = get_u32(bytes, 4);
  if (pkg.version != kPackageVersion && pkg.version != kBlockPackageVersion)
    return fail("version " + std::to_string(pkg.version) + " not supported");
  uint64_t file_size = bytes.size(), json_size = get_u32(bytes, 8);
  if (json_size > file_size - kPackageHeaderBytes)
    return fail("JSON table length " + std::to_string(json_size) + " past the end of the file (" +
                std::to_string(file_size) + " bytes)");
  if (json_size == 0) return fail("JSON table length 0");
  auto inflated =
      inflate_bytes(bytes.data() + kPackageHeaderBytes, size_t(json_size), kMaxTableBytes);
  if (!inflated.ok()) return fail("JSON table: " + inflated.status().message());
  const uint8_t* text = inflated->data();
  const size_t text_size = inflated->size();
  if (json_depth(text, text_size) > kMaxJsonDepth) return fail("JSON table nested too deeply");
  Json j = Json::parse(text, text + text_size, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return fail("JSON table does not parse");
  if (!j.is_object()) return fail("JSON table is not an object");
  Status s;
  uint64_t version = 0;
  if (!(s = get_uint(j, "version", 0xffffffffu, version, "table"))) return s;
  if (version != pkg.version)
    return fail("table version " + std::to_string(version) + " differs from the header's");
  if (!(s = read_view(j, pkg.view)) || !(s = check_limits(j))) return s;

  uint64_t data_start = kPackageHeaderBytes + json_size;
  auto base = j.find("base");
  if (base == j.end() || !base->is_object()) return fail("\"base\" missing or not an object");
  const uint64_t data_size = file_size - data_start;
  if (!(s = get_uint(*base, "offset", data_size, pkg.base_offset, "base"))) return s;
  if (!(s = get_uint(*base, "size", data_size, pkg.base_size, "base"))) return s;
  if (pkg.base_size == 0 || pkg.base_size > data_size - pkg.base_offset)
    return fail("base: range empty or past the end of the file");
  pkg.base_offset += data_start;
  auto deflated = base->find("deflated");
  if (deflated == base->end() || !deflated->is_boolean())
    return fail("base: \"deflated\" missing or not a boolean");
  pkg.base_deflated = deflated->get<bool>();
  if (!(s = get_uint(*base, "glb_size", kMaxBaseBytes, pkg.base_glb_size, "base"))) return s;
  if (!pkg.base_deflated && pkg.base_glb_size != pkg.base_size)
    return fail("base: glb_size differs from the stored size of a base stored as it is");
  auto whole = base->find("whole");  // optional: a base that is the whole model
  if (whole != base->end() && !whole->is_boolean()) return fail("base: \"whole\" is not a boolean");
  pkg.base_whole = whole != base->end() && whole->get<bool>();
  auto base_d = base->find("distortion");
  if (base_d == base->end()) return fail("base: missing \"distortion\"");
  if (!(s = get_finite(*base_d, pkg.base_distortion, "base: \"distortion\""))) return s;
  uint64_t end = pkg.base_offset + pkg.base_size;
  if (!(s = merge_index(bytes, data_start, pkg, j, end))) return s;

  if (!(s = read_meshes(j, pkg))) return s;

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
  if (!(s = block_ranges(*chunks, pkg))) return s;
  std::vector<std::pair<uint32_t, uint32_t>> held;  // per mesh: vertices, faces so far
  std::vector<std::vector<uint8_t>> sent;           // per block mesh, per block: its part read
  for (const PackageMesh& m : pkg.meshes) {
    held.push_back({m.base_vertices, m.base_faces});
    sent.emplace_back(m.blocks.size(), 0);
  }
  bool completed = false;  // the completion was read: no mesh chunk may follow
  for (size_t i = 0; i < chunks->size(); ++i) {
    std::string where = "chunk " + std::to_string(i);
    PackageChunk c;
    if (!(s = read_chunk((*chunks)[i], pkg, data_size, data_start, held, sent, c, where))) return s;
    if (c.offset < end)
      return fail(where + ": offset " + std::to_string(c.offset) +
                  " overlaps the base or the chunk before");
    if (c.kind == StreamStep::kTexture && pkg.texture_width == 0)
      return fail(where + ": texture chunk in a package without texture");
    if (c.kind != StreamStep::kTexture && pkg.base_whole)
      return fail(where + ": mesh refinement in a package whose base is the whole model");
    if (c.kind != StreamStep::kTexture && completed)
      return fail(where + ": a mesh chunk after the completion");
    completed = completed || c.kind == StreamStep::kComplete;
    end = c.offset + c.size;
    pkg.chunks.push_back(std::move(c));
  }

  // Every block that sends anything is sent.
  for (size_t m = 0; m < pkg.meshes.size(); ++m)
    for (size_t k = 0; k < pkg.meshes[m].blocks.size(); ++k) {
      const StreamBlock& b = pkg.meshes[m].blocks[k];
      if (!sent[m][k] && (b.vertex_end > b.vertex_begin || b.face_end > b.face_begin))
        return fail("mesh " + std::to_string(m) + ": block " + std::to_string(k) +
                    " is in no part");
    }
  if (!(s = read_orders(j, pkg))) return s;
  return pkg;
}

}  // namespace meshmux
