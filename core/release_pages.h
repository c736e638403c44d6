// Hands back to the OS the memory of data a caller has read for the last time while the array
// that holds it lives on: a long array consumed from the front (a merge reading many lists in
// turn) shrinks as it is read instead of only when it is freed whole.
#pragma once

#include <cstddef>

namespace meshmux {

// Drops from this process's memory the whole pages inside [begin, begin + bytes) of an array
// this process allocated (anonymous memory: the heap or a private mapping). The caller must
// never read those bytes again (they read as zeros after); the array may still be written
// elsewhere and freed as usual (the allocator keeps nothing inside an allocation in use, and the
// partial pages at either end, which hold the neighbours' data, are left alone).
// O(1) system call; nothing when the range holds no whole page. Never fails (advice only).
void release_pages(const void* begin, size_t bytes);

}  // namespace meshmux
