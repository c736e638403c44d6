// Shared by the libFuzzer targets (scripts/fuzz.sh): each input is written to a file in a
// private temporary folder (the importers take paths, and a .gltf resolves its references in
// its own folder: this one holds nothing else), then imported. Any error is fine; a sanitizer
// report, a crash, a hang or more than the RSS limit is a finding.
#pragma once

#include <stdlib.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <string>

#include "importers/import.h"

namespace meshmux::fuzz {

inline const std::string& folder() {
  static const std::string dir = [] {
    char tmpl[] = "/tmp/meshmux-fuzz-XXXXXX";
    const char* d = mkdtemp(tmpl);
    return std::string(d ? d : "/tmp");
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
