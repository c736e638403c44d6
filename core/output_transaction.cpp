// Output as a transaction (see output_transaction.h).
#include "core/output_transaction.h"

#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <set>

namespace meshmux {

namespace fs = std::filesystem;

namespace {

// What convert writes into a folder: the only entries an existing OUT may hold.
const std::set<std::string> kOwnEntries = {"model.glb",     "base.glb",      "model.mmxp",
                                           "report.json",   "rd.svg",        "index.html",
                                           "index.html.gz", "index.html.br", "viewer"};

// The state letter and start time (clock ticks after boot) of a process, from /proc/<pid>/stat;
// false when it cannot be read. The command name (field 2) may hold spaces and parentheses, so
// the fields are read after its last ')'.
bool process_stat(long pid, char& state, unsigned long long& start_ticks) {
  FILE* f = fopen(("/proc/" + std::to_string(pid) + "/stat").c_str(), "r");
  if (!f) return false;
  char buf[1024];
  const size_t n = fread(buf, 1, sizeof buf - 1, f);
  fclose(f);
  buf[n] = 0;
  const char* p = strrchr(buf, ')');
  if (!p) return false;
  // After ')': state (field 3), then fields 4..21, then starttime (field 22).
  if (sscanf(p + 1, " %c", &state) != 1) return false;
  const char* q = p + 2;
  for (int field = 3; field < 22 && q; ++field) {
    q = strchr(q, ' ');
    if (q) ++q;
  }
  return q && sscanf(q, "%llu", &start_ticks) == 1;
}

// Seconds since the epoch at which the machine booted (/proc/stat "btime"), or -1.
long long boot_time() {
  FILE* f = fopen("/proc/stat", "r");
  if (!f) return -1;
  char line[256];
  long long bt = -1;
  while (fgets(line, sizeof line, f))
    if (sscanf(line, "btime %lld", &bt) == 1) break;
  fclose(f);
  return bt;
}

// Whether the process that named a temporary still runs. A zombie does not (its parent was
// killed and nothing reaps it: kill(pid, 0) still succeeds on it), nor does a process that
// started after the temporary was last written (the pid was reused).
bool process_running(long pid, const fs::path& temporary) {
  if (pid <= 0) return false;
  if (kill(pid_t(pid), 0) != 0 && errno != EPERM) return false;
  char state = 0;
  unsigned long long start = 0;
  if (!process_stat(pid, state, start)) return true;  // no /proc: trust kill()
  if (state == 'Z' || state == 'X') return false;
  struct stat st;
  const long long bt = boot_time();
  const long hz = sysconf(_SC_CLK_TCK);
  if (bt < 0 || hz <= 0 || lstat(temporary.c_str(), &st) != 0) return true;
  const long long started = bt + (long long)(start / (unsigned long long)hz);
  // Slack for the rounding of both clocks and a small step of the wall clock: a live run's
  // temporary must never be judged stale.
  return started <= (long long)st.st_mtime + 10;
}

// The pid a temporary's name ends with after `marker`, or -1.
long pid_after(const std::string& name, const std::string& marker) {
  if (name.size() <= marker.size() || name.compare(0, marker.size(), marker) != 0) return -1;
  std::string digits = name.substr(marker.size());
  if (digits.size() > 4 && digits.compare(digits.size() - 4, 4, "-old") == 0)
    digits.resize(digits.size() - 4);
  if (digits.empty() || digits.size() > 9 ||
      digits.find_first_not_of("0123456789") != std::string::npos)
    return -1;
  return std::stol(digits);
}

std::string parent_of(const std::string& path) {
  fs::path p = fs::path(path).parent_path();
  return p.empty() ? "." : p.string();
}

std::string name_of(const std::string& path) {
  std::string s = path;
  while (s.size() > 1 && s.back() == '/') s.pop_back();
  return fs::path(s).filename().string();
}

}  // namespace

Status refuse_overwriting_input(const std::string& input, const std::string& out, bool folder) {
  std::error_code ec;
  const fs::path in = fs::weakly_canonical(input, ec);
  if (ec) return Status::ok();  // the importer reports a bad input
  const fs::path o = fs::weakly_canonical(out, ec);
  if (ec) return Status::ok();
  if (in == o)
    return Status::error(out + ": is the input itself; refused (choose another output)",
                         ErrorKind::kOutput);
  if (folder) {
    const std::string i = in.string(), d = o.string();
    if (i.size() > d.size() && i.compare(0, d.size(), d) == 0 && i[d.size()] == '/')
      return Status::error(
          out + ": holds the input " + input + ", which replacing the folder would delete; refused",
          ErrorKind::kOutput);
  }
  return Status::ok();
}

void clean_stale_temporaries(const std::string& out) {
  const std::string name = name_of(out);
  std::error_code ec;
  for (const fs::directory_entry& e : fs::directory_iterator(parent_of(out), ec)) {
    const std::string n = e.path().filename().string();
    long pid = pid_after(n, name + ".meshmux-tmp-");
    if (pid < 0) pid = pid_after(n, name + ".tmp-");
    if (pid < 0) pid = pid_after(n, name + ".meshmux-upload-");  // an unpacked .zip upload
    if (pid < 0 || process_running(pid, e.path())) continue;
    std::error_code rm;
    fs::remove_all(e.path(), rm);
  }
}

Result<OutputFolder> OutputFolder::begin(const std::string& out) {
  std::error_code ec;
  struct stat st;
  if (lstat(out.c_str(), &st) == 0) {
    if (S_ISLNK(st.st_mode))
      return Status::error(out + ": is a symbolic link; refused (name the folder itself)",
                           ErrorKind::kOutput);
    if (!S_ISDIR(st.st_mode))
      return Status::error(out + ": exists and is not a folder", ErrorKind::kOutput);
    for (const fs::directory_entry& e : fs::directory_iterator(out, ec)) {
      const std::string n = e.path().filename().string();
      if (!kOwnEntries.count(n))
        return Status::error(out + ": holds '" + n +
                                 "', which meshmux did not write; refused (the folder is "
                                 "replaced as a whole: choose a new or empty folder)",
                             ErrorKind::kOutput);
    }
    if (ec) return Status::error(out + ": cannot list: " + ec.message(), ErrorKind::kOutput);
  }
  const std::string parent = parent_of(out);
  fs::create_directories(parent, ec);
  std::string tmp = parent + "/" + name_of(out) + ".meshmux-tmp-" + std::to_string(getpid());
  fs::remove_all(tmp, ec);  // our own pid's leftover (a reused pid)
  if (mkdir(tmp.c_str(), 0755) != 0)
    return Status::error(
        out + ": cannot create a temporary folder beside it: " + std::strerror(errno),
        ErrorKind::kOutput);
  return OutputFolder(out, tmp);
}

OutputFolder::OutputFolder(OutputFolder&& o) noexcept
    : out_(std::move(o.out_)), tmp_(std::move(o.tmp_)), done_(o.done_) {
  o.done_ = true;
}

OutputFolder::~OutputFolder() {
  if (done_) return;
  std::error_code ec;
  fs::remove_all(tmp_, ec);
}

Status OutputFolder::commit() {
  std::error_code ec;
  struct stat st;
  if (lstat(out_.c_str(), &st) == 0) {
    // Atomic swap: OUT becomes the new output, the temporary name the old one.
    if (renameat2(AT_FDCWD, tmp_.c_str(), AT_FDCWD, out_.c_str(), RENAME_EXCHANGE) != 0) {
      // No RENAME_EXCHANGE (some filesystems): move the old aside, then the new in.
      const std::string old = tmp_ + "-old";
      if (rename(out_.c_str(), old.c_str()) != 0)
        return Status::error(out_ + ": cannot replace: " + std::strerror(errno),
                             ErrorKind::kOutput);
      if (rename(tmp_.c_str(), out_.c_str()) != 0) {
        int e = errno;
        rename(old.c_str(), out_.c_str());  // put the previous output back
        return Status::error(out_ + ": cannot replace: " + std::strerror(e), ErrorKind::kOutput);
      }
      fs::remove_all(old, ec);
      done_ = true;
      return Status::ok();
    }
    fs::remove_all(tmp_, ec);  // the previous output, now under the temporary name
    done_ = true;
    return Status::ok();
  }
  if (rename(tmp_.c_str(), out_.c_str()) != 0)
    return Status::error(out_ + ": cannot move the output into place: " + std::strerror(errno),
                         ErrorKind::kOutput);
  done_ = true;
  return Status::ok();
}

}  // namespace meshmux
