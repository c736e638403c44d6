// Multiplexer benchmark: the whole conversion (pipeline/convert: clean → atlas → texture levels →
// progressive record → the multiplexing of Yang, Shen and Kuo, "Progressive coding of 3D textured
// graphic model via joint mesh-texture optimization" → package), on a generated textured scene of
// ~112,000 triangles (a 100k-triangle model: target ≤ 60 s on 2 cores) and on every textured shared
// model given on the command line. Prints the four areas under the rendered distortion-vs-bytes
// curves and the gain over the best baseline.
// usage: meshmux_bench_multiplex [MODEL ...]
#include <chrono>
#include <cstdio>
#include <string>

#include "importers/import.h"
#include "pipeline/convert.h"
#include "scene/sample.h"

using namespace meshmux;

namespace {

void run(const std::string& name, const Scene& input) {
  auto t0 = std::chrono::steady_clock::now();
  Warnings warnings;
  auto c = convert(input, ConvertOptions{}, &warnings, nullptr);
  auto t2 = std::chrono::steady_clock::now();
  if (!c.ok() || !c->multiplexed) {
    std::printf("| %s | conversion failed: %s |\n", name.c_str(),
                c.ok() ? "no renderer here" : c.status().message().c_str());
    return;
  }
  const MultiplexResult* r = &*c->multiplexed;
  auto t1 = t2 - std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                     std::chrono::duration<double>(r->seconds_total));
  double rd = area_under(r->rd), mf = area_under(r->mesh_first), tf = area_under(r->texture_first),
         cr = area_under(r->constant_ratio), best = std::min({mf, tf, cr});
  std::printf(
      "| %s | %llu | %zu x %zu | %.4g | %.4g | %.4g | %.4g | %.1f%% | %zu | %zu / %zu / %zu | %zu "
      "| %.1f | %.1f |\n",
      name.c_str(), static_cast<unsigned long long>(c->output.scene_triangles),
      r->mesh_bytes.size(), r->texture_bytes.size(), rd, mf, tf, cr, 100 * (1 - rd / best),
      r->views, r->cells_descent, r->cells_evaluated, r->cells_total, r->renders,
      std::chrono::duration<double>(t1 - t0).count(),
      std::chrono::duration<double>(t2 - t1).count());
}

}  // namespace

int main(int argc, char** argv) {
  std::printf(
      "| model | scene tris | mesh x texture layers | area rd | mesh first | texture first | "
      "constant ratio | gain vs best | views | cells descent / all / grid | renders | other stages "
      "s "
      "| multiplex s |\n");
  std::printf("|---|---:|---|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|\n");
  SampleOptions big;
  big.columns_per_side = 18;
  big.ground_cells = 64;
  big.texture_size = 1024;
  run("generated textured scene", make_sample_scene(big));
  for (int i = 1; i < argc; ++i) {
    auto in = import_scene(argv[i], {}, nullptr);
    if (!in.ok()) {
      std::printf("| %s | import failed: %s |\n", argv[i], in.status().message().c_str());
      continue;
    }
    run(argv[i], *in);
  }
}
