// The `meshmux` command: convert, info, sample. Each command parses its own flags, runs the
// stages in order and maps a failed Status to an exit code. Progress and warnings go to
// stderr; data (info) goes to stdout.
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "clean/clean.h"
#include "cli/batch_command.h"
#include "cli/output_transaction.h"
#include "cli/render_command.h"
#include "cli/serve.h"
#include "cli/text.h"
#include "exporters/gltf.h"
#include "exporters/viewer_page.h"
#include "importers/import.h"
#include "importers/upload.h"
#include "pipeline/convert.h"
#include "core/file_io.h"
#include "scene/sample.h"
#include "core/sanitizers.h"
#include "simplify/lod.h"
#include "simplify/simplify.h"

#ifndef MESHMUX_VERSION
#define MESHMUX_VERSION "0.0.0"
#endif

namespace meshmux {
namespace {

// Exit codes, documented in --help.
constexpr int kExitOk = 0;
constexpr int kExitUsage = 1;
constexpr int kExitInput = 2;
constexpr int kExitOutput = 3;
constexpr int kExitInternal = 4;
constexpr int kExitUnavailable = 5;

const char* kUsage =
    "meshmux " MESHMUX_VERSION
    " - turns COLLADA and glTF scenes into web-ready glTF\n"
    "\n"
    "usage:\n"
    "  meshmux convert IN -o OUT [options]   clean IN and write web-ready output\n"
    "      OUT ending in .glb: that one file (full quality, Draco-compressed)\n"
    "      otherwise OUT is a folder that receives model.glb (full quality), base.glb (the\n"
    "      base level of detail that displays first), model.mmxp (the stream package: the\n"
    "      base, then mesh refinements and texture levels in rate-distortion order),\n"
    "      report.json and rd.svg (that order's curves beside three baselines), and the web\n"
    "      viewer (index.html and viewer/: meshmux serve OUT, then open the printed URL)\n"
    "  meshmux batch LIST -o OUTROOT [--jobs N | --slurm] [options]\n"
    "                                        convert many inputs (a list file or a folder) into\n"
    "                                        OUTROOT/<name>/, each in its own process with time\n"
    "                                        and memory limits; resumable; OUTROOT/index.html\n"
    "                                        lists them (meshmux batch --help)\n"
    "  meshmux info FILE [--json]            meshes, instances, triangles, materials,\n"
    "                                        textures, draw calls, bytes (a .gltf counts\n"
    "                                        its external buffers and images too)\n"
    "  meshmux simplify IN -o OUT.glb (--ratio R | --triangles N | --error E)\n"
    "                                        one level of detail: R of the scene triangles,\n"
    "                                        at most N scene triangles, or geometric error E\n"
    "                                        (fraction of the bounding-box diagonal)\n"
    "  meshmux sample -o FILE.glb            write the built-in demo scene\n"
    "  meshmux serve DIR [--port P] [--host H]   HTTP with Range requests for the viewer (loopback "
    "by default)\n"
    "  meshmux render IN -o OUT.png [--size WxH] [--eye X,Y,Z --target X,Y,Z ...]\n"
    "                                        render IN offscreen as the web viewer draws it\n"
    "                                        (meshmux render --help for the camera options)\n"
    "  meshmux --help | --version\n"
    "\n"
    "convert options:\n"
    "  --position-bits N   Draco position quantization bits (default 14)\n"
    "  --normal-bits N     Draco normal quantization bits (default 10)\n"
    "  --uv-bits N         Draco texture coordinate quantization bits (default 12)\n"
    "  --jpeg-quality N    JPEG quality of the texture levels, 1-100 (default 85); model.glb\n"
    "                      embeds the top level, the stream every level\n"
    "  --no-draco          write plain (uncompressed) accessors\n"
    "  --no-atlas          keep the source materials and textures (no single-texture atlas)\n"
    "  --no-report         folder output without renders: model.glb and base.glb only (the\n"
    "                      order is rendered, so no report, stream package or viewer either)\n"
    "  --crease DEGREES    crease angle for generated normals (default 60)\n"
    "  -q, --quiet         no progress or warnings on stderr\n"
    "\n"
    "uploads (convert, info, simplify): IN is a folder, a .zip or one model file\n"
    "  --main PATH         the model file inside a folder or .zip upload (default: the one\n"
    "                      .gltf/.glb/.dae nearest its root; several there is an error)\n"
    "  --root DIR          for a lone model file: the folder its reads may reach (default:\n"
    "                      the file's own folder)\n"
    "  --allow-outside     read buffers and images outside the upload (trusted local\n"
    "                      files only; by default they are refused, as are links out of it)\n"
    "  --max-texels N      decoded texels of all images together\n"
    "  --max-instances N   mesh instances the node graph may expand to\n"
    "  --max-elements N    accessor values read in all (vertices, indices, instance data)\n"
    "  --max-memory MB     heap and private memory of the whole run\n"
    "                      (defaults from the input's size: at least 67 M texels, 1 M\n"
    "                      instances, 67 M values and 2 GB, more for larger inputs)\n"
    "\n"
    "inputs: .gltf (external or embedded buffers and images), .glb, .dae (COLLADA 1.4/1.5),\n"
    "  as one file, a folder or a .zip; every read stays inside the upload (an archive's\n"
    "  members with '..', absolute paths, links or devices are refused, and it may unpack to\n"
    "  at most max(512 MiB, 64x its size)); a texture not where its path says is found by\n"
    "  its file name elsewhere in the upload when exactly one file has that name\n"
    "\n"
    "exit codes:\n"
    "  0  success\n"
    "  1  usage error (unknown command or flag, missing argument)\n"
    "  2  input error (missing, empty, truncated, malformed or unsupported input)\n"
    "  3  output error (the output could not be written; nothing partial is left)\n"
    "  4  internal error\n"
    "  5  unavailable: no offscreen OpenGL 4.5 through EGL here (meshmux render; convert\n"
    "     then writes everything but the report, the package and the viewer, with a warning)\n";

int exit_code(const Status& s) {
  switch (s.kind()) {
    case ErrorKind::kNone:
      return kExitOk;
    case ErrorKind::kInput:
      return kExitInput;
    case ErrorKind::kOutput:
      return kExitOutput;
    case ErrorKind::kInternal:
      return kExitInternal;
    case ErrorKind::kUnavailable:
      return kExitUnavailable;
  }
  return kExitInternal;
}

int fail(const Status& s) {
  std::fprintf(stderr, "meshmux: %s\n", s.message().c_str());
  return exit_code(s);
}

int usage_error(const std::string& message) {
  std::fprintf(stderr, "meshmux: %s\n(see meshmux --help)\n", message.c_str());
  return kExitUsage;
}

// What kind of warning a message is: the message with its numbers and quoted names blanked,
// so "geometry 'a': <lines> skipped (3 lines)" and "geometry 'b': <lines> skipped (9 lines)"
// are one kind.
std::string warning_kind(const std::string& message) {
  std::string kind;
  for (size_t i = 0; i < message.size(); ++i) {
    char c = message[i];
    if (c == '\'' || c == '"') {
      size_t end = message.find(c, i + 1);
      if (end != std::string::npos) {
        kind += "#";
        i = end;
        continue;
      }
    }
    if (std::isdigit(static_cast<unsigned char>(c))) {
      if (kind.empty() || kind.back() != '#') kind += '#';
      continue;
    }
    kind += c;
  }
  return kind;
}

// Progress on stderr: each step with the elapsed time, then the warnings that came since,
// grouped: the first two of a kind are printed, the rest counted and summed up at the end. On a
// terminal, a step that runs over a second also shows its percentage, live, on a line of its
// own that the next line replaces (pipes and logs get the step lines only).
class CliProgress : public Progress {
 public:
  CliProgress(bool quiet, const Warnings* warnings = nullptr)
      : quiet_(quiet),
        warnings_(warnings),
        live_(!quiet && isatty(2)),
        start_(now()),
        step_start_(start_),
        last_live_(start_) {}
  ~CliProgress() override { finish(); }
  void step(const std::string& what) override {
    flush();
    step_start_ = now();
    if (!quiet_) std::fprintf(stderr, "meshmux: [%6.2f s] %s\n", seconds(), what.c_str());
  }
  void fraction(double done) override {
    if (!live_) return;
    const auto t = now();
    if (t - step_start_ < live_after_ || t - last_live_ < std::chrono::milliseconds(100)) return;
    last_live_ = t;
    const int percent = int(std::clamp(done, 0.0, 1.0) * 100);
    std::fprintf(stderr, "\r\033[Kmeshmux: [%6.2f s]   %d%%", seconds(), percent);
    std::fflush(stderr);
    shown_ = true;
  }
  // Prints the warnings not printed yet (two of each kind).
  void flush() {
    clear_live();
    if (!warnings_) return;
    for (; seen_ < warnings_->items().size(); ++seen_) {
      const std::string& w = warnings_->items()[seen_];
      auto [it, fresh] = kinds_.emplace(warning_kind(w), Kind{0, w});
      if (fresh) order_.push_back(it->first);
      if (++it->second.count <= 2 && !quiet_)
        std::fprintf(stderr, "meshmux: warning: %s\n", w.c_str());
    }
  }
  // The counts of the kinds that had more than two.
  void finish() {
    flush();
    for (const std::string& k : order_) {
      const Kind& kind = kinds_[k];
      if (kind.count > 2 && !quiet_)
        std::fprintf(stderr, "meshmux: warning: ... and %zu more like \"%s\"\n", kind.count - 2,
                     kind.first.c_str());
    }
    order_.clear();
  }
  double seconds() const { return std::chrono::duration<double>(now() - start_).count(); }

 private:
  struct Kind {
    size_t count;
    std::string first;  // the first message of the kind
  };
  static std::chrono::steady_clock::time_point now() { return std::chrono::steady_clock::now(); }
  // Erases the live percentage line, if one is shown.
  void clear_live() {
    if (!shown_) return;
    std::fprintf(stderr, "\r\033[K");
    shown_ = false;
  }
  bool quiet_;
  const Warnings* warnings_;
  bool live_;  // stderr is a terminal and not -q
  // A step shows its percentage once it has run this long: 1 s, or MESHMUX_LIVE_PROGRESS_AFTER
  // seconds (tests set 0 to see the live line on small inputs, whatever the machine's speed).
  std::chrono::duration<double> live_after_ = [] {
    const char* e = std::getenv("MESHMUX_LIVE_PROGRESS_AFTER");
    char* end = nullptr;
    const double v = e ? std::strtod(e, &end) : 1.0;
    return std::chrono::duration<double>(e && end != e && v >= 0 ? v : 1.0);
  }();
  bool shown_ = false;  // a live line is on screen
  std::chrono::steady_clock::time_point start_, step_start_, last_live_;
  size_t seen_ = 0;
  std::map<std::string, Kind> kinds_;
  std::vector<std::string> order_;  // kinds in order of first appearance
};

bool ends_with(const std::string& s, const std::string& suffix) {
  if (s.size() < suffix.size()) return false;
  return std::equal(suffix.rbegin(), suffix.rend(), s.rbegin(),
                    [](char a, char b) { return std::tolower(a) == std::tolower(b); });
}

// Parses an integer flag value within [lo, hi].
bool parse_int(const std::string& flag, const std::string& text, int lo, int hi, int* out,
               std::string* error) {
  char* end = nullptr;
  long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || v < lo || v > hi) {
    *error = flag + " expects a whole number from " + std::to_string(lo) + " to " +
             std::to_string(hi) + ", got '" + text + "'";
    return false;
  }
  *out = int(v);
  return true;
}

// Walks one command's arguments. The flags every command shares (-o/--output, -q/--quiet,
// -h/--help) and the positional input are handled by common(); the command handles its own
// flags, reading their values with value().
class Args {
 public:
  Args(std::string cmd, const std::vector<std::string>& args) : cmd_(std::move(cmd)), args_(args) {}
  bool next() { return ++i_ < args_.size(); }
  const std::string& current() const { return args_[i_]; }
  // The value following the current flag.
  bool value(std::string* v) {
    if (i_ + 1 >= args_.size()) return fail(current() + " needs a value");
    *v = args_[++i_];
    return true;
  }
  // 1: a shared flag or the input, handled; 0: not a shared flag (the command's, or unknown);
  // -1: a usage error, see error.
  int common() {
    const std::string& a = current();
    if (a == "-o" || a == "--output") return value(&out) ? 1 : -1;
    if (a == "-q" || a == "--quiet") return quiet = true, 1;
    if (a == "-h" || a == "--help") return help = true, 1;
    if (a == "--allow-outside") return import.allow_outside = true, 1;
    if (a == "--main") return value(&upload.main) ? 1 : -1;
    if (a == "--root") return value(&upload.root) ? 1 : -1;
    // The limit flags: positive whole numbers (--max-memory in MB).
    const std::pair<const char*, uint64_t*> limits[] = {{"--max-texels", &import.max_texels},
                                                        {"--max-instances", &import.max_instances},
                                                        {"--max-elements", &import.max_elements},
                                                        {"--max-memory", &max_memory_mb}};
    for (const auto& [flag, field] : limits) {
      if (a != flag) continue;
      std::string v;
      if (!value(&v)) return -1;
      char* end = nullptr;
      errno = 0;
      unsigned long long n = std::strtoull(v.c_str(), &end, 10);
      if (v.empty() || v[0] == '-' || *end != '\0' || errno != 0 || n == 0)
        return fail(std::string(flag) + " needs a positive whole number, not '" + v + "'") ? 1 : -1;
      *field = n;
      return 1;
    }
    if (!a.empty() && a[0] == '-') return 0;
    if (!in.empty())
      return fail("more than one input given ('" + in + "' and '" + a + "')") ? 1 : -1;
    in = a;
    return 1;
  }
  bool fail(const std::string& message) {
    error = cmd_ + ": " + message;
    return false;
  }
  std::string in, out, error;
  bool quiet = false, help = false;
  ImportOptions import;        // --allow-outside and the resource limits
  UploadOptions upload;        // --main and --root
  uint64_t max_memory_mb = 0;  // --max-memory; 0: from the input's size

 private:
  std::string cmd_;
  const std::vector<std::string>& args_;
  size_t i_ = size_t(-1);
};

// Opens the input as an upload (importers/upload.h): a folder or a .zip, whose model file is
// found inside (an archive unpacked beside `out`, as "<OUT>.meshmux-upload-<pid>", removed when
// the Upload goes; or in TMPDIR when there is no output), or a lone model file. Sets
// `p.import.root` to the upload's folder, which bounds every read.
Result<Upload> open_input(Args& p, const std::string& out) {
  std::string scratch;
  const std::string suffix = ".meshmux-upload-" + std::to_string(getpid());
  if (!out.empty()) {
    std::string o = out;
    while (o.size() > 1 && o.back() == '/') o.pop_back();
    scratch = o + suffix;
  } else {
    const char* tmp = std::getenv("TMPDIR");
    scratch = std::string(tmp && *tmp ? tmp : "/tmp") + "/meshmux" + suffix;
  }
  std::error_code ec;
  std::filesystem::remove_all(scratch, ec);  // our own pid's leftover (a reused pid)
  auto up = open_upload(p.in, p.upload, scratch);
  if (up.ok()) p.import.root = up->root();
  return up;
}

// Writes a conversion's outputs: OUT.glb alone, or the folder's files, each atomically; the
// progress lines name them.
// A folder output is one transaction (cli/output_transaction.h): written into a temporary
// folder beside OUT and swapped in when complete, so a failure leaves the previous output and
// nothing of a previous conversion survives beside the new one.
Status write_outputs(const std::string& out, bool folder, const ConvertOutputs& r,
                     CliProgress& progress) {
  if (!folder) return write_file_atomic(out, r.model_glb);
  auto txn = OutputFolder::begin(out);
  if (!txn.ok()) return txn.status();
  const std::string& dir = txn->dir();
  const std::pair<const char*, const std::vector<uint8_t>*> files[] = {
      {"model.glb", &r.model_glb}, {"base.glb", &r.base_glb}, {"model.mmxp", &r.package}};
  std::vector<std::string> written;
  for (const auto& [name, bytes] : files) {
    if (bytes->empty()) continue;
    if (Status s = write_file_atomic(dir + "/" + name, *bytes); !s) return s;
    written.push_back(out + "/" + name + " (" + human_bytes(bytes->size()) + ")");
  }
  if (!r.report_json.empty()) {
    if (Status s = write_file_atomic(dir + "/report.json", r.report_json); !s) return s;
    if (Status s = write_file_atomic(dir + "/rd.svg", r.rd_svg); !s) return s;
    written.push_back(out + "/report.json and " + out + "/rd.svg");
  }
  if (!r.package.empty()) {
    if (Status s = write_viewer(dir); !s) return s;
    written.push_back(out + "/index.html and " + out + "/viewer/ (meshmux serve " + out + ")");
  }
  if (Status s = txn->commit(); !s) return s;
  for (const std::string& w : written) progress.step("wrote " + w);
  return Status::ok();
}

// Bytes of a model as served: the file itself plus, for a .gltf, the external buffers and
// images it references (data: URIs are inside the file already). COLLADA textures are not
// followed (the file size alone is reported).
uint64_t asset_bytes(const std::string& file, const ImportOptions& import) {
  std::error_code ec;
  uint64_t total = std::filesystem::file_size(file, ec);
  if (ec) return 0;
  if (!ends_with(file, ".gltf")) return total;
  auto text = read_whole_file(file, uint64_t(256) << 20);
  if (!text.ok()) return total;
  auto doc = nlohmann::json::parse(text->begin(), text->end(), nullptr, false);
  if (!doc.is_object()) return total;
  std::filesystem::path dir = std::filesystem::path(file).parent_path();
  auto scope = input_scope(file, import.allow_outside, import.root);
  if (!scope.ok()) return total;
  for (const char* key : {"buffers", "images"}) {
    if (!doc.contains(key) || !doc[key].is_array()) continue;
    for (const auto& item : doc[key]) {
      if (!item.is_object() || !item.contains("uri") || !item["uri"].is_string()) continue;
      std::string uri = item["uri"].get<std::string>();
      if (uri.rfind("data:", 0) == 0) continue;
      // Only files the importer may read: inside the folder, regular (an absolute path once
      // reported the size of a system password file).
      auto path = resolve_in_scope(*scope, (dir / uri).string());
      if (!path.ok() || !std::filesystem::is_regular_file(*path, ec)) continue;
      uint64_t n = std::filesystem::file_size(*path, ec);
      if (!ec) total += n;
    }
  }
  return total;
}

// The memory cap (RLIMIT_DATA: heap and private mappings) for converting `in`: --max-memory, or
// from the input's size, max(2 GiB, 64 × its bytes with external buffers and images). An
// allocation past it fails, and the top level reports it with the option that raises it.
// Not under sanitizers (their shadow memory is private mappings of terabytes).
uint64_t g_memory_limit_mb = 0;
void apply_memory_limit(const std::string& in, const ImportOptions& import, uint64_t max_memory_mb) {
#if MESHMUX_SANITIZED
  (void)in, (void)import, (void)max_memory_mb;
#else
  uint64_t mb = max_memory_mb;
  if (mb == 0) mb = std::max<uint64_t>(2048, 64 * asset_bytes(in, import) / 1000000);
  rlimit rl{};
  if (getrlimit(RLIMIT_DATA, &rl) != 0) return;
  rlim_t want = rlim_t(mb) << 20;
  if (rl.rlim_max != RLIM_INFINITY && want > rl.rlim_max) want = rl.rlim_max;
  rl.rlim_cur = want;
  if (setrlimit(RLIMIT_DATA, &rl) == 0) g_memory_limit_mb = mb;
#endif
}

int cmd_convert(const std::vector<std::string>& args) {
  ConvertOptions o;
  Args p("convert", args);
  while (p.next()) {
    const std::string& a = p.current();
    std::string v, err;
    // Whole-number flags: where the value goes and its range.
    struct IntFlag {
      const char* name;
      int* target;
      int lo, hi;
    };
    int crease = -1;
    const IntFlag flags[] = {{"--position-bits", &o.gltf.position_bits, 1, 30},
                             {"--normal-bits", &o.gltf.normal_bits, 1, 30},
                             {"--uv-bits", &o.gltf.uv_bits, 1, 30},
                             {"--jpeg-quality", &o.textures.jpeg_quality, 1, 100},
                             {"--crease", &crease, 0, 180}};
    const IntFlag* flag = nullptr;
    for (const IntFlag& f : flags)
      if (a == f.name) flag = &f;
    if (a == "--no-draco") {
      o.gltf.draco = false;
    } else if (a == "--no-atlas") {
      o.atlas = false;
    } else if (a == "--no-report") {
      o.report = false;
    } else if (flag) {
      if (!p.value(&v)) return usage_error(p.error);
      if (!parse_int(a, v, flag->lo, flag->hi, flag->target, &err))
        return usage_error("convert: " + err);
      if (crease >= 0) o.clean.crease_angle_degrees = float(crease);
    } else if (int r = p.common(); r <= 0) {
      return usage_error(r < 0 ? p.error : "convert: unknown option " + a);
    }
  }
  if (p.help) return std::fputs(kUsage, stdout), kExitOk;
  if (p.in.empty()) return usage_error("convert: no input file given");
  if (p.out.empty()) return usage_error("convert: no output given (-o OUT.glb or -o FOLDER)");
  o.stream = !ends_with(p.out, ".glb");
  if (Status s = refuse_overwriting_input(p.in, p.out, o.stream); !s) return fail(s);
  clean_stale_temporaries(p.out);
  auto upload = open_input(p, p.out);
  if (!upload.ok()) return fail(upload.status());
  apply_memory_limit(upload->model(), p.import, p.max_memory_mb);
  Warnings warnings;
  CliProgress progress(p.quiet, &warnings);
  progress.step("importing " + upload->display());
  auto scene = import_scene(upload->model(), p.import, &warnings);
  if (!scene.ok()) return progress.flush(), fail(scene.status());
  auto r = convert(*scene, o, &warnings, &progress);
  progress.flush();
  if (!r.ok()) return fail(r.status());
  if (Status s = write_outputs(p.out, o.stream, *r, progress); !s) return fail(s);
  progress.step("wrote " + p.out + " (" + std::to_string(r->output.scene_triangles) +
                " triangles, " + std::to_string(r->output.draw_calls) + " draw calls)");
  return kExitOk;
}

int cmd_info(const std::vector<std::string>& args) {
  bool json = false;
  Args p("info", args);
  while (p.next()) {
    int c = p.common();
    if (c < 0) return usage_error(p.error);
    if (c > 0) continue;
    if (p.current() == "--json")
      json = true;
    else
      return usage_error("info: unknown option " + p.current());
  }
  if (p.help) {
    std::fputs(kUsage, stdout);
    return kExitOk;
  }
  if (p.in.empty()) return usage_error("info: no file given");
  auto upload = open_input(p, "");
  if (!upload.ok()) return fail(upload.status());
  const std::string file = upload->model();
  apply_memory_limit(file, p.import, p.max_memory_mb);
  Warnings warnings;
  auto scene = import_scene(file, p.import, &warnings);
  if (!scene.ok()) return fail(scene.status());
  SceneStats s = compute_stats(*scene);
  uint64_t bytes = asset_bytes(file, p.import);
  Bounds b = scene_bounds(*scene);
  if (json) {
    nlohmann::ordered_json j;
    j["file"] = upload->display();
    j["meshes"] = s.meshes;
    j["primitives"] = s.primitives;
    j["instances"] = s.instances;
    j["scene_triangles"] = s.scene_triangles;
    j["unique_triangles"] = s.unique_triangles;
    j["vertices"] = s.vertices;
    j["materials"] = s.materials;
    j["textures"] = s.textures;
    j["texture_pixels"] = s.texture_pixels;
    j["draw_calls"] = s.draw_calls;
    j["bytes"] = bytes;
    if (!b.empty()) {
      j["bounds"] = {{"min", {b.min.x, b.min.y, b.min.z}}, {"max", {b.max.x, b.max.y, b.max.z}}};
    }
    j["warnings"] = warnings.items();
    std::printf("%s\n", j.dump(1).c_str());
  } else {
    for (const auto& w : warnings.items())
      std::fprintf(stderr, "meshmux: warning: %s\n", w.c_str());
    std::printf("file              %s\n", upload->display().c_str());
    std::printf("bytes             %llu (%s)\n", static_cast<unsigned long long>(bytes),
                human_bytes(bytes).c_str());
    std::printf("meshes            %zu (%zu primitives)\n", s.meshes, s.primitives);
    std::printf("instances         %zu\n", s.instances);
    std::printf("scene triangles   %llu\n", static_cast<unsigned long long>(s.scene_triangles));
    std::printf("unique triangles  %llu\n", static_cast<unsigned long long>(s.unique_triangles));
    std::printf("vertices          %llu\n", static_cast<unsigned long long>(s.vertices));
    std::printf("materials         %zu\n", s.materials);
    std::printf("textures          %zu (%.1f Mpx)\n", s.textures, double(s.texture_pixels) / 1e6);
    std::printf("draw calls        %llu\n", static_cast<unsigned long long>(s.draw_calls));
    if (!b.empty())
      std::printf("bounds            [%g %g %g] .. [%g %g %g]\n", b.min.x, b.min.y, b.min.z,
                  b.max.x, b.max.y, b.max.z);
  }
  return kExitOk;
}

int cmd_simplify(const std::vector<std::string>& args) {
  double ratio = -1, error = -1;
  long long triangles = -1;
  int targets = 0;
  GltfExportOptions gopts;
  Args p("simplify", args);
  while (p.next()) {
    const std::string& a = p.current();
    std::string v;
    char* end = nullptr;
    if (a == "--ratio") {
      if (!p.value(&v)) return usage_error(p.error);
      ratio = std::strtod(v.c_str(), &end);
      if (v.empty() || *end || !(ratio > 0 && ratio <= 1))
        return usage_error("simplify: --ratio expects a number in (0, 1], got '" + v + "'");
      ++targets;
    } else if (a == "--triangles") {
      if (!p.value(&v)) return usage_error(p.error);
      triangles = std::strtoll(v.c_str(), &end, 10);
      if (v.empty() || *end || triangles < 1)
        return usage_error("simplify: --triangles expects a whole number >= 1, got '" + v + "'");
      ++targets;
    } else if (a == "--error") {
      if (!p.value(&v)) return usage_error(p.error);
      error = std::strtod(v.c_str(), &end);
      if (v.empty() || *end || !(error >= 0))
        return usage_error("simplify: --error expects a number >= 0, got '" + v + "'");
      ++targets;
    } else if (int r = p.common(); r < 0) {
      return usage_error(p.error);
    } else if (r == 0) {
      return usage_error("simplify: unknown option " + a);
    }
  }
  if (p.help) {
    std::fputs(kUsage, stdout);
    return kExitOk;
  }
  const std::string &in = p.in, &out = p.out;
  bool quiet = p.quiet;
  if (in.empty()) return usage_error("simplify: no input file given");
  if (out.empty() || !ends_with(out, ".glb"))
    return usage_error("simplify: -o OUT.glb is required");
  if (targets != 1)
    return usage_error("simplify: give exactly one of --ratio, --triangles, --error");
  if (Status s = refuse_overwriting_input(in, out, false); !s) return fail(s);
  clean_stale_temporaries(out);
  auto upload = open_input(p, out);
  if (!upload.ok()) return fail(upload.status());
  apply_memory_limit(upload->model(), p.import, p.max_memory_mb);
  Warnings warnings;
  CliProgress progress(quiet, &warnings);
  progress.step("importing " + upload->display());
  auto scene = import_scene(upload->model(), p.import, &warnings);
  progress.flush();
  if (!scene.ok()) return fail(scene.status());
  Scene cleaned = clean(*scene, CleanOptions{});
  progress.step("simplifying");
  SimplifyReport sr;
  ProgressiveScene ps = build_progressive(cleaned, SimplifyOptions{}, &sr, &progress);
  LodSelection sel;
  if (error >= 0)
    sel = select_error(ps, float(error));
  else if (triangles >= 0)
    sel = select_triangles(ps, uint64_t(triangles));
  else
    sel = select_triangles(ps, uint64_t(std::floor(ratio * double(sr.input_triangles))));
  Scene level = materialize(ps, sel);
  SceneStats ls = compute_stats(level);
  progress.step("level: " + std::to_string(ls.scene_triangles) + " of " +
                std::to_string(sr.input_triangles) + " scene triangles, " +
                std::to_string(ls.unique_triangles) + " unique, " + std::to_string(ls.instances) +
                " instances" + (sr.flattened ? " (flattened)" : ""));
  auto bytes = export_glb_bytes(level, gopts, &warnings);
  progress.flush();
  if (!bytes.ok()) return fail(bytes.status());
  Status s = write_file_atomic(out, *bytes);
  if (!s) return fail(s);
  progress.step("wrote " + out + " (" + human_bytes(bytes->size()) + ")");
  return kExitOk;
}

int cmd_sample(const std::vector<std::string>& args) {
  Args p("sample", args);
  while (p.next()) {
    int r = p.common();
    if (r < 0) return usage_error(p.error);
    if (r == 0 || !p.in.empty()) return usage_error("sample: unexpected argument " + p.current());
  }
  if (p.help) {
    std::fputs(kUsage, stdout);
    return kExitOk;
  }
  const std::string& out = p.out;
  bool quiet = p.quiet;
  if (out.empty()) return usage_error("sample: no output given (-o FILE.glb)");
  if (!ends_with(out, ".glb")) return usage_error("sample: output must end in .glb");
  Warnings warnings;
  Scene scene = make_sample_scene();
  GltfExportOptions gopts;
  gopts.draco = false;  // the sample is an input: keep it exact and readable by anything
  auto bytes = export_glb_bytes(scene, gopts, &warnings);
  if (!bytes.ok()) return fail(bytes.status());
  Status s = write_file_atomic(out, *bytes);
  if (!s) return fail(s);
  if (!quiet) {
    SceneStats st = compute_stats(scene);
    std::fprintf(stderr, "meshmux: wrote %s (%zu meshes, %zu instances, %llu triangles, %s)\n",
                 out.c_str(), st.meshes, st.instances,
                 static_cast<unsigned long long>(st.scene_triangles),
                 human_bytes(bytes->size()).c_str());
  }
  return kExitOk;
}

}  // namespace
}  // namespace meshmux

int meshmux_main(int argc, char** argv) {
  using namespace meshmux;
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.empty()) {
    std::fputs(kUsage, stderr);
    return kExitUsage;
  }
  std::string cmd = args[0];
  std::vector<std::string> rest(args.begin() + 1, args.end());
  try {
    if (cmd == "-h" || cmd == "--help" || cmd == "help") {
      std::fputs(kUsage, stdout);
      return kExitOk;
    }
    if (cmd == "--version" || cmd == "version") {
      std::printf("meshmux %s\n", MESHMUX_VERSION);
      return kExitOk;
    }
    if (cmd == "convert") return cmd_convert(rest);
    if (cmd == "info") return cmd_info(rest);
    if (cmd == "batch") return cmd_batch(rest);
    if (cmd == "sample") return cmd_sample(rest);
    if (cmd == "simplify") return cmd_simplify(rest);
    if (cmd == "serve") return cmd_serve(rest);
    if (cmd == "render") return cmd_render(rest);
    return usage_error("unknown command '" + cmd + "'");
  } catch (const std::bad_alloc&) {
    if (g_memory_limit_mb > 0) {
      std::fprintf(stderr,
                   "meshmux: out of memory: the run needs more than the memory limit of %llu "
                   "MB (set from the input's size, or by --max-memory, which raises it)\n",
                   static_cast<unsigned long long>(g_memory_limit_mb));
      return kExitInput;
    }
    std::fprintf(stderr, "meshmux: out of memory\n");
    return kExitInternal;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "meshmux: internal error: %s\n", e.what());
    return kExitInternal;
  }
}
