// Progress on stderr for the commands: each step with the elapsed time, then the warnings that
// came since, grouped (the first two of a kind printed, the rest counted at the end). On a
// terminal, a step that runs over a second also shows its percentage live.
#pragma once

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include "core/progress.h"
#include "core/status.h"

namespace meshmux {

// What kind of warning a message is: the message with its numbers and quoted names blanked.
std::string warning_kind(const std::string& message);

// Progress on stderr: each step with the elapsed time, then the warnings that came since,
// grouped: the first two of a kind are printed, the rest counted and summed up at the end. On a
// terminal, a step that runs over a second also shows its percentage, live, on a line of its
// own that the next line replaces (pipes and logs get the step lines only).
class StderrProgress : public Progress {
 public:
  StderrProgress(bool quiet, const Warnings* warnings = nullptr)
      : quiet_(quiet),
        warnings_(warnings),
        live_(!quiet && isatty(2)),
        start_(now()),
        step_start_(start_),
        last_live_(start_) {}
  ~StderrProgress() override { finish(); }
  void step(const std::string& what) override {
    flush();
    step_start_ = now();
    if (!quiet_) std::fprintf(stderr, "meshmux: [%6.2f s] %s\n", seconds(), what.c_str());
  }
  void fraction(double done) override {
    if (!live_) return;
    const auto t = now();
    if (t - step_start_ < live_after_ || t - last_live_ < std::chrono::milliseconds(100)) return;
    last_live_ = t;
    const int percent = int(std::clamp(done, 0.0, 1.0) * 100);
    std::fprintf(stderr, "\r\033[Kmeshmux: [%6.2f s]   %d%%", seconds(), percent);
    std::fflush(stderr);
    shown_ = true;
  }
  // Prints the warnings not printed yet (two of each kind).
  void flush() {
    clear_live();
    if (!warnings_) return;
    for (; seen_ < warnings_->items().size(); ++seen_) {
      const std::string& w = warnings_->items()[seen_];
      auto [it, fresh] = kinds_.emplace(warning_kind(w), Kind{0, w});
      if (fresh) order_.push_back(it->first);
      if (++it->second.count <= 2 && !quiet_)
        std::fprintf(stderr, "meshmux: warning: %s\n", w.c_str());
    }
  }
  // The counts of the kinds that had more than two.
  void finish() {
    flush();
    for (const std::string& k : order_) {
      const Kind& kind = kinds_[k];
      if (kind.count > 2 && !quiet_)
        std::fprintf(stderr, "meshmux: warning: ... and %zu more like \"%s\"\n", kind.count - 2,
                     kind.first.c_str());
    }
    order_.clear();
  }
  double seconds() const { return std::chrono::duration<double>(now() - start_).count(); }

 private:
  struct Kind {
    size_t count;
    std::string first;  // the first message of the kind
  };
  static std::chrono::steady_clock::time_point now() { return std::chrono::steady_clock::now(); }
  // Erases the live percentage line, if one is shown.
  void clear_live() {
    if (!shown_) return;
    std::fprintf(stderr, "\r\033[K");
    shown_ = false;
  }
  bool quiet_;
  const Warnings* warnings_;
  bool live_;  // stderr is a terminal and not -q
  // A step shows its percentage once it has run this long: 1 s, or MESHMUX_LIVE_PROGRESS_AFTER
  // seconds (tests set 0 to see the live line on small inputs, whatever the machine's speed).
  std::chrono::duration<double> live_after_ = [] {
    const char* e = std::getenv("MESHMUX_LIVE_PROGRESS_AFTER");
    char* end = nullptr;
    const double v = e ? std::strtod(e, &end) : 1.0;
    return std::chrono::duration<double>(e && end != e && v >= 0 ? v : 1.0);
  }();
  bool shown_ = false;  // a live line is on screen
  std::chrono::steady_clock::time_point start_, step_start_, last_live_;
  size_t seen_ = 0;
  std::map<std::string, Kind> kinds_;
  std::vector<std::string> order_;  // kinds in order of first appearance
};

}  // namespace meshmux
