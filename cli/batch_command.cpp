// meshmux batch LIST -o OUTROOT: the flags into a BatchRequest, then the batch library
// (batch/batch.h), or, inside a Slurm job array, one task's share or the summary
// (batch/slurm.h; --slurm-task and --slurm-summary are how the job scripts call back in).
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "batch/batch.h"
#include "cli/args.h"
#include "cli/commands.h"
#include "core/exit_codes.h"

#ifndef MESHMUX_VERSION
#define MESHMUX_VERSION "0.0.0"
#endif

namespace meshmux {

namespace {

const char* const kBatchUsage =
    "usage: meshmux batch LIST -o OUTROOT [options] [convert options]\n"
    "\n"
    "Converts every input of LIST into OUTROOT/<name>/, as `meshmux convert IN -o\n"
    "OUTROOT/<name>` does, each in its own process with a time and a memory limit, so one bad\n"
    "upload cannot take the batch down. Each input is an upload: a folder or a .zip (its\n"
    "model file found inside, every read kept inside it) or one .gltf/.glb/.dae. LIST is a\n"
    "text file of such paths (one per line, relative to the current folder; blank lines and\n"
    "# comments ignored) or a folder whose top-level sub-folders, .zip files and model files\n"
    "are the uploads. <name> is the upload's name without its extension (with its folders\n"
    "prefixed where two inputs would share a name).\n"
    "\n"
    "Resumable: an input converted before with the same bytes and options is skipped, as is\n"
    "one that failed on its own bytes (a malformed file); run the same command again after a\n"
    "crash or kill. At the end OUTROOT/batch.json and OUTROOT/index.html list every input with\n"
    "its status, error line, time, bytes in and out and a link to its viewer (meshmux serve\n"
    "OUTROOT). Each conversion's messages are in OUTROOT/.meshmux-batch/logs/<name>.log.\n"
    "OUTROOT/world.json places every streamed model in one scene (see --layout).\n"
    "\n"
    "options:\n"
    "  --jobs N           conversions at once (default: one per core)\n"
    "  --timeout S        seconds one conversion may take, then it is killed (default 1800)\n"
    "  --max-memory MB    memory one conversion may use (default: the machine's memory\n"
    "                     divided by --jobs, at least 2048; on Slurm: convert's own default)\n"
    "  --retry-failed     convert again the inputs that failed on their input before\n"
    "  --layout FILE      where the converted models go in OUTROOT/world.json: JSON\n"
    "                     {\"placements\": [{\"name\": NAME, \"translation\": [x, y, z],\n"
    "                     \"scale\": s, \"rotation_y_degrees\": r} or {\"name\": NAME,\n"
    "                     \"matrix\": [16 numbers, column-major]}, ...]} (a name may be placed\n"
    "                     several times); default: a grid, each model scaled to a unit diagonal\n"
    "  -q, --quiet        no progress lines\n"
    "\n"
    "on a cluster (Slurm):\n"
    "  --slurm            submit one job array (sbatch --array) whose tasks convert shares of\n"
    "                     LIST with the same limits, and a job after it that writes the\n"
    "                     summary. OUTROOT, the inputs and this meshmux executable must be at\n"
    "                     the same paths on every node (shared storage).\n"
    "  --partition P      the partition to run in (default: the cluster's default)\n"
    "  --tasks T          tasks in the array (default: one per input, at most 1000)\n"
    "  --throttle K       at most K tasks at once (the array's %K; default 16)\n"
    "  --cpus-per-task C  cores per task, conversions at once in it (default 1)\n"
    "  --wait             wait for the summary, show progress, exit as a local batch does\n"
    "\n"
    "exit codes: 0 every input converted (--slurm without --wait: submitted); 1 usage error;\n"
    "  2 some inputs failed (listed in the summary), or the layout file is broken;\n"
    "  3 OUTROOT could not be written;\n"
    "  5 Slurm is not available or refused the job; 130 interrupted (the summary lists what\n"
    "  was done; run again to finish)\n";

void print_batch_usage() {
  std::fputs(kBatchUsage, stdout);
  std::printf("\nconvert options, given to every conversion (meshmux --help):\n  %s\n",
              convert_flags_text().c_str());
}

}  // namespace

int cmd_batch(const std::vector<std::string>& args) {
  auto p = parse_args(kBatch, args);
  if (!p.ok()) return usage_error(kBatch, p.status().message());
  if (p->help) return print_batch_usage(), kExitOk;
  // Inside a Slurm job: one task's share of the plan, or the summary after the array.
  if (p->has("--slurm-task")) return run_slurm_task(p->text("--slurm-task"));
  if (p->has("--slurm-summary"))
    return run_slurm_summary(p->text("--slurm-summary"), p->text("--array-job"));
  BatchRequest r;
  r.version = MESHMUX_VERSION;
  if (p->positional.empty())
    return usage_error(kBatch, "no LIST given (a text file of input paths, or a folder)");
  r.list = p->positional[0];
  r.outroot = p->text("--output");
  if (r.outroot.empty()) return usage_error(kBatch, "no output given (-o OUTROOT)");
  r.use_slurm = p->has("--slurm");
  if (r.use_slurm && p->has("--jobs"))
    return usage_error(kBatch, "--jobs is for the local pool; on Slurm use --cpus-per-task");
  BatchOptions& o = r.options;
  o.jobs = int(p->whole("--jobs", std::max(1L, sysconf(_SC_NPROCESSORS_ONLN))));
  o.timeout_seconds = double(p->whole("--timeout", 1800));
  o.max_memory_mb = uint64_t(p->whole("--max-memory", 0));
  o.retry_failed = p->has("--retry-failed");
  o.layout = p->text("--layout");
  o.quiet = p->has("--quiet");
  o.convert_args = p->convert_args();
  SlurmOptions& s = r.slurm;
  s.partition = p->text("--partition");
  s.tasks = int(p->whole("--tasks", 0));
  s.throttle = int(p->whole("--throttle", s.throttle));
  s.cpus_per_task = int(p->whole("--cpus-per-task", s.cpus_per_task));
  s.wait = p->has("--wait");
  if (!r.use_slurm && (s.wait || !s.partition.empty() || s.tasks))
    return usage_error(kBatch, "--wait, --partition and --tasks need --slurm");
  return run_batch(r);
}

}  // namespace meshmux
