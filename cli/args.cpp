#include "cli/args.h"

#include <strings.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "core/exit_codes.h"

namespace meshmux {

namespace {

constexpr unsigned kUploads = kConvert | kInfo | kSimplify;  // take an upload as input
constexpr unsigned kAll = kConvert | kBatch | kServe | kRender | kSimplify | kInfo | kSample;

Flag switch_flag(const char* name, unsigned commands, bool to_convert = false) {
  return {name, nullptr, commands, FlagValue::kSwitch, 0, 0, false, false, to_convert};
}
Flag text_flag(const char* name, unsigned commands, const char* alias = nullptr) {
  return {name, alias, commands, FlagValue::kText};
}
Flag whole_flag(const char* name, unsigned commands, double lo, double hi, bool to_convert = false,
                const char* alias = nullptr) {
  return {name, alias, commands, FlagValue::kWhole, lo, hi, false, false, to_convert};
}
Flag number_flag(const char* name, unsigned commands, double lo, double hi, bool open_lo,
                 bool open_hi) {
  return {name, nullptr, commands, FlagValue::kNumber, lo, hi, open_lo, open_hi, false};
}

const std::vector<Flag> kFlags = [] {
  const double kHuge = 18446744073709551615.0;  // UINT64_MAX: the limit flags' own ceiling
  std::vector<Flag> f = {
      // Shared.
      text_flag("--output", kAll & ~(kServe | kInfo), "-o"),
      {"--quiet", "-q", kAll, FlagValue::kSwitch},
      // Uploads (importers/upload.h) and resource limits; batch hands some on.
      text_flag("--main", kUploads),
      text_flag("--root", kUploads),
      switch_flag("--allow-outside", kUploads | kBatch, true),
      whole_flag("--max-texels", kUploads | kBatch, 1, kHuge, true),
      whole_flag("--max-instances", kUploads | kBatch, 1, kHuge, true),
      whole_flag("--max-elements", kUploads | kBatch, 1, kHuge, true),
      whole_flag("--max-memory", kUploads, 1, kHuge),
      // convert (batch hands every one on).
      whole_flag("--position-bits", kConvert | kBatch, 1, 30, true),
      whole_flag("--normal-bits", kConvert | kBatch, 1, 30, true),
      whole_flag("--uv-bits", kConvert | kBatch, 1, 30, true),
      whole_flag("--jpeg-quality", kConvert | kBatch, 1, 100, true),
      whole_flag("--crease", kConvert | kBatch, 0, 180, true),
      {"--max-package-ratio", nullptr, kConvert | kBatch, FlagValue::kNumber, 0, 100, false, false,
       true},
      whole_flag("--blocks-above", kConvert | kBatch, 0, kHuge, true),
      switch_flag("--no-draco", kConvert | kBatch, true),
      switch_flag("--no-atlas", kConvert | kBatch, true),
      switch_flag("--no-report", kConvert | kBatch, true),
      {"--display", nullptr, kConvert | kBatch, FlagValue::kText, 0, 0, false, false, true},
      {"--textures", nullptr, kConvert, FlagValue::kText, 0, 0, false, false, false},
      // info.
      switch_flag("--json", kInfo),
      // simplify: exactly one target.
      number_flag("--ratio", kSimplify, 0, 1, true, false),
      whole_flag("--triangles", kSimplify, 1, 9.2e18),
      number_flag("--error", kSimplify, 0, HUGE_VAL, false, false),
      // batch.
      whole_flag("--jobs", kBatch, 1, 1024, false, "-j"),
      whole_flag("--timeout", kBatch, 1, 7 * 86400),
      whole_flag("--max-memory", kBatch, 64, double(1L << 30)),
      switch_flag("--retry-failed", kBatch),
      switch_flag("--slurm", kBatch),
      text_flag("--partition", kBatch),
      text_flag("--layout", kBatch),
      whole_flag("--tasks", kBatch, 1, 100000),
      whole_flag("--throttle", kBatch, 1, 100000),
      whole_flag("--cpus-per-task", kBatch, 1, 1024),
      switch_flag("--wait", kBatch),
      // batch's own re-entry inside a Slurm job (batch/slurm.h): not in --help.
      text_flag("--slurm-task", kBatch),
      text_flag("--slurm-summary", kBatch),
      text_flag("--array-job", kBatch),
      // serve.
      whole_flag("--port", kServe, 0, 65535),
      text_flag("--host", kServe),
      switch_flag("--cors", kServe),
      // render (the command checks the shapes of --size, --eye, --target, --up, --shading).
      text_flag("--size", kRender),
      text_flag("--eye", kRender),
      text_flag("--target", kRender),
      text_flag("--up", kRender),
      text_flag("--shading", kRender),
      number_flag("--fov", kRender, 0, 180, true, true),
      number_flag("--near", kRender, 0, HUGE_VAL, true, false),
      number_flag("--far", kRender, 0, HUGE_VAL, true, false),
  };
  return f;
}();

const Flag* find_flag(Command command, const std::string& arg) {
  for (const Flag& f : kFlags)
    if ((f.commands & command) && (arg == f.name || (f.alias && arg == f.alias))) return &f;
  return nullptr;
}

std::string number_text(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.15g", v);
  return buf;
}

// The value's check: an empty string when it is fine, else what the flag expects.
std::string check_value(const Flag& f, const std::string& v) {
  if (f.value == FlagValue::kText) return v.empty() ? "a non-empty value" : "";
  char* end = nullptr;
  errno = 0;
  if (f.value == FlagValue::kWhole) {
    std::string expects = "a whole number from " + number_text(f.lo) + " to " + number_text(f.hi);
    if (f.hi >= 1e18) expects = "a positive whole number";
    if (v.empty() || (v[0] == '-' && f.lo >= 0)) return expects;
    const long double n = std::strtold(v.c_str(), &end);
    for (char c : v.substr(v[0] == '-' ? 1 : 0))
      if (c < '0' || c > '9') return expects;
    if (*end != '\0' || errno != 0 || n < f.lo || n > f.hi) return expects;
    return "";
  }
  std::string expects = "a number " + std::string(f.open_lo ? "> " : ">= ") + number_text(f.lo);
  if (std::isfinite(f.hi))
    expects = "a number in " + std::string(f.open_lo ? "(" : "[") + number_text(f.lo) + ", " +
              number_text(f.hi) + (f.open_hi ? ")" : "]");
  const double d = std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0' || !std::isfinite(d)) return expects;
  if (f.open_lo ? !(d > f.lo) : !(d >= f.lo)) return expects;
  if (f.open_hi ? !(d < f.hi) : !(d <= f.hi)) return expects;
  return "";
}

Status usage(const std::string& message) { return Status::error(message, ErrorKind::kInput); }

}  // namespace

const char* command_name(Command c) {
  switch (c) {
    case kConvert:
      return "convert";
    case kBatch:
      return "batch";
    case kServe:
      return "serve";
    case kRender:
      return "render";
    case kSimplify:
      return "simplify";
    case kInfo:
      return "info";
    case kSample:
      return "sample";
  }
  return "meshmux";
}

const std::vector<Flag>& flag_table() { return kFlags; }

bool ParsedArgs::has(const char* name) const {
  for (const auto& [flag, value] : given)
    if (std::string(flag->name) == name) return true;
  return false;
}

std::string ParsedArgs::text(const char* name, const std::string& fallback) const {
  std::string out = fallback;
  for (const auto& [flag, value] : given)
    if (std::string(flag->name) == name) out = value;
  return out;
}

long long ParsedArgs::whole(const char* name, long long fallback) const {
  return has(name) ? std::strtoll(text(name).c_str(), nullptr, 10) : fallback;
}

double ParsedArgs::number(const char* name, double fallback) const {
  return has(name) ? std::strtod(text(name).c_str(), nullptr) : fallback;
}

std::vector<std::string> ParsedArgs::convert_args() const {
  std::vector<std::string> out;
  for (const auto& [flag, value] : given) {
    if (!flag->to_convert) continue;
    out.push_back(flag->name);
    if (flag->value != FlagValue::kSwitch) out.push_back(value);
  }
  return out;
}

Result<ParsedArgs> parse_args(Command command, const std::vector<std::string>& args,
                              size_t max_positional) {
  ParsedArgs p;
  // Help wins over any mistake beside it: a user asking for it gets it.
  for (const std::string& a : args)
    if (a == "-h" || a == "--help") {
      p.help = true;
      return p;
    }
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (const Flag* f = find_flag(command, a)) {
      std::string v;
      if (f->value != FlagValue::kSwitch) {
        if (i + 1 >= args.size()) return usage(a + " needs a value");
        v = args[++i];
        if (std::string expects = check_value(*f, v); !expects.empty())
          return usage(a + " expects " + expects + ", got '" + v + "'");
      }
      p.given.emplace_back(f, v);
      continue;
    }
    if (!a.empty() && a[0] == '-') return usage("unknown option " + a);
    if (p.positional.size() >= max_positional) {
      if (max_positional == 0) return usage("unexpected argument " + a);
      return usage("more than one input given ('" + p.positional.back() + "' and '" + a + "')");
    }
    p.positional.push_back(a);
  }
  return p;
}

int usage_error(Command command, const std::string& message) {
  std::fprintf(stderr, "meshmux: %s: %s\n(see meshmux %s --help)\n", command_name(command),
               message.c_str(), command_name(command));
  return kExitUsage;
}

UploadFlags upload_flags(const ParsedArgs& p) {
  UploadFlags u;
  u.upload.main = p.text("--main");
  u.upload.root = p.text("--root");
  u.import.allow_outside = p.has("--allow-outside");
  const auto limit = [&p](const char* name, uint64_t fallback) {
    return p.has(name) ? uint64_t(std::strtoull(p.text(name).c_str(), nullptr, 10)) : fallback;
  };
  u.import.max_texels = limit("--max-texels", u.import.max_texels);
  u.import.max_instances = limit("--max-instances", u.import.max_instances);
  u.import.max_elements = limit("--max-elements", u.import.max_elements);
  u.max_memory_mb = limit("--max-memory", 0);
  return u;
}

bool has_extension(const std::string& path, const char* extension) {
  const size_t n = std::strlen(extension);
  return path.size() >= n && strcasecmp(path.c_str() + path.size() - n, extension) == 0;
}

std::string convert_flags_text() {
  std::string out;
  for (const Flag& f : kFlags) {
    if (!f.to_convert) continue;
    out += out.empty() ? "" : " ";
    out += f.name;
    if (f.value == FlagValue::kText)
      out += " WxH";  // --display, the one text flag handed on
    else if (f.value != FlagValue::kSwitch)
      out += " N";
  }
  return out;
}

bool parse_size(const std::string& text, int* w, int* h) {
  const size_t x = text.find('x');
  if (x == std::string::npos || x == 0 || x + 1 >= text.size()) return false;
  auto whole = [](const std::string& t, int* out) {
    char* end = nullptr;
    errno = 0;
    const long v = std::strtol(t.c_str(), &end, 10);
    if (errno != 0 || end != t.c_str() + t.size() || !std::isdigit(uint8_t(t[0])) || v < 1 ||
        v > 8192)
      return false;
    *out = int(v);
    return true;
  };
  return whole(text.substr(0, x), w) && whole(text.substr(x + 1), h);
}

}  // namespace meshmux
