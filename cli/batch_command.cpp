// meshmux batch: flags, the input list, resume, then the local pool or Slurm (see
// batch_command.h).
#include "cli/batch_command.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "cli/batch_plan.h"
#include "cli/batch_pool.h"
#include "cli/batch_process.h"
#include "cli/batch_slurm.h"
#include "cli/batch_summary.h"
#include "cli/output_transaction.h"

#ifndef MESHMUX_VERSION
#define MESHMUX_VERSION "0.0.0"
#endif

namespace meshmux {

namespace fs = std::filesystem;

namespace {

constexpr int kOk = 0, kUsage = 1, kSomeFailed = 2, kOutput = 3, kInterrupted = 130;

const char* kBatchUsage =
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
    "\n"
    "options:\n"
    "  --jobs N           conversions at once (default: one per core)\n"
    "  --timeout S        seconds one conversion may take, then it is killed (default 1800)\n"
    "  --max-memory MB    memory one conversion may use (default: the machine's memory\n"
    "                     divided by --jobs, at least 2048; on Slurm: convert's own default)\n"
    "  --retry-failed     convert again the inputs that failed on their input before\n"
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
    "convert options, given to every conversion: --position-bits N --normal-bits N\n"
    "  --uv-bits N --jpeg-quality N --crease DEGREES --no-draco --no-atlas --no-report\n"
    "  --allow-outside --max-texels N --max-instances N --max-elements N (meshmux --help)\n"
    "\n"
    "exit codes: 0 every input converted (--slurm without --wait: submitted); 1 usage error;\n"
    "  2 some inputs failed (listed in the summary); 3 OUTROOT could not be written;\n"
    "  5 Slurm is not available or refused the job; 130 interrupted (the summary lists what\n"
    "  was done; run again to finish)\n";

int usage(const std::string& message) {
  std::fprintf(stderr, "meshmux: batch: %s\n(see meshmux batch --help)\n", message.c_str());
  return kUsage;
}

bool whole_number(const std::string& text, long lo, long hi, long* out) {
  char* end = nullptr;
  errno = 0;
  const long v = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno != 0 || v < lo || v > hi) return false;
  *out = v;
  return true;
}

// OUTROOT may be new, empty, or a batch output (it has .meshmux-batch): nothing else, so the
// summary never lands in a folder of the user's own files.
Status check_outroot(const std::string& outroot) {
  std::error_code ec;
  if (!fs::exists(outroot, ec)) {
    fs::create_directories(outroot, ec);
    if (ec)
      return Status::error("batch: " + outroot + ": cannot create the folder: " + ec.message(),
                           ErrorKind::kOutput);
    return Status::ok();
  }
  if (!fs::is_directory(outroot, ec))
    return Status::error("batch: " + outroot + ": exists and is not a folder", ErrorKind::kOutput);
  if (fs::is_directory(outroot + "/.meshmux-batch", ec)) return Status::ok();
  if (!fs::is_empty(outroot, ec))
    return Status::error("batch: " + outroot +
                             ": a folder with other files in it (not a meshmux batch output); "
                             "give a new or empty folder",
                         ErrorKind::kOutput);
  return Status::ok();
}

uint64_t physical_memory_mb() {
  const long pages = sysconf(_SC_PHYS_PAGES), size = sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || size <= 0) return 0;
  return uint64_t(pages) * uint64_t(size) >> 20;
}

}  // namespace

int cmd_batch(const std::vector<std::string>& args) {
  std::string list, outroot, plan_path, array_job;
  BatchOptions o;
  SlurmOptions slurm;
  bool use_slurm = false, slurm_task = false, slurm_summary = false, jobs_given = false;
  o.jobs = int(std::max(1L, sysconf(_SC_NPROCESSORS_ONLN)));
  // convert's options that take a value, and those that do not: passed to every conversion.
  const char* kValueFlags[] = {"--position-bits", "--normal-bits", "--uv-bits",
                               "--jpeg-quality",  "--crease",      "--max-texels",
                               "--max-instances", "--max-elements"};
  const char* kPlainFlags[] = {"--no-draco", "--no-atlas", "--no-report", "--allow-outside"};
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&](std::string* v) {
      if (i + 1 >= args.size()) return false;
      *v = args[++i];
      return true;
    };
    std::string v;
    long n = 0;
    if (a == "-h" || a == "--help") {
      std::fputs(kBatchUsage, stdout);
      return kOk;
    } else if (a == "-o" || a == "--output") {
      if (!value(&outroot)) return usage(a + " needs a value");
    } else if (a == "-q" || a == "--quiet") {
      o.quiet = true;
    } else if (a == "--jobs" || a == "-j") {
      if (!value(&v) || !whole_number(v, 1, 1024, &n))
        return usage("--jobs expects a whole number from 1 to 1024");
      o.jobs = int(n), jobs_given = true;
    } else if (a == "--timeout") {
      if (!value(&v) || !whole_number(v, 1, 7 * 86400, &n))
        return usage("--timeout expects seconds, a whole number from 1 to 604800");
      o.timeout_seconds = double(n);
    } else if (a == "--max-memory") {
      if (!value(&v) || !whole_number(v, 64, 1L << 30, &n))
        return usage("--max-memory expects megabytes, a whole number of at least 64");
      o.max_memory_mb = uint64_t(n);
    } else if (a == "--retry-failed") {
      o.retry_failed = true;
    } else if (a == "--slurm") {
      use_slurm = true;
    } else if (a == "--partition") {
      if (!value(&slurm.partition) || slurm.partition.empty())
        return usage("--partition needs a name");
    } else if (a == "--tasks") {
      if (!value(&v) || !whole_number(v, 1, 100000, &n))
        return usage("--tasks expects a whole number from 1 to 100000");
      slurm.tasks = int(n);
    } else if (a == "--throttle") {
      if (!value(&v) || !whole_number(v, 1, 100000, &n))
        return usage("--throttle expects a whole number from 1 to 100000");
      slurm.throttle = int(n);
    } else if (a == "--cpus-per-task") {
      if (!value(&v) || !whole_number(v, 1, 1024, &n))
        return usage("--cpus-per-task expects a whole number from 1 to 1024");
      slurm.cpus_per_task = int(n);
    } else if (a == "--wait") {
      slurm.wait = true;
    } else if (a == "--slurm-task") {  // inside the job array (batch_slurm.h)
      if (!value(&plan_path)) return usage("--slurm-task needs the plan");
      slurm_task = true;
    } else if (a == "--slurm-summary") {
      if (!value(&plan_path)) return usage("--slurm-summary needs the plan");
      slurm_summary = true;
    } else if (a == "--array-job") {
      if (!value(&array_job)) return usage("--array-job needs a job id");
    } else if (std::find(std::begin(kPlainFlags), std::end(kPlainFlags), a) !=
               std::end(kPlainFlags)) {
      o.convert_args.push_back(a);
    } else if (std::find(std::begin(kValueFlags), std::end(kValueFlags), a) !=
               std::end(kValueFlags)) {
      if (!value(&v)) return usage(a + " needs a value");
      o.convert_args.insert(o.convert_args.end(), {a, v});
    } else if (!a.empty() && a[0] == '-') {
      return usage("unknown option " + a);
    } else if (list.empty()) {
      list = a;
    } else {
      return usage("more than one LIST given ('" + list + "' and '" + a + "')");
    }
  }
  if (slurm_task) return run_slurm_task(plan_path);
  if (slurm_summary) return run_slurm_summary(plan_path, array_job);
  if (list.empty()) return usage("no LIST given (a text file of input paths, or a folder)");
  if (outroot.empty()) return usage("no output given (-o OUTROOT)");
  if (use_slurm && jobs_given)
    return usage("--jobs is for the local pool; on Slurm use --cpus-per-task");
  if (!use_slurm && (slurm.wait || !slurm.partition.empty() || slurm.tasks))
    return usage("--wait, --partition and --tasks need --slurm");

  install_stop_handlers();
  const auto t0 = std::chrono::steady_clock::now();
  outroot = fs::absolute(outroot).lexically_normal().string();
  while (outroot.size() > 1 && outroot.back() == '/') outroot.pop_back();
  if (Status s = check_outroot(outroot); !s)
    return std::fprintf(stderr, "meshmux: %s\n", s.message().c_str()), kOutput;
  o.outroot = outroot;
  o.state_dir = outroot + "/.meshmux-batch";
  o.exe = self_executable();
  std::error_code ec;
  fs::create_directories(o.state_dir + "/records", ec);
  fs::create_directories(o.state_dir + "/logs", ec);
  if (ec)
    return std::fprintf(stderr, "meshmux: batch: %s: cannot write: %s\n", o.state_dir.c_str(),
                        ec.message().c_str()),
           kOutput;
  // One batch at a time per OUTROOT (the lock goes with the process, even on kill -9).
  const int lock = open((o.state_dir + "/lock").c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lock < 0 || flock(lock, LOCK_EX | LOCK_NB) != 0)
    return std::fprintf(stderr, "meshmux: batch: %s: another meshmux batch is running on it\n",
                        outroot.c_str()),
           kOutput;
  // The fingerprint has the options that decide the outputs: a default memory limit (which
  // depends on --jobs and the machine) only decides whether a conversion fits, and a failure
  // over the limit is retried anyway.
  o.fingerprint = options_fingerprint(o.convert_args, o.max_memory_mb, MESHMUX_VERSION);
  if (o.max_memory_mb == 0 && !use_slurm)
    o.max_memory_mb = std::max<uint64_t>(2048, physical_memory_mb() / uint64_t(o.jobs));
  if (Status s = check_no_running_slurm_batch(o.state_dir); !s)
    return std::fprintf(stderr, "meshmux: %s\n", s.message().c_str()), kOutput;

  auto inputs = read_batch_inputs(list, outroot);
  if (!inputs.ok())
    return std::fprintf(stderr, "meshmux: %s\n", inputs.status().message().c_str()), 2;
  if (inputs->empty())
    return std::fprintf(stderr, "meshmux: batch: %s: no inputs (.gltf, .glb, .dae) in it\n",
                        list.c_str()),
           2;
  const std::vector<std::string> names = batch_names(*inputs);
  std::vector<BatchItem> items(inputs->size());
  std::vector<BatchItem> todo;
  std::vector<std::string> reused;
  for (size_t i = 0; i < items.size(); ++i) {
    if (stop_requested())
      return std::fprintf(stderr, "meshmux: batch: interrupted before any conversion\n"),
             kInterrupted;
    items[i].input = (*inputs)[i];
    items[i].name = names[i];
    fingerprint_input(&items[i]);
    // Temporaries of a killed earlier run, beside this input's output and record.
    clean_stale_temporaries(outroot + "/" + items[i].name);
    clean_stale_temporaries(record_path(o.state_dir, items[i].name));
    auto rec = read_record(o.state_dir, items[i].name);
    if (rec && record_is_final(*rec, items[i], o.fingerprint, outroot, o.retry_failed))
      reused.push_back(items[i].name);
    else
      todo.push_back(items[i]);
  }
  clean_stale_temporaries(outroot + "/batch.json");
  clean_stale_temporaries(outroot + "/index.html");
  clean_stale_temporaries(o.state_dir + "/plan.json");
  if (!o.quiet)
    std::fprintf(stderr,
                 "meshmux: batch: %zu inputs: %zu to convert, %zu done by an earlier run%s\n",
                 items.size(), todo.size(), reused.size(),
                 use_slurm ? "" : (", " + std::to_string(o.jobs) + " at once").c_str());

  if (use_slurm) return submit_slurm_batch(items, todo, reused, o, slurm);

  PoolResult r = run_pool(todo, o, reused.size(), items.size());
  BatchSummaryInfo info;
  info.mode = "local";
  info.convert_args = o.convert_args;
  info.fingerprint = o.fingerprint;
  info.skipped = reused;
  info.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!r.usage_error.empty())
    info.missing_default = "not converted: the batch stopped on a usage error: " + r.usage_error;
  auto counts = write_batch_summary(outroot, o.state_dir, items, info);
  if (!counts.ok())
    return std::fprintf(stderr, "meshmux: %s\n", counts.status().message().c_str()), kOutput;
  if (!r.usage_error.empty()) return usage("the conversions refused the options: " + r.usage_error);
  if (!o.quiet)
    std::fprintf(stderr,
                 "meshmux: batch: %zu inputs: %zu converted (%zu with warnings, %zu from an "
                 "earlier run), %zu failed, %zu not converted in %.1f s; wrote %s/index.html\n",
                 counts->inputs, counts->ok, counts->with_warnings, counts->reused, counts->failed,
                 counts->not_converted, info.seconds, outroot.c_str());
  if (r.interrupted) return kInterrupted;
  return counts->failed + counts->not_converted ? kSomeFailed : kOk;
}

}  // namespace meshmux
