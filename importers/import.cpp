#include "importers/import.h"

#include <algorithm>
#include <cstring>

#include "importers/collada.h"
#include "importers/gltf.h"
#include "core/file_io.h"

namespace meshmux {

Result<Scene> import_scene(const std::string& path, const ImportOptions& options,
                           Warnings* warnings) {
  std::string ext;
  size_t dot = path.find_last_of('.');
  if (dot != std::string::npos && path.find('/', dot) == std::string::npos)
    ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  if (ext == "gltf" || ext == "glb") return import_gltf(path, options, warnings);
  if (ext == "dae" || ext == "xml") return import_collada(path, options, warnings);
  // Unknown extension: look at the first bytes (read as a regular file only: a FIFO or a
  // device named as the input must not block or stream forever).
  auto bytes = read_whole_file(path, options.max_file_bytes);
  if (!bytes.ok()) return Status::error("import: " + bytes.status().message(), ErrorKind::kInput);
  std::string h(bytes->begin(), bytes->begin() + long(std::min<size_t>(512, bytes->size())));
  if (h.empty())
    return Status::error("import: " + base_name(path) + ": file is empty", ErrorKind::kInput);
  if (h.compare(0, 4, "glTF") == 0 || h.find("\"asset\"") != std::string::npos)
    return import_gltf(path, options, warnings);
  if (h.find("<COLLADA") != std::string::npos) return import_collada(path, options, warnings);
  return Status::error(
      "import: " + base_name(path) + ": unknown format (expected .gltf, .glb or .dae)",
      ErrorKind::kInput);
}

}  // namespace meshmux
