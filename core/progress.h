// Progress of long work: a stage reports each step it starts or finishes as one line ("built the
// atlas: 36 charts, 1024x1024"). The CLI prints them on stderr with the elapsed time; tests and
// benches may pass none (nullptr) or collect them.
#pragma once

#include <string>

namespace meshmux {

class Progress {
 public:
  virtual ~Progress() = default;
  virtual void step(const std::string& what) = 0;
  // How much of the step begun last is done, in [0, 1] (an estimate; may be called often, so
  // sinks throttle). The CLI shows it live on a terminal for steps over a second.
  virtual void fraction(double done) {}
};

// Reports to a sink that may be null.
inline void report_step(Progress* progress, const std::string& what) {
  if (progress) progress->step(what);
}
inline void report_fraction(Progress* progress, double done) {
  if (progress) progress->fraction(done);
}

}  // namespace meshmux
