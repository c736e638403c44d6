// Offscreen renderer benchmark (moved out of the unit tests: timing is a figure, not a test).
// Renders the built-in sample scene at the multiplexer's default size (256²) from the default
// view and prints the upload time and the time per render; the multiplexer's cost is about
// renders × this. A second row draws the same geometry untextured with its uvs ×100 (uvs that
// span hundreds of periods on a mesh no texture reads, as simulator models come): on llvmpipe
// it must cost what the first row's geometry costs untextured (a third row), not many times
// more. usage: meshmux_bench_render [COLUMNS_PER_SIDE]
#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "multiplex/render.h"
#include "multiplex/viewpoints.h"
#include "scene/sample.h"

using namespace meshmux;

int main(int argc, char** argv) {
  SampleOptions so;
  so.columns_per_side = argc > 1 ? std::max(1, std::atoi(argv[1])) : 18;
  so.ground_cells = 64;
  so.texture_size = 512;
  Scene s = make_sample_scene(so);
  auto created = Renderer::create(RenderOptions{});
  if (!created.ok()) {
    std::printf("render bench: %s\n", created.status().message().c_str());
    return created.status().kind() == ErrorKind::kUnavailable ? 0 : 1;
  }
  Renderer& r = **created;
  using Clock = std::chrono::steady_clock;
  auto t0 = Clock::now();
  int g = r.add_geometry(s);
  int t = r.add_texture(s.images[0]);
  auto t1 = Clock::now();
  ViewOptions vo;
  Camera cam = camera_for(normalize(vo.direction), scene_bounds(s), 1.0f, vo);
  r.render(g, t, cam);  // warm-up (shader JIT)
  const int runs = 20;
  size_t covered = 0;
  auto t2 = Clock::now();
  for (int i = 0; i < runs; ++i)
    for (uint8_t c : r.render(g, t, cam).coverage) covered += c;
  auto t3 = Clock::now();
  SceneStats st = compute_stats(s);
  std::printf("| scene triangles | image | upload ms | ms per render | covered px |\n");
  std::printf("|---:|---|---:|---:|---:|\n");
  std::printf("| %llu | 256x256, texture %dx%d | %.1f | %.2f | %zu |\n",
              static_cast<unsigned long long>(st.scene_triangles), s.images[0].width,
              s.images[0].height, std::chrono::duration<double, std::milli>(t1 - t0).count(),
              std::chrono::duration<double, std::milli>(t3 - t2).count() / runs, covered / runs);
  // Untextured, uvs as they are and ×100.
  for (float scale : {1.0f, 100.0f}) {
    Scene u = s;
    for (Material& m : u.materials) m = Material{};
    for (Mesh& mesh : u.meshes)
      for (Primitive& p : mesh.primitives)
        for (auto& set : p.uvs)
          for (Vec2& c : set) c = {c.x * scale, c.y * scale};
    int gu = r.add_geometry(u);
    r.render(gu, -1, cam);
    auto u0 = Clock::now();
    for (int i = 0; i < runs; ++i) r.render(gu, -1, cam);
    auto u1 = Clock::now();
    std::printf("| %llu | 256x256, untextured, uvs x%g | | %.2f | |\n",
                static_cast<unsigned long long>(st.scene_triangles), double(scale),
                std::chrono::duration<double, std::milli>(u1 - u0).count() / runs);
  }
  return 0;
}
