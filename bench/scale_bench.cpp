// meshmux_bench_scale: the geometric error of meshmux's progressive record on one (big,
// scan-like) model at a few fractions of its triangles, beside meshoptimizer's meshopt_simplify
// at the same triangle counts (a global simplifier we did not write: the reference). Run by
// bench/scale.sh on the generated scan-like meshes and the Stanford bunny.
//
// In one run: import_scene (images not decoded) → clean → build_progressive (timed: the record
// every fraction is selected from). Per fraction f (default 0.25, 0.06, 0.015):
// - meshmux: select_triangles(record, floor(f × input triangles)) → materialize (timed together
//   as "select s");
// - meshopt_simplify on the flattened cleaned scene (bench/meshopt_reference.h, as
//   meshmux_bench_simplify runs it) to meshmux's triangle count; when it stops more than 5%
//   short (seams and hard edges kept), again with the vertices welded on position alone. Its
//   seconds are the simplify calls of the run compared;
// - the symmetric Hausdorff distance of each to the cleaned input (bench/hausdorff.h), relative
//   to the input's bounding-box diagonal, --samples points on each surface.
// With --global, the same record is also built without the block levels (today's global
// simplifier: the whole-unit loop alone) and measured at the same counts: the block-built
// levels against it (the target: ≤ 1.1×). --block-above N lowers the block levels' size
// threshold (simplify.h block_above) so that a smaller real scan takes them, --block-positions N
// their size. When the record
// has a block hierarchy, its DAG (simplify/block_dag.h) is built and described: blocks per
// level, dependencies, the seconds it took.
// Prints a markdown table; --json FILE writes the same figures as JSON.
//
// usage: meshmux_bench_scale MODEL [--fractions F,F,...] [--samples N] [--json FILE]
//                            [--global] [--block-above N] [--block-positions N]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "bench/format.h"
#include "bench/hausdorff.h"
#include "bench/meshopt_reference.h"
#include "clean/clean.h"
#include "clean/flatten.h"
#include "importers/import.h"
#include "scene/scene.h"
#include "simplify/block_dag.h"
#include "simplify/lod.h"
#include "simplify/simplify.h"

using namespace meshmux;
using namespace meshmux::bench;

namespace {

// Hausdorff distances below this (relative) count as exact (as meshmux_bench_simplify).
constexpr double kExact = 1e-6;
// meshopt_simplify counts as reaching meshmux's count within this share (+2 triangles).
constexpr double kCountSlack = 0.05;

struct Config {
  std::string model;
  std::vector<double> fractions = {0.25, 0.06, 0.015};
  HausdorffOptions hopt;
  std::string json;
  bool global = false;           // also the record without block levels
  uint64_t block_above = 0;      // 0: SimplifyOptions' default
  uint64_t block_positions = 0;  // 0: SimplifyOptions' default
  bool help = false;
};

void print_usage(FILE* to) {
  std::fprintf(
      to,
      "usage: meshmux_bench_scale MODEL [--fractions F,F,...] [--samples N] [--json FILE]\n"
      "                           [--global] [--block-above N] [--block-positions N]\n"
      "Imports and cleans MODEL, builds meshmux's progressive record and, at each fraction of\n"
      "the input triangles (default 0.25,0.06,0.015), measures the symmetric Hausdorff distance\n"
      "(relative to the bounding-box diagonal) of meshmux's level and of meshopt_simplify at the\n"
      "same triangle count to the cleaned input. --samples: points sampled on each surface\n"
      "(default %zu; lower bounds the cost on huge meshes). Prints a markdown table; --json\n"
      "FILE writes the same as JSON. --global: also the record built without block levels\n"
      "(the whole-unit simplifier alone), measured at the same counts. --block-above N: the\n"
      "block levels' size threshold in triangles, --block-positions N the positions per block\n"
      "(defaults: the converter's).\n",
      HausdorffOptions{}.samples);
}

Result<std::vector<double>> parse_fractions(const std::string& list) {
  std::vector<double> out;
  size_t at = 0;
  while (at <= list.size()) {
    size_t comma = std::min(list.find(',', at), list.size());
    std::string item = list.substr(at, comma - at);
    char* end = nullptr;
    double f = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0' || !(f > 0 && f <= 1))
      return Status::error("--fractions: '" + item + "' is not a number in (0, 1]",
                           ErrorKind::kInput);
    out.push_back(f);
    at = comma + 1;
  }
  return out;
}

Result<Config> parse_args(int argc, char** argv) {
  Config cfg;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    bool has_value = i + 1 < argc;
    if (a == "-h" || a == "--help") {
      cfg.help = true;
    } else if (a == "--fractions" && has_value) {
      Result<std::vector<double>> f = parse_fractions(argv[++i]);
      if (!f) return f.status();
      cfg.fractions = f.take();
    } else if (a == "--samples" && has_value) {
      std::string v = argv[++i];
      char* end = nullptr;
      unsigned long long n = std::strtoull(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0' || n == 0)
        return Status::error("--samples: '" + v + "' is not a positive integer", ErrorKind::kInput);
      cfg.hopt.samples = size_t(n);
    } else if (a == "--json" && has_value) {
      cfg.json = argv[++i];
    } else if (a == "--global") {
      cfg.global = true;
    } else if ((a == "--block-above" || a == "--block-positions") && has_value) {
      std::string v = argv[++i];
      char* end = nullptr;
      unsigned long long n = std::strtoull(v.c_str(), &end, 10);
      if (v.empty() || *end != '\0' || n == 0 || n > UINT32_MAX)
        return Status::error(a + ": '" + v + "' is not a positive integer", ErrorKind::kInput);
      (a == "--block-above" ? cfg.block_above : cfg.block_positions) = n;
    } else if (!a.empty() && a[0] != '-' && cfg.model.empty()) {
      cfg.model = a;
    } else {
      return Status::error("unexpected argument '" + a + "' (see --help)", ErrorKind::kInput);
    }
  }
  if (cfg.model.empty() && !cfg.help)
    return Status::error("no MODEL given (see --help)", ErrorKind::kInput);
  return cfg;
}

// ---------------------------------------------------------------------------------------------
// Measuring

// The record's block hierarchy, when it has one (its largest mesh's).
struct DagFigures {
  size_t blocks = 0, levels = 0, deps = 0, max_deps = 0;
  std::vector<size_t> per_level;  // blocks per block level, finest first (the root last)
  double seconds = 0;
  std::string error;  // block_dag's, when it failed
};

struct Input {
  ProgressiveScene record;
  std::optional<ProgressiveScene> global;  // --global: without block levels
  double global_s = 0;
  DagFigures dag;
  Scene flat;  // the cleaned scene flattened: meshopt_simplify's input
  std::optional<HausdorffReference> reference;
  uint64_t triangles = 0;
  double diagonal = 0;
  double import_s = 0, clean_s = 0, record_s = 0, reference_s = 0;
  bool flattened = false;  // build_progressive took the flatten path
};

DagFigures dag_figures(const ProgressiveScene& ps) {
  DagFigures d;
  const ProgressiveMesh* big = nullptr;
  for (const ProgressiveMesh& pm : ps.meshes)
    if (!pm.blocks.empty() && (!big || pm.face_count() > big->face_count())) big = &pm;
  if (!big) return d;
  auto t0 = Clock::now();
  ProgressiveMesh ordered = *big;  // the DAG the converter's package carries
  if (Status s = order_by_blocks(ordered); !s) {
    d.error = s.message();
    return d;
  }
  Result<BlockDag> dag = block_dag(ordered);
  d.seconds = seconds_since(t0);
  if (!dag) {
    d.error = dag.status().message();
    return d;
  }
  d.blocks = dag->nodes.size();
  for (size_t b = 0; b < d.blocks; ++b) {
    const size_t level = ordered.blocks[b].level;
    if (d.per_level.size() <= level) d.per_level.resize(level + 1, 0);
    ++d.per_level[level];
    d.deps += dag->nodes[b].deps.size();
    d.max_deps = std::max(d.max_deps, dag->nodes[b].deps.size());
  }
  d.levels = d.per_level.size();
  std::fprintf(stderr, "scale: block DAG: %zu blocks, %zu dependencies, in %.2f s\n", d.blocks,
               d.deps, d.seconds);
  return d;
}

Result<Input> prepare(const Config& cfg) {
  Input in;
  auto t0 = Clock::now();
  ImportOptions iopt;
  iopt.decode_images = false;  // geometry only
  Warnings w;
  Result<Scene> imported = import_scene(cfg.model, iopt, &w);
  if (!imported) return imported.status();
  in.import_s = seconds_since(t0);
  t0 = Clock::now();
  Scene cleaned = clean(imported.take(), CleanOptions{});
  in.clean_s = seconds_since(t0);
  in.triangles = scene_tris(cleaned);
  if (in.triangles == 0)
    return Status::error(cfg.model + ": no triangles after cleaning", ErrorKind::kInput);
  std::fprintf(stderr, "scale: %s: %s triangles (import %.2f s, clean %.2f s)\n", cfg.model.c_str(),
               group(in.triangles).c_str(), in.import_s, in.clean_s);
  t0 = Clock::now();
  in.diagonal = double(scene_bounds(cleaned).diagonal());
  in.reference.emplace(world_triangles(cleaned), in.diagonal, cfg.hopt);
  in.reference_s = seconds_since(t0);
  t0 = Clock::now();
  SimplifyReport rep;
  SimplifyOptions sopt;
  // build_progressive's record keeps the levels merged by error: a prefix is a uniform cut (the
  // converter then orders it by blocks for the stream: dag_figures below).
  if (cfg.block_above) sopt.block_above = cfg.block_above;
  if (cfg.block_positions) sopt.block_positions = uint32_t(cfg.block_positions);
  in.record = build_progressive(cleaned, sopt, &rep);
  in.record_s = seconds_since(t0);
  in.flattened = rep.flattened;
  std::fprintf(stderr, "scale: progressive record in %.2f s (%u block levels)\n", in.record_s,
               rep.block_levels);
  in.dag = dag_figures(in.record);
  if (cfg.global) {
    t0 = Clock::now();
    SimplifyOptions whole;
    whole.block_above = UINT64_MAX;
    in.global = build_progressive(cleaned, whole);
    in.global_s = seconds_since(t0);
    std::fprintf(stderr, "scale: record without block levels in %.2f s\n", in.global_s);
  }
  in.flat = flatten(std::move(cleaned));
  return in;
}

struct Row {
  double fraction = 0;
  uint64_t target = 0;
  uint64_t mm_tris = 0, mo_tris = 0;
  HausdorffResult mm_h, mo_h;
  uint64_t gl_tris = 0;  // --global: the record without block levels at the same count
  HausdorffResult gl_h;
  double select_s = 0, mo_s = 0;
  bool mo_position_only = false;
};

// meshopt_simplify to `target` triangles; position-only (welded, computed once into *welded)
// when the run keeping seams stops short.
MeshoptRun meshopt_at(const Scene& flat, std::optional<Scene>* welded, uint64_t target,
                      bool* position_only) {
  MeshoptRun run = meshopt_to_count(flat, target);
  *position_only = false;
  double miss = std::abs(double(run.triangles) - double(target));
  if (miss <= kCountSlack * double(target) + 2) return run;
  if (!*welded) welded->emplace(weld_positions(flat));
  *position_only = true;
  return meshopt_to_count(**welded, target);
}

Row measure(const Input& in, std::optional<Scene>* welded, double fraction) {
  Row r;
  r.fraction = fraction;
  r.target = uint64_t(std::floor(fraction * double(in.triangles)));
  auto t0 = Clock::now();
  LodSelection sel = select_triangles(in.record, r.target);
  Scene level = materialize(in.record, sel, false, /*with_images=*/false);
  r.select_s = seconds_since(t0);
  r.mm_tris = scene_tris(level);
  r.mm_h = in.reference->compare(world_triangles(level));
  level = Scene();
  if (in.global) {
    Scene g = materialize(*in.global, select_triangles(*in.global, r.target), false, false);
    r.gl_tris = scene_tris(g);
    r.gl_h = in.reference->compare(world_triangles(g));
  }
  MeshoptRun mo = meshopt_at(in.flat, welded, r.mm_tris, &r.mo_position_only);
  r.mo_tris = mo.triangles;
  r.mo_s = mo.seconds;
  r.mo_h = in.reference->compare(world_triangles(mo.scene));
  std::fprintf(stderr, "scale: %.4g: meshmux %s tris %.5f, meshopt %s tris %.5f\n", fraction,
               group(r.mm_tris).c_str(), r.mm_h.hausdorff, group(r.mo_tris).c_str(),
               r.mo_h.hausdorff);
  return r;
}

// ---------------------------------------------------------------------------------------------
// Output

// meshmux / its record without block levels, or nullopt (no --global, invalid, exact).
std::optional<double> global_ratio(const Row& r) {
  if (!r.mm_h.valid || !r.gl_h.valid || r.gl_h.hausdorff <= kExact) return std::nullopt;
  return r.mm_h.hausdorff / r.gl_h.hausdorff;
}

// meshmux / meshopt, or nullopt when either is invalid or meshopt's is exact.
std::optional<double> ratio(const Row& r) {
  if (!r.mm_h.valid || !r.mo_h.valid || r.mo_h.hausdorff <= kExact) return std::nullopt;
  return r.mm_h.hausdorff / r.mo_h.hausdorff;
}

std::string ratio_text(const Row& r) {
  if (std::optional<double> q = ratio(r)) return fmt("%.2f", *q);
  if (r.mm_h.valid && r.mo_h.valid)
    return r.mm_h.hausdorff <= kExact ? "1 (both exact)" : "∞ (meshopt exact)";
  return "n/a";
}

std::string hd_text(const HausdorffResult& h) { return h.valid ? fmt("%.5f", h.hausdorff) : "n/a"; }

void print_table(const Config& cfg, const Input& in, const std::vector<Row>& rows) {
  std::printf("## %s: %s input triangles%s\n\n", cfg.model.c_str(), group(in.triangles).c_str(),
              in.flattened ? " (record flattened)" : "");
  std::printf(
      "Hausdorff: symmetric, %zu samples per surface, relative to the bounding-box diagonal, "
      "against the cleaned input. record s: build_progressive, once for every row; select s: "
      "select_triangles + materialize; meshopt s: its simplify calls at that count.\n\n",
      cfg.hopt.samples);
  std::printf(
      "| fraction | triangles | meshmux Hausdorff | meshopt triangles | meshopt Hausdorff | ratio "
      "meshmux/meshopt | record s | select s | meshopt s |\n"
      "|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const Row& r : rows)
    std::printf("| %.4g | %s | %s | %s%s | %s | %s | %.3f | %.3f | %.3f |\n", r.fraction,
                group(r.mm_tris).c_str(), hd_text(r.mm_h).c_str(), group(r.mo_tris).c_str(),
                r.mo_position_only ? " (position-only)" : "", hd_text(r.mo_h).c_str(),
                ratio_text(r).c_str(), in.record_s, r.select_s, r.mo_s);
  if (in.global) {
    std::printf(
        "\nBlock-built levels against the record without block levels (the whole-unit "
        "simplifier alone, %.2f s; target ≤ 1.1×):\n\n"
        "| fraction | block-built triangles | Hausdorff | whole-unit triangles | Hausdorff | ratio "
        "|\n|---:|---:|---:|---:|---:|---:|\n",
        in.global_s);
    for (const Row& r : rows) {
      const std::optional<double> q = global_ratio(r);
      std::printf("| %.4g | %s | %s | %s | %s | %s |\n", r.fraction, group(r.mm_tris).c_str(),
                  hd_text(r.mm_h).c_str(), group(r.gl_tris).c_str(), hd_text(r.gl_h).c_str(),
                  q ? fmt("%.2f", *q).c_str() : "n/a");
    }
  }
  if (!in.dag.error.empty()) {
    std::printf("\nBlock DAG: FAILED: %s\n", in.dag.error.c_str());
  } else if (in.dag.blocks) {
    std::string per;
    for (size_t l = 0; l < in.dag.per_level.size(); ++l)
      per += (l ? ", " : "") + std::to_string(in.dag.per_level[l]);
    std::printf(
        "\nBlock DAG: %zu blocks (per level, finest first, the root last: %s), %zu dependencies "
        "(at most %zu a block), built in %.2f s\n",
        in.dag.blocks, per.c_str(), in.dag.deps, in.dag.max_deps, in.dag.seconds);
  }
}

nlohmann::json hausdorff_json(const HausdorffResult& h) {
  if (!h.valid) return nullptr;
  return {{"hausdorff", h.hausdorff},
          {"forward", h.forward},
          {"backward", h.backward},
          {"mean", h.mean},
          {"rms", h.rms}};
}

Status write_json(const Config& cfg, const Input& in, const std::vector<Row>& rows) {
  nlohmann::json j = {{"model", cfg.model},
                      {"input_triangles", in.triangles},
                      {"diagonal", in.diagonal},
                      {"samples", cfg.hopt.samples},
                      {"record_flattened", in.flattened},
                      {"seconds",
                       {{"import", in.import_s},
                        {"clean", in.clean_s},
                        {"hausdorff_reference", in.reference_s},
                        {"record", in.record_s},
                        {"record_without_blocks", in.global_s},
                        {"block_dag", in.dag.seconds}}}};
  j["block_dag"] = {{"blocks", in.dag.blocks},
                    {"blocks_per_level", in.dag.per_level},
                    {"dependencies", in.dag.deps},
                    {"max_dependencies", in.dag.max_deps},
                    {"error", in.dag.error}};
  j["fractions"] = nlohmann::json::array();
  for (const Row& r : rows) {
    std::optional<double> q = ratio(r);
    j["fractions"].push_back({{"fraction", r.fraction},
                              {"target_triangles", r.target},
                              {"meshmux",
                               {{"triangles", r.mm_tris},
                                {"select_seconds", r.select_s},
                                {"h", hausdorff_json(r.mm_h)}}},
                              {"meshopt",
                               {{"triangles", r.mo_tris},
                                {"seconds", r.mo_s},
                                {"position_only", r.mo_position_only},
                                {"h", hausdorff_json(r.mo_h)}}},
                              {"ratio", q ? nlohmann::json(*q) : nlohmann::json(nullptr)}});
    if (in.global) {
      std::optional<double> g = global_ratio(r);
      j["fractions"].back()["whole_unit"] = {
          {"triangles", r.gl_tris},
          {"h", hausdorff_json(r.gl_h)},
          {"ratio", g ? nlohmann::json(*g) : nlohmann::json(nullptr)}};
    }
  }
  std::ofstream out(cfg.json);
  out << j.dump(2) << "\n";
  out.close();
  if (!out) return Status::error("cannot write " + cfg.json, ErrorKind::kOutput);
  return Status::ok();
}

int run(const Config& cfg) {
  Result<Input> in = prepare(cfg);
  if (!in) {
    std::fprintf(stderr, "meshmux_bench_scale: %s\n", in.status().message().c_str());
    return 1;
  }
  std::vector<Row> rows;
  std::optional<Scene> welded;
  for (double f : cfg.fractions) rows.push_back(measure(*in, &welded, f));
  print_table(cfg, *in, rows);
  if (!cfg.json.empty()) {
    if (Status s = write_json(cfg, *in, rows); !s) {
      std::fprintf(stderr, "meshmux_bench_scale: %s\n", s.message().c_str());
      return 1;
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Result<Config> cfg = parse_args(argc, argv);
  if (!cfg) {
    std::fprintf(stderr, "meshmux_bench_scale: %s\n", cfg.status().message().c_str());
    return 2;
  }
  if (cfg->help) {
    print_usage(stdout);
    return 0;
  }
  try {
    return run(*cfg);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "meshmux_bench_scale: %s\n", e.what());
    return 1;
  }
}
