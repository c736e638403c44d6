// Spatial parts of a big primitive (see split_primitive.h).
#include "exporters/split_primitive.h"

#include <algorithm>
#include <cstdint>
#include <limits>

#include "core/parallel.h"

namespace meshmux {

namespace {

uint32_t spread10(uint32_t v) {  // 10 bits → every third bit of 30
  v &= 0x3FF;
  v = (v | v << 16) & 0x030000FF;
  v = (v | v << 8) & 0x0300F00F;
  v = (v | v << 4) & 0x030C30C3;
  v = (v | v << 2) & 0x09249249;
  return v;
}

// The part of `p` holding the faces listed (in that order), its vertices in order of first use.
Primitive part_of(const Primitive& p, const std::vector<uint32_t>& faces) {
  Primitive out;
  out.material = p.material;
  out.flat = p.flat;
  out.uvs.resize(p.uvs.size());
  std::vector<uint32_t> remap(p.positions.size(), UINT32_MAX);
  out.indices.reserve(3 * faces.size());
  for (uint32_t f : faces)
    for (int c = 0; c < 3; ++c) {
      const uint32_t v = p.indices[3 * size_t(f) + size_t(c)];
      if (remap[v] == UINT32_MAX) {
        remap[v] = uint32_t(out.positions.size());
        out.positions.push_back(p.positions[v]);
        if (!p.normals.empty()) out.normals.push_back(p.normals[v]);
        for (size_t s = 0; s < p.uvs.size(); ++s) out.uvs[s].push_back(p.uvs[s][v]);
        if (!p.colors.empty()) out.colors.push_back(p.colors[v]);
      }
      out.indices.push_back(remap[v]);
    }
  return out;
}

}  // namespace

std::vector<Primitive> split_primitive(const Primitive& p, size_t max_triangles) {
  const size_t n = p.triangle_count();
  if (max_triangles == 0 || n <= max_triangles) return {p};
  const size_t parts = (n + max_triangles - 1) / max_triangles;
  Vec3 lo{std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
          std::numeric_limits<float>::max()};
  Vec3 hi{-lo.x, -lo.y, -lo.z};
  for (const Vec3& v : p.positions) {
    lo = {std::min(lo.x, v.x), std::min(lo.y, v.y), std::min(lo.z, v.z)};
    hi = {std::max(hi.x, v.x), std::max(hi.y, v.y), std::max(hi.z, v.z)};
  }
  const float extent = std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z});
  const float scale = extent > 0 ? 1023.0f / extent : 0.0f;
  // (Morton code of the centroid, face): a strict order, so the parts are the same on any run.
  std::vector<uint64_t> keyed(n);
  parallel_chunks(n, 65536, [&](size_t begin, size_t end) {
    for (size_t f = begin; f < end; ++f) {
      Vec3 c{0, 0, 0};
      for (int k = 0; k < 3; ++k) c = c + p.positions[p.indices[3 * f + size_t(k)]];
      auto q = [&](float x, float l) {
        return uint32_t(std::clamp((x / 3 - l) * scale, 0.0f, 1023.0f));
      };
      const uint32_t code =
          spread10(q(c.x, lo.x)) | spread10(q(c.y, lo.y)) << 1 | spread10(q(c.z, lo.z)) << 2;
      keyed[f] = uint64_t(code) << 32 | uint64_t(f);
    }
  });
  // Cut points by selection: part k holds ranks [k·n/parts, (k+1)·n/parts).
  std::vector<size_t> cut(parts + 1);
  for (size_t k = 0; k <= parts; ++k) cut[k] = k * n / parts;
  // Bisected: each selection splits a run of parts in two, log K rounds over the faces.
  auto select = [&](auto& self, size_t first, size_t last) -> void {
    if (last - first < 2) return;
    const size_t mid = (first + last) / 2;
    std::nth_element(keyed.begin() + ptrdiff_t(cut[first]), keyed.begin() + ptrdiff_t(cut[mid]),
                     keyed.begin() + ptrdiff_t(cut[last]));
    self(self, first, mid);
    self(self, mid, last);
  };
  select(select, 0, parts);
  std::vector<Primitive> out(parts);
  parallel_chunks(parts, 1, [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) {
      std::vector<uint32_t> faces;
      faces.reserve(cut[k + 1] - cut[k]);
      for (size_t i = cut[k]; i < cut[k + 1]; ++i) faces.push_back(uint32_t(keyed[i]));
      std::sort(faces.begin(), faces.end());  // the original relative order
      out[k] = part_of(p, faces);
    }
  });
  return out;
}

}  // namespace meshmux
