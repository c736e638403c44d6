#include "bench/instanced_scene.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace meshmux::bench {

namespace {

// Smooth deterministic bumps on the unit sphere: a few low-frequency waves.
float lump(float theta, float phi) {
  return 1.0f + 0.12f * std::sin(3 * theta + 0.7f) * std::sin(2 * phi) +
         0.08f * std::cos(5 * phi + 1.3f) * std::sin(theta) +
         0.05f * std::sin(7 * theta) * std::cos(3 * phi);
}

// A noisy UV sphere sitting on y = 0, radius about 0.5: one vertex at each pole, inner rings
// of slices + 1 vertices (the last column repeats the first with u = 1: a uv seam). Smooth
// normals are given (averaged across the seam), so clean() has no crease to split.
Primitive bush(int slices, int stacks) {
  Primitive p;
  p.uvs.resize(1);
  const float kPi = 3.14159265358979f;
  std::vector<uint32_t> spot;  // per vertex: its position id (seam duplicates share one)
  auto vertex = [&](float theta, float phi, float u, float v, uint32_t id) {
    float r = 0.5f * lump(theta, phi);
    p.positions.push_back({r * std::sin(phi) * std::cos(theta), 0.55f + 0.9f * r * std::cos(phi),
                           r * std::sin(phi) * std::sin(theta)});
    p.uvs[0].push_back({u, v});
    spot.push_back(id);
  };
  vertex(0, 0, 0.5f, 0, 0);  // top pole
  for (int r = 1; r < stacks; ++r) {
    float phi = kPi * float(r) / float(stacks);
    for (int s = 0; s <= slices; ++s) {
      float theta = 2 * kPi * float(s % slices) / float(slices);
      vertex(theta, phi, float(s) / float(slices), float(r) / float(stacks),
             uint32_t(1 + (r - 1) * slices + s % slices));
    }
  }
  uint32_t bottom = uint32_t(p.positions.size());
  vertex(0, kPi, 0.5f, 1, uint32_t(1 + (stacks - 1) * slices));

  auto ring = [&](int r, int s) { return uint32_t(1 + (r - 1) * (slices + 1) + s); };
  for (int s = 0; s < slices; ++s)  // top cap
    p.indices.insert(p.indices.end(), {0u, ring(1, s + 1), ring(1, s)});
  for (int r = 1; r + 1 < stacks; ++r)
    for (int s = 0; s < slices; ++s) {
      uint32_t a = ring(r, s), b = ring(r, s + 1), c = ring(r + 1, s), d = ring(r + 1, s + 1);
      p.indices.insert(p.indices.end(), {a, b, c, b, d, c});
    }
  for (int s = 0; s < slices; ++s)  // bottom cap
    p.indices.insert(p.indices.end(), {ring(stacks - 1, s), ring(stacks - 1, s + 1), bottom});

  // Area-weighted face normals summed per position id.
  std::vector<Vec3> sum(size_t(2 + (stacks - 1) * slices));
  for (size_t i = 0; i < p.indices.size(); i += 3) {
    Vec3 a = p.positions[p.indices[i]], b = p.positions[p.indices[i + 1]],
         c = p.positions[p.indices[i + 2]];
    Vec3 n = cross(b - a, c - a);
    for (int k = 0; k < 3; ++k)
      sum[spot[p.indices[i + size_t(k)]]] = sum[spot[p.indices[i + size_t(k)]]] + n;
  }
  for (uint32_t id : spot) p.normals.push_back(normalize(sum[id]));
  return p;
}

// A gently rolling ground grid in x/z, with uvs.
Primitive ground(int cells, float half) {
  Primitive p;
  p.uvs.resize(1);
  for (int j = 0; j <= cells; ++j)
    for (int i = 0; i <= cells; ++i) {
      float u = float(i) / float(cells), v = float(j) / float(cells);
      float x = -half + 2 * half * u, z = -half + 2 * half * v;
      p.positions.push_back({x, 0.2f * std::sin(x * 0.5f) * std::cos(z * 0.4f), z});
      p.uvs[0].push_back({u, v});
    }
  for (int j = 0; j < cells; ++j)
    for (int i = 0; i < cells; ++i) {
      uint32_t a = uint32_t(j * (cells + 1) + i), b = a + 1, c = a + uint32_t(cells + 1), d = c + 1;
      p.indices.insert(p.indices.end(), {a, c, b, b, c, d});
    }
  return p;
}

uint32_t hash32(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352dU;
  x ^= x >> 15;
  x *= 0x846ca68bU;
  x ^= x >> 16;
  return x;
}
double unit(uint32_t seed) { return double(hash32(seed) >> 8) / double(1 << 24); }  // [0,1)

}  // namespace

Scene make_instanced_scene(const InstancedSceneOptions& o) {
  Scene scene;
  Material leaves;
  leaves.name = "leaves";
  leaves.base_color_factor = {0.18f, 0.45f, 0.12f, 1};
  leaves.metallic_factor = 0;
  leaves.roughness_factor = 0.9f;
  scene.materials.push_back(leaves);
  Material soil;
  soil.name = "soil";
  soil.base_color_factor = {0.42f, 0.3f, 0.18f, 1};
  soil.metallic_factor = 0;
  soil.roughness_factor = 1;
  scene.materials.push_back(soil);

  int n = std::max(1, o.bushes_per_side);
  float half = 1.5f * float(n) / 2 + 1;  // 1.5 units between bushes

  Mesh g;
  g.name = "ground";
  g.primitives.push_back(ground(std::max(1, o.ground_cells), half));
  g.primitives.back().material = 1;
  scene.meshes.push_back(g);
  scene.instances.push_back({0, Mat4::identity(), "ground"});

  Mesh b;
  b.name = "bush";
  b.primitives.push_back(bush(std::max(3, o.bush_slices), std::max(3, o.bush_stacks)));
  b.primitives.back().material = 0;
  scene.meshes.push_back(b);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      uint32_t k = uint32_t(j * n + i) * 4;
      double x = -1.5 * n / 2 + 1.5 * (i + 0.5) + 0.5 * (unit(k) - 0.5);
      double z = -1.5 * n / 2 + 1.5 * (j + 0.5) + 0.5 * (unit(k + 1) - 0.5);
      double y = 0.2 * std::sin(x * 0.5) * std::cos(z * 0.4) - 0.05;  // on the ground
      double angle = 2 * 3.141592653589793 * unit(k + 2);
      double s = 0.7 + 0.6 * unit(k + 3);
      double q[4] = {0, std::sin(angle / 2), 0, std::cos(angle / 2)};
      double t[3] = {x, y, z}, sc[3] = {s, s * (0.85 + 0.3 * unit(k + 5)), s};
      scene.instances.push_back(
          {1, Mat4::trs(t, q, sc), "bush-" + std::to_string(j) + "-" + std::to_string(i)});
    }
  return scene;
}

}  // namespace meshmux::bench
