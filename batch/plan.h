// What `meshmux batch` works on: the inputs (from a list file or a folder), the output name of
// each, a fingerprint of each input's bytes, and the record a finished conversion leaves in
// OUTROOT/.meshmux-batch/records/<name>.json, which a later run reads to skip finished work.
//
// OUTROOT layout:
//   OUTROOT/<name>/              one conversion, as `meshmux convert IN -o OUTROOT/<name>`
//   OUTROOT/batch.json           every input: status, error line, time, bytes in and out
//   OUTROOT/index.html           the same as a page, with a link to each viewer
//   OUTROOT/.meshmux-batch/      records/, logs/ (each conversion's stderr), plan.json and
//                                slurm/ (job scripts and task logs) for a Slurm run
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/status.h"

namespace meshmux {

// One input of a batch.
struct BatchItem {
  std::string input;      // absolute path
  std::string name;       // output folder under OUTROOT, unique in the batch
  std::string hash;       // 16 hex digits over the input and the files it references; "" unread
  uint64_t bytes_in = 0;  // the input and its referenced files (buffers, images), as served
};

// Reads LIST. A folder: each of its top-level entries is one upload (importers/upload.h) —
// a sub-folder (links to folders not followed, hidden entries, __MACOSX and `skip` skipped),
// a .zip, or a lone .gltf/.glb/.dae (any letter case) — in path order. A file lists one input
// per line, each a folder, a .zip or a model file (relative paths from the current folder;
// blank lines and lines starting with '#' ignored; a path listed twice counts once). Errors
// (kInput) name LIST.
// An input that does not exist stays in the list: its conversion fails and says so.
Result<std::vector<std::string>> read_batch_inputs(const std::string& list,
                                                   const std::string& skip);

// Output names for `inputs` (in order): the file name without its extension (a folder's whole
// name), restricted to
// ASCII letters, digits, '-' and '_' (no '.': see clean_name). Where names clash
// (case-insensitively), the folders above are prefixed ("Fox-glb_Fox", "Fox-meshopt-glb_Fox") until
// they differ, then the extension ("model-gltf", "model-glb"), then "-2", "-3" in list order;
// "viewer" (OUTROOT/viewer/ holds world.html's library) becomes "viewer-model". The same list
// always gives the same names.
std::vector<std::string> batch_names(const std::vector<std::string>& inputs);

// The input's fingerprint and size: the file and, for .gltf, its external buffers and images,
// for .dae the images its <init_from> elements name; for a folder upload, every file in it.
// O(bytes). A missing file hashes as such.
void fingerprint_input(BatchItem* item);

// What a finished conversion left.
struct BatchRecord {
  std::string input, name, hash;
  std::string options;        // the conversion options' fingerprint (see batch options)
  std::string status;         // "ok" or "failed"
  std::string error;          // failed: one line, why
  int exit_code = 0;          // the conversion's exit code (-1: killed by a signal)
  std::string cause;          // failed: "input", "memory", "timeout", "crash", "internal",
                              // "output", "unavailable", "usage"
  int warnings = 0;           // how many warnings the conversion printed
  std::string first_warning;  // the first of them
  double seconds = 0;         // wall time of the conversion
  uint64_t bytes_in = 0;      // the input as served (see BatchItem)
  uint64_t glb_bytes = 0;     // OUTROOT/<name>/model.glb
  uint64_t stream_bytes = 0;  // OUTROOT/<name>/model.mmxp (0: no stream was written)
  bool viewer = false;        // OUTROOT/<name>/index.html exists
  std::string worker;         // "local" or "slurm task N"
};

std::string record_path(const std::string& state_dir, const std::string& name);
Status write_record(const std::string& state_dir, const BatchRecord& record);
std::optional<BatchRecord> read_record(const std::string& state_dir, const std::string& name);

// Whether a record means the input needs no new conversion: the same input bytes and options,
// and either converted (with its output folder present) or failed on its input (a malformed
// file fails the same way again; `retry_failed` retries those too). Timeouts, memory limits,
// crashes and internal errors are always retried.
bool record_is_final(const BatchRecord& record, const BatchItem& item, const std::string& options,
                     const std::string& outroot, bool retry_failed);

}  // namespace meshmux
