// Scene → .glb. The JSON is built with nlohmann_json and the GLB container is written here:
// tinygltf is not used for writing because libdraco.so exports its own, older copy of
// tinygltf's symbols, and a writer that resolves into the wrong copy is a hazard we need not take.
#include "exporters/gltf.h"

#include "stream/quantize.h"

// GCC 12 reports a false -Wmaybe-uninitialized inside Eigen's 3x3 JacobiSVD.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <eigen3/Eigen/Geometry>
#include <eigen3/Eigen/SVD>
#pragma GCC diagnostic pop
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstring>
#include <exception>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <utility>

#include "core/file_io.h"
#include "core/parallel.h"
#include "exporters/draco_encode.h"
#include "exporters/gltf_constants.h"
#include "exporters/gltf_meshopt.h"
#include "exporters/ktx2_images.h"
#include "exporters/split_primitive.h"
#include "image/encode.h"

namespace meshmux {

namespace {

using json = nlohmann::json;

using namespace gltf_enum;
constexpr int kMaxTexCoord = 7;  // highest TEXCOORD_n we are willing to pad a primitive up to

const char* const kDraco = "KHR_draco_mesh_compression";
const char* const kTextureBasisu = "KHR_texture_basisu";
const char* const kMeshopt = "EXT_meshopt_compression";
const char* const kQuantization = "KHR_mesh_quantization";
const char* const kInstancing = "EXT_mesh_gpu_instancing";
const char* const kTextureTransform = "KHR_texture_transform";
const char* const kUnlit = "KHR_materials_unlit";
const char* const kEmissiveStrength = "KHR_materials_emissive_strength";
const char* const kSheen = "KHR_materials_sheen";
const char* const kTransmission = "KHR_materials_transmission";
const char* const kIor = "KHR_materials_ior";
const char* const kVolume = "KHR_materials_volume";
const char* const kClearcoat = "KHR_materials_clearcoat";
const char* const kSpecular = "KHR_materials_specular";
const char* const kIridescence = "KHR_materials_iridescence";
const char* const kAnisotropy = "KHR_materials_anisotropy";

// The JSON number that prints as the shortest decimal reading back to exactly `f`.
json num(float f) {
  if (!std::isfinite(f)) return 0.0;
  char buf[64];
  auto r = std::to_chars(buf, buf + sizeof buf, f);
  double d = f;
  if (r.ec == std::errc()) std::from_chars(buf, r.ptr, d);
  return d;
}

json num(double d) { return std::isfinite(d) ? json(d) : json(0.0); }

bool is_png(const std::vector<uint8_t>& b) {
  static const uint8_t sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  return b.size() >= 8 && std::memcmp(b.data(), sig, 8) == 0;
}

bool is_jpeg(const std::vector<uint8_t>& b) {
  return b.size() >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF;
}

bool is_ktx2(const std::vector<uint8_t>& b) {  // KTX 2.0 §3.1: the file identifier
  static const uint8_t id[12] = {0xAB, 'K', 'T', 'X', ' ', '2', '0', 0xBB, '\r', '\n', 0x1A, '\n'};
  return b.size() >= 12 && std::memcmp(b.data(), id, 12) == 0;
}

// Everything about an instance's transform the node writer needs.
struct Placement {
  Mat4 world;  // affine part of the instance transform
  bool trs = false;
  double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
};

// Rotation matrix → unit quaternion (x, y, z, w) with w >= 0.
std::array<double, 4> quaternion(const Eigen::Matrix3d& r) {
  Eigen::Quaterniond q(r);
  q.normalize();
  std::array<double, 4> out = {q.x(), q.y(), q.z(), q.w()};
  if (out[3] < 0)
    for (double& v : out) v = -v;
  return out;
}

class Exporter {
 public:
  Exporter(const Scene& scene, const GltfExportOptions& options, Warnings* warnings)
      : scene_(scene), opt_(options), warnings_(warnings) {}

  Result<std::vector<uint8_t>> run() {
    if (opt_.ktx2) {
      auto k = encode_images_ktx2(scene_, image_uses(scene_), opt_.ktx2_options);
      if (!k.ok()) return k.status().with_prefix("gltf export");
      ktx2_ = k.take();
    }
    prepare_images();
    write_materials();
    write_meshes();
    write_nodes();
    write_lines();
    return assemble();
  }

 private:
  void note(const std::string& message) { warn(warnings_, "gltf export: " + message); }

  // Appends bytes to the binary chunk, 4-byte aligned; returns the bufferView index.
  int add_view(const void* data, size_t size, int target) {
    while (bin_.size() % 4) bin_.push_back(0);
    json v = {{"buffer", 0}, {"byteOffset", bin_.size()}, {"byteLength", size}};
    if (target) v["target"] = target;
    const uint8_t* p = static_cast<const uint8_t*>(data);
    bin_.insert(bin_.end(), p, p + size);
    views_.push_back(std::move(v));
    return int(views_.size() - 1);
  }

  int add_accessor(int view, int component, const char* type, size_t count, json min = nullptr,
                   json max = nullptr) {
    json a = {{"componentType", component}, {"type", type}, {"count", count}};
    if (view >= 0) a["bufferView"] = view;
    if (!min.is_null()) a["min"] = std::move(min);
    if (!max.is_null()) a["max"] = std::move(max);
    accessors_.push_back(std::move(a));
    return int(accessors_.size() - 1);
  }

  template <class T>
  int add_float_accessor(const std::vector<T>& values, const char* type, int target) {
    int view = add_view(values.data(), values.size() * sizeof(T), target);
    return add_accessor(view, kFloat, type, values.size());
  }

  // ---- images, samplers, textures ----

  void prepare_images() {
    std::set<int32_t> referenced;
    for (const Material& m : scene_.materials)
      for (const TextureRef* t : texture_refs(m))
        if (t->present() && size_t(t->image) < scene_.images.size()) referenced.insert(t->image);
    image_map_.assign(scene_.images.size(), -1);
    for (int32_t i : referenced) {
      const Image& img = scene_.images[i];
      const std::string label = "image " + std::to_string(i) + " '" + img.name + "'";
      std::vector<uint8_t> png;
      const std::vector<uint8_t>* bytes = nullptr;
      std::string mime;
      if (i < int32_t(ktx2_.size()) && !ktx2_[size_t(i)].empty()) {
        bytes = &ktx2_[size_t(i)], mime = "image/ktx2";
      } else if (img.mime_type == "image/ktx2" && is_ktx2(img.encoded)) {
        bytes = &img.encoded, mime = "image/ktx2";  // as it came, or as the levels made it
      } else if (img.mime_type == "image/png" && is_png(img.encoded)) {
        bytes = &img.encoded, mime = "image/png";
      } else if (img.mime_type == "image/jpeg" && is_jpeg(img.encoded)) {
        bytes = &img.encoded, mime = "image/jpeg";
      } else if (img.decoded()) {
        auto r = encode_png(img, opt_.counts);
        if (!r.ok()) {
          note(label + ": cannot embed (" + r.status().message() + ")");
          continue;
        }
        png = r.take();
        bytes = &png, mime = "image/png";
      } else {
        note(label + ": cannot embed (not decoded)");
        continue;
      }
      json j = {{"bufferView", add_view(bytes->data(), bytes->size(), 0)}, {"mimeType", mime}};
      if (!img.name.empty()) j["name"] = img.name;
      if (opt_.tag_meshes) j["extras"] = {{"meshmux_image", i}};
      image_map_[i] = int(images_.size());
      images_.push_back(std::move(j));
    }
  }

  // Sampler index, or -1 when every field has glTF's default.
  int sampler_index(const Sampler& s, const std::string& where) {
    auto wrap = [](Wrap w) {
      int v = int(w);
      return v == 10497 || v == 33071 || v == 33648 ? v : 10497;
    };
    int mag = s.mag_filter, min = s.min_filter;
    if (mag != 0 && mag != 9728 && mag != 9729) {
      note(where + ": magFilter " + std::to_string(mag) + " invalid; left unspecified");
      mag = 0;
    }
    if (min != 0 && !(min == 9728 || min == 9729 || (min >= 9984 && min <= 9987))) {
      note(where + ": minFilter " + std::to_string(min) + " invalid; left unspecified");
      min = 0;
    }
    std::array<int, 4> key = {wrap(s.wrap_s), wrap(s.wrap_t), mag, min};
    if (key == std::array<int, 4>{10497, 10497, 0, 0}) return -1;
    auto it = samplers_index_.find(key);
    if (it != samplers_index_.end()) return it->second;
    json j = json::object();
    if (key[0] != 10497) j["wrapS"] = key[0];
    if (key[1] != 10497) j["wrapT"] = key[1];
    if (mag) j["magFilter"] = mag;
    if (min) j["minFilter"] = min;
    samplers_.push_back(std::move(j));
    return samplers_index_[key] = int(samplers_.size() - 1);
  }

  // textureInfo JSON, or null when the texture is absent or was dropped.
  json texture_info(const TextureRef& t, const std::string& where) {
    if (!t.present()) return nullptr;
    int image = size_t(t.image) < image_map_.size() ? image_map_[t.image] : -1;
    if (image < 0) return nullptr;  // warned about in prepare_images
    if (t.tex_coord > uint32_t(kMaxTexCoord)) {
      note(where + ": texCoord " + std::to_string(t.tex_coord) + " unsupported; texture dropped");
      return nullptr;
    }
    int sampler = sampler_index(t.sampler, where);
    std::pair<int, int> key(image, sampler);
    auto it = textures_index_.find(key);
    int texture;
    if (it != textures_index_.end()) {
      texture = it->second;
    } else {
      json j = json::object();
      // A KTX2 image has no core source: a KTX2-reading loader is required.
      if (images_[size_t(image)]["mimeType"] == "image/ktx2") {
        j["extensions"][kTextureBasisu] = {{"source", image}};
        used_.insert(kTextureBasisu), required_.insert(kTextureBasisu);
      } else {
        j["source"] = image;
      }
      if (sampler >= 0) j["sampler"] = sampler;
      textures_.push_back(std::move(j));
      texture = textures_index_[key] = int(textures_.size() - 1);
    }
    json info = {{"index", texture}};
    if (t.tex_coord) info["texCoord"] = t.tex_coord;
    const TextureTransform& x = t.transform;
    if (!x.is_identity()) {
      if (!std::isfinite(x.offset[0]) || !std::isfinite(x.offset[1]) ||
          !std::isfinite(x.rotation) || !std::isfinite(x.scale[0]) || !std::isfinite(x.scale[1])) {
        note(where + ": texture transform is not finite; left out");
      } else {
        json e = json::object();
        if (x.offset[0] != 0 || x.offset[1] != 0)
          e["offset"] = {num(x.offset[0]), num(x.offset[1])};
        if (x.rotation != 0) e["rotation"] = num(x.rotation);
        if (x.scale[0] != 1 || x.scale[1] != 1) e["scale"] = {num(x.scale[0]), num(x.scale[1])};
        info["extensions"][kTextureTransform] = std::move(e);
        used_.insert(kTextureTransform);
      }
    }
    return info;
  }

  // ---- materials ----

  // v clamped to [lo, hi]; NaN becomes `def`. Warns when the value changes.
  float bounded(float v, float lo, float hi, float def, const std::string& what) {
    float r = std::isnan(v) ? def : std::clamp(v, lo, hi);
    if (!(r == v))
      note(what + " " + std::to_string(v) + " out of range; written as " + std::to_string(r));
    return r;
  }

  // A linear RGB factor as a JSON array, each component within [0, hi] (1 where NaN).
  json colour(Vec3 c, float hi, const std::string& what) {
    return {num(bounded(c.x, 0, hi, 1, what)), num(bounded(c.y, 0, hi, 1, what)),
            num(bounded(c.z, 0, hi, 1, what))};
  }

  // Glass: KHR_materials_transmission (factor, and the texture whose R channel scales it),
  // KHR_materials_ior where it is not glTF's default 1.5, KHR_materials_volume where the
  // surface has a thickness (the same texture's G channel scales it).
  template <class Tex>
  void write_glass(const Material& m, const std::string& where, Tex& tex, json& j) {
    json t = json::object();
    t["transmissionFactor"] =
        num(bounded(m.transmission_factor, 0, 1, 0, where + ": transmissionFactor"));
    if (json info = tex(m.transmission, "transmissionTexture"); !info.is_null())
      t["transmissionTexture"] = std::move(info);
    j["extensions"][kTransmission] = std::move(t);
    used_.insert(kTransmission);
    const float ior = bounded(m.ior, 1, 10, 1.5f, where + ": ior");
    if (ior != 1.5f) {
      j["extensions"][kIor] = {{"ior", num(ior)}};
      used_.insert(kIor);
    }
    const float thickness =
        std::isfinite(m.thickness_factor) ? std::max(0.0f, m.thickness_factor) : 0;
    if (thickness > 0) {
      json v = json::object();
      v["thicknessFactor"] = num(thickness);
      if (json info = tex(m.layer(LayerSlot::kThickness), "thicknessTexture"); !info.is_null())
        v["thicknessTexture"] = std::move(info);
      if (m.attenuation_distance > 0 && std::isfinite(m.attenuation_distance))
        v["attenuationDistance"] = num(m.attenuation_distance);
      if (!(m.attenuation_color == Vec3{1, 1, 1}))
        v["attenuationColor"] = colour(m.attenuation_color, 1, where + ": attenuationColor");
      j["extensions"][kVolume] = std::move(v);
      used_.insert(kVolume);
    }
  }

  // The reflection's layers, where they differ from glTF's defaults: clearcoat, specular
  // (strength and F0 colour), iridescence (thin film), anisotropy; each with its textures
  // (LayerSlot, under kLayerSlots' keys).
  template <class Tex>
  void write_layers(const Material& m, const std::string& where, Tex& tex, json& j) {
    // The layer textures of `extension` into `e` (the clearcoat's normal map with its scale).
    auto layer_textures = [&](const char* extension, json& e) {
      for (size_t k = 0; k < size_t(LayerSlot::kCount); ++k) {
        if (std::string(kLayerSlots[k].extension) != extension) continue;
        json info = tex(m.layers[k], kLayerSlots[k].key);
        if (info.is_null()) continue;
        if (LayerSlot(k) == LayerSlot::kClearcoatNormal && std::isfinite(m.layers[k].scale) &&
            m.layers[k].scale != 1)
          info["scale"] = num(m.layers[k].scale);
        e[kLayerSlots[k].key] = std::move(info);
      }
    };
    if (m.clearcoat_factor > 0) {
      json c = json::object();
      c["clearcoatFactor"] = num(bounded(m.clearcoat_factor, 0, 1, 0, where + ": clearcoatFactor"));
      const float r =
          bounded(m.clearcoat_roughness_factor, 0, 1, 0, where + ": clearcoatRoughness");
      if (r != 0) c["clearcoatRoughnessFactor"] = num(r);
      layer_textures(kClearcoat, c);
      j["extensions"][kClearcoat] = std::move(c);
      used_.insert(kClearcoat);
    }
    const Vec3 sc = m.specular_color_factor;
    if (m.specular_factor != 1 || !(sc == Vec3{1, 1, 1}) ||
        m.layer(LayerSlot::kSpecular).present() || m.layer(LayerSlot::kSpecularColor).present()) {
      json sp = json::object();
      const float f = bounded(m.specular_factor, 0, 1, 1, where + ": specularFactor");
      if (f != 1) sp["specularFactor"] = num(f);
      if (!(sc == Vec3{1, 1, 1}))
        sp["specularColorFactor"] = colour(sc, 100, where + ": specularColorFactor");
      layer_textures(kSpecular, sp);
      j["extensions"][kSpecular] = std::move(sp);
      used_.insert(kSpecular);
    }
    if (m.iridescence_factor > 0) {
      json ir = json::object();
      ir["iridescenceFactor"] =
          num(bounded(m.iridescence_factor, 0, 1, 0, where + ": iridescenceFactor"));
      const float ior = bounded(m.iridescence_ior, 1, 10, 1.3f, where + ": iridescenceIor");
      if (ior != 1.3f) ir["iridescenceIor"] = num(ior);
      const float t =
          bounded(m.iridescence_thickness, 0, 1e5f, 400, where + ": iridescenceThickness");
      if (t != 400) ir["iridescenceThicknessMaximum"] = num(t);
      const float lo = bounded(m.iridescence_thickness_minimum, 0, 1e5f, 100,
                               where + ": iridescenceThicknessMinimum");
      if (lo != 100) ir["iridescenceThicknessMinimum"] = num(lo);
      layer_textures(kIridescence, ir);
      j["extensions"][kIridescence] = std::move(ir);
      used_.insert(kIridescence);
    }
    // Anisotropy needs a tangent space (glTF: TANGENT, or one derived along a normal map);
    // meshmux writes no TANGENT, so without a normal map it is left out (said once).
    const bool anisotropic = m.anisotropy_strength > 0 || m.layer(LayerSlot::kAnisotropy).present();
    if (anisotropic && !m.normal.present())
      note(where + ": KHR_materials_anisotropy left out: no normal map to give it a tangent space");
    if (anisotropic && m.normal.present()) {
      json an = json::object();
      const float f = bounded(m.anisotropy_strength, 0, 1, 0, where + ": anisotropyStrength");
      if (f != 0) an["anisotropyStrength"] = num(f);
      if (std::isfinite(m.anisotropy_rotation) && m.anisotropy_rotation != 0)
        an["anisotropyRotation"] = num(m.anisotropy_rotation);
      layer_textures(kAnisotropy, an);
      j["extensions"][kAnisotropy] = std::move(an);
      used_.insert(kAnisotropy);
    }
  }

  void write_materials() {
    material_uv_sets_.assign(scene_.materials.size(), 0);
    for (size_t i = 0; i < scene_.materials.size(); ++i) {
      const Material& m = scene_.materials[i];
      const std::string where = "material " + std::to_string(i) + " '" + m.name + "'";
      json j = json::object();
      if (!m.name.empty()) j["name"] = m.name;
      int& uv_sets = material_uv_sets_[i];
      auto tex = [&](const TextureRef& t, const char* slot) {
        json info = texture_info(t, where + " " + slot);
        if (!info.is_null()) uv_sets = std::max(uv_sets, int(t.tex_coord) + 1);
        return info;
      };
      json pbr = json::object();
      float c[4] = {m.base_color_factor.x, m.base_color_factor.y, m.base_color_factor.z,
                    m.base_color_factor.w};
      for (float& v : c) v = bounded(v, 0, 1, 1, where + ": baseColorFactor component");
      if (c[0] != 1 || c[1] != 1 || c[2] != 1 || c[3] != 1)
        pbr["baseColorFactor"] = {num(c[0]), num(c[1]), num(c[2]), num(c[3])};
      if (json t = tex(m.base_color, "baseColorTexture"); !t.is_null())
        pbr["baseColorTexture"] = std::move(t);
      float metallic = bounded(m.metallic_factor, 0, 1, 1, where + ": metallicFactor");
      if (metallic != 1) pbr["metallicFactor"] = num(metallic);
      float roughness = bounded(m.roughness_factor, 0, 1, 1, where + ": roughnessFactor");
      if (roughness != 1) pbr["roughnessFactor"] = num(roughness);
      if (json t = tex(m.metallic_roughness, "metallicRoughnessTexture"); !t.is_null())
        pbr["metallicRoughnessTexture"] = std::move(t);
      if (!pbr.empty()) j["pbrMetallicRoughness"] = std::move(pbr);
      if (json t = tex(m.normal, "normalTexture"); !t.is_null()) {
        float scale = std::isfinite(m.normal.scale) ? m.normal.scale : 1.0f;
        if (scale != 1) t["scale"] = num(scale);
        j["normalTexture"] = std::move(t);
      }
      if (json t = tex(m.occlusion, "occlusionTexture"); !t.is_null()) {
        float strength = bounded(m.occlusion.scale, 0, 1, 1, where + ": occlusion strength");
        if (strength != 1) t["strength"] = num(strength);
        j["occlusionTexture"] = std::move(t);
      }
      if (json t = tex(m.emissive, "emissiveTexture"); !t.is_null())
        j["emissiveTexture"] = std::move(t);
      // Emissive factors beyond 1 (KHR_materials_emissive_strength folded in on import) are
      // written as a factor in [0, 1] and the strength that scales it.
      float e[3] = {m.emissive_factor.x, m.emissive_factor.y, m.emissive_factor.z};
      float strength = 1;
      for (float v : e)
        if (std::isfinite(v) && v > strength) strength = v;
      for (float& v : e) v = bounded(v / strength, 0, 1, 0, where + ": emissiveFactor component");
      if (e[0] != 0 || e[1] != 0 || e[2] != 0)
        j["emissiveFactor"] = {num(e[0]), num(e[1]), num(e[2])};
      if (strength > 1) {
        j["extensions"][kEmissiveStrength] = {{"emissiveStrength", num(strength)}};
        used_.insert(kEmissiveStrength);
      }
      // A sheen layer (cloth): its colour factor and texture, its roughness factor.
      const Vec3 sc = m.sheen_color_factor;
      if (sc.x > 0 || sc.y > 0 || sc.z > 0 || m.sheen_color.present()) {
        json sheen = json::object();
        sheen["sheenColorFactor"] = {num(bounded(sc.x, 0, 1, 0, where + ": sheenColorFactor")),
                                     num(bounded(sc.y, 0, 1, 0, where + ": sheenColorFactor")),
                                     num(bounded(sc.z, 0, 1, 0, where + ": sheenColorFactor"))};
        if (json t = tex(m.sheen_color, "sheenColorTexture"); !t.is_null())
          sheen["sheenColorTexture"] = std::move(t);
        if (json t = tex(m.layer(LayerSlot::kSheenRoughness), "sheenRoughnessTexture");
            !t.is_null())
          sheen["sheenRoughnessTexture"] = std::move(t);
        const float r = bounded(m.sheen_roughness_factor, 0, 1, 0, where + ": sheenRoughness");
        if (r != 0) sheen["sheenRoughnessFactor"] = num(r);
        j["extensions"][kSheen] = std::move(sheen);
        used_.insert(kSheen);
      }
      if (m.transmissive() && !m.unlit) write_glass(m, where, tex, j);
      if (!m.unlit) write_layers(m, where, tex, j);
      if (m.alpha_mode == AlphaMode::kMask) {
        j["alphaMode"] = "MASK";
        float cutoff = std::isfinite(m.alpha_cutoff) ? m.alpha_cutoff : 0.5f;
        j["alphaCutoff"] = num(bounded(cutoff, 0, INFINITY, 0.5f, where + ": alphaCutoff"));
      } else if (m.alpha_mode == AlphaMode::kBlend) {
        j["alphaMode"] = "BLEND";
      }
      if (m.double_sided) j["doubleSided"] = true;
      if (m.unlit) {
        j["extensions"][kUnlit] = json::object();
        used_.insert(kUnlit);
      }
      materials_.push_back(std::move(j));
    }
  }

  // ---- meshes ----

  // Attribute arrays of one primitive, made safe to write.
  struct Clean {
    std::vector<Vec3> normals;
    std::vector<std::vector<Vec2>> uvs;
    std::vector<Vec4> colors;
  };

  Clean clean_primitive(const Primitive& p, const std::string& where) {
    Clean c;
    const size_t n = p.positions.size();
    size_t fixed = 0;
    // A flat primitive's viewers compute its flat normals themselves (glTF 3.7.2.1).
    const std::vector<Vec3> none;
    const std::vector<Vec3>& normals = p.flat ? none : p.normals;
    c.normals.reserve(normals.size());
    for (Vec3 v : normals) {
      // unit_normal is what the stream's vertex splits quantize too (stream/quantize.h).
      double l = std::sqrt(double(v.x) * v.x + double(v.y) * v.y + double(v.z) * v.z);
      if (!(l > 1e-20) || !std::isfinite(l)) ++fixed;
      c.normals.push_back(unit_normal(v));
    }
    if (fixed)
      note(where + ": " + std::to_string(fixed) + " zero or non-finite normals written as +Z");
    c.uvs = p.uvs;
    for (auto& set : c.uvs)
      for (Vec2& v : set) {
        if (!std::isfinite(v.x)) v.x = 0;
        if (!std::isfinite(v.y)) v.y = 0;
      }
    int need = p.material >= 0 && size_t(p.material) < material_uv_sets_.size()
                   ? material_uv_sets_[p.material]
                   : 0;
    if (c.uvs.size() < size_t(need)) {
      note(where + ": material " + std::to_string(p.material) + " uses TEXCOORD_" +
           std::to_string(need - 1) + ", which the primitive lacks; zeros written");
      c.uvs.resize(size_t(need), std::vector<Vec2>(n));
    }
    c.colors = p.colors;
    for (Vec4& v : c.colors)
      for (float* f : {&v.x, &v.y, &v.z, &v.w})
        *f = std::isnan(*f) ? 0.0f : std::clamp(*f, 0.0f, 1.0f);
    return c;
  }

  json plain_primitive(const Primitive& p, const Clean& c) {
    json attrs = json::object();
    const size_t n = p.positions.size();
    Bounds b;
    for (Vec3 v : p.positions) b.add(v);
    int view = add_view(p.positions.data(), n * sizeof(Vec3), kArrayBuffer);
    attrs["POSITION"] =
        add_accessor(view, kFloat, "VEC3", n, {num(b.min.x), num(b.min.y), num(b.min.z)},
                     {num(b.max.x), num(b.max.y), num(b.max.z)});
    if (!c.normals.empty()) attrs["NORMAL"] = add_float_accessor(c.normals, "VEC3", kArrayBuffer);
    for (size_t u = 0; u < c.uvs.size(); ++u)
      attrs["TEXCOORD_" + std::to_string(u)] = add_float_accessor(c.uvs[u], "VEC2", kArrayBuffer);
    if (!c.colors.empty()) attrs["COLOR_0"] = add_float_accessor(c.colors, "VEC4", kArrayBuffer);
    int indices;
    if (n <= 65535) {
      std::vector<uint16_t> idx(p.indices.begin(), p.indices.end());
      int v = add_view(idx.data(), idx.size() * 2, kElementArrayBuffer);
      indices = add_accessor(v, kUnsignedShort, "SCALAR", idx.size());
    } else {
      int v = add_view(p.indices.data(), p.indices.size() * 4, kElementArrayBuffer);
      indices = add_accessor(v, kUnsignedInt, "SCALAR", p.indices.size());
    }
    return {{"attributes", std::move(attrs)}, {"indices", indices}};
  }

  json draco_primitive(const DracoOutput& d) {
    json attrs = json::object(), ids = json::object();
    const auto& mn = d.position_min;
    const auto& mx = d.position_max;
    attrs["POSITION"] =
        add_accessor(-1, kFloat, "VEC3", d.num_points, {num(mn[0]), num(mn[1]), num(mn[2])},
                     {num(mx[0]), num(mx[1]), num(mx[2])});
    ids["POSITION"] = d.position_id;
    if (d.normal_id >= 0) {
      attrs["NORMAL"] = add_accessor(-1, kFloat, "VEC3", d.num_points);
      ids["NORMAL"] = d.normal_id;
    }
    for (size_t u = 0; u < d.uv_ids.size(); ++u) {
      std::string name = "TEXCOORD_" + std::to_string(u);
      attrs[name] = add_accessor(-1, kFloat, "VEC2", d.num_points);
      ids[name] = d.uv_ids[u];
    }
    if (d.color_id >= 0) {
      attrs["COLOR_0"] = add_accessor(-1, kFloat, "VEC4", d.num_points);
      ids["COLOR_0"] = d.color_id;
    }
    int indices = add_accessor(-1, d.num_points <= 65535 ? kUnsignedShort : kUnsignedInt, "SCALAR",
                               size_t(d.num_faces) * 3);
    int view = add_view(d.bytes.data(), d.bytes.size(), 0);
    used_.insert(kDraco);
    required_.insert(kDraco);
    json prim = {{"attributes", std::move(attrs)}, {"indices", indices}};
    prim["extensions"][kDraco] = {{"bufferView", view}, {"attributes", std::move(ids)}};
    return prim;
  }

  // A meshopt-coded accessor: its bytes go to the BIN chunk, its bufferView reads the fallback
  // buffer (1, no data) and points at them through the extension.
  int add_meshopt_accessor(const MeshoptAccessor& a) {
    static const char* const kTypes[] = {"SCALAR", "VEC2", "VEC3", "VEC4"};
    while (bin_.size() % 4) bin_.push_back(0);
    const size_t at = bin_.size();
    bin_.insert(bin_.end(), a.encoded.begin(), a.encoded.end());
    fallback_bytes_ = (fallback_bytes_ + 3) / 4 * 4;
    const size_t length = size_t(a.count) * a.stride;
    json v = {{"buffer", 1}, {"byteOffset", fallback_bytes_}, {"byteLength", length}};
    if (!a.triangles) v["byteStride"] = a.stride;  // index views may not have one
    v["target"] = a.triangles ? kElementArrayBuffer : kArrayBuffer;
    v["extensions"][kMeshopt] = {{"buffer", 0},
                                 {"byteOffset", at},
                                 {"byteLength", a.encoded.size()},
                                 {"byteStride", a.stride},
                                 {"count", a.count},
                                 {"mode", a.triangles ? "TRIANGLES" : "ATTRIBUTES"}};
    fallback_bytes_ += length;
    views_.push_back(std::move(v));
    json min = a.min.empty() ? json(nullptr) : json(a.min);
    json max = a.max.empty() ? json(nullptr) : json(a.max);
    int index = add_accessor(int(views_.size() - 1), a.component_type,
                             kTypes[std::clamp(a.components, 1, 4) - 1], a.count, std::move(min),
                             std::move(max));
    if (a.normalized) accessors_[size_t(index)]["normalized"] = true;
    return index;
  }

  // Mesh m's kept primitives written with meshopt, or an empty array (and a warning) when the
  // encoder fails, so that the caller writes them plain. Records the mesh's grid.
  json meshopt_primitives(size_t m, const std::vector<size_t>& kept,
                          const std::vector<Clean>& cleans) {
    const Mesh& mesh = scene_.meshes[m];
    const PositionQuantization grid = m < opt_.position_quantization.size()
                                          ? opt_.position_quantization[m]
                                          : position_quantization(mesh_bounds(mesh));
    std::vector<MeshoptInput> in(kept.size());
    for (size_t k = 0; k < kept.size(); ++k) {
      const Primitive& p = mesh.primitives[kept[k]];
      in[k].positions = &p.positions;
      in[k].normals = &cleans[k].normals;
      in[k].uvs = &cleans[k].uvs;
      in[k].colors = &cleans[k].colors;
      in[k].indices = &p.indices;
    }
    auto r = meshopt_encode_mesh(in, grid);
    const std::string where = "mesh " + std::to_string(m) + " '" + mesh.name + "'";
    if (!r.ok()) {
      note(where + ": meshopt: " + r.status().message() + "; written uncompressed");
      return json::array();
    }
    if (r->clamped_coordinates)
      note(where + ": " + std::to_string(r->clamped_coordinates) +
           " position coordinates outside the given quantization grid; clamped");
    std::vector<int> accessor(r->accessors.size());
    for (size_t a = 0; a < r->accessors.size(); ++a)
      accessor[a] = add_meshopt_accessor(r->accessors[a]);
    json prims = json::array();
    for (const MeshoptPrimitive& p : r->primitives) {
      json attrs = json::object();
      for (const auto& [name, a] : p.attributes) attrs[name] = accessor[size_t(a)];
      prims.push_back({{"attributes", std::move(attrs)}, {"indices", accessor[size_t(p.indices)]}});
    }
    grids_[m] = grid;
    for (const char* e : {kMeshopt, kQuantization}) used_.insert(e), required_.insert(e);
    return prims;
  }

  // The mesh's kept primitives written with Draco (or plainly, where Draco is off or fails):
  // a primitive over `split_draco_above` triangles as spatial parts (split_primitive), one
  // glTF primitive each; the encodes run on every core, the buffers are written in order.
  json draco_or_plain_primitives(size_t m, const std::vector<size_t>& kept,
                                 const std::vector<Clean>& cleans, const DracoSettings& ds) {
    const Mesh& mesh = scene_.meshes[m];
    struct Piece {
      size_t k;                // the kept primitive
      const Primitive* prim;   // its positions and indices (the part's own when split)
      const Clean* clean;      // its written attributes
      DracoSettings settings;  // a part's: the whole's position grid
    };
    std::vector<Piece> pieces;
    std::vector<std::vector<Primitive>> parts(kept.size());
    std::vector<std::vector<Clean>> part_cleans(kept.size());
    const bool draco = opt_.draco && !opt_.meshopt;
    for (size_t k = 0; k < kept.size(); ++k) {
      const Primitive& p = mesh.primitives[kept[k]];
      if (!draco || opt_.split_draco_above == 0 || p.triangle_count() <= opt_.split_draco_above) {
        pieces.push_back({k, &p, &cleans[k], ds});
        continue;
      }
      Primitive written = p;  // with the attributes as written
      written.normals = cleans[k].normals, written.uvs = cleans[k].uvs;
      written.colors = cleans[k].colors;
      parts[k] = split_primitive(written, opt_.split_draco_above);
      for (Primitive& q : parts[k]) {
        Clean c;
        c.normals.swap(q.normals), c.uvs.swap(q.uvs), c.colors.swap(q.colors);
        part_cleans[k].push_back(std::move(c));
      }
      // The whole's grid, as Draco would take it from the whole's bounds.
      DracoSettings part_ds = ds;
      Vec3 lo = p.positions[0], hi = p.positions[0];
      for (const Vec3& v : p.positions) {
        lo = {std::min(lo.x, v.x), std::min(lo.y, v.y), std::min(lo.z, v.z)};
        hi = {std::max(hi.x, v.x), std::max(hi.y, v.y), std::max(hi.z, v.z)};
      }
      part_ds.position_origin[0] = lo.x, part_ds.position_origin[1] = lo.y;
      part_ds.position_origin[2] = lo.z;
      part_ds.position_range = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, 1e-30f});
      for (size_t i = 0; i < parts[k].size(); ++i)
        pieces.push_back({k, &parts[k][i], &part_cleans[k][i], part_ds});
    }
    std::vector<std::optional<Result<DracoOutput>>> coded(pieces.size());
    if (draco)
      parallel_chunks(pieces.size(), 1, [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) {
          DracoInput in;
          in.positions = &pieces[i].prim->positions;
          in.normals = &pieces[i].clean->normals;
          in.uvs = &pieces[i].clean->uvs;
          in.colors = &pieces[i].clean->colors;
          in.indices = &pieces[i].prim->indices;
          coded[i] = draco_encode(in, pieces[i].settings);
        }
      });
    json prims = json::array();
    for (size_t i = 0; i < pieces.size(); ++i) {
      json prim;
      if (coded[i] && coded[i]->ok())
        prim = draco_primitive(**coded[i]);
      else if (coded[i])
        note("mesh " + std::to_string(m) + " primitive " + std::to_string(kept[pieces[i].k]) +
             ": draco: " + coded[i]->status().message() + "; written uncompressed");
      if (prim.is_null()) prim = plain_primitive(*pieces[i].prim, *pieces[i].clean);
      if (mesh.primitives[kept[pieces[i].k]].material >= 0)
        prim["material"] = mesh.primitives[kept[pieces[i].k]].material;
      prims.push_back(std::move(prim));
      coded[i].reset();
    }
    return prims;
  }

  void write_meshes() {
    DracoSettings ds;
    ds.position_bits = opt_.position_bits;
    ds.normal_bits = opt_.normal_bits;
    ds.uv_bits = opt_.uv_bits;
    ds.color_bits = opt_.color_bits;
    ds.speed = opt_.draco_speed;
    mesh_map_.assign(scene_.meshes.size(), -1);
    grids_.assign(scene_.meshes.size(), std::nullopt);
    for (size_t m = 0; m < scene_.meshes.size(); ++m) {
      const Mesh& mesh = scene_.meshes[m];
      std::vector<size_t> kept;
      std::vector<Clean> cleans;
      for (size_t pi = 0; pi < mesh.primitives.size(); ++pi) {
        const Primitive& p = mesh.primitives[pi];
        const std::string where = "mesh " + std::to_string(m) + " primitive " + std::to_string(pi);
        if (p.positions.empty() || p.triangle_count() == 0) {
          note(where + ": no triangles; primitive left out");
          continue;
        }
        kept.push_back(pi);
        cleans.push_back(clean_primitive(p, where));
      }
      json prims = json::array();
      if (opt_.meshopt && !kept.empty()) prims = meshopt_primitives(m, kept, cleans);
      const bool coded = !prims.empty();  // by meshopt
      if (coded) {
        for (size_t k = 0; k < kept.size(); ++k)
          if (mesh.primitives[kept[k]].material >= 0)
            prims[k]["material"] = mesh.primitives[kept[k]].material;
      } else {
        prims = draco_or_plain_primitives(m, kept, cleans, ds);
      }
      if (prims.empty()) {
        note("mesh " + std::to_string(m) + " '" + mesh.name + "': no triangles; mesh left out");
        continue;
      }
      json j = {{"primitives", std::move(prims)}};
      if (!mesh.name.empty()) j["name"] = mesh.name;
      if (opt_.tag_meshes) j["extras"] = {{"meshmux_mesh", m}};
      mesh_map_[m] = int(meshes_.size());
      meshes_.push_back(std::move(j));
    }
  }

  // ---- nodes ----

  // translate(origin)·scale(step) of a mesh written on a quantization grid.
  static Mat4 dequantization(const PositionQuantization& g) {
    return Mat4::translation(g.origin.x, g.origin.y, g.origin.z) *
           Mat4::scale(g.step, g.step, g.step);
  }

  Placement place(size_t i) {
    const Instance& inst = scene_.instances[i];
    Placement p;
    p.world = inst.world;
    const Mat4& w = inst.world;
    if (w.at(3, 0) != 0 || w.at(3, 1) != 0 || w.at(3, 2) != 0 || w.at(3, 3) != 1) {
      if (w.at(3, 3) != 0 && std::isfinite(1 / w.at(3, 3)) && w.at(3, 0) == 0 && w.at(3, 1) == 0 &&
          w.at(3, 2) == 0) {
        for (double& v : p.world.m) v /= w.at(3, 3);  // homogeneous scale only
      } else {
        note("instance " + std::to_string(i) + " '" + inst.name +
             "': projective transform; perspective part dropped");
      }
      p.world.at(3, 0) = p.world.at(3, 1) = p.world.at(3, 2) = 0;
      p.world.at(3, 3) = 1;
    }
    p.trs = decompose_trs(p.world, p.t, p.q, p.s);
    return p;
  }

  int add_instanced_node(uint32_t mesh, const std::vector<Placement>& places) {
    std::vector<float> t, r, s;
    for (size_t i = 0; i < scene_.instances.size(); ++i) {
      if (scene_.instances[i].mesh != mesh || !places[i].trs) continue;
      const Placement& p = places[i];
      double pt[3] = {p.t[0], p.t[1], p.t[2]}, ps[3] = {p.s[0], p.s[1], p.s[2]};
      if (const auto& g = grids_[mesh]) {  // TRS·D = (t + R(r)·(s ⊙ origin), r, s·step)
        Mat4 d = Mat4::trs(p.t, p.q, p.s) * dequantization(*g);
        for (int k = 0; k < 3; ++k) pt[k] = d.at(k, 3), ps[k] *= g->step;
      }
      for (int k = 0; k < 3; ++k) t.push_back(float(pt[k]));
      for (int k = 0; k < 4; ++k) r.push_back(float(p.q[k]));
      for (int k = 0; k < 3; ++k) s.push_back(float(ps[k]));
    }
    const size_t count = t.size() / 3;
    json attrs = {
        {"TRANSLATION", add_accessor(add_view(t.data(), t.size() * 4, 0), kFloat, "VEC3", count)},
        {"ROTATION", add_accessor(add_view(r.data(), r.size() * 4, 0), kFloat, "VEC4", count)},
        {"SCALE", add_accessor(add_view(s.data(), s.size() * 4, 0), kFloat, "VEC3", count)}};
    json node = {{"mesh", mesh_map_[mesh]}};
    node["extensions"][kInstancing] = {{"attributes", std::move(attrs)}};
    if (!scene_.meshes[mesh].name.empty()) node["name"] = scene_.meshes[mesh].name;
    used_.insert(kInstancing);
    nodes_.push_back(std::move(node));
    return int(nodes_.size() - 1);
  }

  // A transform glTF cannot hold in one node (shear): split by SVD, A = U S V^T, into a parent
  // node T * R(U) * S and a child node R(V^T) holding the mesh. Both are plain TRS.
  int add_sheared_node(const Instance& inst, const Placement& p) {
    Eigen::Matrix3d a;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) a(r, c) = p.world.at(r, c);
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(a, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d u = svd.matrixU(), v = svd.matrixV();
    Eigen::Vector3d s = svd.singularValues();
    if (u.determinant() < 0) u.col(2) *= -1, s(2) *= -1;
    if (v.determinant() < 0) v.col(2) *= -1, s(2) *= -1;
    json parent = json::object();
    if (!inst.name.empty()) parent["name"] = inst.name;
    double tx = p.world.at(0, 3), ty = p.world.at(1, 3), tz = p.world.at(2, 3);
    if (tx != 0 || ty != 0 || tz != 0) parent["translation"] = {num(tx), num(ty), num(tz)};
    auto rot = [](const std::array<double, 4>& q) {
      return json{num(q[0]), num(q[1]), num(q[2]), num(q[3])};
    };
    std::array<double, 4> qu = quaternion(u), qv = quaternion(v.transpose());
    if (qu != std::array<double, 4>{0, 0, 0, 1}) parent["rotation"] = rot(qu);
    parent["scale"] = {num(s(0)), num(s(1)), num(s(2))};
    int index = int(nodes_.size());
    parent["children"] = {index + 1};
    json child = {{"mesh", mesh_map_[inst.mesh]}};
    if (const auto& g = grids_[inst.mesh]) {  // R(qv)·D = (R(qv)·origin, qv, step)
      Mat4 d = Mat4::rotation(qv[0], qv[1], qv[2], qv[3]) * dequantization(*g);
      if (d.at(0, 3) != 0 || d.at(1, 3) != 0 || d.at(2, 3) != 0)
        child["translation"] = {num(d.at(0, 3)), num(d.at(1, 3)), num(d.at(2, 3))};
    }
    if (qv != std::array<double, 4>{0, 0, 0, 1}) child["rotation"] = rot(qv);
    if (const auto& g = grids_[inst.mesh]; g && g->step != 1)
      child["scale"] = {num(g->step), num(g->step), num(g->step)};
    nodes_.push_back(std::move(parent));
    nodes_.push_back(std::move(child));
    return index;
  }

  void write_nodes() {
    const std::vector<size_t> counts = instance_counts(scene_);
    std::vector<Placement> places;
    places.reserve(scene_.instances.size());
    for (size_t i = 0; i < scene_.instances.size(); ++i) places.push_back(place(i));
    std::vector<bool> instanced(scene_.meshes.size(), false), warned(scene_.meshes.size(), false);
    const size_t min_gpu = std::max<size_t>(opt_.min_gpu_instances, 1);
    for (size_t i = 0; i < scene_.instances.size(); ++i) {
      const Instance& inst = scene_.instances[i];
      const Placement& p = places[i];
      if (mesh_map_[inst.mesh] < 0) {
        if (!warned[inst.mesh])
          note("mesh " + std::to_string(inst.mesh) + ": left out; its instances are dropped");
        warned[inst.mesh] = true;
        continue;
      }
      if (counts[inst.mesh] >= min_gpu && p.trs) {
        if (!instanced[inst.mesh]) roots_.push_back(add_instanced_node(inst.mesh, places));
        instanced[inst.mesh] = true;
        continue;
      }
      if (!p.trs) {
        roots_.push_back(add_sheared_node(inst, p));
        continue;
      }
      json node = {{"mesh", mesh_map_[inst.mesh]}};
      if (!inst.name.empty()) node["name"] = inst.name;
      const Mat4 world = grids_[inst.mesh] ? p.world * dequantization(*grids_[inst.mesh]) : p.world;
      if (!world.is_identity()) {
        json m = json::array();
        for (double v : world.m) m.push_back(num(v));
        node["matrix"] = std::move(m);
      }
      nodes_.push_back(std::move(node));
      roots_.push_back(int(nodes_.size() - 1));
    }
  }

  // Points and lines (Scene::lines): one plain primitive each (mode POINTS or LINES), in world
  // space under one node, with a material of their colour (glTF viewers draw them unlit).
  void write_lines() {
    json primitives = json::array();
    for (size_t l = 0; l < scene_.lines.size(); ++l) {
      const LineSet& set = scene_.lines[l];
      const size_t n = set.positions.size();
      bool ok = n > 0 && !set.indices.empty();
      for (uint32_t i : set.indices) ok = ok && i < n;
      for (const Vec3& v : set.positions)
        ok = ok && std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
      if (!ok) {
        note("points/lines " + std::to_string(l) + " '" + set.name + "': invalid; left out");
        continue;
      }
      Bounds b;
      for (Vec3 v : set.positions) b.add(v);
      json attrs = json::object();
      attrs["POSITION"] = add_accessor(
          add_view(set.positions.data(), n * sizeof(Vec3), kArrayBuffer), kFloat, "VEC3", n,
          {num(b.min.x), num(b.min.y), num(b.min.z)}, {num(b.max.x), num(b.max.y), num(b.max.z)});
      if (set.colors.size() == n) {
        std::vector<Vec4> c = set.colors;
        for (Vec4& v : c)
          for (float* f : {&v.x, &v.y, &v.z, &v.w})
            *f = std::isnan(*f) ? 0.0f : std::clamp(*f, 0.0f, 1.0f);
        attrs["COLOR_0"] = add_float_accessor(c, "VEC4", kArrayBuffer);
      }
      int indices =
          add_accessor(add_view(set.indices.data(), set.indices.size() * 4, kElementArrayBuffer),
                       kUnsignedInt, "SCALAR", set.indices.size());
      json material = json::object();
      float c[4] = {set.color.x, set.color.y, set.color.z, set.color.w};
      for (float& v : c) v = std::isnan(v) ? 1.0f : std::clamp(v, 0.0f, 1.0f);
      material["pbrMetallicRoughness"] = {
          {"baseColorFactor", {num(c[0]), num(c[1]), num(c[2]), num(c[3])}}, {"metallicFactor", 0}};
      if (c[3] < 1) material["alphaMode"] = "BLEND";
      material["name"] = set.points ? "points" : "lines";
      materials_.push_back(std::move(material));
      primitives.push_back({{"attributes", std::move(attrs)},
                            {"indices", indices},
                            {"mode", set.points ? 0 : 1},
                            {"material", int(materials_.size() - 1)}});
    }
    if (primitives.empty()) return;
    meshes_.push_back({{"name", "points and lines"}, {"primitives", std::move(primitives)}});
    nodes_.push_back({{"name", "points and lines"}, {"mesh", int(meshes_.size() - 1)}});
    roots_.push_back(int(nodes_.size() - 1));
  }

  // ---- container ----

  Result<std::vector<uint8_t>> assemble() {
    json root = json::object();
    root["asset"] = {{"version", "2.0"}, {"generator", opt_.generator}};
    root["scene"] = 0;
    json scene = json::object();
    if (!roots_.empty()) scene["nodes"] = roots_;
    root["scenes"] = json::array({std::move(scene)});
    auto put = [&](const char* key, json& arr) {
      if (!arr.empty()) root[key] = std::move(arr);
    };
    put("nodes", nodes_);
    put("meshes", meshes_);
    put("materials", materials_);
    put("textures", textures_);
    put("samplers", samplers_);
    put("images", images_);
    put("accessors", accessors_);
    put("bufferViews", views_);
    while (bin_.size() % 4) bin_.push_back(0);
    if (!bin_.empty()) root["buffers"] = json::array({{{"byteLength", bin_.size()}}});
    if (fallback_bytes_ > 0) {  // meshopt's data-less fallback buffer: bufferViews' layout
      json fallback = {{"byteLength", (fallback_bytes_ + 3) / 4 * 4}};
      fallback["extensions"][kMeshopt] = {{"fallback", true}};
      root["buffers"].push_back(std::move(fallback));
    }
    if (!used_.empty()) root["extensionsUsed"] = used_;
    if (!required_.empty()) root["extensionsRequired"] = required_;

    std::string text = root.dump(-1, ' ', false, json::error_handler_t::replace);
    while (text.size() % 4) text.push_back(' ');
    const uint64_t total = 12 + 8 + text.size() + (bin_.empty() ? 0 : 8 + bin_.size());
    if (total > 0xFFFFFFFFull)
      return Status::error("gltf export: output of " + std::to_string(total) +
                               " bytes is over the GLB limit of 4 GiB",
                           ErrorKind::kOutput);
    std::vector<uint8_t> out;
    out.reserve(size_t(total));
    auto u32 = [&](uint32_t v) {
      for (int k = 0; k < 4; ++k) out.push_back(uint8_t(v >> (8 * k)));
    };
    u32(0x46546C67);  // "glTF"
    u32(2);
    u32(uint32_t(total));
    u32(uint32_t(text.size()));
    u32(0x4E4F534A);  // "JSON"
    out.insert(out.end(), text.begin(), text.end());
    if (!bin_.empty()) {
      u32(uint32_t(bin_.size()));
      u32(0x004E4942);  // "BIN\0"
      out.insert(out.end(), bin_.begin(), bin_.end());
    }
    return out;
  }

  const Scene& scene_;
  const GltfExportOptions& opt_;
  Warnings* warnings_;

  std::vector<uint8_t> bin_;
  json views_ = json::array(), accessors_ = json::array(), meshes_ = json::array();
  json nodes_ = json::array(), materials_ = json::array(), textures_ = json::array();
  json samplers_ = json::array(), images_ = json::array();
  std::vector<int> roots_;
  std::set<std::string> used_, required_;
  std::vector<int> image_map_;              // scene image → glTF image, -1 when not embedded
  std::vector<std::vector<uint8_t>> ktx2_;  // per scene image: its KTX2 bytes (options.ktx2)
  std::vector<int> material_uv_sets_;       // per material: uv sets its textures need
  std::vector<int> mesh_map_;               // scene mesh → glTF mesh, -1 when left out
  // Per scene mesh: the grid its positions were quantized on (meshopt), else none.
  std::vector<std::optional<PositionQuantization>> grids_;
  size_t fallback_bytes_ = 0;  // meshopt: decoded bytes the fallback buffer stands for
  std::map<std::pair<int, int>, int> textures_index_;
  std::map<std::array<int, 4>, int> samplers_index_;
};

Status check_options(const GltfExportOptions& o) {
  for (size_t m = 0; o.meshopt && m < o.position_quantization.size(); ++m) {
    const PositionQuantization& g = o.position_quantization[m];
    if (!(g.step > 0) || !std::isfinite(g.step) || !std::isfinite(g.origin.x) ||
        !std::isfinite(g.origin.y) || !std::isfinite(g.origin.z))
      return Status::error("gltf export: position_quantization of mesh " + std::to_string(m) +
                               " has a non-finite origin or a step that is not positive",
                           ErrorKind::kInternal);
  }
  if (!o.draco || o.meshopt) return Status::ok();
  const std::pair<const char*, int> bits[] = {{"position_bits", o.position_bits},
                                              {"normal_bits", o.normal_bits},
                                              {"uv_bits", o.uv_bits},
                                              {"color_bits", o.color_bits}};
  for (const auto& [name, v] : bits)
    if (v < 1 || v > 30)
      return Status::error(
          "gltf export: " + std::string(name) + " " + std::to_string(v) + " out of range 1-30",
          ErrorKind::kInternal);
  if (o.draco_speed < 0 || o.draco_speed > 10)
    return Status::error(
        "gltf export: draco_speed " + std::to_string(o.draco_speed) + " out of range 0-10",
        ErrorKind::kInternal);
  return Status::ok();
}

}  // namespace

Result<std::vector<uint8_t>> export_glb_bytes(const Scene& scene, const GltfExportOptions& options,
                                              Warnings* warnings) {
  Status s = check_options(options);
  if (!s) return s;
  s = validate(scene, "gltf export");
  if (!s) return s;
  try {
    return Exporter(scene, options, warnings).run();
  } catch (const std::exception& e) {
    return Status::error(std::string("gltf export: ") + e.what(), ErrorKind::kInternal);
  }
}

Status export_glb(const Scene& scene, const std::string& path, const GltfExportOptions& options,
                  Warnings* warnings) {
  auto bytes = export_glb_bytes(scene, options, warnings);
  if (!bytes.ok()) return bytes.status();
  Status s = write_file_atomic(path, *bytes);
  if (!s) return s.with_prefix("gltf export");
  return Status::ok();
}

}  // namespace meshmux
