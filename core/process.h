// Child processes: a conversion of `meshmux batch` in its own process (its own process group,
// killed with the batch, output to a log file), and commands whose output is read back (sbatch
// and scontrol for the batch; node and basisu for the image stage's KTX2 transcoder and encoder,
// under a time and a memory limit). POSIX fork/exec; Linux's PR_SET_PDEATHSIG ties a child's
// life to its parent's, so `kill -9` of meshmux leaves no child running.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "core/status.h"

namespace meshmux {

// The running executable's absolute path (/proc/self/exe), for re-running meshmux itself.
std::string self_executable();

struct SpawnOptions {
  std::string log_path;  // stdout and stderr go here (created or truncated); empty: /dev/null
  std::vector<std::pair<std::string, std::string>> env;  // set in the child only
};

// Starts argv[0] (a path) with argv in a new process group whose leader is the child, stdin
// from /dev/null. The child is killed (SIGKILL) when the calling thread's process dies.
// Errors (kInternal) when fork fails; a failed exec shows as exit code 127 in the log.
Result<pid_t> spawn_process(const std::vector<std::string>& argv, const SpawnOptions& options);

// How a child ended.
struct ExitInfo {
  int code = -1;                 // exit code, or -1 when killed by a signal
  int signal = 0;                // the signal that killed it, or 0
  std::string describe() const;  // "exit code 2", "signal 11 (SIGSEGV)"
};
ExitInfo exit_info(int wait_status);

// Runs a command to completion (at most `timeout_seconds`, then it is killed), returning its
// exit and its combined stdout and stderr. Errors (kUnavailable) when the program cannot be
// started (not installed), or it ran over the time.
struct CommandOutput {
  ExitInfo exit;
  std::string output;
};
Result<CommandOutput> run_command(const std::vector<std::string>& argv, double timeout_seconds);

// The limits and place of run_command's child.
struct RunOptions {
  double timeout_seconds = 60;  // then the child's group is killed and the run is an error
  uint64_t max_data_bytes = 0;  // RLIMIT_DATA of the child (0: inherited). Data, not address
                                // space: node's WebAssembly reserves gigabytes it never touches.
                                // Not applied in sanitizer builds (core/sanitizers.h).
  std::string working_dir;      // the child's current folder; empty: ours
  size_t max_output_bytes = size_t(1) << 20;  // output kept (its end); the rest is read and
                                              // dropped, so a chatty child never blocks
};
// As above, with those limits. A child killed by the kernel for memory shows as a signal.
Result<CommandOutput> run_command(const std::vector<std::string>& argv, const RunOptions& options);

// The path of `name` on PATH (as the shell finds it), `name` itself when it holds a '/', or ""
// when it is not found or not executable (either way).
std::string find_program(const std::string& name);

// The last non-empty line of a child's output, cut to `max_chars` (what an error quotes).
std::string last_output_line(const std::string& output, size_t max_chars = 300);

// Kills a child's whole process group with SIGKILL (the child and anything it started).
void kill_group(pid_t pid);

}  // namespace meshmux
