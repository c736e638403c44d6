// An open-addressing table of (64-bit key, 32-bit value) entries for welding and deduplication:
// several entries may share a key (the caller tells them apart), find() returns the first
// whose value `same` accepts. Sized once for `capacity` insertions (load ≤ 1/2, linear
// probing); two flat arrays, where a node-based hash map (std::unordered_map, a heap block per
// entry) spent most of the welding's time allocating. Deterministic: find() and insert() depend
// only on the keys and the insertion order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace meshmux {

class KeyTable {
 public:
  // Room for `capacity` insertions; more would loop forever in insert(), so callers size it
  // for the most they can insert. Memory: 12 bytes per slot, 2 to 4 slots per capacity.
  explicit KeyTable(size_t capacity) {
    size_t n = 16;
    while (n < 2 * capacity) n *= 2;
    keys_.assign(n, 0);
    values_.assign(n, kEmpty);
    mask_ = n - 1;
  }
  // The first value with this key that same(value) accepts, else kEmpty. O(1) expected.
  template <class Same>
  uint32_t find(uint64_t key, const Same& same) const {
    for (size_t i = slot(key); values_[i] != kEmpty; i = (i + 1) & mask_)
      if (keys_[i] == key && same(values_[i])) return values_[i];
    return kEmpty;
  }
  // Adds (key, value); value must not be kEmpty.
  void insert(uint64_t key, uint32_t value) {
    size_t i = slot(key);
    while (values_[i] != kEmpty) i = (i + 1) & mask_;
    keys_[i] = key, values_[i] = value;
  }
  static constexpr uint32_t kEmpty = UINT32_MAX;

 private:
  size_t slot(uint64_t key) const {
    key ^= key >> 33;
    key *= 0xFF51AFD7ED558CCDull;
    key ^= key >> 33;
    return size_t(key) & mask_;
  }
  std::vector<uint64_t> keys_;
  std::vector<uint32_t> values_;
  size_t mask_ = 0;
};

}  // namespace meshmux
