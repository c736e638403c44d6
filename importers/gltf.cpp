// glTF 2.0 importer (tinygltf). Implements the import half of the "clean and normalize" input
// stage of Terrace, Cheslack-Postava, Levis and Freedman, "Unsupervised conversion of 3D models
// for interactive metaverses" §4.1: every accessor layout glTF allows is read into plain
// float/uint32 arrays, the node hierarchy is flattened to world-transformed instances while
// shared meshes stay shared (the instance-aware simplification of Azim, Cheslack-Postava and
// Levis, "Instance-aware simplification of 3D polygonal meshes" needs the instances intact), and
// every offset is bounds-checked before use because uploads are untrusted.
#include "importers/gltf.h"

#include <sys/stat.h>
#include <tiny_gltf.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>

#include "core/file_io.h"
#include "core/json_depth.h"
#include "core/parallel.h"
#include "draco/compression/decode.h"
#include "image/decode.h"
#include "image/ktx2_transcode.h"
#include "importers/skinning.h"
#include "importers/upload.h"

namespace meshmux {

namespace {

// Material extensions that change appearance, with what the output shows instead: the
// metal-roughness core of the material (factors and maps) is kept, the effect is not.
const std::map<std::string, std::string> kAppearanceExtensions = {
    {"KHR_materials_dispersion", "dispersion dropped"},
    {"KHR_materials_diffuse_transmission", "diffuse transmission dropped"},
};

// Extensions whose presence in extensionsRequired we can honour.
const std::set<std::string> kSupportedRequired = {
    "KHR_draco_mesh_compression",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
    "EXT_texture_webp",
    "EXT_mesh_gpu_instancing",
    "KHR_materials_unlit",
    "KHR_materials_emissive_strength",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_materials_ior",
    "KHR_materials_clearcoat",
    "KHR_materials_specular",
    "KHR_materials_iridescence",
    "KHR_materials_sheen",
    "KHR_materials_anisotropy",
    "KHR_texture_basisu",
};

constexpr size_t kMaxAccessorCount = size_t(1) << 28;  // 268M elements: far beyond real models

int component_size(int type) {
  switch (type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT:
      return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT:
      return 4;
    default:
      return 0;
  }
}

int component_count(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR:
      return 1;
    case TINYGLTF_TYPE_VEC2:
      return 2;
    case TINYGLTF_TYPE_VEC3:
      return 3;
    case TINYGLTF_TYPE_VEC4:
      return 4;
    case TINYGLTF_TYPE_MAT2:
      return 4;
    case TINYGLTF_TYPE_MAT3:
      return 9;
    case TINYGLTF_TYPE_MAT4:
      return 16;
    default:
      return 0;
  }
}

// One component as float, normalized when asked (glTF 2.0 §3.11 normalization rules).
float read_component(const uint8_t* p, int type, bool normalized) {
  switch (type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      int8_t v;
      std::memcpy(&v, p, 1);
      return normalized ? std::max(v / 127.0f, -1.0f) : float(v);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return normalized ? p[0] / 255.0f : float(p[0]);
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      int16_t v;
      std::memcpy(&v, p, 2);
      return normalized ? std::max(v / 32767.0f, -1.0f) : float(v);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      uint16_t v;
      std::memcpy(&v, p, 2);
      return normalized ? v / 65535.0f : float(v);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
      uint32_t v;
      std::memcpy(&v, p, 4);
      return float(v);
    }
    case TINYGLTF_COMPONENT_TYPE_FLOAT: {
      float v;
      std::memcpy(&v, p, 4);
      return v;
    }
  }
  return 0;
}

uint32_t read_index(const uint8_t* p, int type) {
  switch (type) {
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return p[0];
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      uint16_t v;
      std::memcpy(&v, p, 2);
      return v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
      uint32_t v;
      std::memcpy(&v, p, 4);
      return v;
    }
  }
  return 0;
}

class Reader {
 public:
  Reader(const tinygltf::Model& model, std::string file, uint64_t max_values)
      : m_(model), file_(std::move(file)), values_left_(max_values), max_values_(max_values) {}

  // Takes `n` values (floats or indices) from the budget of ImportOptions::max_elements, before
  // anything is allocated: an accessor may declare a count its bytes do not hold (or hold no
  // bytes at all: zeros), and 2^28 elements of a 896-byte file must not cost 3 GB.
  Status take(unsigned __int128 n, const std::string& where) const {
    if (n > values_left_)
      return Status::error(
          "gltf: " + file_ + ": " + where + ": the model reads more than " +
              std::to_string(max_values_) +
              " values in all (the limit from the input's size; --max-elements raises it)",
          ErrorKind::kInput);
    values_left_ -= uint64_t(n);
    return Status::ok();
  }

  Status err(const std::string& where, const std::string& what) const {
    return Status::error("gltf: " + file_ + ": " + where + (where.empty() ? "" : ": ") + what,
                         ErrorKind::kInput);
  }

  // Locates `count` elements of `elem_size` bytes with `stride` in a buffer view; checks
  // every byte lies inside the view and the buffer.
  Status locate(int view_index, size_t offset, size_t count, size_t elem_size, size_t stride,
                const std::string& where, const uint8_t** out) const {
    if (view_index < 0 || size_t(view_index) >= m_.bufferViews.size())
      return err(where, "bufferView " + std::to_string(view_index) + " does not exist");
    const tinygltf::BufferView& view = m_.bufferViews[size_t(view_index)];
    if (view.buffer < 0 || size_t(view.buffer) >= m_.buffers.size())
      return err(where, "bufferView " + std::to_string(view_index) + ": buffer " +
                            std::to_string(view.buffer) + " does not exist");
    const auto& data = m_.buffers[size_t(view.buffer)].data;
    if (view.byteOffset > data.size() || view.byteLength > data.size() - view.byteOffset)
      return err(where, "bufferView " + std::to_string(view_index) + " out of bounds of buffer " +
                            std::to_string(view.buffer) + " (" + std::to_string(data.size()) +
                            " bytes)");
    if (count > 0) {
      // Last byte read: offset + stride*(count-1) + elem_size, in 128-bit-safe arithmetic.
      unsigned __int128 end =
          (unsigned __int128)offset + (unsigned __int128)stride * (count - 1) + elem_size;
      if (end > view.byteLength)
        return err(where, "accessor data out of bounds of bufferView " +
                              std::to_string(view_index) + " (" + std::to_string(view.byteLength) +
                              " bytes)");
    }
    *out = data.data() + view.byteOffset + offset;
    return Status::ok();
  }

  // Reads an accessor into floats, `comps` per element (fewer source components are padded
  // with `pad`, e.g. alpha 1 for VEC3 colours). Applies sparse substitution.
  Status floats(int index, int comps, float pad, const std::string& where,
                std::vector<float>* out) const {
    std::string w = where + ": accessor " + std::to_string(index);
    if (index < 0 || size_t(index) >= m_.accessors.size()) return err(w, "does not exist");
    const tinygltf::Accessor& a = m_.accessors[size_t(index)];
    int csize = component_size(a.componentType);
    int ccount = component_count(a.type);
    if (csize == 0 || ccount == 0) return err(w, "invalid componentType or type");
    // Vectors of up to 4 (one component more than asked is dropped); MAT4 only when asked for
    // whole (a skin's inverse bind matrices).
    if (ccount > comps + 1 || (ccount > 4 && ccount != comps))
      return err(w, "unexpected type for this attribute");
    if (a.count > kMaxAccessorCount)
      return err(w, "count " + std::to_string(a.count) + " too large");
    size_t elem = size_t(csize) * size_t(ccount);
    // The bytes are located (bounds-checked) and the values budgeted before allocating.
    const uint8_t* base = nullptr;
    size_t stride = elem;
    if (a.bufferView >= 0) {
      if (size_t(a.bufferView) >= m_.bufferViews.size())
        return err(w, "bufferView " + std::to_string(a.bufferView) + " does not exist");
      stride = m_.bufferViews[size_t(a.bufferView)].byteStride;
      if (stride == 0) stride = elem;
      if (stride < elem)
        return err(w, "byteStride " + std::to_string(stride) + " smaller than its element");
      Status s = locate(a.bufferView, a.byteOffset, a.count, elem, stride, w, &base);
      if (!s) return s;
    }
    if (Status s = take((unsigned __int128)a.count * unsigned(comps), w); !s) return s;
    out->assign(a.count * size_t(comps), pad);
    auto put = [&](size_t i, const uint8_t* src) {
      for (int c = 0; c < comps; ++c)
        (*out)[i * size_t(comps) + size_t(c)] =
            c < ccount ? read_component(src + c * csize, a.componentType, a.normalized) : pad;
    };
    if (base) {
      for (size_t i = 0; i < a.count; ++i) put(i, base + i * stride);
    } else {
      // No bufferView: zeros (then sparse substitution, if any).
      for (size_t i = 0; i < out->size(); ++i)
        (*out)[i] = (i % size_t(comps)) < size_t(ccount) ? 0.0f : pad;
    }
    if (a.sparse.isSparse) {
      size_t n = size_t(std::max(a.sparse.count, 0));
      if (n > a.count) return err(w, "sparse count exceeds accessor count");
      int icsize = component_size(a.sparse.indices.componentType);
      if (a.sparse.indices.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
          a.sparse.indices.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
          a.sparse.indices.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
        return err(w, "invalid sparse index componentType");
      const uint8_t *ip, *vp;
      Status s =
          locate(a.sparse.indices.bufferView, size_t(std::max(a.sparse.indices.byteOffset, 0)), n,
                 size_t(icsize), size_t(icsize), w + " sparse indices", &ip);
      if (!s) return s;
      s = locate(a.sparse.values.bufferView, size_t(std::max(a.sparse.values.byteOffset, 0)), n,
                 elem, elem, w + " sparse values", &vp);
      if (!s) return s;
      for (size_t k = 0; k < n; ++k) {
        uint32_t target = read_index(ip + k * size_t(icsize), a.sparse.indices.componentType);
        if (target >= a.count)
          return err(w, "sparse index " + std::to_string(target) + " out of range");
        put(target, vp + k * elem);
      }
    }
    return Status::ok();
  }

  Status indices(int index, const std::string& where, std::vector<uint32_t>* out) const {
    std::string w = where + ": accessor " + std::to_string(index);
    if (index < 0 || size_t(index) >= m_.accessors.size()) return err(w, "does not exist");
    const tinygltf::Accessor& a = m_.accessors[size_t(index)];
    if (a.type != TINYGLTF_TYPE_SCALAR ||
        (a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
         a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
         a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT))
      return err(w, "indices must be unsigned integer scalars");
    if (a.sparse.isSparse || a.bufferView < 0) {
      // Rare but legal: read through the general path.
      std::vector<float> f;
      Status s = floats(index, 1, 0, where, &f);
      if (!s) return s;
      out->resize(f.size());
      for (size_t i = 0; i < f.size(); ++i) (*out)[i] = uint32_t(f[i]);
      return Status::ok();
    }
    if (a.count > kMaxAccessorCount) return err(w, "count too large");
    size_t csize = size_t(component_size(a.componentType));
    if (size_t(a.bufferView) >= m_.bufferViews.size())
      return err(w, "bufferView " + std::to_string(a.bufferView) + " does not exist");
    size_t stride = m_.bufferViews[size_t(a.bufferView)].byteStride;
    if (stride == 0) stride = csize;
    const uint8_t* base;
    Status s = locate(a.bufferView, a.byteOffset, a.count, csize, stride, w, &base);
    if (!s) return s;
    if (s = take(a.count, w); !s) return s;
    out->resize(a.count);
    for (size_t i = 0; i < a.count; ++i) (*out)[i] = read_index(base + i * stride, a.componentType);
    return Status::ok();
  }

  const tinygltf::Model& m_;
  std::string file_;
  mutable uint64_t values_left_;  // of the max_elements budget
  uint64_t max_values_;
};

Mat4 node_local(const tinygltf::Node& n) {
  if (n.matrix.size() == 16) {
    Mat4 r;
    for (int i = 0; i < 16; ++i) r.m[size_t(i)] = n.matrix[size_t(i)];
    return r;
  }
  double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
  if (n.translation.size() == 3) std::copy(n.translation.begin(), n.translation.end(), t);
  if (n.rotation.size() == 4) std::copy(n.rotation.begin(), n.rotation.end(), q);
  if (n.scale.size() == 3) std::copy(n.scale.begin(), n.scale.end(), s);
  return Mat4::trs(t, q, s);
}

TextureTransform read_transform(const tinygltf::ExtensionMap& ext, uint32_t* tex_coord) {
  TextureTransform t;
  auto it = ext.find("KHR_texture_transform");
  if (it == ext.end() || !it->second.IsObject()) return t;
  const tinygltf::Value& v = it->second;
  if (v.Has("offset") && v.Get("offset").ArrayLen() == 2) {
    t.offset[0] = float(v.Get("offset").Get(0).GetNumberAsDouble());
    t.offset[1] = float(v.Get("offset").Get(1).GetNumberAsDouble());
  }
  if (v.Has("scale") && v.Get("scale").ArrayLen() == 2) {
    t.scale[0] = float(v.Get("scale").Get(0).GetNumberAsDouble());
    t.scale[1] = float(v.Get("scale").Get(1).GetNumberAsDouble());
  }
  if (v.Has("rotation") && v.Get("rotation").IsNumber())
    t.rotation = float(v.Get("rotation").GetNumberAsDouble());
  if (v.Has("texCoord") && v.Get("texCoord").IsNumber())
    *tex_coord = uint32_t(std::max(0, v.Get("texCoord").GetNumberAsInt()));
  return t;
}

// tinygltf hands us the encoded bytes; decoding happens later with OpenImageIO so that an
// image that fails to decode is a warning, not a failed load.
// tinygltf 2.7 hands an image stored in a bufferView over as a pointer into its buffer without
// checking the view against the buffer (offset 2^31 - 1 crashed; a view 64 KiB too long copied
// 64 KiB of heap into the output). Such images are not copied here: the importer reads them
// through Reader::locate, which checks every byte. External and data: images arrive as owned
// vectors of their real size.
bool keep_encoded_image(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                        const unsigned char* bytes, int size, void*) {
  if (image->bufferView >= 0) {
    image->image.clear();
  } else {
    image->image.assign(bytes, bytes + std::max(size, 0));
  }
  image->width = image->height = -1;
  image->as_is = true;
  return true;
}

// tinygltf 2.7 (Debian 12) rejects an indices accessor without a bufferView, which is exactly
// what KHR_draco_mesh_compression primitives carry. Their indices come from the Draco stream
// anyway, so such "indices" entries are dropped from the JSON before tinygltf sees it. The
// GLB container is rebuilt around the patched JSON chunk. Returns false if nothing changed.
bool drop_draco_index_accessors(std::vector<uint8_t>& data, bool binary) {
  static const char kNeedle[] = "KHR_draco_mesh_compression";
  if (std::search(data.begin(), data.end(), kNeedle, kNeedle + sizeof kNeedle - 1) == data.end())
    return false;
  size_t json_at = 0, json_len = data.size();
  if (binary) {
    if (data.size() < 20) return false;
    uint32_t len, type;
    std::memcpy(&len, data.data() + 12, 4);
    std::memcpy(&type, data.data() + 16, 4);
    if (type != 0x4E4F534Au || size_t(len) > data.size() - 20) return false;
    json_at = 20;
    json_len = len;
  }
  nlohmann::json doc = nlohmann::json::parse(data.begin() + long(json_at),
                                             data.begin() + long(json_at + json_len), nullptr,
                                             /*allow_exceptions=*/false);
  if (doc.is_discarded() || !doc.is_object() || !doc.contains("meshes") ||
      !doc["meshes"].is_array())
    return false;
  bool changed = false;
  const nlohmann::json* accessors = doc.contains("accessors") ? &doc["accessors"] : nullptr;
  for (auto& mesh : doc["meshes"]) {
    if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array())
      continue;
    for (auto& prim : mesh["primitives"]) {
      if (!prim.is_object() || !prim.contains("indices") || !prim.contains("extensions")) continue;
      const auto& ext = prim["extensions"];
      if (!ext.is_object() || !ext.contains("KHR_draco_mesh_compression")) continue;
      const auto& idx = prim["indices"];
      bool has_view = idx.is_number_integer() && accessors && accessors->is_array() &&
                      idx.get<int64_t>() >= 0 && size_t(idx.get<int64_t>()) < accessors->size() &&
                      (*accessors)[size_t(idx.get<int64_t>())].contains("bufferView");
      if (has_view) continue;
      prim.erase("indices");
      changed = true;
    }
  }
  if (!changed) return false;
  std::string text = doc.dump();
  if (!binary) {
    data.assign(text.begin(), text.end());
    return true;
  }
  while (text.size() % 4) text.push_back(' ');
  std::vector<uint8_t> out(data.begin(), data.begin() + 12);
  uint32_t len = uint32_t(text.size()), type = 0x4E4F534Au;
  out.insert(out.end(), reinterpret_cast<uint8_t*>(&len), reinterpret_cast<uint8_t*>(&len) + 4);
  out.insert(out.end(), reinterpret_cast<uint8_t*>(&type), reinterpret_cast<uint8_t*>(&type) + 4);
  out.insert(out.end(), text.begin(), text.end());
  size_t rest = 20 + json_len;
  while (rest % 4 && rest < data.size()) ++rest;  // JSON chunk padding in the original
  out.insert(out.end(), data.begin() + long(std::min(rest, data.size())), data.end());
  uint32_t total = uint32_t(out.size());
  std::memcpy(out.data() + 8, &total, 4);
  data.swap(out);
  return true;
}

}  // namespace

// Decodes one KHR_draco_mesh_compression primitive (implemented in gltf_draco.cpp).
Status decode_draco_primitive(const std::vector<uint8_t>& bytes,
                              const std::vector<std::pair<std::string, int>>& attributes,
                              const std::vector<std::pair<std::string, bool>>& normalized,
                              Primitive* out, SkinInfluences* skin, std::string* error);

// Rewrites a GLB using EXT_meshopt_compression into plain glTF (gltf_meshopt.cpp).
Result<bool> decode_meshopt_glb(std::vector<uint8_t>& data, const std::string& file,
                                uint64_t max_decoded);

namespace {

class Importer {
 public:
  Importer(const tinygltf::Model& model, const std::string& file, const ImportOptions& opts,
           Warnings* warnings)
      : m_(model),
        r_(model, file, opts.max_elements),
        file_(file),
        opts_(opts),
        warnings_(warnings) {}

  Result<Scene> run() {
    Status s = check_extensions();
    if (!s) return s;
    s = images();
    if (!s) return s;
    materials();
    s = meshes();
    if (!s) return s;
    s = nodes();
    if (!s) return s;
    if (!m_.animations.empty())
      warn(warnings_, "gltf: " + file_ + ": " + std::to_string(m_.animations.size()) +
                          " animation(s) dropped");
    if (morphed_)
      warn(warnings_, "gltf: " + file_ +
                          ": morph targets applied at their default weights "
                          "(the shape shown without animation)");
    return std::move(scene_);
  }

 private:
  Status check_extensions() {
    for (const std::string& e : m_.extensionsRequired) {
      if (kSupportedRequired.count(e)) continue;
      if (e == "EXT_meshopt_compression")
        return r_.err("",
                      "required extension EXT_meshopt_compression is supported in .glb "
                      "files only (pack this .gltf into a .glb)");
      return r_.err("", "required extension " + e + " is not supported");
    }
    return Status::ok();
  }

  // A texture's KHR_texture_basisu source (a KTX2 image), or -1.
  static int basisu_source(const tinygltf::Texture& tex) {
    auto it = tex.extensions.find("KHR_texture_basisu");
    if (it == tex.extensions.end() || !it->second.IsObject() || !it->second.Has("source") ||
        !it->second.Get("source").IsInt())
      return -1;
    return it->second.Get("source").GetNumberAsInt();
  }

  // The images some texture of some material names (core source, EXT_texture_webp's, and
  // KHR_texture_basisu's where there is no core source: a KTX2 costs a transcode).
  std::vector<char> referenced_images() const {
    std::vector<char> used(m_.images.size(), 0);
    auto mark_texture = [&](int t) {
      if (t < 0 || size_t(t) >= m_.textures.size()) return;
      const tinygltf::Texture& tex = m_.textures[size_t(t)];
      if (tex.source >= 0 && size_t(tex.source) < used.size()) used[size_t(tex.source)] = 1;
      const int basisu = basisu_source(tex);
      if (tex.source < 0 && basisu >= 0 && size_t(basisu) < used.size()) used[size_t(basisu)] = 1;
      auto webp = tex.extensions.find("EXT_texture_webp");
      if (webp != tex.extensions.end() && webp->second.Has("source") &&
          webp->second.Get("source").IsInt()) {
        int w = webp->second.Get("source").GetNumberAsInt();
        if (w >= 0 && size_t(w) < used.size()) used[size_t(w)] = 1;
      }
    };
    for (const tinygltf::Material& m : m_.materials) {
      mark_texture(m.pbrMetallicRoughness.baseColorTexture.index);
      mark_texture(m.pbrMetallicRoughness.metallicRoughnessTexture.index);
      mark_texture(m.normalTexture.index);
      mark_texture(m.occlusionTexture.index);
      mark_texture(m.emissiveTexture.index);
      // A textureInfo inside an extension: extension → key → index.
      auto mark_in = [&](const char* extension, const char* key) {
        auto it = m.extensions.find(extension);
        if (it == m.extensions.end() || !it->second.IsObject() || !it->second.Has(key)) return;
        const tinygltf::Value& info = it->second.Get(key);
        if (info.IsObject() && info.Has("index") && info.Get("index").IsInt())
          mark_texture(info.Get("index").GetNumberAsInt());
      };
      mark_in("KHR_materials_sheen", "sheenColorTexture");
      mark_in("KHR_materials_transmission", "transmissionTexture");
      for (const LayerSlotName& slot : kLayerSlots) mark_in(slot.extension, slot.key);
    }
    return used;
  }

  // Images no material uses are not read or decoded (3 unused entries naming one PNG that
  // decodes to 3 GB cost 9.6 GB). The decoded texels of all images share the max_texels budget;
  // exceeding it is an error naming the option.
  Status images() {
    image_map_.assign(m_.images.size(), -1);
    const std::vector<char> used = referenced_images();
    // Read in file order; decoded a few at a time on every core (a batch per thread count,
    // each image within the texels left when its batch began), then taken in file order: the
    // budget, the warnings and the errors are those of decoding one by one, and at most one
    // batch is decoded past the budget.
    struct Pending {
      size_t index = 0;
      std::string label;
      Image image;
      Status decoded;
      bool over = false;
      bool done = false;   // decoded already (KTX2, in one batch before the others)
      bool quiet = false;  // its failure is the KTX2 transcoder's, warned about once
    };
    std::vector<Pending> pending;
    for (size_t i = 0; i < m_.images.size(); ++i) {
      if (!used[i]) continue;
      const tinygltf::Image& src = m_.images[i];
      std::string label =
          "image " + std::to_string(i) +
          (src.uri.empty() || src.uri.rfind("data:", 0) == 0 ? "" : " '" + src.uri + "'");
      std::vector<uint8_t> encoded;
      if (src.bufferView >= 0) {
        const uint8_t* bytes;
        size_t length = size_t(src.bufferView) < m_.bufferViews.size()
                            ? m_.bufferViews[size_t(src.bufferView)].byteLength
                            : 0;
        Status s = r_.locate(src.bufferView, 0, length > 0 ? 1 : 0, length, length, label, &bytes);
        if (!s) return s;
        encoded.assign(bytes, bytes + length);
      } else {
        encoded = src.image;
      }
      if (encoded.empty() || src.width != -1) {
        warn(warnings_, "gltf: " + file_ + ": " + label +
                            ": could not be loaded; textures using it are dropped");
        continue;
      }
      Pending p;
      p.index = i;
      p.label = std::move(label);
      Image& img = p.image;
      img.name = src.uri.empty() || src.uri.rfind("data:", 0) == 0
                     ? (src.name.empty() ? p.label : src.name)
                     : src.uri;
      img.encoded = std::move(encoded);
      img.mime_type = sniff_image_mime(img.encoded, src.uri);
      if (img.mime_type.empty()) img.mime_type = src.mimeType;
      pending.push_back(std::move(p));
    }
    if (opts_.decode_images) transcode_ktx2(pending);
    uint64_t texels_left = opts_.max_texels;
    const size_t batch = size_t(std::max(1, worker_threads()));
    for (size_t begin = 0; begin < pending.size(); begin += batch) {
      const size_t end = std::min(pending.size(), begin + batch);
      const uint64_t limit = std::min(opts_.max_image_pixels, texels_left);
      if (opts_.decode_images)
        parallel_chunks(end - begin, 1, [&](size_t b, size_t e) {
          for (size_t k = begin + b; k < begin + e; ++k)
            if (!pending[k].done)
              pending[k].decoded = decode_image(pending[k].image, limit, &pending[k].over);
        });
      for (size_t k = begin; k < end; ++k)
        if (Status s = take_image(pending[k], texels_left); !s) return s;
    }
    return Status::ok();
  }

  // The KTX2 images among `pending` decoded in one transcoder run (image/ktx2_transcode.h), in
  // file order within the texels budget (those past it are left over it, for take_image to
  // refuse by name). A transcoder that cannot run is one warning; the images then fail quietly.
  template <typename Pending>
  void transcode_ktx2(std::vector<Pending>& pending) {
    std::vector<Image*> images;
    std::vector<Pending*> owners;
    uint64_t texels = 0;
    for (Pending& p : pending) {
      if (p.image.mime_type != "image/ktx2") continue;
      p.done = true;
      auto header = read_ktx2_header(p.image.encoded);
      if (header.ok()) texels += uint64_t(header->width) * uint64_t(header->height);
      if (header.ok() && texels > opts_.max_texels) {
        p.over = true;
        p.decoded = Status::error(p.image.name + ": over the texels budget", ErrorKind::kInput);
        continue;
      }
      images.push_back(&p.image);
      owners.push_back(&p);
    }
    if (images.empty()) return;
    Ktx2TranscodeOptions options;
    options.max_pixels = std::min(opts_.max_image_pixels, opts_.max_texels);
    Ktx2Transcoded t = transcode_ktx2_images(images, options);
    size_t run_failed = 0;
    for (size_t k = 0; k < owners.size(); ++k) {
      owners[k]->decoded = t.images[k].status;
      owners[k]->over = t.images[k].over_limit;
      owners[k]->quiet = t.images[k].run_failed;
      run_failed += t.images[k].run_failed;
    }
    if (run_failed > 0)
      warn(warnings_,
           "gltf: " + file_ + ": " + std::to_string(run_failed) +
               " KTX2 image(s) not decoded, textures using them are dropped: " + t.run.message());
  }

  // One image read and decoded (images()), taken in file order: within the texels left, or
  // an error naming the limit; another failure dropped with a warning.
  template <typename Pending>
  Status take_image(Pending& p, uint64_t& texels_left) {
    if (opts_.decode_images) {
      const Status& s = p.decoded;
      const uint64_t texels = uint64_t(p.image.width) * uint64_t(p.image.height);
      // Decoded within its batch's limit but past what the images before it left.
      const bool past = s && texels > texels_left;
      if (past || (!s && p.over && texels_left < opts_.max_image_pixels))
        return r_.err(p.label, "decoding it would take the model's images over " +
                                   std::to_string(opts_.max_texels) +
                                   " texels in all (the limit from the input's size; "
                                   "--max-texels raises it)");
      if (!s && p.quiet) return Status::ok();  // transcode_ktx2 warned once
      if (!s) {
        warn(warnings_, "gltf: " + file_ + ": " + p.label + ": " + s.message() +
                            "; textures using it are dropped");
        return Status::ok();
      }
      texels_left -= texels;
    }
    image_map_[p.index] = int32_t(scene_.images.size());
    scene_.images.push_back(std::move(p.image));
    return Status::ok();
  }

  // The image a texture shows: EXT_texture_webp's source when it decoded (WebP, which OpenImageIO
  // reads), else the core source, else KHR_texture_basisu's; -1 when none gives a decoded image.
  int texture_source(const tinygltf::Texture& t) const {
    auto usable = [&](int i) {
      return i >= 0 && size_t(i) < m_.images.size() && image_map_[size_t(i)] >= 0;
    };
    auto webp = t.extensions.find("EXT_texture_webp");
    if (webp != t.extensions.end() && webp->second.Has("source") &&
        webp->second.Get("source").IsInt() && usable(webp->second.Get("source").GetNumberAsInt()))
      return webp->second.Get("source").GetNumberAsInt();
    if (usable(t.source)) return t.source;
    return usable(basisu_source(t)) ? basisu_source(t) : -1;
  }

  TextureRef texture(int index, int tex_coord, const tinygltf::ExtensionMap& ext,
                     const std::string& where) {
    TextureRef ref;
    if (index < 0) return ref;
    if (size_t(index) >= m_.textures.size()) {
      warn(warnings_, "gltf: " + file_ + ": " + where + ": texture " + std::to_string(index) +
                          " does not exist; dropped");
      return ref;
    }
    const tinygltf::Texture& t = m_.textures[size_t(index)];
    int source = texture_source(t);
    if (source < 0) return ref;  // no usable image (already warned about, or none given)
    ref.image = image_map_[size_t(source)];
    if (t.sampler >= 0 && size_t(t.sampler) < m_.samplers.size()) {
      const tinygltf::Sampler& s = m_.samplers[size_t(t.sampler)];
      auto wrap = [](int w) {
        return w == int(Wrap::kClampToEdge)      ? Wrap::kClampToEdge
               : w == int(Wrap::kMirroredRepeat) ? Wrap::kMirroredRepeat
                                                 : Wrap::kRepeat;
      };
      ref.sampler.wrap_s = wrap(s.wrapS);
      ref.sampler.wrap_t = wrap(s.wrapT);
      ref.sampler.mag_filter = std::max(s.magFilter, 0);
      ref.sampler.min_filter = std::max(s.minFilter, 0);
    }
    ref.tex_coord = uint32_t(std::max(tex_coord, 0));
    ref.transform = read_transform(ext, &ref.tex_coord);
    return ref;
  }

  // Material extensions folded into the metal-roughness core:
  // - KHR_materials_emissive_strength multiplies the emissive factor (exact; the exporter
  //   writes the extension back when a component exceeds 1);
  // - KHR_materials_sheen, _transmission, _ior, _volume, _clearcoat, _specular, _iridescence
  //   and _anisotropy are carried: their factors here, their textures in layer_textures.
  // Number fields that are missing or not finite keep their glTF defaults.
  static void approximate_extensions(const tinygltf::Material& src, Material* mat) {
    auto number = [](const tinygltf::Value& v, const char* key, double fallback) {
      if (!v.IsObject() || !v.Has(key) || !v.Get(key).IsNumber()) return fallback;
      const double d = v.Get(key).GetNumberAsDouble();
      return std::isfinite(d) ? d : fallback;
    };
    if (auto it = src.extensions.find("KHR_materials_emissive_strength");
        it != src.extensions.end()) {
      const float strength = float(std::max(0.0, number(it->second, "emissiveStrength", 1.0)));
      mat->emissive_factor = {mat->emissive_factor.x * strength, mat->emissive_factor.y * strength,
                              mat->emissive_factor.z * strength};
    }
    // KHR_materials_sheen is carried: its colour (factor and texture), its roughness factor.
    if (auto it = src.extensions.find("KHR_materials_sheen"); it != src.extensions.end()) {
      const tinygltf::Value& v = it->second;
      if (v.IsObject() && v.Has("sheenColorFactor") && v.Get("sheenColorFactor").IsArray() &&
          v.Get("sheenColorFactor").ArrayLen() == 3) {
        float c[3];
        for (int k = 0; k < 3; ++k) {
          const tinygltf::Value& e = v.Get("sheenColorFactor").Get(k);
          const double d = e.IsNumber() ? e.GetNumberAsDouble() : 0.0;
          c[k] = float(std::isfinite(d) ? std::clamp(d, 0.0, 1.0) : 0.0);
        }
        mat->sheen_color_factor = {c[0], c[1], c[2]};
      }
      mat->sheen_roughness_factor =
          float(std::clamp(number(v, "sheenRoughnessFactor", 0.0), 0.0, 1.0));
    }
    // Clearcoat, specular and iridescence: their factors.
    if (auto it = src.extensions.find("KHR_materials_clearcoat"); it != src.extensions.end()) {
      mat->clearcoat_factor =
          float(std::clamp(number(it->second, "clearcoatFactor", 0.0), 0.0, 1.0));
      mat->clearcoat_roughness_factor =
          float(std::clamp(number(it->second, "clearcoatRoughnessFactor", 0.0), 0.0, 1.0));
    }
    if (auto it = src.extensions.find("KHR_materials_specular"); it != src.extensions.end()) {
      const tinygltf::Value& v = it->second;
      mat->specular_factor = float(std::clamp(number(v, "specularFactor", 1.0), 0.0, 1.0));
      if (v.IsObject() && v.Has("specularColorFactor") && v.Get("specularColorFactor").IsArray() &&
          v.Get("specularColorFactor").ArrayLen() == 3) {
        float c[3];
        for (int k = 0; k < 3; ++k) {
          const tinygltf::Value& e = v.Get("specularColorFactor").Get(k);
          const double x = e.IsNumber() ? e.GetNumberAsDouble() : 1.0;
          c[k] = float(std::isfinite(x) ? std::clamp(x, 0.0, 100.0) : 1.0);
        }
        mat->specular_color_factor = {c[0], c[1], c[2]};
      }
    }
    if (auto it = src.extensions.find("KHR_materials_iridescence"); it != src.extensions.end()) {
      const tinygltf::Value& v = it->second;
      mat->iridescence_factor = float(std::clamp(number(v, "iridescenceFactor", 0.0), 0.0, 1.0));
      const double ior = number(v, "iridescenceIor", 1.3);
      mat->iridescence_ior = float(ior >= 1 && ior <= 10 ? ior : 1.3);
      mat->iridescence_thickness =
          float(std::clamp(number(v, "iridescenceThicknessMaximum", 400.0), 0.0, 1e5));
      mat->iridescence_thickness_minimum =
          float(std::clamp(number(v, "iridescenceThicknessMinimum", 100.0), 0.0, 1e5));
    }
    if (auto it = src.extensions.find("KHR_materials_anisotropy"); it != src.extensions.end()) {
      mat->anisotropy_strength =
          float(std::clamp(number(it->second, "anisotropyStrength", 0.0), 0.0, 1.0));
      mat->anisotropy_rotation = float(number(it->second, "anisotropyRotation", 0.0));
    }
    // Glass is carried as glass: transmission, ior and volume (thickness, attenuation).
    if (auto it = src.extensions.find("KHR_materials_transmission"); it != src.extensions.end())
      mat->transmission_factor =
          float(std::clamp(number(it->second, "transmissionFactor", 0.0), 0.0, 1.0));
    if (auto it = src.extensions.find("KHR_materials_ior"); it != src.extensions.end()) {
      const double ior = number(it->second, "ior", 1.5);
      mat->ior = float(ior >= 1 && ior <= 10 ? ior : 1.5);
    }
    if (auto it = src.extensions.find("KHR_materials_volume"); it != src.extensions.end()) {
      const tinygltf::Value& v = it->second;
      mat->thickness_factor = float(std::max(0.0, number(v, "thicknessFactor", 0.0)));
      const double d = number(v, "attenuationDistance", 0.0);
      mat->attenuation_distance = float(d > 0 ? d : 0.0);
      if (v.IsObject() && v.Has("attenuationColor") && v.Get("attenuationColor").IsArray() &&
          v.Get("attenuationColor").ArrayLen() == 3) {
        float c[3];
        for (int k = 0; k < 3; ++k) {
          const tinygltf::Value& e = v.Get("attenuationColor").Get(k);
          const double x = e.IsNumber() ? e.GetNumberAsDouble() : 1.0;
          c[k] = float(std::isfinite(x) ? std::clamp(x, 0.0, 1.0) : 1.0);
        }
        mat->attenuation_color = {c[0], c[1], c[2]};
      }
    }
  }

  // A textureInfo given as a JSON value (inside an extension): the texture, its uv set, its
  // KHR_texture_transform and its scale (normal maps) or strength.
  TextureRef texture_info(const tinygltf::Value& info, const std::string& where) {
    if (!info.IsObject() || !info.Has("index") || !info.Get("index").IsInt()) return {};
    const int coord = info.Has("texCoord") && info.Get("texCoord").IsInt()
                          ? info.Get("texCoord").GetNumberAsInt()
                          : 0;
    tinygltf::ExtensionMap ext;
    if (info.Has("extensions") && info.Get("extensions").IsObject())
      for (const std::string& key : info.Get("extensions").Keys())
        ext[key] = info.Get("extensions").Get(key);
    TextureRef ref = texture(info.Get("index").GetNumberAsInt(), coord, ext, where);
    if (info.Has("scale") && info.Get("scale").IsNumber()) {
      const double k = info.Get("scale").GetNumberAsDouble();
      if (std::isfinite(k)) ref.scale = float(k);
    }
    return ref;
  }

  // Anisotropy's direction lives in a tangent space, which glTF takes from TANGENT or, without
  // it, derives along the normal texture's uvs; meshmux writes no TANGENT, so a material with
  // anisotropy and no normal map gets a flat one (1 × 1, (0, 0, 1): the shading normal is
  // unchanged) on the anisotropy texture's uv set, and its output stays valid and anisotropic.
  void flat_normal_map(Material* mat) {
    if (flat_normal_ < 0) {
      Image flat;
      flat.name = "flat normal (anisotropy's tangent space)";
      flat.width = flat.height = 1;
      flat.rgba = {128, 128, 255, 255};
      flat_normal_ = int32_t(scene_.images.size());
      scene_.images.push_back(std::move(flat));
    }
    mat->normal.image = flat_normal_;
    mat->normal.tex_coord = mat->layer(LayerSlot::kAnisotropy).present()
                                ? mat->layer(LayerSlot::kAnisotropy).tex_coord
                                : 0;
  }

  // KHR_materials_anisotropy's direction is tangent-space: x along T, y along the bitangent.
  // With TANGENT the bitangent is glTF's (3.7.2.1: cross(N, T) · w, up the image, −v); without
  // it viewers derive B along +v (three.js getTangentFrame; GLTFLoader mirrors normal maps for
  // it by negating normalScale.y, anisotropy not). meshmux writes no TANGENT, so the direction
  // of a material drawn by primitives with TANGENT is mirrored across T into the derived frame:
  // rotation → −rotation, the texture's direction y → −y (G → 255 − G, exact for 2G/255 − 1).
  // This takes the source's T to be the uv-derived one (MikkTSpace's is, up to its smoothing).
  // A material drawn both with and without TANGENT gets a mirrored copy for the former
  // (tangent_material_). Before, AnisotropyRotationTest's rotated highlights turned the other
  // way (lit 19.3 dB).
  void anisotropy_in_tangent_frames() {
    const size_t n = m_.materials.size();
    tangent_material_.resize(n);
    std::vector<char> with(n, 0), without(n, 0);
    for (const tinygltf::Mesh& mesh : m_.meshes)
      for (const tinygltf::Primitive& p : mesh.primitives)
        if (p.material >= 0 && size_t(p.material) < n)
          (p.attributes.count("TANGENT") ? with : without)[size_t(p.material)] = 1;
    for (size_t i = 0; i < n; ++i) {
      tangent_material_[i] = int32_t(i);
      const Material& mat = scene_.materials[i];
      const bool directed =
          mat.anisotropy_rotation != 0 || mat.layer(LayerSlot::kAnisotropy).present();
      if (!with[i] || mat.anisotropy_strength <= 0 || !directed) continue;
      Material mirrored = mat;
      mirrored.anisotropy_rotation = -mat.anisotropy_rotation;
      TextureRef& tex = mirrored.layer(LayerSlot::kAnisotropy);
      if (tex.present()) tex.image = mirrored_direction_image(tex.image);
      if (!without[i]) {
        scene_.materials[i] = std::move(mirrored);
        continue;
      }
      tangent_material_[i] = int32_t(scene_.materials.size());
      scene_.materials.push_back(std::move(mirrored));
    }
  }

  // A copy of an anisotropy texture with its direction's y negated (G → 255 − G); the image
  // itself when it is not decoded (said once).
  int32_t mirrored_direction_image(int32_t image) {
    if (auto it = mirrored_images_.find(image); it != mirrored_images_.end()) return it->second;
    const Image& src = scene_.images[size_t(image)];
    if (!src.decoded()) {
      warn(warnings_, "gltf: " + file_ + ": anisotropy texture " + src.name +
                          " not decoded: its direction stays in TANGENT's frame");
      return mirrored_images_[image] = image;
    }
    Image out;
    out.name = src.name + " (direction in the uv-derived tangent frame)";
    out.width = src.width;
    out.height = src.height;
    out.rgba = src.rgba;
    for (size_t k = 1; k < out.rgba.size(); k += 4) out.rgba[k] = uint8_t(255 - out.rgba[k]);
    scene_.images.push_back(std::move(out));
    return mirrored_images_[image] = int32_t(scene_.images.size() - 1);
  }

  // The layers' textures (kLayerSlots) and the transmission texture: carried as they came.
  void layer_textures(const tinygltf::Material& src, const std::string& where, Material* mat) {
    auto info = [&](const char* extension, const char* key) -> const tinygltf::Value* {
      auto it = src.extensions.find(extension);
      if (it == src.extensions.end() || !it->second.IsObject() || !it->second.Has(key))
        return nullptr;
      return &it->second.Get(key);
    };
    for (size_t k = 0; k < size_t(LayerSlot::kCount); ++k)
      if (const tinygltf::Value* v = info(kLayerSlots[k].extension, kLayerSlots[k].key))
        mat->layers[k] = texture_info(*v, where + " " + kLayerSlots[k].key);
    if (const tinygltf::Value* v = info("KHR_materials_transmission", "transmissionTexture"))
      mat->transmission = texture_info(*v, where + " transmissionTexture");
  }

  void materials() {
    for (size_t i = 0; i < m_.materials.size(); ++i) {
      const tinygltf::Material& src = m_.materials[i];
      std::string where = "material " + std::to_string(i);
      Material mat;
      mat.name = src.name;
      const auto& pbr = src.pbrMetallicRoughness;
      if (pbr.baseColorFactor.size() == 4)
        mat.base_color_factor = {float(pbr.baseColorFactor[0]), float(pbr.baseColorFactor[1]),
                                 float(pbr.baseColorFactor[2]), float(pbr.baseColorFactor[3])};
      mat.base_color = texture(pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord,
                               pbr.baseColorTexture.extensions, where);
      mat.metallic_factor = float(pbr.metallicFactor);
      mat.roughness_factor = float(pbr.roughnessFactor);
      mat.metallic_roughness =
          texture(pbr.metallicRoughnessTexture.index, pbr.metallicRoughnessTexture.texCoord,
                  pbr.metallicRoughnessTexture.extensions, where);
      mat.normal = texture(src.normalTexture.index, src.normalTexture.texCoord,
                           src.normalTexture.extensions, where);
      mat.normal.scale = float(src.normalTexture.scale);
      mat.occlusion = texture(src.occlusionTexture.index, src.occlusionTexture.texCoord,
                              src.occlusionTexture.extensions, where);
      mat.occlusion.scale = float(src.occlusionTexture.strength);
      mat.emissive = texture(src.emissiveTexture.index, src.emissiveTexture.texCoord,
                             src.emissiveTexture.extensions, where);
      if (src.emissiveFactor.size() == 3)
        mat.emissive_factor = {float(src.emissiveFactor[0]), float(src.emissiveFactor[1]),
                               float(src.emissiveFactor[2])};
      mat.alpha_mode = src.alphaMode == "MASK"    ? AlphaMode::kMask
                       : src.alphaMode == "BLEND" ? AlphaMode::kBlend
                                                  : AlphaMode::kOpaque;
      mat.alpha_cutoff = float(src.alphaCutoff);
      mat.double_sided = src.doubleSided;
      mat.unlit = src.extensions.count("KHR_materials_unlit") > 0;
      approximate_extensions(src, &mat);
      if (auto it = src.extensions.find("KHR_materials_sheen");
          it != src.extensions.end() && it->second.IsObject() &&
          it->second.Has("sheenColorTexture") && it->second.Get("sheenColorTexture").IsObject()) {
        const tinygltf::Value& info = it->second.Get("sheenColorTexture");
        const int index = info.Has("index") && info.Get("index").IsInt()
                              ? info.Get("index").GetNumberAsInt()
                              : -1;
        const int coord = info.Has("texCoord") && info.Get("texCoord").IsInt()
                              ? info.Get("texCoord").GetNumberAsInt()
                              : 0;
        if (index >= 0) mat.sheen_color = texture(index, coord, {}, where + " sheen colour");
      }
      for (const auto& [name, value] : src.extensions)
        if (kAppearanceExtensions.count(name)) ++effects_[name];
      layer_textures(src, where, &mat);
      if (mat.anisotropy_strength > 0 && !mat.normal.present()) flat_normal_map(&mat);
      scene_.materials.push_back(std::move(mat));
    }
    anisotropy_in_tangent_frames();
    // One warning per material extension that changes appearance and is not carried over,
    // saying what the output shows instead (sheen cloth once turned near-black silently).
    for (const auto& [name, count] : effects_)
      warn(warnings_, "gltf: " + file_ + ": " + name + " on " + std::to_string(count) +
                          " material(s): " + kAppearanceExtensions.at(name));
    if (std::find(m_.extensionsUsed.begin(), m_.extensionsUsed.end(), "KHR_materials_variants") !=
        m_.extensionsUsed.end())
      warn(warnings_, "gltf: " + file_ +
                          ": KHR_materials_variants: the default materials are kept, the other "
                          "variants dropped");
  }

  Status primitive(const tinygltf::Primitive& p, const std::string& where, Primitive* out,
                   SkinInfluences* skin, bool* skip) {
    *skip = false;
    int mode = p.mode < 0 ? TINYGLTF_MODE_TRIANGLES : p.mode;
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
        mode != TINYGLTF_MODE_TRIANGLE_FAN) {
      *skip = true;
      return Status::ok();
    }
    if (p.material >= int(m_.materials.size()))
      return r_.err(where, "material " + std::to_string(p.material) + " does not exist");
    out->material = p.material;
    if (p.material >= 0 && p.attributes.count("TANGENT"))
      out->material = tangent_material_[size_t(p.material)];
    auto draco = p.extensions.find("KHR_draco_mesh_compression");
    if (draco != p.extensions.end()) return draco_primitive(p, draco->second, where, out, skin);

    auto pos = p.attributes.find("POSITION");
    if (pos == p.attributes.end()) return r_.err(where, "has no POSITION attribute");
    std::vector<float> f;
    Status s = r_.floats(pos->second, 3, 0, where, &f);
    if (!s) return s;
    size_t n = f.size() / 3;
    out->positions.resize(n);
    for (size_t i = 0; i < n; ++i) out->positions[i] = {f[3 * i], f[3 * i + 1], f[3 * i + 2]};
    auto attribute = [&](const std::string& name, int comps, float pad) -> Status {
      auto it = p.attributes.find(name);
      if (it == p.attributes.end()) return Status::ok();
      Status st = r_.floats(it->second, comps, pad, where + ": " + name, &f);
      if (!st) return st;
      if (f.size() / size_t(comps) != n)
        return r_.err(where, name + " has " + std::to_string(f.size() / size_t(comps)) +
                                 " elements for " + std::to_string(n) + " positions");
      return Status::ok();
    };
    if (!(s = attribute("NORMAL", 3, 0))) return s;
    if (p.attributes.count("NORMAL")) {
      out->normals.resize(n);
      for (size_t i = 0; i < n; ++i)
        out->normals[i] = normalize(Vec3{f[3 * i], f[3 * i + 1], f[3 * i + 2]});
    }
    for (int set = 0;; ++set) {
      std::string name = "TEXCOORD_" + std::to_string(set);
      if (!p.attributes.count(name)) break;
      if (!(s = attribute(name, 2, 0))) return s;
      out->uvs.emplace_back(n);
      for (size_t i = 0; i < n; ++i) out->uvs.back()[i] = {f[2 * i], f[2 * i + 1]};
    }
    if (p.attributes.count("COLOR_0")) {
      if (!(s = attribute("COLOR_0", 4, 1))) return s;
      out->colors.resize(n);
      for (size_t i = 0; i < n; ++i)
        out->colors[i] = {f[4 * i], f[4 * i + 1], f[4 * i + 2], f[4 * i + 3]};
    }
    std::vector<uint32_t> idx;
    if (p.indices >= 0) {
      if (!(s = r_.indices(p.indices, where + ": indices", &idx))) return s;
    } else {
      idx.resize(n);
      for (size_t i = 0; i < n; ++i) idx[i] = uint32_t(i);
    }
    for (uint32_t i : idx)
      if (i >= n)
        return r_.err(where, "index " + std::to_string(i) + " out of range (" + std::to_string(n) +
                                 " vertices)");
    to_triangles(mode, idx, &out->indices);
    return influences(p, n, where, skin);
  }

  // JOINTS_n / WEIGHTS_n (n = 0, 1), read for posing a skin (importers/skinning.h).
  Status influences(const tinygltf::Primitive& p, size_t n, const std::string& where,
                    SkinInfluences* skin) {
    std::vector<std::vector<float>> joints, weights;
    for (int set = 0; set < 2; ++set) {
      auto j = p.attributes.find("JOINTS_" + std::to_string(set));
      auto w = p.attributes.find("WEIGHTS_" + std::to_string(set));
      if (j == p.attributes.end() || w == p.attributes.end()) break;
      std::vector<float> jf, wf;
      if (Status s = r_.floats(j->second, 4, 0, where + ": JOINTS", &jf); !s) return s;
      if (Status s = r_.floats(w->second, 4, 0, where + ": WEIGHTS", &wf); !s) return s;
      if (jf.size() != 4 * n || wf.size() != 4 * n)
        return r_.err(where, "JOINTS/WEIGHTS do not have one element per vertex");
      joints.push_back(std::move(jf));
      weights.push_back(std::move(wf));
    }
    skin->sets = int(joints.size());
    const size_t per = 4 * joints.size();
    skin->joints.assign(n * per, 0);
    skin->weights.assign(n * per, 0);
    for (size_t set = 0; set < joints.size(); ++set)
      for (size_t i = 0; i < n; ++i)
        for (size_t c = 0; c < 4; ++c) {
          const float jv = joints[set][4 * i + c];
          skin->joints[i * per + 4 * set + c] = jv >= 0 && jv < 65536 ? uint32_t(jv) : 65535u;
          skin->weights[i * per + 4 * set + c] = weights[set][4 * i + c];
        }
    return Status::ok();
  }

  // glTF 2.0 §3.7.2.1: "When normals are not specified, client implementations MUST calculate
  // flat normals" (three.js's GLTFLoader shows such meshes flat-shaded). The primitive is
  // marked flat: clean() generates normals for our own use, the exporter writes none, so every
  // viewer computes the flat ones again, at no byte cost. Unlit materials ignore normals.
  void mark_flat(Primitive* p) const {
    if (!p->normals.empty()) return;
    if (p->material >= 0 && size_t(p->material) < m_.materials.size() &&
        m_.materials[size_t(p->material)].extensions.count("KHR_materials_unlit"))
      return;
    p->flat = true;
  }

  static void to_triangles(int mode, const std::vector<uint32_t>& idx, std::vector<uint32_t>* tri) {
    tri->clear();
    if (mode == TINYGLTF_MODE_TRIANGLES) {
      tri->assign(idx.begin(), idx.begin() + long(idx.size() / 3 * 3));
    } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
      for (size_t i = 2; i < idx.size(); ++i) {
        if (i % 2 == 0)
          tri->insert(tri->end(), {idx[i - 2], idx[i - 1], idx[i]});
        else
          tri->insert(tri->end(), {idx[i - 1], idx[i - 2], idx[i]});
      }
    } else {
      for (size_t i = 2; i < idx.size(); ++i) tri->insert(tri->end(), {idx[i - 1], idx[i], idx[0]});
    }
  }

  Status draco_primitive(const tinygltf::Primitive& p, const tinygltf::Value& ext,
                         const std::string& where, Primitive* out, SkinInfluences* skin) {
    if (!ext.IsObject() || !ext.Has("bufferView") || !ext.Has("attributes"))
      return r_.err(where, "KHR_draco_mesh_compression lacks bufferView or attributes");
    int view = ext.Get("bufferView").GetNumberAsInt();
    if (view < 0 || size_t(view) >= m_.bufferViews.size())
      return r_.err(where, "KHR_draco_mesh_compression: bufferView " + std::to_string(view) +
                               " does not exist");
    const uint8_t* data;
    size_t len = m_.bufferViews[size_t(view)].byteLength;
    Status s = r_.locate(view, 0, len > 0 ? 1 : 0, len, len, where, &data);
    if (!s) return s;
    std::vector<std::pair<std::string, int>> attrs;
    std::vector<std::pair<std::string, bool>> norm;
    const tinygltf::Value& a = ext.Get("attributes");
    for (const std::string& key : a.Keys()) {
      attrs.emplace_back(key, a.Get(key).GetNumberAsInt());
      auto acc = p.attributes.find(key);
      bool normalized = acc != p.attributes.end() && acc->second >= 0 &&
                        size_t(acc->second) < m_.accessors.size() &&
                        m_.accessors[size_t(acc->second)].normalized;
      norm.emplace_back(key, normalized);
    }
    std::vector<uint8_t> bytes(data, data + len);
    std::string e;
    s = decode_draco_primitive(bytes, attrs, norm, out, skin, &e);
    if (!s) return r_.err(where, "KHR_draco_mesh_compression: " + s.message());
    return Status::ok();
  }

  // The weights a mesh's morph targets show at rest (glTF 2.0 §3.7.2.2): the first node using
  // the mesh that gives weights, else the mesh's own; missing entries are 0. Nodes that give
  // different weights for one mesh share its first node's shape (said in one warning).
  std::vector<double> morph_weights(size_t mesh) {
    std::vector<double> w = m_.meshes[mesh].weights;
    bool from_node = false;
    for (const tinygltf::Node& n : m_.nodes) {
      if (n.mesh != int(mesh) || n.weights.empty()) continue;
      if (!from_node) {
        w = n.weights;
        from_node = true;
      } else if (n.weights != w && differing_weights_.insert(mesh).second) {
        warn(warnings_, "gltf: " + file_ + ": mesh " + std::to_string(mesh) +
                            ": nodes give it different morph weights; all show the first's");
      }
    }
    return w;
  }

  // Adds each morph target's POSITION and NORMAL displacements times its weight (what a viewer
  // shows without animation). A target's accessor must have the primitive's vertex count.
  Status apply_morph_targets(const tinygltf::Primitive& p, const std::vector<double>& weights,
                             const std::string& where, Primitive* out) {
    const size_t n = out->positions.size();
    bool moved = false;
    for (size_t t = 0; t < p.targets.size(); ++t) {
      const double w = t < weights.size() && std::isfinite(weights[t]) ? weights[t] : 0.0;
      if (w == 0) continue;
      for (const char* attr : {"POSITION", "NORMAL"}) {
        auto it = p.targets[t].find(attr);
        if (it == p.targets[t].end() || (attr[0] == 'N' && out->normals.empty())) continue;
        std::vector<float> d;
        const std::string what = where + ": morph target " + std::to_string(t) + " " + attr;
        if (Status s = r_.floats(it->second, 3, 0, what, &d); !s) return s;
        if (d.size() != 3 * n)
          return r_.err(where, "morph target " + std::to_string(t) + " " + attr + " has " +
                                   std::to_string(d.size() / 3) + " elements for " +
                                   std::to_string(n) + " vertices");
        std::vector<Vec3>& v = attr[0] == 'P' ? out->positions : out->normals;
        for (size_t i = 0; i < n; ++i)
          v[i] = v[i] + Vec3{float(w * d[3 * i]), float(w * d[3 * i + 1]), float(w * d[3 * i + 2])};
      }
      moved = true;
    }
    if (moved) {
      for (Vec3& nv : out->normals) nv = normalize(nv);
      morphed_ = true;
    }
    return Status::ok();
  }

  // A POINTS, LINES, LINE_STRIP or LINE_LOOP primitive as a LineSet in its mesh's space (its
  // nodes place it, visit). Draco-coded ones are skipped with a warning.
  Status line_primitive(const tinygltf::Primitive& p, const std::string& where, LineSet* out) {
    if (p.extensions.count("KHR_draco_mesh_compression")) {
      warn(warnings_, "gltf: " + file_ + ": " + where + ": Draco-coded points/lines skipped");
      return Status::ok();
    }
    auto pos = p.attributes.find("POSITION");
    if (pos == p.attributes.end()) return r_.err(where, "has no POSITION attribute");
    std::vector<float> f;
    if (Status s = r_.floats(pos->second, 3, 0, where, &f); !s) return s;
    const size_t n = f.size() / 3;
    for (size_t i = 0; i < n; ++i) out->positions.push_back({f[3 * i], f[3 * i + 1], f[3 * i + 2]});
    if (auto c = p.attributes.find("COLOR_0"); c != p.attributes.end()) {
      if (Status s = r_.floats(c->second, 4, 1, where + ": COLOR_0", &f); !s) return s;
      if (f.size() / 4 == n)
        for (size_t i = 0; i < n; ++i)
          out->colors.push_back({f[4 * i], f[4 * i + 1], f[4 * i + 2], f[4 * i + 3]});
    }
    std::vector<uint32_t> idx;
    if (p.indices >= 0) {
      if (Status s = r_.indices(p.indices, where + ": indices", &idx); !s) return s;
    } else {
      for (size_t i = 0; i < n; ++i) idx.push_back(uint32_t(i));
    }
    for (uint32_t i : idx)
      if (i >= n)
        return r_.err(where, "index " + std::to_string(i) + " out of range (" + std::to_string(n) +
                                 " vertices)");
    out->points = p.mode == TINYGLTF_MODE_POINTS;
    if (p.mode == TINYGLTF_MODE_POINTS || p.mode == TINYGLTF_MODE_LINE) {
      out->indices.assign(
          idx.begin(),
          idx.end() - std::ptrdiff_t(p.mode == TINYGLTF_MODE_LINE ? idx.size() % 2 : 0));
    } else {  // LINE_STRIP, LINE_LOOP
      for (size_t i = 0; i + 1 < idx.size(); ++i)
        out->indices.insert(out->indices.end(), {idx[i], idx[i + 1]});
      if (p.mode == TINYGLTF_MODE_LINE_LOOP && idx.size() > 2)
        out->indices.insert(out->indices.end(), {idx.back(), idx.front()});
    }
    if (p.material >= 0 && size_t(p.material) < m_.materials.size()) {
      const auto& c = m_.materials[size_t(p.material)].pbrMetallicRoughness.baseColorFactor;
      if (c.size() == 4) out->color = {float(c[0]), float(c[1]), float(c[2]), float(c[3])};
    }
    return Status::ok();
  }

  Status meshes() {
    mesh_map_.assign(m_.meshes.size(), -1);
    mesh_lines_.assign(m_.meshes.size(), {});
    for (size_t mi = 0; mi < m_.meshes.size(); ++mi) {
      const tinygltf::Mesh& src = m_.meshes[mi];
      Mesh mesh;
      mesh.name = src.name;
      std::vector<SkinInfluences> skins;  // per primitive kept
      for (size_t pi = 0; pi < src.primitives.size(); ++pi) {
        std::string where = "mesh " + std::to_string(mi) + " primitive " + std::to_string(pi);
        if (const int mode = src.primitives[pi].mode;
            mode == TINYGLTF_MODE_POINTS || mode == TINYGLTF_MODE_LINE ||
            mode == TINYGLTF_MODE_LINE_LOOP || mode == TINYGLTF_MODE_LINE_STRIP) {
          LineSet set;
          set.name = where;
          if (Status s = line_primitive(src.primitives[pi], where, &set); !s) return s;
          if (!set.indices.empty()) mesh_lines_[mi].push_back(std::move(set));
          continue;
        }
        Primitive prim;
        SkinInfluences skin;
        bool skip;
        Status s = primitive(src.primitives[pi], where, &prim, &skin, &skip);
        if (!s) return s;
        if (skip) continue;
        if (!(s = apply_morph_targets(src.primitives[pi], morph_weights(mi), where, &prim)))
          return s;
        if (prim.indices.empty()) {
          warn(warnings_, "gltf: " + file_ + ": " + where + ": no triangles; skipped");
          continue;
        }
        mark_flat(&prim);
        mesh.primitives.push_back(std::move(prim));
        skins.push_back(std::move(skin));
      }
      if (mesh.primitives.empty()) continue;
      mesh_map_[mi] = int32_t(scene_.meshes.size());
      scene_.meshes.push_back(std::move(mesh));
      influences_.push_back(std::move(skins));
    }
    return Status::ok();
  }

  Status instancing(const tinygltf::Node& node, int node_index, const Mat4& world, uint32_t mesh) {
    const tinygltf::Value& ext = node.extensions.at("EXT_mesh_gpu_instancing");
    std::string where = "node " + std::to_string(node_index) + ": EXT_mesh_gpu_instancing";
    if (!ext.IsObject() || !ext.Has("attributes") || !ext.Get("attributes").IsObject())
      return r_.err(where, "has no attributes");
    const tinygltf::Value& a = ext.Get("attributes");
    std::vector<float> t, r, s;
    size_t count = SIZE_MAX;
    auto read = [&](const char* name, int comps, std::vector<float>* out) -> Status {
      if (!a.Has(name)) return Status::ok();
      Status st = r_.floats(a.Get(name).GetNumberAsInt(), comps, 0, where + ": " + name, out);
      if (!st) return st;
      count = std::min(count, out->size() / size_t(comps));
      return Status::ok();
    };
    Status st;
    if (!(st = read("TRANSLATION", 3, &t)) || !(st = read("ROTATION", 4, &r)) ||
        !(st = read("SCALE", 3, &s)))
      return st;
    if (count == SIZE_MAX) return r_.err(where, "has no TRANSLATION, ROTATION or SCALE");
    if ((!t.empty() && t.size() / 3 != count) || (!r.empty() && r.size() / 4 != count) ||
        (!s.empty() && s.size() / 3 != count))
      return r_.err(where, "attribute counts differ");
    if (Status st2 = count_instances(count, where); !st2) return st2;
    for (size_t i = 0; i < count; ++i) {
      double tt[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, ss[3] = {1, 1, 1};
      for (int k = 0; k < 3 && !t.empty(); ++k) tt[k] = t[3 * i + size_t(k)];
      for (int k = 0; k < 4 && !r.empty(); ++k) q[k] = r[4 * i + size_t(k)];
      for (int k = 0; k < 3 && !s.empty(); ++k) ss[k] = s[3 * i + size_t(k)];
      Instance inst;
      inst.mesh = mesh;
      inst.world = world * Mat4::trs(tt, q, ss);
      inst.name = node.name;
      scene_.instances.push_back(std::move(inst));
    }
    return Status::ok();
  }

  // The instance budget (ImportOptions::max_instances): 25 nodes each listing the next twice
  // expand to 2^25 paths; `n` more instances (or node visits) must fit.
  Status count_instances(size_t n, const std::string& where) {
    instances_ += n;
    if (instances_ > opts_.max_instances)
      return r_.err(where, "the node graph expands to more than " +
                               std::to_string(opts_.max_instances) +
                               " instances (the limit from the input's size; --max-instances "
                               "raises it)");
    return Status::ok();
  }

  Status visit(int index, const Mat4& parent, std::vector<char>& on_path, int depth) {
    if (index < 0 || size_t(index) >= m_.nodes.size())
      return r_.err("", "node " + std::to_string(index) + " does not exist");
    if (on_path[size_t(index)] || depth > 1024)
      return r_.err("node " + std::to_string(index), "node hierarchy has a cycle");
    if (Status s = count_instances(1, "node " + std::to_string(index)); !s) return s;
    on_path[size_t(index)] = 1;
    const tinygltf::Node& node = m_.nodes[size_t(index)];
    Mat4 world = parent * node_local(node);
    if (node.mesh >= 0) {
      if (size_t(node.mesh) >= m_.meshes.size())
        return r_.err("node " + std::to_string(index),
                      "mesh " + std::to_string(node.mesh) + " does not exist");
      for (const LineSet& set : mesh_lines_[size_t(node.mesh)]) {  // placed in the world
        LineSet placed = set;
        for (Vec3& v : placed.positions) v = world.transform_point(v);
        scene_.lines.push_back(std::move(placed));
      }
      int32_t mesh = mesh_map_[size_t(node.mesh)];
      if (mesh >= 0) {
        if (node.skin >= 0 && size_t(node.skin) < m_.skins.size() && has_influences(mesh)) {
          skinned_.push_back({index, scene_.instances.size()});
          scene_.instances.push_back({uint32_t(mesh), Mat4::identity(), node.name});
        } else if (node.extensions.count("EXT_mesh_gpu_instancing")) {
          Status s = instancing(node, index, world, uint32_t(mesh));
          if (!s) return s;
        } else {
          scene_.instances.push_back({uint32_t(mesh), world, node.name});
        }
      }
    }
    for (int child : node.children) {
      Status s = visit(child, world, on_path, depth + 1);
      if (!s) return s;
    }
    on_path[size_t(index)] = 0;
    return Status::ok();
  }

  Status nodes() {
    std::vector<int> roots;
    if (!m_.scenes.empty()) {
      int si =
          m_.defaultScene >= 0 && size_t(m_.defaultScene) < m_.scenes.size() ? m_.defaultScene : 0;
      roots = m_.scenes[size_t(si)].nodes;
    } else {
      std::vector<char> is_child(m_.nodes.size(), 0);
      for (const auto& n : m_.nodes)
        for (int c : n.children)
          if (c >= 0 && size_t(c) < is_child.size()) is_child[size_t(c)] = 1;
      for (size_t i = 0; i < m_.nodes.size(); ++i)
        if (!is_child[i]) roots.push_back(int(i));
    }
    std::vector<char> on_path(m_.nodes.size(), 0);
    for (int root : roots) {
      Status s = visit(root, Mat4::identity(), on_path, 0);
      if (!s) return s;
    }
    return pose_skins();
  }

  bool has_influences(int32_t mesh) const {
    for (const SkinInfluences& s : influences_[size_t(mesh)])
      if (!s.empty()) return true;
    return false;
  }

  // A node's world matrix through its parents (the joints of a skin may lie anywhere in the
  // node graph). Cycles were refused by visit(); the depth bound guards the rest.
  Mat4 node_world(int index, const std::vector<int>& parent) const {
    Mat4 world = node_local(m_.nodes[size_t(index)]);
    for (int p = parent[size_t(index)], depth = 0; p >= 0 && depth < 1024;
         p = parent[size_t(p)], ++depth)
      world = node_local(m_.nodes[size_t(p)]) * world;
    return world;
  }

  // Each skinned node's instance gets its own copy of the mesh, posed by its skin at rest.
  Status pose_skins() {
    if (skinned_.empty()) return Status::ok();
    std::vector<int> parent(m_.nodes.size(), -1);
    for (size_t i = 0; i < m_.nodes.size(); ++i)
      for (int c : m_.nodes[i].children)
        if (c >= 0 && size_t(c) < parent.size()) parent[size_t(c)] = int(i);
    for (const auto& [node, instance] : skinned_) {
      const tinygltf::Skin& skin = m_.skins[size_t(m_.nodes[size_t(node)].skin)];
      const std::string where = "skin " + std::to_string(m_.nodes[size_t(node)].skin);
      std::vector<float> ibm;
      if (skin.inverseBindMatrices >= 0)
        if (Status s =
                r_.floats(skin.inverseBindMatrices, 16, 0, where + ": inverseBindMatrices", &ibm);
            !s)
          return s;
      std::vector<Mat4> joints;
      for (size_t j = 0; j < skin.joints.size(); ++j) {
        const int jn = skin.joints[j];
        if (jn < 0 || size_t(jn) >= m_.nodes.size())
          return r_.err(where, "joint node " + std::to_string(jn) + " does not exist");
        Mat4 bind;
        if (ibm.size() >= 16 * (j + 1))
          for (size_t k = 0; k < 16; ++k) bind.m[k] = ibm[16 * j + k];
        joints.push_back(node_world(jn, parent) * bind);
      }
      const uint32_t source = scene_.instances[instance].mesh;
      Mesh posed = scene_.meshes[source];
      for (size_t pi = 0; pi < posed.primitives.size(); ++pi)
        posed.primitives[pi] = pose_skinned(posed.primitives[pi], influences_[source][pi], joints);
      scene_.instances[instance].mesh = uint32_t(scene_.meshes.size());
      scene_.meshes.push_back(std::move(posed));
      influences_.emplace_back();
    }
    warn(warnings_, "gltf: " + file_ + ": " + std::to_string(skinned_.size()) +
                        " skinned mesh node(s) posed as the joints stand at rest");
    drop_unplaced_meshes();
    return Status::ok();
  }

  // Meshes no instance places any more (a skinned mesh whose every node got a posed copy).
  void drop_unplaced_meshes() {
    std::vector<int32_t> remap(scene_.meshes.size(), -1);
    for (const Instance& inst : scene_.instances) remap[inst.mesh] = 0;
    std::vector<Mesh> kept;
    for (size_t m = 0; m < scene_.meshes.size(); ++m)
      if (remap[m] == 0) {
        remap[m] = int32_t(kept.size());
        kept.push_back(std::move(scene_.meshes[m]));
      }
    for (Instance& inst : scene_.instances) inst.mesh = uint32_t(remap[inst.mesh]);
    scene_.meshes = std::move(kept);
  }

  const tinygltf::Model& m_;
  std::map<std::string, size_t> effects_;  // appearance extension → materials using it
  std::set<size_t> differing_weights_;     // meshes whose nodes disagree on morph weights
  int32_t flat_normal_ = -1;               // the flat normal map anisotropy needs (if made)
  std::vector<int32_t> tangent_material_;  // per glTF material: the one primitives with TANGENT
                                           // use (anisotropy_in_tangent_frames)
  std::map<int32_t, int32_t> mirrored_images_;    // anisotropy texture → its mirrored copy
  std::vector<std::vector<LineSet>> mesh_lines_;  // per glTF mesh: its points and lines
  bool morphed_ = false;                          // some primitive shows morph targets at rest
  std::vector<std::vector<SkinInfluences>> influences_;  // per scene mesh, per primitive
  std::vector<std::pair<int, size_t>> skinned_;  // skinned node → its instance (posed later)
  Reader r_;
  std::string file_;
  const ImportOptions& opts_;
  Warnings* warnings_;
  Scene scene_;
  std::vector<int32_t> image_map_;  // glTF image → scene image (-1: unusable)
  std::vector<int32_t> mesh_map_;   // glTF mesh → scene mesh (-1: nothing drawable)
  uint64_t instances_ = 0;          // node visits and instances so far (max_instances)
};

// Files a .gltf references (buffers, images) are read only through these callbacks: resolved
// (links and ".." followed, after tinygltf's percent-decoding) and refused outside the model's
// folder unless --allow-outside, and only regular files (a FIFO or /dev/zero is never opened
// for reading). The first refusal is kept for the error message; the bytes read are counted
// for the resource limits.
struct FsScope {
  InputScope scope;
  uint64_t max_bytes = 0;
  uint64_t bytes_read = 0;
  std::string refusal;
  std::map<std::string, std::string> relocated;  // missing path → the one file of its name
  std::vector<std::string> notes;                // warnings: where relocated files were found
};

// A referenced file that does not exist where the URI says is looked for by its file name
// in the upload: exactly one match is used (with a warning naming where), none or several
// leave the path as it was (and the read fails as before).
std::string relocate(FsScope* fs, const std::string& path) {
  struct stat st;
  if (stat(path.c_str(), &st) == 0 || errno != ENOENT) return path;
  if (auto it = fs->relocated.find(path); it != fs->relocated.end()) return it->second;
  std::vector<std::string> found = find_by_file_name(fs->scope.root, base_name(path));
  std::string use = path;
  if (found.size() == 1) {
    use = found.front();
    fs->notes.push_back(base_name(path) + " is not at " + path + "; using " + use +
                        " (the only file of that name in the upload)");
  }
  fs->relocated.emplace(path, use);
  return use;
}

bool fs_file_exists(const std::string& path, void* user) {
  auto* fs = static_cast<FsScope*>(user);
  auto resolved = resolve_in_scope(fs->scope, relocate(fs, path));
  if (!resolved.ok()) {
    if (fs->refusal.empty() &&
        resolved.status().message().find("outside the upload's folder") != std::string::npos)
      fs->refusal = resolved.status().message();
    return false;
  }
  struct stat st;
  if (stat(resolved->c_str(), &st) != 0) return false;
  if (!S_ISREG(st.st_mode)) {
    if (fs->refusal.empty())
      fs->refusal = path + ": not a regular file (a device, pipe or socket is not read)";
    return false;
  }
  return true;
}

std::string fs_expand(const std::string& path, void*) { return path; }

bool fs_read(std::vector<unsigned char>* out, std::string* err, const std::string& path,
             void* user) {
  auto* fs = static_cast<FsScope*>(user);
  auto resolved = resolve_in_scope(fs->scope, relocate(fs, path));
  if (!resolved.ok()) {
    if (err) *err += resolved.status().message();
    if (fs->refusal.empty()) fs->refusal = resolved.status().message();
    return false;
  }
  auto bytes = read_whole_file(*resolved, fs->max_bytes);
  if (!bytes.ok()) {
    if (err) *err += bytes.status().message();
    return false;
  }
  fs->bytes_read += bytes->size();
  *out = bytes.take();
  return true;
}

bool fs_write(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  if (err) *err += "meshmux never writes through the glTF loader";
  return false;
}

constexpr int kMaxJsonDepth = 64;  // real glTF files nest under 12 levels

}  // namespace

Result<Scene> import_gltf(const std::string& path, const ImportOptions& options,
                          Warnings* warnings) {
  std::string file = base_name(path);
  auto bytes = read_whole_file(path, options.max_file_bytes);
  if (!bytes.ok()) return Status::error("gltf: " + bytes.status().message(), ErrorKind::kInput);
  std::vector<uint8_t>& data = *bytes;
  if (data.empty()) return Status::error("gltf: " + file + ": file is empty", ErrorKind::kInput);
  if (data.size() > 0xFFFFFFFFu)
    return Status::error("gltf: " + file + ": file too large", ErrorKind::kInput);

  std::string dir = ".";
  size_t slash = path.find_last_of('/');
  if (slash != std::string::npos) dir = path.substr(0, slash);

  // Nesting, before any JSON parser (ours or tinygltf's) sees the text.
  {
    size_t at = 0, len = data.size();
    if (data.size() >= 20 && std::memcmp(data.data(), "glTF", 4) == 0) {
      uint32_t chunk;
      std::memcpy(&chunk, data.data() + 12, 4);
      at = 20;
      len = std::min<size_t>(chunk, data.size() - 20);
    }
    if (json_depth(data.data() + at, len, kMaxJsonDepth) > kMaxJsonDepth)
      return Status::error("gltf: " + file + ": JSON nested deeper than " +
                               std::to_string(kMaxJsonDepth) + " levels; refused",
                           ErrorKind::kInput);
  }
  auto scope = input_scope(path, options.allow_outside, options.root);
  if (!scope.ok()) return Status::error("gltf: " + scope.status().message(), ErrorKind::kInput);
  FsScope fs_scope;
  fs_scope.scope = *scope;
  fs_scope.max_bytes = options.max_file_bytes;

  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(keep_encoded_image, nullptr);
  loader.SetFsCallbacks({fs_file_exists, fs_expand, fs_read, fs_write, &fs_scope});
  tinygltf::Model model;
  std::string err, warn_text;
  bool ok;
  bool binary = data.size() >= 4 && std::memcmp(data.data(), "glTF", 4) == 0;
  try {
    if (binary) {
      if (data.size() < 20)
        return Status::error(
            "gltf: " + file + ": truncated GLB (" + std::to_string(data.size()) + " bytes)",
            ErrorKind::kInput);
      uint32_t declared;
      std::memcpy(&declared, data.data() + 8, 4);
      if (declared > data.size())
        return Status::error("gltf: " + file + ": truncated GLB: header declares " +
                                 std::to_string(declared) + " bytes, file has " +
                                 std::to_string(data.size()),
                             ErrorKind::kInput);
      // Decoded meshopt buffers: at most 32× the file (real ratios are under 10×), ≥ 64 MB,
      // ≤ 1 GB.
      auto meshopt = decode_meshopt_glb(
          data, file,
          std::min<uint64_t>(uint64_t(1) << 30,
                             std::max<uint64_t>(uint64_t(64) << 20, 32 * uint64_t(data.size()))));
      if (!meshopt.ok()) return meshopt.status();
      drop_draco_index_accessors(data, true);
      ok = loader.LoadBinaryFromMemory(&model, &err, &warn_text, data.data(), unsigned(data.size()),
                                       dir);
    } else {
      drop_draco_index_accessors(data, false);
      ok = loader.LoadASCIIFromString(&model, &err, &warn_text,
                                      reinterpret_cast<const char*>(data.data()),
                                      unsigned(data.size()), dir);
    }
  } catch (const std::bad_alloc&) {
    throw;  // the caller knows the memory limit and the option that raises it
  } catch (const std::exception& e) {
    return Status::error("gltf: " + file + ": cannot parse: " + e.what(), ErrorKind::kInput);
  }
  if (!fs_scope.refusal.empty())
    return Status::error("gltf: " + file + ": " + fs_scope.refusal, ErrorKind::kInput);
  if (!ok) {
    std::string reason = err.empty() ? warn_text : err;
    while (!reason.empty() && (reason.back() == '\n' || reason.back() == ' ')) reason.pop_back();
    for (char& c : reason)
      if (c == '\n') c = ';';
    return Status::error(
        "gltf: " + file + ": cannot parse: " + (reason.empty() ? "invalid glTF" : reason),
        ErrorKind::kInput);
  }
  // tinygltf reports missing external images as warnings; the image pass turns those into
  // per-image warnings, so its raw text is not repeated here.
  for (const std::string& note : fs_scope.notes) warn(warnings, "gltf: " + file + ": " + note);
  // The limits, from the bytes the model's files hold.
  const ImportOptions limits = resolved_limits(options, data.size() + fs_scope.bytes_read);
  Importer importer(model, file, limits, warnings);
  auto scene = importer.run();
  if (!scene.ok()) return scene.status();
  scene->source = path;
  Status s = validate(*scene, "gltf: " + file);
  if (!s) return s;
  return scene;
}

}  // namespace meshmux
