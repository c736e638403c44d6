#include "bench/meshopt_reference.h"

#include <meshoptimizer.h>

#include <algorithm>
#include <cmath>
#include <type_traits>
#include <vector>

#include "bench/format.h"

namespace meshmux::bench {

uint64_t scene_tris(const Scene& s) { return compute_stats(s).scene_triangles; }

void compact(Primitive& p) {
  std::vector<uint32_t> remap(p.positions.size(), UINT32_MAX);
  uint32_t next = 0;
  for (uint32_t& i : p.indices) {
    if (remap[i] == UINT32_MAX) remap[i] = next++;
    i = remap[i];
  }
  auto pick = [&](auto& attr) {
    if (attr.empty()) return;
    std::remove_reference_t<decltype(attr)> out(next);
    for (size_t v = 0; v < remap.size(); ++v)
      if (remap[v] != UINT32_MAX) out[remap[v]] = attr[v];
    attr.swap(out);
  };
  pick(p.positions);
  pick(p.normals);
  for (auto& uv : p.uvs) pick(uv);
  pick(p.colors);
}

Scene weld_positions(const Scene& in) {
  Scene out = in;
  for (Mesh& m : out.meshes)
    for (Primitive& p : m.primitives) {
      if (p.positions.empty() || p.indices.empty()) continue;
      std::vector<uint32_t> remap(p.positions.size());
      size_t n = meshopt_generateVertexRemap(remap.data(), p.indices.data(), p.indices.size(),
                                             p.positions.data(), p.positions.size(), sizeof(Vec3));
      meshopt_remapIndexBuffer(p.indices.data(), p.indices.data(), p.indices.size(), remap.data());
      auto apply = [&](auto& attr) {
        if (attr.empty()) return;
        std::remove_reference_t<decltype(attr)> o(n);
        meshopt_remapVertexBuffer(o.data(), attr.data(), attr.size(), sizeof(attr[0]),
                                  remap.data());
        attr.swap(o);
      };
      apply(p.positions);
      apply(p.normals);
      for (auto& uv : p.uvs) apply(uv);
      apply(p.colors);
    }
  return out;
}

MeshoptRun meshopt_run(const Scene& flat, double ratio) {
  MeshoptRun r;
  r.ratio = ratio;
  r.scene = flat;
  for (Mesh& m : r.scene.meshes)
    for (Primitive& p : m.primitives) {
      if (p.positions.empty() || p.indices.empty()) continue;
      size_t target = size_t(std::llround(double(p.indices.size() / 3) * ratio)) * 3;
      std::vector<uint32_t> out(p.indices.size());
      auto t0 = Clock::now();
      size_t n = meshopt_simplify(out.data(), p.indices.data(), p.indices.size(), &p.positions[0].x,
                                  p.positions.size(), sizeof(Vec3), target, 1.0f, 0, nullptr);
      r.seconds += seconds_since(t0);
      out.resize(n);
      p.indices.swap(out);
      compact(p);
      r.triangles += p.indices.size() / 3;
    }
  return r;
}

MeshoptRun meshopt_to_count(const Scene& flat, uint64_t target) {
  uint64_t total = scene_tris(flat);
  double ratio = total ? std::min(1.0, double(target) / double(total)) : 1.0;
  MeshoptRun best;
  bool have = false;
  for (int iter = 0; iter < 8; ++iter) {
    MeshoptRun r = meshopt_run(flat, ratio);
    uint64_t reached = r.triangles;
    auto miss = [&](const MeshoptRun& x) { return std::abs(double(x.triangles) - double(target)); };
    if (!have || miss(r) < miss(best)) {
      best = std::move(r);
      have = true;
    }
    if (miss(best) <= 0.005 * double(target) || reached == 0) break;
    double next = std::min(1.0, ratio * double(target) / double(reached));
    if (std::abs(next - ratio) < 1e-6) break;
    ratio = next;
  }
  return best;
}

}  // namespace meshmux::bench
