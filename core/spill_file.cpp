#include "core/spill_file.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/types.h>
#include <unistd.h>

#include <stdexcept>

namespace meshmux {

MappedPages::~MappedPages() {
  if (base) ::munmap(base, bytes);
}

void MappedPages::drop() const {
  if (base) ::madvise(base, bytes, MADV_DONTNEED);
}

SpillFile::SpillFile(const std::string& dir) {
  if (dir.empty()) return;
  fd_ = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
  if (fd_ >= 0) return;
  std::string name = dir + "/.meshmux-spill-XXXXXX";
  fd_ = ::mkostemp(name.data(), O_CLOEXEC);
  if (fd_ >= 0) ::unlink(name.c_str());
}

SpillFile::~SpillFile() {
  if (fd_ >= 0) ::close(fd_);
}

uint64_t SpillFile::put(const void* data, size_t n) {
  if (fd_ < 0) return kFailed;
  const uint64_t at = end_.fetch_add(n);
  for (size_t done = 0; done < n;) {
    const ssize_t w =
        ::pwrite(fd_, static_cast<const char*>(data) + done, n - done, off_t(at + done));
    if (w <= 0) return kFailed;
    done += size_t(w);
  }
  return at;
}

void SpillFile::get(uint64_t at, void* data, size_t n) const {
  for (size_t done = 0; done < n;) {
    const ssize_t r = ::pread(fd_, static_cast<char*>(data) + done, n - done, off_t(at + done));
    if (r <= 0) throw std::runtime_error("a spill file could not be read back");
    done += size_t(r);
  }
}

std::shared_ptr<MappedPages> SpillFile::map(size_t bytes) {
  if (fd_ < 0 || bytes == 0 || end_ != 0 || ::posix_fallocate(fd_, 0, off_t(bytes)) != 0)
    return nullptr;
  void* base = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED, fd_, 0);
  if (base == MAP_FAILED) return nullptr;
  auto pages = std::make_shared<MappedPages>();
  pages->base = base, pages->bytes = bytes;
  end_ = bytes;
  return pages;
}

}  // namespace meshmux
