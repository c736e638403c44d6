// core/release_pages.h: a merge hands back the pages of lists it has read for the last time
// while the lists live on. Only the whole pages inside the range go (they read as zeros after);
// the partial pages at its ends, which may hold data still to be read, and everything past it
// keep their values, and the array is written and freed as usual afterwards.
#include "core/release_pages.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <vector>

namespace meshmux {
namespace {

TEST(ReleasePages, DropsOnlyTheWholePagesInsideTheRange) {
  const size_t page = size_t(sysconf(_SC_PAGESIZE));
  std::vector<uint8_t> v(64 * page + 100, 7);  // a big allocation: its own anonymous mapping
  const size_t start = 100, end = 40 * page + 50;  // neither end on a page boundary
  release_pages(v.data() + start, end - start);
  const uintptr_t base = uintptr_t(v.data());
  size_t zeros = 0;
  for (size_t i = 0; i < v.size(); ++i) {
    const uintptr_t a = base + i;
    const bool whole_page_inside =
        a / page * page >= base + start && (a / page + 1) * page <= base + end;
    if (whole_page_inside) {
      ASSERT_EQ(v[i], 0) << "byte " << i;
      ++zeros;
    } else {
      ASSERT_EQ(v[i], 7) << "byte " << i;
    }
  }
  EXPECT_GE(zeros, 38 * page);  // ~39 whole pages in the range
  v[start + page] = 9;          // still the caller's memory
  EXPECT_EQ(v[start + page], 9);
}

TEST(ReleasePages, ARangeWithoutAWholePageChangesNothing) {
  std::vector<uint32_t> v(4096, 5);
  release_pages(v.data() + 1, 100);
  release_pages(v.data(), 0);
  release_pages(nullptr, 0);
  for (uint32_t x : v) ASSERT_EQ(x, 5u);
}

}  // namespace
}  // namespace meshmux
