// Whole-file reads and all-or-nothing writes. Every output of meshmux goes through
// write_file_atomic: the bytes go to "<path>.tmp-<pid>" first and are renamed onto `path` only
// when completely written, so a failure never leaves a partial file behind.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/status.h"

namespace meshmux {

// Reads a whole regular file. Errors (kInput) name the file: "scene.glb: no such file",
// "scene.glb: is a directory", "scene.glb: not a regular file" (a FIFO, device or socket is
// never read, so nothing blocks or streams forever), "scene.glb: cannot read: <reason>".
// Files larger than `max_bytes` are refused.
Result<std::vector<uint8_t>> read_whole_file(const std::string& path,
                                             uint64_t max_bytes = uint64_t(4) << 30);

// The folder a model's referenced files (buffers, images) may be read from: the upload's.
struct InputScope {
  std::string root;            // the upload's folder, resolved (no links, no "..")
  bool allow_outside = false;  // trusted local use: any readable regular file
};

// The scope of a model file: `root` (an upload's folder, see importers/upload.h) when given,
// else the file's folder; resolved. Errors (kInput) name the file.
Result<InputScope> input_scope(const std::string& model_path, bool allow_outside,
                               const std::string& root = "");

// `path` (absolute, or relative to the working directory) with links and ".." resolved,
// when it lies inside `scope.root` (or anywhere, with allow_outside). Errors (kInput):
// "<path>: no such file", "<path>: outside the upload's folder <root> ...; refused".
// Read the result with read_whole_file, which refuses anything but a regular file.
Result<std::string> resolve_in_scope(const InputScope& scope, const std::string& path);

// Writes bytes to a temporary name beside `path`, flushes, then renames onto `path`.
// Errors are kOutput and name the file. On failure the temporary is removed.
Status write_file_atomic(const std::string& path, const void* data, size_t size);
inline Status write_file_atomic(const std::string& path, const std::vector<uint8_t>& bytes) {
  return write_file_atomic(path, bytes.data(), bytes.size());
}
inline Status write_file_atomic(const std::string& path, const std::string& text) {
  return write_file_atomic(path, text.data(), text.size());
}

// The file name without folders, for messages ("models/duck.dae" → "duck.dae").
std::string base_name(const std::string& path);

}  // namespace meshmux
