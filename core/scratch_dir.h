// A private temporary folder (mode 0700, under $TMPDIR or /tmp) removed with everything in it
// when its owner goes out of scope, on every path: for the files a child process reads and
// writes (the image stage's KTX2 transcoder and encoder).
#pragma once

#include <string>

#include "core/status.h"

namespace meshmux {

class ScratchDir {
 public:
  // Creates "<tmp>/meshmux-<what>-XXXXXX". Errors (kOutput) name the folder and the cause.
  static Result<ScratchDir> create(const std::string& what);
  ScratchDir(ScratchDir&& other) noexcept;
  ScratchDir& operator=(ScratchDir&& other) noexcept;
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  ~ScratchDir();  // removes the folder and its contents (errors ignored)

  const std::string& path() const { return path_; }
  // path() + "/" + name.
  std::string file(const std::string& name) const { return path_ + "/" + name; }

 private:
  ScratchDir() = default;
  std::string path_;
};

}  // namespace meshmux
