// The local process pool of meshmux batch (see batch/pool.h). The source system of Terrace,
// Cheslack-Postava, Levis and Freedman, "Unsupervised conversion of 3D models for interactive
// metaverses" ran its converter behind a task queue, one worker process per upload; this is that
// worker model on one machine, with per-upload limits and a record per finished upload.
#include "batch/pool.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "core/process.h"
#include "core/output_transaction.h"
#include "core/text.h"

namespace meshmux {

namespace fs = std::filesystem;

namespace {

volatile sig_atomic_t g_stop_signal = 0;
extern "C" void on_stop_signal(int sig) { g_stop_signal = sig; }

std::string human_duration(double s) {
  char buf[32];
  if (s < 90)
    std::snprintf(buf, sizeof buf, "%.0f s", s);
  else if (s < 5400)
    std::snprintf(buf, sizeof buf, "%.0f min", s / 60);
  else
    std::snprintf(buf, sizeof buf, "%.1f h", s / 3600);
  return buf;
}

// What a conversion's stderr says: its warnings (counted, the first kept) and its error line.
struct LogSummary {
  int warnings = 0;
  std::string first_warning, error;
};

LogSummary read_log(const std::string& path) {
  LogSummary s;
  std::ifstream in(path, std::ios::binary);
  std::string line;
  const std::string prefix = "meshmux: ", warn = "meshmux: warning: ", more = "... and ";
  while (std::getline(in, line)) {
    if (line.size() > 2000) line.resize(2000);
    if (line.rfind(warn, 0) == 0) {
      std::string w = line.substr(warn.size());
      if (w.rfind(more, 0) == 0) {
        s.warnings += std::atoi(w.c_str() + more.size());
        continue;
      }
      if (s.warnings++ == 0) s.first_warning = w;
      continue;
    }
    if (line.rfind(prefix, 0) == 0 && line.rfind("meshmux: [", 0) != 0)
      s.error = line.substr(prefix.size());
    else if (!line.empty() && line[0] != '(' && line.rfind("meshmux", 0) != 0)
      s.error = line;  // a library's own line (the last one is the best clue)
  }
  return s;
}

uint64_t file_size_or_zero(const std::string& path) {
  std::error_code ec;
  const auto n = fs::file_size(path, ec);
  return ec ? 0 : uint64_t(n);
}

struct Running {
  BatchItem item;
  pid_t pid;
  std::chrono::steady_clock::time_point start;
  bool timed_out = false;
};

BatchRecord finish(const Running& r, const ExitInfo& exit, double seconds, const BatchOptions& o) {
  BatchRecord rec;
  rec.input = r.item.input;
  rec.name = r.item.name;
  rec.hash = r.item.hash;
  rec.options = o.fingerprint;
  rec.exit_code = exit.signal ? -1 : exit.code;
  rec.seconds = seconds;
  rec.bytes_in = r.item.bytes_in;
  rec.worker = o.worker;
  const LogSummary log = read_log(o.state_dir + "/logs/" + r.item.name + ".log");
  rec.warnings = log.warnings;
  rec.first_warning = log.first_warning;
  if (exit.signal == 0 && exit.code == 0) {
    const std::string dir = o.outroot + "/" + r.item.name;
    rec.status = "ok";
    rec.glb_bytes = file_size_or_zero(dir + "/model.glb");
    rec.stream_bytes = file_size_or_zero(dir + "/model.mmxp");
    std::error_code ec;
    rec.viewer = fs::is_regular_file(dir + "/index.html", ec);
    return rec;
  }
  rec.status = "failed";
  if (r.timed_out) {
    rec.cause = "timeout";
    rec.error = "timed out after " + human_duration(o.timeout_seconds) + " (--timeout)";
  } else if (exit.signal) {
    rec.cause = "crash";
    rec.error = "ended by " + exit.describe() +
                (exit.signal == SIGKILL ? " (out of system memory?)" : "") +
                (log.error.empty() ? "" : "; last line: " + log.error);
  } else {
    switch (exit.code) {
      case 1:
        rec.cause = "usage";
        break;
      case 2:
        // Over the memory limit: another limit (or machine) may convert it; retried.
        rec.cause = log.error.find("--max-memory") != std::string::npos ? "memory" : "input";
        break;
      case 3:
        rec.cause = "output";
        break;
      case 5:
        rec.cause = "unavailable";
        break;
      default:
        rec.cause = "internal";
        break;
    }
    rec.error = log.error.empty() ? "failed with " + exit.describe() : log.error;
  }
  return rec;
}

}  // namespace

void install_stop_handlers() {
  static bool installed = false;
  if (installed) return;
  installed = true;
  struct sigaction sa {};
  sa.sa_handler = on_stop_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

bool stop_requested() { return g_stop_signal != 0; }

std::string options_fingerprint(const std::vector<std::string>& convert_args,
                                uint64_t max_memory_mb, const std::string& version) {
  std::string s = "meshmux " + version + "\n--max-memory " + std::to_string(max_memory_mb);
  for (const std::string& a : convert_args) s += "\n" + a;
  uint64_t h = 0xcbf29ce484222325ull;
  for (unsigned char c : s) h = (h ^ c) * 0x100000001b3ull;
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return hex;
}

PoolResult run_pool(const std::vector<BatchItem>& todo_in, const BatchOptions& o,
                    size_t done_before, size_t total) {
  PoolResult result;
  std::vector<BatchItem> todo = todo_in;
  std::stable_sort(todo.begin(), todo.end(),
                   [](const BatchItem& a, const BatchItem& b) { return a.bytes_in > b.bytes_in; });
  std::error_code ec;
  fs::create_directories(o.state_dir + "/logs", ec);
  fs::create_directories(o.state_dir + "/records", ec);

  // Several conversions share the cores: llvmpipe (the renderer) and the atlas baking get
  // their share of threads
  // (in a Slurm task, of the task's cores, not the node's). The images do not depend on it.
  const long cores = o.cores > 0 ? o.cores : std::max(1L, sysconf(_SC_NPROCESSORS_ONLN));
  const int jobs = std::max(1, o.jobs);
  std::vector<std::pair<std::string, std::string>> env;
  const std::string share = std::to_string(std::max(1L, cores / jobs));
  if (!std::getenv("LP_NUM_THREADS")) env.emplace_back("LP_NUM_THREADS", share);
  if (!std::getenv("MESHMUX_THREADS")) env.emplace_back("MESHMUX_THREADS", share);  // baking

  install_stop_handlers();

  const auto t0 = std::chrono::steady_clock::now();
  auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  std::vector<Running> running;
  size_t next = 0, finished = 0;
  while (next < todo.size() || !running.empty()) {
    if (g_stop_signal) {
      for (const Running& r : running) kill_group(r.pid);
      for (const Running& r : running) {
        waitpid(r.pid, nullptr, 0);
        clean_stale_temporaries(o.outroot + "/" + r.item.name);  // its half-written output
      }
      result.interrupted = true;
      break;
    }
    while (running.size() < size_t(jobs) && next < todo.size() && result.usage_error.empty()) {
      const BatchItem& item = todo[next++];
      // This very executable, even if its file was replaced meanwhile (a rebuild, an upgrade).
      std::vector<std::string> argv = {"/proc/self/exe", "convert", item.input, "-o",
                                       o.outroot + "/" + item.name};
      if (o.max_memory_mb)
        argv.insert(argv.end(), {"--max-memory", std::to_string(o.max_memory_mb)});
      argv.insert(argv.end(), o.convert_args.begin(), o.convert_args.end());
      SpawnOptions so;
      so.log_path = o.state_dir + "/logs/" + item.name + ".log";
      so.env = env;
      auto pid = spawn_process(argv, so);
      if (!pid.ok()) {
        BatchRecord rec;
        rec.input = item.input, rec.name = item.name, rec.hash = item.hash;
        rec.options = o.fingerprint, rec.status = "failed", rec.cause = "internal";
        rec.error = pid.status().message(), rec.worker = o.worker;
        (void)write_record(o.state_dir, rec);
        ++result.failed, ++finished;
        continue;
      }
      running.push_back({item, *pid, std::chrono::steady_clock::now()});
    }
    if (running.empty()) break;
    // Reap whatever ended; kill what ran over its time.
    bool any = false;
    for (size_t i = 0; i < running.size();) {
      Running& r = running[i];
      int status = 0;
      const pid_t w = waitpid(r.pid, &status, WNOHANG);
      const double secs =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - r.start).count();
      if (w == 0) {
        if (secs > o.timeout_seconds && !r.timed_out) {
          r.timed_out = true;
          kill_group(r.pid);
        }
        ++i;
        continue;
      }
      any = true;
      kill_group(r.pid);  // anything the conversion left running in its group
      const ExitInfo exit = w == r.pid ? exit_info(status) : ExitInfo{-1, SIGKILL};
      BatchRecord rec = finish(r, exit, secs, o);
      if (rec.status != "ok") clean_stale_temporaries(o.outroot + "/" + r.item.name);
      if (rec.cause == "usage" && result.usage_error.empty()) result.usage_error = rec.error;
      if (Status s = write_record(o.state_dir, rec); !s && !o.quiet)
        std::fprintf(stderr, "meshmux: batch: %s\n", s.message().c_str());
      (rec.status == "ok" ? result.converted : result.failed) += 1;
      ++finished;
      if (!o.quiet) {
        const double t = elapsed();
        const double rate = finished / std::max(t, 1e-3);
        const size_t left = todo.size() - finished;
        std::string line = rec.status == "ok"
                               ? "ok      " + rec.name + " (" + human_duration(secs) + ", " +
                                     human_bytes(rec.bytes_in) + " -> " +
                                     human_bytes(rec.glb_bytes) + ")"
                               : "FAILED  " + rec.name + ": " + rec.error;
        std::fprintf(
            stderr, "meshmux: batch [%7.1f s] %zu/%zu %s | %zu running, %zu failed, %.2f/s%s\n", t,
            done_before + finished, total, line.c_str(), running.size() - 1, result.failed, rate,
            left ? (", about " + human_duration(left / rate) + " left").c_str() : "");
      }
      running.erase(running.begin() + long(i));
    }
    if (!any) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (!result.usage_error.empty() && running.empty()) break;
  }
  return result;
}

}  // namespace meshmux
