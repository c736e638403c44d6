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
// Prints a markdown table; --json FILE writes the same figures as JSON.
//
// usage: meshmux_bench_scale MODEL [--fractions F,F,...] [--samples N] [--json FILE]
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
  bool help = false;
};

void print_usage(FILE* to) {
  std::fprintf(
      to,
      "usage: meshmux_bench_scale MODEL [--fractions F,F,...] [--samples N] [--json FILE]\n"
      "Imports and cleans MODEL, builds meshmux's progressive record and, at each fraction of\n"
      "the input triangles (default 0.25,0.06,0.015), measures the symmetric Hausdorff distance\n"
      "(relative to the bounding-box diagonal) of meshmux's level and of meshopt_simplify at the\n"
      "same triangle count to the cleaned input. --samples: points sampled on each surface\n"
      "(default %zu; lower bounds the cost on huge meshes). Prints a markdown table; --json\n"
      "FILE writes the same as JSON.\n",
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

struct Input {
  ProgressiveScene record;
  Scene flat;  // the cleaned scene flattened: meshopt_simplify's input
  std::optional<HausdorffReference> reference;
  uint64_t triangles = 0;
  double diagonal = 0;
  double import_s = 0, clean_s = 0, record_s = 0, reference_s = 0;
  bool flattened = false;  // build_progressive took the flatten path
};

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
  in.record = build_progressive(cleaned, SimplifyOptions{}, &rep);
  in.record_s = seconds_since(t0);
  in.flattened = rep.flattened;
  std::fprintf(stderr, "scale: progressive record in %.2f s\n", in.record_s);
  in.flat = flatten(std::move(cleaned));
  return in;
}

struct Row {
  double fraction = 0;
  uint64_t target = 0;
  uint64_t mm_tris = 0, mo_tris = 0;
  HausdorffResult mm_h, mo_h;
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
                        {"record", in.record_s}}}};
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
