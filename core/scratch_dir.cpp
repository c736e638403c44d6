// Private temporary folders (see core/scratch_dir.h).
#include "core/scratch_dir.h"

#include <stdlib.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <vector>

namespace meshmux {

Result<ScratchDir> ScratchDir::create(const std::string& what) {
  const char* env = std::getenv("TMPDIR");
  std::string base = env && *env ? env : "/tmp";
  std::string pattern = base + "/meshmux-" + what + "-XXXXXX";
  std::vector<char> name(pattern.begin(), pattern.end());
  name.push_back('\0');
  if (!mkdtemp(name.data()))  // mode 0700
    return Status::error(
        "cannot create a temporary folder in " + base + ": " + std::strerror(errno),
        ErrorKind::kOutput);
  ScratchDir dir;
  dir.path_ = name.data();
  return dir;
}

ScratchDir::ScratchDir(ScratchDir&& other) noexcept : path_(std::move(other.path_)) {
  other.path_.clear();
}

ScratchDir& ScratchDir::operator=(ScratchDir&& other) noexcept {
  if (this != &other) {
    this->~ScratchDir();
    path_ = std::move(other.path_);
    other.path_.clear();
  }
  return *this;
}

ScratchDir::~ScratchDir() {
  if (path_.empty()) return;
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

}  // namespace meshmux
