// A command's input: the upload opened (a folder, a .zip unpacked beside the output, or a lone
// model file), the bytes it serves, and the process's memory cap set from them.
#pragma once

#include <cstdint>
#include <string>

#include "core/status.h"
#include "importers/import.h"
#include "importers/upload.h"

namespace meshmux {

// Opens `in` as an upload (importers/upload.h): a folder or a .zip, whose model file is found
// inside (an archive unpacked beside `out`, as "<OUT>.meshmux-upload-<pid>", removed when the
// Upload goes; or in TMPDIR when `out` is empty), or a lone model file. Sets import->root to
// the upload's folder, which bounds every read. Errors: open_upload's.
Result<Upload> open_input(const std::string& in, const UploadOptions& options,
                          const std::string& out, ImportOptions* import);

// The input of a command that writes `out` (a folder when `folder_output`, else one file): refuses
// an output that is, holds or is held by the input (core/output_transaction.h), removes the
// temporaries a killed earlier run left beside `out`, opens the upload (open_input) and caps the
// process's memory for it (apply_memory_limit). Errors: those of the three.
Result<Upload> open_command_input(const std::string& in, const std::string& out, bool folder_output,
                                  const UploadOptions& options, ImportOptions* import,
                                  uint64_t max_memory_mb);

// Bytes of a model as served: the file itself plus, for a .gltf, the external buffers and
// images it references inside the upload (COLLADA: the file alone). 0 when it is unreadable.
uint64_t asset_bytes(const std::string& file, const ImportOptions& import);

// Caps the process's heap and private memory (RLIMIT_DATA) for reading `in`: `max_memory_mb`,
// or 0 for max(2 GiB, 64 × asset_bytes). Not under sanitizers. An allocation past the cap
// throws std::bad_alloc; memory_limit_mb() then says which cap it was, for the one line.
void apply_memory_limit(const std::string& in, const ImportOptions& import, uint64_t max_memory_mb);
uint64_t memory_limit_mb();  // the cap set, MB; 0 when none

}  // namespace meshmux
