// Deduplication on every core: for each of n items, the first item equal to it. Welding
// (equal vertices) and duplicate removal (equal triangles) ask exactly this; one hash table over
// all items (10M vertices: 400 MB) spent its time in cache misses on one core.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/key_table.h"
#include "core/parallel.h"

namespace meshmux {

// rep[i] = the smallest j ≤ i with same(j, i), for items 0 .. hash.size() − 1 (< 2³² − 1) whose
// 64-bit hashes are `hash` (equal items must have equal hashes; same(i, i) need not hold: an item
// nothing equals is its own). Items are split into buckets by their hashes' top bits, and each
// bucket is scanned in item order with a table of its own (a few MB: in cache) on every core, so
// the result is the serial scan's whatever the bucket and thread counts. `same` is called from
// several threads at once and must only read. Memory: 4 bytes per item besides the hashes and
// the result; O(n) expected time.
template <class Same>
std::vector<uint32_t> first_equal(const std::vector<uint64_t>& hash, const Same& same) {
  const size_t n = hash.size();
  std::vector<uint32_t> rep(n);
  // Buckets of ~64k items (a table of 1.5 MB), at most 2^12.
  int bits = 0;
  while (bits < 12 && (n >> bits) > (size_t(1) << 16)) ++bits;
  const size_t buckets = size_t(1) << bits;
  auto bucket_of = [&](uint64_t h) { return bits == 0 ? size_t(0) : size_t(h >> (64 - bits)); };
  std::vector<uint32_t> start(buckets + 1, 0), items(n);
  for (uint64_t h : hash) ++start[bucket_of(h) + 1];
  for (size_t b = 0; b < buckets; ++b) start[b + 1] += start[b];
  {
    std::vector<uint32_t> at(start.begin(), start.end() - 1);
    for (size_t i = 0; i < n; ++i) items[at[bucket_of(hash[i])]++] = uint32_t(i);
  }
  parallel_chunks(buckets, 1, [&](size_t begin, size_t end) {
    for (size_t b = begin; b < end; ++b) {
      KeyTable table(start[b + 1] - start[b]);
      for (uint32_t k = start[b]; k < start[b + 1]; ++k) {
        const uint32_t i = items[k];
        const uint32_t j = table.find(hash[i], [&](uint32_t c) { return same(c, i); });
        if (j != KeyTable::kEmpty) {
          rep[i] = j;
        } else {
          rep[i] = i;
          table.insert(hash[i], i);
        }
      }
    }
  });
  return rep;
}

}  // namespace meshmux
