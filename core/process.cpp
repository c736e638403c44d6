// Child processes (see core/process.h).
#include "core/process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <thread>

#include "core/sanitizers.h"

namespace meshmux {

std::string self_executable() {
  std::error_code ec;
  auto p = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return "meshmux";
  std::string s = p.string();
  const std::string deleted = " (deleted)";  // the binary was replaced while running
  if (s.size() > deleted.size() &&
      s.compare(s.size() - deleted.size(), deleted.size(), deleted) == 0)
    s.resize(s.size() - deleted.size());
  return s;
}

// Resolves a bare program name on PATH (execv wants a path), as the shell does.
std::string find_program(const std::string& name) {
  if (name.find('/') != std::string::npos) return access(name.c_str(), X_OK) == 0 ? name : "";
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "/usr/bin:/bin";
  dirs += ":/usr/sbin:/sbin";
  size_t start = 0;
  while (start <= dirs.size()) {
    size_t end = dirs.find(':', start);
    if (end == std::string::npos) end = dirs.size();
    std::string candidate = dirs.substr(start, end - start) + "/" + name;
    if (end > start && access(candidate.c_str(), X_OK) == 0) return candidate;
    start = end + 1;
  }
  return "";
}

namespace {

// What the child sets up between fork and exec (system calls only).
struct ChildSetup {
  uint64_t max_data_bytes = 0;  // RLIMIT_DATA; 0: inherited
  const char* working_dir = nullptr;
};

// Everything the child needs is prepared before fork: between fork and exec the child only
// makes system calls (no allocation, no locks), so a batch with threads stays safe.
struct Prepared {
  std::vector<std::string> strings, env_strings;
  std::vector<char*> argv, envp;
};

extern "C" char** environ;

pid_t fork_exec(const std::vector<std::string>& args, const std::string& log_path,
                const std::vector<std::pair<std::string, std::string>>& env, int out_fd,
                const ChildSetup& setup = {}) {
  Prepared p;
  p.strings = args;
  for (std::string& s : p.strings) p.argv.push_back(s.data());
  p.argv.push_back(nullptr);
  // The environment: ours, with `env` replacing or adding entries.
  for (char** e = environ; e && *e; ++e) {
    const std::string entry = *e;
    const std::string key = entry.substr(0, entry.find('='));
    bool replaced = false;
    for (const auto& kv : env) replaced = replaced || kv.first == key;
    if (!replaced) p.env_strings.push_back(entry);
  }
  for (const auto& [k, v] : env) p.env_strings.push_back(k + "=" + v);
  for (std::string& s : p.env_strings) p.envp.push_back(s.data());
  p.envp.push_back(nullptr);
  const char* log = log_path.empty() ? "/dev/null" : log_path.c_str();
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid != 0) return pid;
  // The child: its own group, dies with the batch, quiet stdin, output to the log or pipe.
  setpgid(0, 0);
  prctl(PR_SET_PDEATHSIG, SIGKILL);
  if (getppid() != parent) _exit(127);  // the batch died before prctl
  int in = open("/dev/null", O_RDONLY | O_CLOEXEC);
  if (in >= 0) dup2(in, 0);
  int out = out_fd;
  if (out < 0) out = open(log, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (out < 0) out = open("/dev/null", O_WRONLY | O_CLOEXEC);
  if (out >= 0) {
    dup2(out, 1);
    dup2(out, 2);
  }
  if (setup.max_data_bytes > 0 && !MESHMUX_SANITIZED) {
    const rlimit rl{rlim_t(setup.max_data_bytes), rlim_t(setup.max_data_bytes)};
    setrlimit(RLIMIT_DATA, &rl);
  }
  if (setup.working_dir && chdir(setup.working_dir) != 0) _exit(127);
  execve(p.argv[0], p.argv.data(), p.envp.data());
  const char* msg = "meshmux: could not start the program\n";
  (void)!write(2, msg, std::strlen(msg));
  _exit(127);
}

}  // namespace

Result<pid_t> spawn_process(const std::vector<std::string>& argv, const SpawnOptions& options) {
  if (argv.empty()) return Status::error("process: nothing to run", ErrorKind::kInternal);
  const pid_t pid = fork_exec(argv, options.log_path, options.env, -1);
  if (pid < 0)
    return Status::error(std::string("process: cannot start a process: ") + std::strerror(errno),
                         ErrorKind::kInternal);
  setpgid(pid, pid);  // also from this side, so kill_group works at once
  return pid;
}

ExitInfo exit_info(int wait_status) {
  ExitInfo e;
  if (WIFEXITED(wait_status)) e.code = WEXITSTATUS(wait_status);
  if (WIFSIGNALED(wait_status)) e.signal = WTERMSIG(wait_status);
  return e;
}

std::string ExitInfo::describe() const {
  if (signal == 0) return "exit code " + std::to_string(code);
  const char* name = sigabbrev_np(signal);
  return "signal " + std::to_string(signal) + (name ? std::string(" (SIG") + name + ")" : "");
}

void kill_group(pid_t pid) {
  if (pid <= 0) return;
  if (kill(-pid, SIGKILL) != 0) kill(pid, SIGKILL);  // not yet its own group's leader
}

Result<CommandOutput> run_command(const std::vector<std::string>& argv, double timeout_seconds) {
  RunOptions options;
  options.timeout_seconds = timeout_seconds;
  return run_command(argv, options);
}

Result<CommandOutput> run_command(const std::vector<std::string>& argv, const RunOptions& options) {
  if (argv.empty()) return Status::error("process: nothing to run", ErrorKind::kInternal);
  std::vector<std::string> args = argv;
  args[0] = find_program(argv[0]);
  if (args[0].empty())
    return Status::error(argv[0] + ": not found (is it installed and on PATH?)",
                         ErrorKind::kUnavailable);
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0)
    return Status::error(std::string("process: pipe: ") + std::strerror(errno),
                         ErrorKind::kInternal);
  ChildSetup setup;
  setup.max_data_bytes = options.max_data_bytes;
  if (!options.working_dir.empty()) setup.working_dir = options.working_dir.c_str();
  const pid_t pid = fork_exec(args, "", {}, fds[1], setup);
  close(fds[1]);
  if (pid > 0) setpgid(pid, pid);  // so that kill_group reaches it at once
  if (pid < 0) {
    close(fds[0]);
    return Status::error(
        std::string("process: cannot start ") + argv[0] + ": " + std::strerror(errno),
        ErrorKind::kInternal);
  }
  fcntl(fds[0], F_SETFL, O_NONBLOCK);
  CommandOutput result;
  const auto deadline = std::chrono::steady_clock::now() +
                        std::chrono::milliseconds(int64_t(options.timeout_seconds * 1000));
  int status = 0;
  bool done = false, timed_out = false;
  char buf[4096];
  while (true) {
    ssize_t n;
    while ((n = read(fds[0], buf, sizeof buf)) > 0) {
      result.output.append(buf, size_t(n));
      if (result.output.size() > 2 * options.max_output_bytes)  // keep the end
        result.output.erase(0, result.output.size() - options.max_output_bytes);
    }
    if (done && n <= 0) break;
    if (!done && waitpid(pid, &status, WNOHANG) == pid) {
      done = true;
      continue;  // drain what is left
    }
    if (!done && std::chrono::steady_clock::now() > deadline) {
      kill_group(pid);
      waitpid(pid, &status, 0);
      timed_out = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  close(fds[0]);
  if (result.output.size() > options.max_output_bytes)
    result.output.erase(0, result.output.size() - options.max_output_bytes);
  if (timed_out)
    return Status::error(
        argv[0] + ": no answer within " + std::to_string(int(options.timeout_seconds)) + " s",
        ErrorKind::kUnavailable);
  result.exit = exit_info(status);
  return result;
}

std::string last_output_line(const std::string& output, size_t max_chars) {
  const size_t end = output.find_last_not_of(" \t\r\n");
  if (end == std::string::npos) return "";
  size_t start = output.find_last_of('\n', end);
  start = start == std::string::npos ? 0 : start + 1;
  return output.substr(start, std::min(end + 1 - start, max_chars));
}

}  // namespace meshmux
