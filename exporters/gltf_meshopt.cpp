// One mesh → EXT_meshopt_compression + KHR_mesh_quantization accessors (exporters/gltf_meshopt.h).
#include "exporters/gltf_meshopt.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "exporters/gltf_constants.h"

namespace meshmux {

namespace {

using namespace gltf_enum;

// An attribute array before coding: its format and its decoded bytes.
struct RawAttribute {
  int component_type = 0;  // GL enum
  int components = 1;      // per element
  bool normalized = false;
  uint32_t stride = 0;         // bytes per element, a multiple of 4
  std::vector<uint8_t> bytes;  // count × stride

  bool same_as(const RawAttribute& o) const {
    return component_type == o.component_type && components == o.components &&
           normalized == o.normalized && stride == o.stride && bytes == o.bytes;
  }
};

template <class T>
std::vector<uint8_t> as_bytes(const std::vector<T>& v) {
  std::vector<uint8_t> b(v.size() * sizeof(T));
  if (!b.empty()) std::memcpy(b.data(), v.data(), b.size());
  return b;
}

RawAttribute positions_raw(const std::vector<Vec3>& positions, const PositionQuantization& g,
                           size_t* clamped) {
  RawAttribute a;
  a.component_type = kUnsignedShort;
  a.components = 3;
  a.stride = 8;
  std::vector<uint16_t> q(positions.size() * 4, 0);  // the 4th short of each vertex stays 0
  const float origin[3] = {g.origin.x, g.origin.y, g.origin.z};
  for (size_t i = 0; i < positions.size(); ++i) {
    const float x[3] = {positions[i].x, positions[i].y, positions[i].z};
    for (int k = 0; k < 3; ++k) {
      q[i * 4 + k] = quantize_coordinate(x[k], origin[k], g.step);
      double t = (double(x[k]) - double(origin[k])) / g.step;
      if (!(t >= -0.5 && t <= kPositionMax + 0.5)) ++*clamped;
    }
  }
  a.bytes = as_bytes(q);
  return a;
}

RawAttribute normals_raw(const std::vector<Vec3>& normals) {
  RawAttribute a;
  a.component_type = kByte;
  a.components = 3;
  a.normalized = true;
  a.stride = 4;
  std::vector<int8_t> q(normals.size() * 4, 0);
  for (size_t i = 0; i < normals.size(); ++i) {
    q[i * 4 + 0] = quantize_normal(normals[i].x);
    q[i * 4 + 1] = quantize_normal(normals[i].y);
    q[i * 4 + 2] = quantize_normal(normals[i].z);
  }
  a.bytes = as_bytes(q);
  return a;
}

// Normalized unsigned shorts on the kUvBits grid when the set lies in [0, 1]; floats otherwise.
RawAttribute uvs_raw(const std::vector<Vec2>& uvs) {
  RawAttribute a;
  a.components = 2;
  bool unit = std::all_of(uvs.begin(), uvs.end(),
                          [](Vec2 v) { return v.x >= 0 && v.x <= 1 && v.y >= 0 && v.y <= 1; });
  if (unit) {
    a.component_type = kUnsignedShort;
    a.normalized = true;
    a.stride = 4;
    std::vector<uint16_t> q(uvs.size() * 2);
    for (size_t i = 0; i < uvs.size(); ++i) {
      q[i * 2 + 0] = uv12_to_unorm16(quantize_uv(uvs[i].x));
      q[i * 2 + 1] = uv12_to_unorm16(quantize_uv(uvs[i].y));
    }
    a.bytes = as_bytes(q);
  } else {
    a.component_type = kFloat;
    a.stride = 8;
    a.bytes = as_bytes(uvs);
  }
  return a;
}

RawAttribute colors_raw(const std::vector<Vec4>& colors) {
  RawAttribute a;
  a.component_type = kUnsignedByte;
  a.components = 4;
  a.normalized = true;
  a.stride = 4;
  auto unorm8 = [](float c) {
    return uint8_t(std::lround(std::clamp(std::isnan(c) ? 0.0 : double(c), 0.0, 1.0) * 255));
  };
  std::vector<uint8_t> q(colors.size() * 4);
  for (size_t i = 0; i < colors.size(); ++i) {
    q[i * 4 + 0] = unorm8(colors[i].x);
    q[i * 4 + 1] = unorm8(colors[i].y);
    q[i * 4 + 2] = unorm8(colors[i].z);
    q[i * 4 + 3] = unorm8(colors[i].w);
  }
  a.bytes = q;
  return a;
}

// Integer bounds of the first three components of quantized positions (stride 8).
void position_bounds(const RawAttribute& a, MeshoptAccessor* out) {
  const size_t n = a.bytes.size() / 8;
  uint16_t lo[3] = {0xFFFF, 0xFFFF, 0xFFFF}, hi[3] = {0, 0, 0};
  for (size_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) {
      uint16_t v;
      std::memcpy(&v, a.bytes.data() + i * 8 + size_t(k) * 2, 2);
      lo[k] = std::min(lo[k], v);
      hi[k] = std::max(hi[k], v);
    }
  if (n == 0) std::fill(lo, lo + 3, uint16_t(0));
  out->min = {double(lo[0]), double(lo[1]), double(lo[2])};
  out->max = {double(hi[0]), double(hi[1]), double(hi[2])};
}

class MeshEncoder {
 public:
  // The accessor index of an attribute array: an earlier identical one, or a new one.
  Result<int> attribute(RawAttribute raw, bool is_position) {
    for (size_t i = 0; i < raws_.size(); ++i)
      if (raws_[i].second.same_as(raw)) return raws_[i].first;
    MeshoptAccessor acc;
    acc.count = uint32_t(raw.bytes.size() / raw.stride);
    acc.stride = raw.stride;
    acc.component_type = raw.component_type;
    acc.components = raw.components;
    acc.normalized = raw.normalized;
    if (is_position) position_bounds(raw, &acc);
    acc.encoded.resize(meshopt_encodeVertexBufferBound(acc.count, acc.stride));
    size_t size = meshopt_encodeVertexBuffer(acc.encoded.data(), acc.encoded.size(),
                                             raw.bytes.data(), acc.count, acc.stride);
    if (size == 0) return Status::error("meshopt vertex encoding failed", ErrorKind::kInternal);
    acc.encoded.resize(size);
    int index = int(out_.accessors.size());
    out_.accessors.push_back(std::move(acc));
    raws_.emplace_back(index, std::move(raw));
    return index;
  }

  Result<int> indices(const std::vector<uint32_t>& idx, size_t vertices) {
    if (idx.empty() || idx.size() % 3)
      return Status::error(
          "index count " + std::to_string(idx.size()) + " is not a positive multiple of 3",
          ErrorKind::kInternal);
    MeshoptAccessor acc;
    acc.triangles = true;
    acc.count = uint32_t(idx.size());
    acc.stride = vertices <= 65535 ? 2 : 4;
    acc.component_type = acc.stride == 2 ? kUnsignedShort : kUnsignedInt;
    acc.encoded.resize(meshopt_encodeIndexBufferBound(idx.size(), vertices));
    size_t size =
        meshopt_encodeIndexBuffer(acc.encoded.data(), acc.encoded.size(), idx.data(), idx.size());
    if (size == 0) return Status::error("meshopt index encoding failed", ErrorKind::kInternal);
    acc.encoded.resize(size);
    out_.accessors.push_back(std::move(acc));
    return int(out_.accessors.size() - 1);
  }

  MeshoptMesh& out() { return out_; }

 private:
  MeshoptMesh out_;
  std::vector<std::pair<int, RawAttribute>> raws_;  // attribute accessors and their bytes
};

}  // namespace

Result<MeshoptMesh> meshopt_encode_mesh(const std::vector<MeshoptInput>& primitives,
                                        const PositionQuantization& grid) {
  if (!(grid.step > 0) || !std::isfinite(grid.step))
    return Status::error("position grid step " + std::to_string(grid.step) + " is not positive",
                         ErrorKind::kInternal);
  // The formats every decoder reads (the EXT_meshopt_compression spec's bitstreams): vertex
  // version 0 and index version 1 (header 0xe1). Set on every call: the setting is global.
  meshopt_encodeVertexVersion(0);
  meshopt_encodeIndexVersion(1);
  MeshEncoder enc;
  for (size_t pi = 0; pi < primitives.size(); ++pi) {
    const MeshoptInput& in = primitives[pi];
    const std::string where = "primitive " + std::to_string(pi) + ": ";
    if (!in.positions || !in.indices || in.positions->size() > 0xFFFFFFFFu ||
        in.indices->size() > 0xFFFFFFFFu)
      return Status::error(where + "no positions or indices, or too many", ErrorKind::kInternal);
    const size_t n = in.positions->size();
    auto sized = [&](size_t count) { return count == n; };
    MeshoptPrimitive prim;
    auto add = [&](const std::string& name, RawAttribute raw, bool is_position) -> Status {
      auto r = enc.attribute(std::move(raw), is_position);
      if (!r.ok()) return r.status().with_prefix(where + name);
      prim.attributes.emplace_back(name, *r);
      return Status::ok();
    };
    Status s =
        add("POSITION", positions_raw(*in.positions, grid, &enc.out().clamped_coordinates), true);
    if (!s) return s;
    if (in.normals && !in.normals->empty()) {
      if (!sized(in.normals->size()))
        return Status::error(where + "normal count differs", ErrorKind::kInternal);
      if (!(s = add("NORMAL", normals_raw(*in.normals), false))) return s;
    }
    if (in.uvs)
      for (size_t u = 0; u < in.uvs->size(); ++u) {
        if (!sized((*in.uvs)[u].size()))
          return Status::error(where + "uv count differs", ErrorKind::kInternal);
        if (!(s = add("TEXCOORD_" + std::to_string(u), uvs_raw((*in.uvs)[u]), false))) return s;
      }
    if (in.colors && !in.colors->empty()) {
      if (!sized(in.colors->size()))
        return Status::error(where + "colour count differs", ErrorKind::kInternal);
      if (!(s = add("COLOR_0", colors_raw(*in.colors), false))) return s;
    }
    auto idx = enc.indices(*in.indices, n);
    if (!idx.ok()) return idx.status().with_prefix(where + "indices");
    prim.indices = *idx;
    enc.out().primitives.push_back(std::move(prim));
  }
  return std::move(enc.out());
}

}  // namespace meshmux
