// Shared by the libFuzzer targets (scripts/fuzz.sh): each input is written to a file in a
// private temporary folder (the importers take paths, and a .gltf resolves its references in
// its own folder: this one holds nothing else), then imported. Any error is fine; a sanitizer
// report, a crash, a hang or more than the RSS limit is a finding.
#pragma once

#include <stdlib.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>

#include "importers/import.h"

namespace meshmux::fuzz {

// The folder, made on first use and removed with what it holds when the fuzzer exits normally
// (a run of -runs=N or -max_total_time; a crash leaves it, beside libFuzzer's own artifact).
// Its name lives in plain static storage, still there when exit handlers run.
inline const std::string& folder() {
  static char made[] = "/tmp/meshmux-fuzz-XXXXXX";
  static const std::string dir = [] {
    if (!mkdtemp(made)) return std::string("/tmp");
    std::atexit([] {
      std::error_code ignored;
      std::filesystem::remove_all(made, ignored);
    });
    return std::string(made);
  }();
  return dir;
}

inline void import_bytes(const uint8_t* data, size_t size, const char* name) {
  const std::string path = folder() + "/" + name;
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) return;
  if (size) std::fwrite(data, 1, size, f);
  std::fclose(f);
  Warnings warnings;
  (void)import_scene(path, ImportOptions{}, &warnings);
}

}  // namespace meshmux::fuzz
