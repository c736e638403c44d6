// A conversion's outputs as one transaction: everything is written into a fresh temporary folder
// beside OUT, and only when every file is complete is it swapped into place (atomically, with
// renameat2(RENAME_EXCHANGE)); the previous good output stays until then, and on any failure (disk
// full, a killed run) it is what remains. Stale files of an earlier conversion never survive beside
// new ones, because the whole folder is replaced.
//
// Safety rules:
// - OUT may replace only a folder that is empty or holds nothing but meshmux outputs (the
//   names convert writes); anything else is refused, so `-o ~` never deletes a home folder;
// - an output that would overwrite the input (the same file, or a folder containing it) is
//   refused;
// - temporaries are named "<OUT>.meshmux-tmp-<pid>" (folders), "<file>.tmp-<pid>" (single
//   files) and "<OUT>.meshmux-upload-<pid>" (a .zip upload unpacked, see importers/upload.h);
//   those of processes no longer running are removed when the next run starts.
#pragma once

#include <string>

#include "core/status.h"

namespace meshmux {

// Refuses an output that would overwrite `input`: the same file (links resolved), or, for a
// folder output, a folder the input lies in. kUsage-like errors are kOutput.
Status refuse_overwriting_input(const std::string& input, const std::string& out, bool folder);

// Removes the temporaries of dead meshmux runs beside `out` (its folder's entries named
// "<out name>.meshmux-tmp-<pid>" or "<out name>.tmp-<pid>" whose pid is not running). A zombie
// (a killed run's child that nothing reaps, as under a container's init) does not count as
// running, nor does a process that started after the temporary was last written (a reused pid).
void clean_stale_temporaries(const std::string& out);

class OutputFolder {
 public:
  // Checks OUT (missing, empty, or meshmux's own) and creates the temporary folder.
  static Result<OutputFolder> begin(const std::string& out);
  OutputFolder(OutputFolder&& o) noexcept;
  OutputFolder& operator=(OutputFolder&&) = delete;
  ~OutputFolder();  // not committed: the temporary folder is removed

  const std::string& dir() const { return tmp_; }  // write the outputs here
  // Swaps the temporary folder into place of OUT and removes the previous output.
  Status commit();

 private:
  OutputFolder(std::string out, std::string tmp) : out_(std::move(out)), tmp_(std::move(tmp)) {}
  std::string out_, tmp_;
  bool done_ = false;
};

}  // namespace meshmux
