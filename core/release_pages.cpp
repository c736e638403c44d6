#include "core/release_pages.h"

#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>

namespace meshmux {

void release_pages(const void* begin, size_t bytes) {
  static const uintptr_t page = uintptr_t(sysconf(_SC_PAGESIZE));
  const uintptr_t a = (uintptr_t(begin) + page - 1) / page * page;
  const uintptr_t b = (uintptr_t(begin) + bytes) / page * page;
  if (b > a) ::madvise(reinterpret_cast<void*>(a), b - a, MADV_DONTNEED);
}

}  // namespace meshmux
