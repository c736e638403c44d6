// Files that big stages set data aside in while they do not need it in memory (the simplifier's
// block levels at 20M triangles: quadrics, corners, the input's vertex attributes). The file is
// unnamed (O_TMPFILE, else a name unlinked at once), so it is gone when the process ends,
// however it ends; its pages live in the OS's cache, not in this process's memory.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace meshmux {

// Pages of a file mapped into memory (SpillFile::map): unmapped when the last owner goes.
// drop() takes them out of this process's memory; their contents stay in the file, read back
// on the next access. Safe while other threads use them.
struct MappedPages {
  void* base = nullptr;
  size_t bytes = 0;
  MappedPages() = default;
  MappedPages(const MappedPages&) = delete;
  MappedPages& operator=(const MappedPages&) = delete;
  ~MappedPages();
  void drop() const;
};

// An unnamed file in `dir`. An empty dir or one where no file can be made gives a file that is
// not ok(): callers then keep their data in memory (the file is an economy, not a need).
class SpillFile {
 public:
  static constexpr uint64_t kFailed = UINT64_MAX;
  explicit SpillFile(const std::string& dir);
  ~SpillFile();
  SpillFile(const SpillFile&) = delete;
  SpillFile& operator=(const SpillFile&) = delete;
  bool ok() const { return fd_ >= 0; }
  uint64_t size() const { return end_; }  // bytes handed out
  // Writes n bytes at a fresh offset (any thread, at once); the offset, or kFailed.
  uint64_t put(const void* data, size_t n);
  // Reads n bytes at `at` (written by put); throws std::runtime_error where the file cannot
  // be read back.
  void get(uint64_t at, void* data, size_t n) const;
  // The file (a fresh one: nothing put) made `bytes` long, its blocks allocated (a full disk
  // fails here, not as a fault on a later write), and mapped shared; null where any step fails.
  std::shared_ptr<MappedPages> map(size_t bytes);

  // A vector's values put (its size is the caller's to keep); kFailed as put.
  template <typename T>
  uint64_t put_all(const std::vector<T>& v) {
    return v.empty() ? 0 : put(v.data(), v.size() * sizeof(T));
  }
  // ... and read back into a vector of n values.
  template <typename T>
  void get_all(uint64_t at, size_t n, std::vector<T>& v) const {
    v.resize(n);
    if (n > 0) get(at, v.data(), n * sizeof(T));
  }

 private:
  int fd_ = -1;
  std::atomic<uint64_t> end_{0};
};

}  // namespace meshmux
