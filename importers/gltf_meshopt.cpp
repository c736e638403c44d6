// EXT_meshopt_compression (Khronos glTF extension, as gltfpack and glTF-Transform write it):
// bufferViews whose data is meshoptimizer-coded in another buffer, with a "fallback" buffer
// that holds no data. tinygltf 2.7 knows nothing of it (and rejects the data-less fallback
// buffer), so the GLB is rewritten before tinygltf sees it: every compressed view is decoded
// with meshoptimizer's own decoders (modes ATTRIBUTES, TRIANGLES, INDICES; filters OCTAHEDRAL,
// QUATERNION, EXPONENTIAL), its bytes appended to the BIN chunk and the view pointed at them;
// fallback buffers are dropped and buffer indices renumbered. Every offset and length is checked
// against the chunk before use; decoded sizes are bounded by `max_decoded`.
#include <meshoptimizer.h>

#include <algorithm>
#include <cstring>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/status.h"

namespace meshmux {

namespace {

using Json = nlohmann::json;

bool get_u64(const Json& o, const char* key, uint64_t* out) {
  auto it = o.find(key);
  if (it == o.end() || !it->is_number_unsigned()) return false;
  *out = it->get<uint64_t>();
  return true;
}

// Decodes one compressed view into `out` (count × stride bytes). Returns "" or the reason.
std::string decode_view(const Json& ext, const std::vector<uint8_t>& source,
                        std::vector<uint8_t>& out, uint64_t max_decoded) {
  uint64_t offset = 0, length = 0, stride = 0, count = 0;
  if (!get_u64(ext, "byteLength", &length) || !get_u64(ext, "byteStride", &stride) ||
      !get_u64(ext, "count", &count))
    return "byteLength, byteStride or count missing";
  get_u64(ext, "byteOffset", &offset);
  if (offset > source.size() || length > source.size() - offset)
    return "compressed data [" + std::to_string(offset) + ", +" + std::to_string(length) +
           ") outside its buffer (" + std::to_string(source.size()) + " bytes)";
  if (stride == 0 || stride > 256 || count > max_decoded / stride)
    return "count " + std::to_string(count) + " × stride " + std::to_string(stride) +
           " out of range";
  std::string mode = ext.value("mode", std::string());
  std::string filter = ext.value("filter", std::string("NONE"));
  out.assign(size_t(count * stride), 0);
  const unsigned char* src = source.data() + offset;
  int rc = -1;
  if (mode == "ATTRIBUTES") {
    if (stride % 4) return "ATTRIBUTES stride " + std::to_string(stride) + " is not a multiple of 4";
    rc = meshopt_decodeVertexBuffer(out.data(), size_t(count), size_t(stride), src, size_t(length));
  } else if (mode == "TRIANGLES" || mode == "INDICES") {
    if (stride != 2 && stride != 4) return "index stride " + std::to_string(stride);
    if (mode == "TRIANGLES" && count % 3) return "TRIANGLES count is not a multiple of 3";
    rc = mode == "TRIANGLES"
             ? meshopt_decodeIndexBuffer(out.data(), size_t(count), size_t(stride), src,
                                         size_t(length))
             : meshopt_decodeIndexSequence(out.data(), size_t(count), size_t(stride), src,
                                           size_t(length));
  } else {
    return "unknown mode \"" + mode + "\"";
  }
  if (rc != 0) return "data does not decode (" + mode + ")";
  if (filter == "OCTAHEDRAL") {
    if (stride != 4 && stride != 8) return "OCTAHEDRAL stride " + std::to_string(stride);
    meshopt_decodeFilterOct(out.data(), size_t(count), size_t(stride));
  } else if (filter == "QUATERNION") {
    if (stride != 8) return "QUATERNION stride " + std::to_string(stride);
    meshopt_decodeFilterQuat(out.data(), size_t(count), size_t(stride));
  } else if (filter == "EXPONENTIAL") {
    if (stride % 4) return "EXPONENTIAL stride " + std::to_string(stride);
    meshopt_decodeFilterExp(out.data(), size_t(count), size_t(stride));
  } else if (filter != "NONE") {
    return "unknown filter \"" + filter + "\"";
  }
  return "";
}

}  // namespace

// Rewrites a GLB that uses EXT_meshopt_compression into plain glTF (see above). Returns false
// (and nothing changed) when the file does not use it; an error status when it does but cannot
// be decoded. `file` names the input in messages.
Result<bool> decode_meshopt_glb(std::vector<uint8_t>& data, const std::string& file,
                                uint64_t max_decoded) {
  static const char kNeedle[] = "EXT_meshopt_compression";
  if (std::search(data.begin(), data.end(), kNeedle, kNeedle + sizeof kNeedle - 1) == data.end())
    return false;
  auto fail = [&](const std::string& why) {
    return Status::error("gltf: " + file + ": EXT_meshopt_compression: " + why, ErrorKind::kInput);
  };
  if (data.size() < 20) return false;
  uint32_t json_len, json_type;
  std::memcpy(&json_len, data.data() + 12, 4);
  std::memcpy(&json_type, data.data() + 16, 4);
  if (json_type != 0x4E4F534Au || size_t(json_len) > data.size() - 20) return false;
  Json doc = Json::parse(data.begin() + 20, data.begin() + 20 + long(json_len), nullptr, false);
  if (doc.is_discarded() || !doc.is_object() || !doc.contains("bufferViews") ||
      !doc.contains("buffers") || !doc["buffers"].is_array() || !doc["bufferViews"].is_array())
    return false;
  // The BIN chunk: buffer 0's bytes.
  size_t bin_at = 20 + size_t(json_len);
  while (bin_at % 4) ++bin_at;
  std::vector<uint8_t> bin;
  if (bin_at + 8 <= data.size()) {
    uint32_t len, type;
    std::memcpy(&len, data.data() + bin_at, 4);
    std::memcpy(&type, data.data() + bin_at + 4, 4);
    if (type != 0x004E4942u || size_t(len) > data.size() - bin_at - 8)
      return fail("BIN chunk malformed");
    bin.assign(data.begin() + long(bin_at + 8), data.begin() + long(bin_at + 8 + len));
  }
  Json& buffers = doc["buffers"];
  // Which buffers are fallbacks (no data); every other buffer must be the BIN chunk here.
  std::vector<bool> fallback(buffers.size(), false);
  for (size_t b = 0; b < buffers.size(); ++b) {
    const Json& buf = buffers[b];
    if (buf.is_object() && buf.contains("extensions") && buf["extensions"].is_object() &&
        buf["extensions"].contains(kNeedle))
      fallback[b] = true;
    else if (b != 0 || (buf.is_object() && buf.contains("uri")))
      return fail("buffer " + std::to_string(b) +
                  " is not the GLB's BIN chunk (external buffers are not supported with it)");
  }
  uint64_t decoded_total = 0;
  size_t views = 0;
  for (size_t v = 0; v < doc["bufferViews"].size(); ++v) {
    Json& view = doc["bufferViews"][v];
    if (!view.is_object() || !view.contains("extensions") || !view["extensions"].is_object() ||
        !view["extensions"].contains(kNeedle))
      continue;
    const Json& ext = view["extensions"][kNeedle];
    uint64_t src_buffer = 0;
    if (!ext.is_object() || !get_u64(ext, "buffer", &src_buffer) || src_buffer >= buffers.size() ||
        fallback[src_buffer])
      return fail("bufferView " + std::to_string(v) + ": no source buffer");
    std::vector<uint8_t> out;
    std::string why = decode_view(ext, bin, out, max_decoded - decoded_total);
    if (!why.empty()) return fail("bufferView " + std::to_string(v) + ": " + why);
    decoded_total += out.size();
    while (bin.size() % 4) bin.push_back(0);
    view["buffer"] = 0;
    view["byteOffset"] = uint64_t(bin.size());
    view["byteLength"] = uint64_t(out.size());
    view["extensions"].erase(kNeedle);
    if (view["extensions"].empty()) view.erase("extensions");
    bin.insert(bin.end(), out.begin(), out.end());
    ++views;
  }
  // No view may still read a fallback buffer; then the fallbacks go and indices shift.
  std::vector<int64_t> renumber(buffers.size(), -1);
  Json kept = Json::array();
  for (size_t b = 0; b < buffers.size(); ++b)
    if (!fallback[b]) renumber[b] = int64_t(kept.size()), kept.push_back(buffers[b]);
  for (size_t v = 0; v < doc["bufferViews"].size(); ++v) {
    Json& view = doc["bufferViews"][v];
    uint64_t b = 0;
    if (!view.is_object() || !get_u64(view, "buffer", &b) || b >= buffers.size()) continue;
    if (renumber[b] < 0) return fail("bufferView " + std::to_string(v) + " reads a fallback buffer");
    view["buffer"] = renumber[b];
  }
  if (kept.empty()) kept.push_back(Json::object());
  kept[0]["byteLength"] = uint64_t(bin.size());
  doc["buffers"] = kept;
  for (const char* list : {"extensionsRequired", "extensionsUsed"}) {
    if (!doc.contains(list) || !doc[list].is_array()) continue;
    Json rest = Json::array();
    for (const Json& e : doc[list])
      if (!(e.is_string() && e.get<std::string>() == kNeedle)) rest.push_back(e);
    doc[list] = rest;
  }
  // Rebuild the container: header, JSON chunk, BIN chunk.
  std::string text = doc.dump();
  while (text.size() % 4) text.push_back(' ');
  while (bin.size() % 4) bin.push_back(0);
  std::vector<uint8_t> out(data.begin(), data.begin() + 12);
  auto put32 = [&](uint32_t v) {
    out.insert(out.end(), reinterpret_cast<uint8_t*>(&v), reinterpret_cast<uint8_t*>(&v) + 4);
  };
  put32(uint32_t(text.size()));
  put32(0x4E4F534Au);
  out.insert(out.end(), text.begin(), text.end());
  put32(uint32_t(bin.size()));
  put32(0x004E4942u);
  out.insert(out.end(), bin.begin(), bin.end());
  uint32_t total = uint32_t(out.size());
  std::memcpy(out.data() + 8, &total, 4);
  data.swap(out);
  return views > 0;
}

}  // namespace meshmux
