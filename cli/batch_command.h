// `meshmux batch LIST -o OUTROOT [options]`: converts many inputs, each into OUTROOT/<name>/
// as `meshmux convert` does, on a local pool of worker processes (default) or as a Slurm job
// array (--slurm). Resumable, with per-file time and memory limits and a summary
// (OUTROOT/batch.json, OUTROOT/index.html). `meshmux batch --help` documents the options.
#pragma once

#include <string>
#include <vector>

namespace meshmux {

// Exit codes: 0 every input converted (or, --slurm without --wait, the job submitted);
// 1 usage; 2 some inputs failed or were not converted (listed in the summary); 3 OUTROOT or
// the summary could not be written; 5 Slurm unavailable or it refused the job; 130
// interrupted (SIGINT/SIGTERM; the summary lists what was done).
int cmd_batch(const std::vector<std::string>& args);

}  // namespace meshmux
