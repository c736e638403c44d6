// The exit codes of every meshmux command, declared once (meshmux --help lists them). Library
// code returns Status; the commands, and the batch and serve libraries that run as a command's
// whole body, end with one of these.
#pragma once

#include <cstdio>

#include "core/status.h"

namespace meshmux {

enum ExitCode : int {
  kExitOk = 0,
  kExitUsage = 1,          // unknown command or flag, missing or bad argument
  kExitInput = 2,          // missing, empty, truncated, malformed or unsupported input
  kExitSomeFailed = 2,     // batch: some inputs failed (listed in the summary)
  kExitOutput = 3,         // the output could not be written; nothing partial is left
  kExitInternal = 4,       // a bug or an unexpected library failure
  kExitUnavailable = 5,    // no offscreen OpenGL here; batch: Slurm absent or refusing the job
  kExitInterrupted = 130,  // batch: stopped by SIGINT/SIGTERM (run again to finish)
};

// The exit code a failed Status ends a command with (kExitOk for ok).
inline int exit_code(const Status& s) {
  switch (s.kind()) {
    case ErrorKind::kNone:
      return kExitOk;
    case ErrorKind::kInput:
      return kExitInput;
    case ErrorKind::kOutput:
      return kExitOutput;
    case ErrorKind::kInternal:
      return kExitInternal;
    case ErrorKind::kUnavailable:
      return kExitUnavailable;
  }
  return kExitInternal;
}

// Prints "meshmux: MESSAGE" (the status's one line) on stderr and returns `code`, or the
// status's own exit code.
inline int print_error(const Status& s, int code) {
  std::fprintf(stderr, "meshmux: %s\n", s.message().c_str());
  return code;
}
inline int print_error(const Status& s) { return print_error(s, exit_code(s)); }

}  // namespace meshmux
