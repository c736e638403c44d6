// The local pool of `meshmux batch`: each input converts in its own `meshmux convert` process
// (at most `jobs` at once), under a wall-time limit (the process group is killed) and a memory
// limit (convert's --max-memory: RLIMIT_DATA), so one bad upload cannot take the batch down.
// Each finished conversion leaves a record (batch/plan.h) at once, so a batch killed at any
// point resumes where it stopped. Used by a local batch and by each task of a Slurm array.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "batch/plan.h"

namespace meshmux {

struct BatchOptions {
  std::string outroot;                    // absolute; OUTROOT/<name>/ per input
  std::string state_dir;                  // OUTROOT/.meshmux-batch
  std::vector<std::string> convert_args;  // convert's options, given to every conversion
  std::string fingerprint;                // of convert_args, the limits and the version
  int jobs = 1;                           // conversions at once (local default: one per core)
  int cores = 0;                          // cores they share; 0: the machine's
  double timeout_seconds = 1800;          // wall time of one conversion, then it is killed
  uint64_t max_memory_mb = 0;             // per conversion (convert --max-memory); 0: convert's
                                          // (the fingerprint has only a --max-memory given)
  bool retry_failed = false;              // convert again inputs that failed on their input
  std::string layout;                     // a layout file for world.json (batch/world.h); "": grid
  bool quiet = false;                     // no progress lines
  std::string worker = "local";           // recorded: "local" or "slurm task N"
  std::string exe;                        // the meshmux executable the workers run
};

// The convert options' fingerprint: a hash of the arguments, limits and meshmux's version.
std::string options_fingerprint(const std::vector<std::string>& convert_args,
                                uint64_t max_memory_mb, const std::string& version);

// SIGINT and SIGTERM ask the batch to stop (running conversions are killed, the summary
// says what was done). Installed once; idempotent.
void install_stop_handlers();
bool stop_requested();

struct PoolResult {
  size_t converted = 0;      // ended with exit code 0
  size_t failed = 0;         // any other end (recorded)
  bool interrupted = false;  // SIGINT/SIGTERM: running conversions were killed, not recorded
  std::string usage_error;   // a conversion rejected the options: the batch stopped
};

// Converts `todo`, writing a record per input. `done_before` and `total` only shape the
// progress lines ("7/45"). Largest inputs start first (the batch ends sooner).
PoolResult run_pool(const std::vector<BatchItem>& todo, const BatchOptions& options,
                    size_t done_before, size_t total);

}  // namespace meshmux
