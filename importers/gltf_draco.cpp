// KHR_draco_mesh_compression decoding for the glTF importer (Draco's own decoder). Kept apart
// from gltf.cpp so that Draco's headers stay in one translation unit.
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "draco/compression/decode.h"
#include "importers/skinning.h"
#include "scene/scene.h"

namespace meshmux {

Status decode_draco_primitive(const std::vector<uint8_t>& bytes,
                              const std::vector<std::pair<std::string, int>>& attributes,
                              const std::vector<std::pair<std::string, bool>>& normalized,
                              Primitive* out, SkinInfluences* skin, std::string*) {
  draco::DecoderBuffer buffer;
  buffer.Init(reinterpret_cast<const char*>(bytes.data()), bytes.size());
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
  if (!decoded.ok())
    return Status::error(std::string("cannot decode: ") + decoded.status().error_msg(),
                         ErrorKind::kInput);
  std::unique_ptr<draco::Mesh> mesh = std::move(decoded).value();
  size_t n = mesh->num_points();
  bool have_position = false;
  for (size_t k = 0; k < attributes.size(); ++k) {
    const std::string& name = attributes[k].first;
    int32_t att_id = mesh->GetAttributeIdByUniqueId(uint32_t(attributes[k].second));
    draco::PointAttribute* att = att_id >= 0 ? mesh->attribute(att_id) : nullptr;
    if (!att)
      return Status::error("attribute " + name + " (id " + std::to_string(attributes[k].second) +
                               ") not in the Draco stream",
                           ErrorKind::kInput);
    if (normalized[k].second && att->data_type() != draco::DT_FLOAT32) att->set_normalized(true);
    int comps = att->num_components();
    if (comps < 1 || comps > 4)
      return Status::error("attribute " + name + " has " + std::to_string(comps) + " components",
                           ErrorKind::kInput);
    float v[4] = {0, 0, 0, 1};
    auto get = [&](size_t i) {
      v[0] = v[1] = v[2] = 0;
      v[3] = 1;
      att->ConvertValue<float>(att->mapped_index(draco::PointIndex(uint32_t(i))), int8_t(comps), v);
    };
    if (name == "POSITION") {
      have_position = true;
      out->positions.resize(n);
      for (size_t i = 0; i < n; ++i) get(i), out->positions[i] = {v[0], v[1], v[2]};
    } else if (name == "NORMAL") {
      out->normals.resize(n);
      for (size_t i = 0; i < n; ++i) get(i), out->normals[i] = normalize(Vec3{v[0], v[1], v[2]});
    } else if (name.rfind("TEXCOORD_", 0) == 0) {
      size_t set = size_t(std::atoi(name.c_str() + 9));
      if (set > 8) continue;
      if (out->uvs.size() <= set) out->uvs.resize(set + 1);
      out->uvs[set].resize(n);
      for (size_t i = 0; i < n; ++i) get(i), out->uvs[set][i] = {v[0], v[1]};
    } else if ((name == "JOINTS_0" || name == "WEIGHTS_0") && skin) {
      std::vector<float> values(4 * n);
      for (size_t i = 0; i < n; ++i) {
        get(i);
        for (int c = 0; c < 4; ++c) values[4 * i + size_t(c)] = c < comps ? v[c] : 0.0f;
      }
      if (name == "WEIGHTS_0") {
        skin->weights = std::move(values);
      } else {
        skin->joints.resize(4 * n);
        for (size_t i = 0; i < 4 * n; ++i)
          skin->joints[i] = values[i] >= 0 && values[i] < 65536 ? uint32_t(values[i]) : 65535u;
      }
      skin->sets = !skin->joints.empty() && !skin->weights.empty() ? 1 : 0;
    } else if (name == "COLOR_0") {
      out->colors.resize(n);
      for (size_t i = 0; i < n; ++i)
        get(i), out->colors[i] = {v[0], v[1], v[2], comps == 4 ? v[3] : 1.0f};
    }
  }
  if (!have_position) return Status::error("no POSITION attribute", ErrorKind::kInput);
  // A gap in the uv sets (TEXCOORD_1 without TEXCOORD_0) would break the one-entry-per-vertex
  // rule; fill it with zeros.
  for (auto& set : out->uvs)
    if (set.size() != n) set.assign(n, Vec2{});
  out->indices.resize(size_t(mesh->num_faces()) * 3);
  for (uint32_t f = 0; f < mesh->num_faces(); ++f) {
    const auto& face = mesh->face(draco::FaceIndex(f));
    for (int c = 0; c < 3; ++c) out->indices[size_t(f) * 3 + size_t(c)] = face[c].value();
  }
  return Status::ok();
}

}  // namespace meshmux
