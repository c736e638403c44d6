// The inputs, names, fingerprints and records of meshmux batch (see batch/plan.h).
#include "batch/plan.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "core/file_io.h"
#include "core/text.h"

namespace meshmux {

namespace fs = std::filesystem;

namespace {

std::string lower(std::string s) {
  for (char& c : s) c = char(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool is_model_file(const fs::path& p) {
  const std::string ext = lower(p.extension().string());
  return ext == ".gltf" || ext == ".glb" || ext == ".dae";
}

// A path made absolute and lexically normal, without resolving links (the name a user knows).
std::string absolute_path(const std::string& path) {
  std::error_code ec;
  fs::path p = fs::absolute(path, ec);
  if (ec) p = path;
  return p.lexically_normal().string();
}

// Restricts a name to ASCII letters, digits, '-' and '_'. No '.': a name never ends in
// ".glb" (convert would write one file), never looks like a temporary ("<name>.tmp-<pid>",
// "<name>.meshmux-tmp-<pid>", which a run removes) and is never hidden.
std::string clean_name(const std::string& s) {
  std::string out;
  for (char c : s) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                    c == '-' || c == '_';
    out += ok ? c : '_';
  }
  return out.empty() ? "model" : out;
}

// A .glb's JSON chunk (the first chunk, type "JSON"), or "" when there is none.
std::string glb_json(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char h[20];
  if (!in.read(reinterpret_cast<char*>(h), 20)) return "";
  auto u32 = [&](int at) {
    return uint32_t(h[at]) | uint32_t(h[at + 1]) << 8 | uint32_t(h[at + 2]) << 16 |
           uint32_t(h[at + 3]) << 24;
  };
  if (u32(0) != 0x46546C67u || u32(16) != 0x4E4F534Au) return "";  // "glTF", "JSON"
  const uint32_t n = u32(12);
  if (n > (64u << 20)) return "";
  std::string json(n, '\0');
  if (!in.read(json.data(), std::streamsize(n))) return "";
  return json;
}

// FNV-1a, 64 bits, continued over several files.
struct Fnv {
  uint64_t h = 0xcbf29ce484222325ull;
  void add(const void* data, size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 0x100000001b3ull;
  }
  void add(const std::string& s) { add(s.data(), s.size() + 1); }
};

// Adds a file's bytes (1 MiB at a time) to the hash; returns its size, or -1 when unreadable.
int64_t hash_file(const std::string& path, Fnv* h) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return -1;
  std::ifstream in(path, std::ios::binary);
  if (!in) return -1;
  std::vector<char> buf(1 << 20);
  int64_t total = 0;
  while (in) {
    in.read(buf.data(), std::streamsize(buf.size()));
    const auto n = in.gcount();
    if (n <= 0) break;
    h->add(buf.data(), size_t(n));
    total += n;
  }
  return total;
}

// The external files a model names: a .gltf's buffer and image URIs, a .dae's <init_from>
// texts (image paths), relative to the model's folder; data: URIs are inside the file.
std::vector<std::string> referenced_files(const std::string& model) {
  std::vector<std::string> refs;
  const std::string ext = lower(fs::path(model).extension().string());
  if (ext != ".gltf" && ext != ".dae" && ext != ".glb") return refs;
  std::string text;
  if (ext == ".glb") {
    text = glb_json(model);
  } else {
    auto bytes = read_whole_file(model, uint64_t(256) << 20);
    if (!bytes.ok()) return refs;
    text.assign(bytes->begin(), bytes->end());
  }
  const fs::path dir = fs::path(model).parent_path();
  auto add = [&](std::string uri) {
    if (uri.empty() || uri.rfind("data:", 0) == 0) return;
    uri = percent_decode(uri);
    if (uri.rfind("file://", 0) == 0) uri = uri.substr(7);
    fs::path p = fs::path(uri).is_absolute() ? fs::path(uri) : dir / uri;
    refs.push_back(p.lexically_normal().string());
  };
  if (ext != ".dae") {
    auto doc = nlohmann::json::parse(text.begin(), text.end(), nullptr, false);
    if (!doc.is_object()) return refs;
    for (const char* key : {"buffers", "images"}) {
      if (!doc.contains(key) || !doc[key].is_array()) continue;
      for (const auto& item : doc[key])
        if (item.is_object() && item.contains("uri") && item["uri"].is_string())
          add(item["uri"].get<std::string>());
    }
  } else {
    const std::string& s = text;
    const std::string open = "<init_from>", close = "</init_from>";
    for (size_t at = 0; (at = s.find(open, at)) != std::string::npos;) {
      at += open.size();
      const size_t end = s.find(close, at);
      if (end == std::string::npos || end - at > 4096) break;
      std::string v = s.substr(at, end - at);
      v.erase(0, v.find_first_not_of(" \t\r\n"));
      v.erase(v.find_last_not_of(" \t\r\n") + 1);
      // Only names that look like image files: COLLADA 1.5 also puts image ids there.
      const std::string e = lower(fs::path(v).extension().string());
      if (e == ".png" || e == ".jpg" || e == ".jpeg" || e == ".tga" || e == ".bmp" ||
          e == ".webp" || e == ".gif" || e == ".dds" || e == ".tif" || e == ".tiff")
        add(v);
      at = end;
    }
  }
  std::sort(refs.begin(), refs.end());
  refs.erase(std::unique(refs.begin(), refs.end()), refs.end());
  return refs;
}

}  // namespace

Result<std::vector<std::string>> read_batch_inputs(const std::string& list,
                                                   const std::string& skip) {
  std::error_code ec;
  std::vector<std::string> inputs;
  if (fs::is_directory(list, ec)) {
    // Each top-level entry is one upload: a folder (its model file is found inside), a .zip,
    // or a lone model file. Other files (notes, licences) are not inputs.
    const fs::path skip_path = skip.empty() ? fs::path() : fs::weakly_canonical(skip, ec);
    fs::directory_iterator it(list, fs::directory_options::skip_permission_denied, ec);
    if (ec)
      return Status::error("batch: " + list + ": cannot read the folder: " + ec.message(),
                           ErrorKind::kInput);
    for (; it != fs::directory_iterator(); it.increment(ec)) {
      if (ec)
        return Status::error("batch: " + list + ": cannot list the folder: " + ec.message(),
                             ErrorKind::kInput);
      const fs::path& p = it->path();
      const std::string leaf = p.filename().string();
      std::error_code e2;
      if (leaf.empty() || leaf[0] == '.' || leaf == "__MACOSX") continue;
      if (it->is_directory(e2)) {
        if (it->is_symlink(e2)) continue;  // links to folders are not followed
        if (!skip_path.empty() && fs::weakly_canonical(p, e2) == skip_path) continue;
        inputs.push_back(absolute_path(p.string()));
      } else if (it->is_regular_file(e2) &&
                 (is_model_file(p) || lower(p.extension().string()) == ".zip")) {
        inputs.push_back(absolute_path(p.string()));
      }
    }
    std::sort(inputs.begin(), inputs.end());
    return inputs;
  }
  auto text = read_whole_file(list, uint64_t(64) << 20);
  if (!text.ok()) return text.status().with_prefix("batch");
  std::istringstream lines(std::string(text->begin(), text->end()));
  std::string line;
  std::set<std::string> seen;
  while (std::getline(lines, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    line.erase(line.find_last_not_of(" \t") + 1);
    if (line.find('\0') != std::string::npos)
      return Status::error("batch: " + list + ": not a text list of paths (a NUL byte)",
                           ErrorKind::kInput);
    std::string path = absolute_path(line.substr(first));
    if (seen.insert(path).second) inputs.push_back(path);
  }
  return inputs;
}

std::vector<std::string> batch_names(const std::vector<std::string>& inputs) {
  const size_t n = inputs.size();
  std::vector<std::vector<std::string>> parents(n);  // nearest folder first
  std::vector<std::string> stems(n), exts(n), names(n);
  for (size_t i = 0; i < n; ++i) {
    fs::path p(inputs[i]);
    std::error_code ec;
    const bool folder = fs::is_directory(p, ec);  // a folder upload: its whole name
    stems[i] = clean_name(folder ? p.filename().string() : p.stem().string());
    exts[i] = folder ? "folder"
                     : clean_name(lower(p.extension().string())
                                      .substr(std::min<size_t>(1, p.extension().string().size())));
    for (fs::path d = p.parent_path(); d.has_filename(); d = d.parent_path())
      parents[i].push_back(clean_name(d.filename().string()));
  }
  // depth[i]: how many folders are prefixed; with_ext[i]: the extension appended.
  std::vector<size_t> depth(n, 0);
  std::vector<bool> with_ext(n, false);
  auto make = [&](size_t i) {
    std::string s;
    for (size_t k = std::min(depth[i], parents[i].size()); k-- > 0;) s += parents[i][k] + "_";
    s += stems[i];
    if (with_ext[i]) s += "-" + exts[i];  // never ".glb": convert would write one file
    return s;
  };
  // OUTROOT's own files, and viewer/ (world.html's library).
  const std::set<std::string> reserved = {"index.html", "batch.json", "index.html.gz",
                                          "index.html.br", "viewer"};
  for (int round = 0; round < 64; ++round) {
    std::map<std::string, std::vector<size_t>> groups;
    for (size_t i = 0; i < n; ++i) groups[lower(make(i))].push_back(i);
    bool changed = false;
    for (auto& [key, members] : groups) {
      if (members.size() < 2) continue;
      // Files of one name but different extensions (model.glb, model.gltf): the extension
      // tells them apart; otherwise the folders above do.
      std::set<std::string> distinct;
      for (size_t i : members) distinct.insert(exts[i]);
      const bool by_ext = distinct.size() == members.size();
      for (size_t i : members) {
        if (!by_ext && depth[i] < parents[i].size()) {
          ++depth[i];
          changed = true;
        } else if (!with_ext[i]) {
          with_ext[i] = true;
          changed = true;
        }
      }
    }
    if (!changed) break;
  }
  std::set<std::string> used;
  for (size_t i = 0; i < n; ++i) {
    std::string base = make(i);
    if (reserved.count(lower(base))) base += "-model";
    std::string name = base;
    for (int k = 2; used.count(lower(name)); ++k) name = base + "-" + std::to_string(k);
    used.insert(lower(name));
    names[i] = name;
  }
  return names;
}

// A folder upload's fingerprint: every regular file below it (hidden entries skipped), by
// relative path in sorted order; -1 when it cannot be listed.
int64_t hash_folder(const std::string& root, Fnv* h) {
  std::vector<std::string> files;
  std::error_code ec;
  fs::recursive_directory_iterator it(root, fs::directory_options::skip_permission_denied, ec);
  if (ec) return -1;
  for (; !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    const std::string leaf = it->path().filename().string();
    std::error_code e2;
    if (!leaf.empty() && leaf[0] == '.') {
      if (it->is_directory(e2)) it.disable_recursion_pending();
      continue;
    }
    if (it->is_regular_file(e2) && !it->is_symlink(e2)) files.push_back(it->path().string());
    if (files.size() > 200000) break;  // the conversion refuses such a folder anyway
  }
  std::sort(files.begin(), files.end());
  int64_t total = 0;
  for (const std::string& f : files) {
    h->add(fs::path(f).lexically_relative(root).string());
    const int64_t n = hash_file(f, h);
    if (n > 0) total += n;
  }
  return total;
}

void fingerprint_input(BatchItem* item) {
  Fnv h;
  h.add("meshmux-batch-input-1");
  std::error_code ec;
  if (fs::is_directory(item->input, ec)) {
    h.add("folder");
    const int64_t n = hash_folder(item->input, &h);
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h.h));
    item->hash = n < 0 ? "" : hex;
    item->bytes_in = n < 0 ? 0 : uint64_t(n);
    return;
  }
  const int64_t main = hash_file(item->input, &h);
  if (main < 0) {
    item->hash = "";
    item->bytes_in = 0;
    return;
  }
  uint64_t total = uint64_t(main);
  for (const std::string& ref : referenced_files(item->input)) {
    h.add(fs::path(ref).lexically_relative(fs::path(item->input).parent_path()).string());
    const int64_t n = hash_file(ref, &h);
    if (n < 0)
      h.add("missing");
    else
      total += uint64_t(n);
  }
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h.h));
  item->hash = hex;
  item->bytes_in = total;
}

std::string record_path(const std::string& state_dir, const std::string& name) {
  return state_dir + "/records/" + name + ".json";
}

Status write_record(const std::string& state_dir, const BatchRecord& r) {
  nlohmann::ordered_json j;
  j["input"] = r.input;
  j["name"] = r.name;
  j["hash"] = r.hash;
  j["options"] = r.options;
  j["status"] = r.status;
  j["error"] = r.error;
  j["cause"] = r.cause;
  j["exit_code"] = r.exit_code;
  j["warnings"] = r.warnings;
  j["first_warning"] = r.first_warning;
  j["seconds"] = r.seconds;
  j["bytes_in"] = r.bytes_in;
  j["glb_bytes"] = r.glb_bytes;
  j["stream_bytes"] = r.stream_bytes;
  j["viewer"] = r.viewer;
  j["worker"] = r.worker;
  std::error_code ec;
  fs::create_directories(state_dir + "/records", ec);
  return write_file_atomic(record_path(state_dir, r.name),
                           j.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
}

std::optional<BatchRecord> read_record(const std::string& state_dir, const std::string& name) {
  auto text = read_whole_file(record_path(state_dir, name), uint64_t(1) << 20);
  if (!text.ok()) return std::nullopt;
  auto j = nlohmann::json::parse(text->begin(), text->end(), nullptr, false);
  if (!j.is_object()) return std::nullopt;
  BatchRecord r;
  try {
    r.input = j.at("input").get<std::string>();
    r.name = j.at("name").get<std::string>();
    r.hash = j.at("hash").get<std::string>();
    r.options = j.at("options").get<std::string>();
    r.status = j.at("status").get<std::string>();
    r.error = j.at("error").get<std::string>();
    r.cause = j.at("cause").get<std::string>();
    r.exit_code = j.at("exit_code").get<int>();
    r.warnings = j.at("warnings").get<int>();
    r.first_warning = j.at("first_warning").get<std::string>();
    r.seconds = j.at("seconds").get<double>();
    r.bytes_in = j.at("bytes_in").get<uint64_t>();
    r.glb_bytes = j.at("glb_bytes").get<uint64_t>();
    r.stream_bytes = j.at("stream_bytes").get<uint64_t>();
    r.viewer = j.at("viewer").get<bool>();
    r.worker = j.at("worker").get<std::string>();
  } catch (const nlohmann::json::exception&) {
    return std::nullopt;  // a record of another version: convert again
  }
  return r;
}

bool record_is_final(const BatchRecord& r, const BatchItem& item, const std::string& options,
                     const std::string& outroot, bool retry_failed) {
  if (r.input != item.input || r.hash != item.hash || r.options != options || item.hash.empty())
    return false;
  if (r.status == "ok") {
    std::error_code ec;
    return fs::is_regular_file(outroot + "/" + r.name + "/model.glb", ec);
  }
  return r.status == "failed" && r.cause == "input" && !retry_failed;
}

}  // namespace meshmux
