// The render plan's benchmark: where a model's order is forced (one mesh layer or one texture
// level: the steepest descent of Yang, Shen and Kuo, "Progressive coding of 3D textured graphic
// model via joint mesh-texture optimization", has no choice), the multiplexer measures its curve
// cheaply when asked (MultiplexOptions::forced_view_layers, forced_image_size). Each model given is
// converted twice, cheaply and with the full measurement (10 views at 256²), and the table says
// what the cheap one costs and how far its curve is from the full one's: the area under the
// rate-distortion curve (target: within 2%), and whether the two orders are the same chunks.
// usage: meshmux_bench_render_plan [--layers L] [--size S] MODEL ...
//   (the cheap measurement's viewing-sphere layers and image size; default 0 and 128: the 4
//   tetrahedron views at 128²)
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>

#include "importers/import.h"
#include "pipeline/convert.h"

using namespace meshmux;

namespace {

struct Run {
  double seconds = 0;
  std::optional<MultiplexResult> r;  // none when the conversion failed or had no renderer
};

Run convert_with(const Scene& input, int forced_view_layers, int forced_image_size) {
  Run run;
  ConvertOptions options;
  options.multiplex.forced_view_layers = forced_view_layers;
  options.multiplex.forced_image_size = forced_image_size;
  Warnings warnings;
  auto t0 = std::chrono::steady_clock::now();
  auto c = convert(input, options, &warnings, nullptr);
  run.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (c.ok()) run.r = std::move(c->multiplexed);
  return run;
}

bool same_order(const RdPath& a, const RdPath& b) { return a.cells == b.cells; }

}  // namespace

int main(int argc, char** argv) {
  std::printf(
      "| model | grid | forced | views cheap / full | renders cheap / full | multiplex s cheap / "
      "full | convert s cheap / full | area cheap | area full | difference (≤ 2%%) | same order "
      "|\n");
  std::printf("|---|---|---|---|---|---|---|---:|---:|---:|---|\n");
  int layers = 0, size = 128;  // 4 views at 128²
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    if ((flag == "--layers" || flag == "--size") && i + 1 < argc) {
      (flag == "--layers" ? layers : size) = std::atoi(argv[++i]);
      continue;
    }
    auto in = import_scene(argv[i], {}, nullptr);
    if (!in.ok()) {
      std::printf("| %s | import failed: %s |\n", argv[i], in.status().message().c_str());
      continue;
    }
    Run cheap = convert_with(*in, layers, size);
    Run full = convert_with(*in, -1, size);
    if (!cheap.r || !full.r) {
      std::printf("| %s | conversion failed |\n", argv[i]);
      continue;
    }
    const MultiplexResult &a = *cheap.r, &b = *full.r;
    const size_t m = a.mesh_bytes.size(), n = a.texture_bytes.size();
    const double area_a = area_under(a.rd), area_b = area_under(b.rd);
    std::printf(
        "| %s | %zu x %zu | %s | %zu / %zu | %zu / %zu | %.2f / %.2f | %.2f / %.2f | %.5g | "
        "%.5g | %.2f%% | %s |\n",
        argv[i], m, n, m == 1 || n == 1 ? "yes" : "no", a.views, b.views, a.renders, b.renders,
        a.seconds_total, b.seconds_total, cheap.seconds, full.seconds, area_a, area_b,
        area_b > 0 ? 100 * std::fabs(area_a - area_b) / area_b : 0.0,
        same_order(a.rd, b.rd) ? "yes" : "no");
    std::fflush(stdout);
  }
}
