// `meshmux batch --slurm`: the batch as one Slurm job array. The submitting run writes the
// plan (OUTROOT/.meshmux-batch/plan.json: every input, the ones left to convert, the options
// and limits), submits `sbatch --array=0-(T-1)%K` whose task i converts the inputs i, i+T,
// i+2T... of that list with the local pool (batch/pool.h: the same per-file limits), then a
// job that depends on the whole array (afterany) and writes batch.json and index.html, listing
// an input whose task ended before converting it with that task's Slurm state. OUTROOT, the
// inputs and the meshmux executable must be at the same paths on every node (shared storage).
#pragma once

#include <string>
#include <vector>

#include "batch/pool.h"

namespace meshmux {

struct SlurmOptions {
  std::string partition;  // sbatch --partition; "" for the cluster's default
  int tasks = 0;          // array size; 0: one task per input, at most 1000
  int throttle = 16;      // at most this many tasks at once (the array's %K)
  int cpus_per_task = 1;  // sbatch --cpus-per-task; conversions at once in a task
  bool wait = false;      // wait for the summary job, then report like a local batch
};

// Submits the plan: `all` is every input (list order), `todo` those to convert, `reused` the
// names kept from an earlier run. Returns the exit code of `meshmux batch` (0: submitted, or
// with `wait` every input converted; 2: some failed; 5: Slurm unavailable or refused the job).
int submit_slurm_batch(const std::vector<BatchItem>& all, const std::vector<BatchItem>& todo,
                       const std::vector<std::string>& reused, const BatchOptions& options,
                       const SlurmOptions& slurm);

// Refuses (kOutput) while a Slurm batch submitted on this OUTROOT is still queued or running
// (its job ids in .meshmux-batch/slurm/jobs.json, its state from scontrol): a second run
// would convert the same inputs at once and replace the plan its tasks read. Ok when there
// was none, it ended, or Slurm cannot be asked.
Status check_no_running_slurm_batch(const std::string& state_dir);

// Inside the job array: converts this task's share (SLURM_ARRAY_TASK_ID of the plan's tasks).
// Exit code 0 when every input of the share converted, 2 when one failed.
int run_slurm_task(const std::string& plan_path);

// The dependent job: writes the summary, with the array's task states. Exit 0 or 2.
int run_slurm_summary(const std::string& plan_path, const std::string& array_job);

}  // namespace meshmux
