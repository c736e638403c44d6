#include "scene/sample.h"

#include <cmath>

namespace meshmux {

namespace {

// A 2x2 atlas of procedural tiles: ground checker (top-left), crate planks (top-right),
// column stone bands (bottom half). Distinct colours so texture errors show.
Image make_texture(int size) {
  Image img;
  img.name = "sample-texture";
  img.width = img.height = size;
  img.rgba.resize(size_t(size) * size_t(size) * 4);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      uint8_t* p = &img.rgba[(size_t(y) * size_t(size) + size_t(x)) * 4];
      int h = size / 2;
      int r, g, b;
      if (y < h && x < h) {  // ground: green/olive checker with thin grid lines
        bool check = ((x / (h / 8)) + (y / (h / 8))) % 2 == 0;
        bool line = x % (h / 8) == 0 || y % (h / 8) == 0;
        r = line ? 40 : check ? 96 : 120;
        g = line ? 60 : check ? 148 : 128;
        b = line ? 30 : check ? 70 : 60;
      } else if (y < h) {  // crate: wooden planks
        int plank = (y * 6) / h;
        double grain = 0.5 + 0.5 * std::sin(x * 0.35 + plank * 1.7 + std::sin(y * 0.2));
        r = int(150 + 50 * grain) - plank * 4;
        g = int(100 + 35 * grain) - plank * 3;
        b = int(50 + 15 * grain);
        if ((y * 6) % h < 3 || x - h < 3 || size - 1 - x < 3) r /= 2, g /= 2, b /= 2;
      } else {  // column: stone bands
        int band = ((y - h) * 10) / h;
        double n = 0.5 + 0.25 * std::sin(x * 0.9) * std::cos(y * 0.7);
        r = int(170 + 40 * n) - (band % 2) * 40;
        g = int(165 + 40 * n) - (band % 2) * 35;
        b = int(175 + 30 * n) - (band % 2) * 20;
      }
      p[0] = uint8_t(std::max(0, std::min(255, r)));
      p[1] = uint8_t(std::max(0, std::min(255, g)));
      p[2] = uint8_t(std::max(0, std::min(255, b)));
      p[3] = 255;
    }
  return img;
}

Primitive ground(int cells) {
  Primitive p;
  float half = 10.0f;
  for (int j = 0; j <= cells; ++j)
    for (int i = 0; i <= cells; ++i) {
      float u = float(i) / float(cells), v = float(j) / float(cells);
      float x = -half + 2 * half * u, z = -half + 2 * half * v;
      float y = 0.15f * std::sin(x * 0.6f) * std::cos(z * 0.5f);
      p.positions.push_back({x, y, z});
      p.uvs.resize(1);
      p.uvs[0].push_back({u * 0.5f, v * 0.5f});  // top-left quarter of the texture
    }
  for (int j = 0; j < cells; ++j)
    for (int i = 0; i < cells; ++i) {
      uint32_t a = uint32_t(j * (cells + 1) + i), b = a + 1, c = a + uint32_t(cells + 1), d = c + 1;
      p.indices.insert(p.indices.end(), {a, c, b, b, c, d});
    }
  return p;
}

Primitive crate() {
  Primitive p;
  p.uvs.resize(1);
  const Vec3 n[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int f = 0; f < 6; ++f) {
    Vec3 nn = n[f];
    Vec3 u = std::abs(nn.y) > 0.5f ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    Vec3 v = cross(nn, u);
    uint32_t base = uint32_t(p.positions.size());
    const float cs[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (auto& c : cs) {
      Vec3 pos = nn + u * c[0] + v * c[1];
      p.positions.push_back(pos * 0.75f + Vec3{0, 0.75f, 0});
      p.normals.push_back(nn);
      p.uvs[0].push_back({0.5f + 0.25f * (c[0] + 1) * 0.999f, 0.25f * (c[1] + 1) * 0.999f});
    }
    // Winding such that the face normal is nn: (u × v) = nn by construction order.
    if (dot(cross(u, v), nn) > 0)
      p.indices.insert(p.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    else
      p.indices.insert(p.indices.end(), {base, base + 2, base + 1, base, base + 3, base + 2});
  }
  return p;
}

// A column with an entasis profile and a capital: smooth sides, so normals are left for
// clean() to generate.
Primitive column(int segments) {
  Primitive p;
  p.uvs.resize(1);
  const float profile[][2] = {{0.0f, 0.34f}, {0.1f, 0.34f}, {0.12f, 0.26f}, {1.0f, 0.24f},
                              {2.0f, 0.22f}, {2.5f, 0.2f},  {2.55f, 0.3f},  {2.7f, 0.3f}};
  const int rings = int(sizeof profile / sizeof profile[0]);
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s <= segments; ++s) {
      float a = 2 * float(M_PI) * float(s) / float(segments);
      float rad = profile[r][1];
      p.positions.push_back({rad * std::cos(a), profile[r][0], rad * std::sin(a)});
      p.uvs[0].push_back({float(s) / float(segments), 0.5f + 0.5f * profile[r][0] / 2.7f * 0.999f});
    }
  for (int r = 0; r + 1 < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      uint32_t a = uint32_t(r * (segments + 1) + s), b = a + 1;
      uint32_t c = a + uint32_t(segments + 1), d = c + 1;
      p.indices.insert(p.indices.end(), {a, c, b, b, c, d});
    }
  // Top cap.
  uint32_t centre = uint32_t(p.positions.size());
  p.positions.push_back({0, profile[rings - 1][0], 0});
  p.uvs[0].push_back({0.5f, 0.75f});
  uint32_t top = uint32_t((rings - 1) * (segments + 1));
  for (int s = 0; s < segments; ++s)
    p.indices.insert(p.indices.end(), {centre, top + uint32_t(s) + 1, top + uint32_t(s)});
  return p;
}

}  // namespace

Scene make_sample_scene(const SampleOptions& o) {
  Scene scene;
  scene.images.push_back(make_texture(std::max(16, o.texture_size)));
  Material textured;
  textured.name = "sample-atlas";
  textured.base_color.image = 0;
  textured.roughness_factor = 0.8f;
  textured.metallic_factor = 0.0f;
  scene.materials.push_back(textured);
  Material painted;
  painted.name = "painted-metal";
  painted.base_color_factor = {0.8f, 0.1f, 0.08f, 1};
  painted.metallic_factor = 0.6f;
  painted.roughness_factor = 0.4f;
  scene.materials.push_back(painted);

  Mesh g;
  g.name = "ground";
  g.primitives.push_back(ground(std::max(1, o.ground_cells)));
  g.primitives.back().material = 0;
  scene.meshes.push_back(g);
  scene.instances.push_back({0, Mat4::identity(), "ground"});

  Mesh c;
  c.name = "crate";
  c.primitives.push_back(crate());
  c.primitives.back().material = 0;
  // A red lid plate: a second material on the same mesh.
  Primitive lid;
  lid.positions = {
      {-0.6f, 1.52f, -0.6f}, {0.6f, 1.52f, -0.6f}, {0.6f, 1.52f, 0.6f}, {-0.6f, 1.52f, 0.6f}};
  lid.indices = {0, 2, 1, 0, 3, 2};
  lid.material = 1;
  c.primitives.push_back(lid);
  scene.meshes.push_back(c);
  scene.instances.push_back({1, Mat4::translation(0, 0, 0), "crate"});
  double q[4] = {0, std::sin(0.3), 0, std::cos(0.3)}, t[3] = {2.2, 0, 1.0}, s[3] = {0.8, 0.8, 0.8};
  scene.instances.push_back({1, Mat4::trs(t, q, s), "crate-small"});

  Mesh col;
  col.name = "column";
  col.primitives.push_back(column(std::max(3, o.column_segments)));
  col.primitives.back().material = 0;
  scene.meshes.push_back(col);
  int n = std::max(1, o.columns_per_side);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      double x = -9 + 18.0 * (i + 0.5) / n, z = -9 + 18.0 * (j + 0.5) / n;
      if (std::abs(x) < 3 && std::abs(z) < 3) continue;  // clearing for the crates
      double angle = 0.37 * (i * 7 + j * 13);
      double scale = 0.8 + 0.4 * (((i * 31 + j * 17) % 11) / 10.0);
      double qq[4] = {0, std::sin(angle / 2), 0, std::cos(angle / 2)};
      double tt[3] = {x, 0, z}, ss[3] = {scale, scale, scale};
      scene.instances.push_back(
          {2, Mat4::trs(tt, qq, ss), "column-" + std::to_string(j) + "-" + std::to_string(i)});
    }
  return scene;
}

}  // namespace meshmux
