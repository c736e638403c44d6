// meshmux batch as a library: many uploads converted into OUTROOT/<name>/, each by its own
// meshmux process with time and memory limits (the local pool, batch/pool.h) or as a Slurm job
// array (batch/slurm.h); resumable from the records each conversion leaves (batch/plan.h); a
// summary (batch.json, index.html) at the end (batch/summary.h). The command line that fills a
// BatchRequest is cli/batch_command.cpp.
#pragma once

#include <string>

#include "batch/pool.h"
#include "batch/slurm.h"

namespace meshmux {

struct BatchRequest {
  std::string list;        // a text file of upload paths, or a folder whose entries are uploads
  std::string outroot;     // new, empty or an earlier batch's output
  BatchOptions options;    // jobs, limits, convert_args, quiet (outroot, state_dir, exe and the
                           // fingerprint are filled in by run_batch)
  bool use_slurm = false;  // submit to Slurm instead of the local pool
  SlurmOptions slurm;      // with use_slurm
  std::string version;     // meshmux's version, part of the options' fingerprint
};

// Runs the batch: checks OUTROOT (creating it; refusing a folder of other files), locks it
// against a second batch, reads the list, skips what an earlier run finished, converts the
// rest and writes the summary. Progress and one-line errors on stderr. Returns an exit code
// (core/exit_codes.h): kExitOk, kExitSomeFailed, kExitInput (no list or no inputs),
// kExitOutput (OUTROOT unwritable or busy), kExitUsage (the conversions refused the convert
// options), kExitUnavailable (Slurm), kExitInterrupted.
int run_batch(const BatchRequest& r);

}  // namespace meshmux
