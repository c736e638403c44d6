#include "pipeline/inputs.h"

#include <strings.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/file_io.h"
#include "core/output_transaction.h"
#include "core/sanitizers.h"

namespace meshmux {

namespace {
uint64_t g_memory_limit_mb = 0;
}  // namespace

// Opens the input as an upload (importers/upload.h): a folder or a .zip, whose model file is
// found inside (an archive unpacked beside `out`, as "<OUT>.meshmux-upload-<pid>", removed when
// the Upload goes; or in TMPDIR when there is no output), or a lone model file. Sets
// `import->root` to the upload's folder, which bounds every read.
Result<Upload> open_input(const std::string& in, const UploadOptions& options,
                          const std::string& out, ImportOptions* import) {
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
  auto up = open_upload(in, options, scratch);
  if (up.ok()) import->root = up->root();
  return up;
}

// Bytes of a model as served: the file itself plus, for a .gltf, the external buffers and
// images it references (data: URIs are inside the file already). COLLADA textures are not
// followed (the file size alone is reported).
uint64_t asset_bytes(const std::string& file, const ImportOptions& import) {
  std::error_code ec;
  uint64_t total = std::filesystem::file_size(file, ec);
  if (ec) return 0;
  if (file.size() < 5 || strcasecmp(file.c_str() + file.size() - 5, ".gltf") != 0) return total;
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
void apply_memory_limit(const std::string& in, const ImportOptions& import,
                        uint64_t max_memory_mb) {
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

uint64_t memory_limit_mb() { return g_memory_limit_mb; }

Result<Upload> open_command_input(const std::string& in, const std::string& out, bool folder_output,
                                  const UploadOptions& options, ImportOptions* import,
                                  uint64_t max_memory_mb) {
  if (Status s = refuse_overwriting_input(in, out, folder_output); !s) return s;
  clean_stale_temporaries(out);
  auto upload = open_input(in, options, out, import);
  if (upload.ok()) apply_memory_limit(upload->model(), *import, max_memory_mb);
  return upload;
}

}  // namespace meshmux
