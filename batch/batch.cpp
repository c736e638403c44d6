#include "batch/batch.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>

#include "batch/plan.h"
#include "core/process.h"
#include "batch/summary.h"
#include "batch/world.h"
#include "core/exit_codes.h"
#include "core/output_transaction.h"

namespace meshmux {

namespace fs = std::filesystem;

namespace {

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

int run_batch(const BatchRequest& r) {
  BatchOptions o = r.options;
  install_stop_handlers();
  const auto t0 = std::chrono::steady_clock::now();
  std::string outroot = fs::absolute(r.outroot).lexically_normal().string();
  while (outroot.size() > 1 && outroot.back() == '/') outroot.pop_back();
  if (Status s = check_outroot(outroot); !s) return print_error(s, kExitOutput);
  o.outroot = outroot;
  o.state_dir = outroot + "/.meshmux-batch";
  o.exe = self_executable();
  // The layout is read now, so a bad file fails before any conversion (and again, as it is
  // then, when world.json is written).
  if (!o.layout.empty()) {
    o.layout = fs::absolute(o.layout).lexically_normal().string();
    if (auto layout = read_layout(o.layout); !layout.ok())
      return print_error(layout.status().with_prefix("batch"), kExitInput);
  }
  std::error_code ec;
  fs::create_directories(o.state_dir + "/records", ec);
  fs::create_directories(o.state_dir + "/logs", ec);
  if (ec)
    return print_error(Status::error("batch: " + o.state_dir + ": cannot write: " + ec.message(),
                                     ErrorKind::kOutput));
  // One batch at a time per OUTROOT (the lock goes with the process, even on kill -9).
  const int lock = open((o.state_dir + "/lock").c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lock < 0 || flock(lock, LOCK_EX | LOCK_NB) != 0)
    return print_error(Status::error(
        "batch: " + outroot + ": another meshmux batch is running on it", ErrorKind::kOutput));
  // The fingerprint has the options that decide the outputs: a default memory limit (which
  // depends on --jobs and the machine) only decides whether a conversion fits, and a failure
  // over the limit is retried anyway.
  o.fingerprint = options_fingerprint(o.convert_args, o.max_memory_mb, r.version);
  if (o.max_memory_mb == 0 && !r.use_slurm)
    o.max_memory_mb = std::max<uint64_t>(2048, physical_memory_mb() / uint64_t(o.jobs));
  if (Status s = check_no_running_slurm_batch(o.state_dir); !s) return print_error(s, kExitOutput);

  auto inputs = read_batch_inputs(r.list, outroot);
  if (!inputs.ok()) return print_error(inputs.status(), kExitInput);
  if (inputs->empty())
    return print_error(Status::error("batch: " + r.list + ": no inputs (.gltf, .glb, .dae) in it",
                                     ErrorKind::kInput));
  const std::vector<std::string> names = batch_names(*inputs);
  std::vector<BatchItem> items(inputs->size());
  std::vector<BatchItem> todo;
  std::vector<std::string> reused;
  for (size_t i = 0; i < items.size(); ++i) {
    if (stop_requested())
      return print_error(
          Status::error("batch: interrupted before any conversion", ErrorKind::kInput),
          kExitInterrupted);
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
                 r.use_slurm ? "" : (", " + std::to_string(o.jobs) + " at once").c_str());

  if (r.use_slurm) return submit_slurm_batch(items, todo, reused, o, r.slurm);

  PoolResult pool = run_pool(todo, o, reused.size(), items.size());
  BatchSummaryInfo info;
  info.mode = "local";
  info.convert_args = o.convert_args;
  info.layout = o.layout;
  info.fingerprint = o.fingerprint;
  info.skipped = reused;
  info.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (!pool.usage_error.empty())
    info.missing_default = "not converted: the batch stopped on a usage error: " + pool.usage_error;
  auto counts = write_batch_summary(outroot, o.state_dir, items, info);
  if (!counts.ok()) return print_error(counts.status(), kExitOutput);
  if (!pool.usage_error.empty()) {
    std::fprintf(
        stderr,
        "meshmux: batch: the conversions refused the options: %s\n(see meshmux batch --help)\n",
        pool.usage_error.c_str());
    return kExitUsage;
  }
  for (const std::string& note : counts->world_notes)
    std::fprintf(stderr, "meshmux: batch: %s\n", note.c_str());
  if (!o.quiet)
    std::fprintf(stderr,
                 "meshmux: batch: %zu inputs: %zu converted (%zu with warnings, %zu from an "
                 "earlier run), %zu failed, %zu not converted in %.1f s; wrote %s/index.html and "
                 "world.json (%zu models, %zu placements)\n",
                 counts->inputs, counts->ok, counts->with_warnings, counts->reused, counts->failed,
                 counts->not_converted, info.seconds, outroot.c_str(), counts->world_packages,
                 counts->world_placements);
  if (pool.interrupted) return kExitInterrupted;
  return counts->failed + counts->not_converted ? kExitSomeFailed : kExitOk;
}

}  // namespace meshmux
