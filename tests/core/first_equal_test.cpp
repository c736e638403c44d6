// Deduplication on every core: each item's first equal item, as one serial scan finds it, over
// inputs large enough to be split into many buckets.
#include "core/first_equal.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <map>

namespace meshmux {
namespace {

// 300k items of 40k distinct values; the hash keeps only value % 997, so most items share a
// hash with unequal ones (the equality test must tell them apart) and hashes spread over buckets
// by their top bits.
struct Items {
  std::vector<uint32_t> value;
  std::vector<uint64_t> hash;
};

Items colliding_items(size_t n) {
  Items it;
  uint32_t state = 7;
  for (size_t i = 0; i < n; ++i) {
    state = state * 1664525u + 1013904223u;
    it.value.push_back(state % 40000);
    it.hash.push_back(uint64_t(it.value.back() % 997) * 0x9E3779B97F4A7C15ull);
  }
  return it;
}

TEST(FirstEqual, EveryItemGetsTheFirstItemEqualToIt) {
  const Items it = colliding_items(300000);
  const std::vector<uint32_t> rep =
      first_equal(it.hash, [&](uint32_t a, uint32_t b) { return it.value[a] == it.value[b]; });
  std::map<uint32_t, uint32_t> first;  // value → its first item
  for (uint32_t i = 0; i < it.value.size(); ++i) {
    first.emplace(it.value[i], i);
    ASSERT_EQ(rep[i], first[it.value[i]]) << "item " << i;
  }
}

// The buckets are scanned on every core: one thread or several, the same answer.
TEST(FirstEqual, SameAnswerWhateverTheThreadCount) {
  const Items it = colliding_items(200000);
  auto run = [&](const char* threads) {
    setenv("MESHMUX_THREADS", threads, 1);
    auto rep =
        first_equal(it.hash, [&](uint32_t a, uint32_t b) { return it.value[a] == it.value[b]; });
    unsetenv("MESHMUX_THREADS");
    return rep;
  };
  EXPECT_EQ(run("1"), run("3"));
}

// An item that nothing equals (a degenerate triangle among duplicates) is its own first, and
// later items equal to one before it skip it.
TEST(FirstEqual, ItemsThatEqualNothingAreTheirOwn) {
  const std::vector<uint64_t> hash(6, 42);
  const std::vector<bool> excluded = {true, false, true, false, false, true};
  const std::vector<uint32_t> rep =
      first_equal(hash, [&](uint32_t a, uint32_t b) { return !excluded[a] && !excluded[b]; });
  EXPECT_EQ(rep, (std::vector<uint32_t>{0, 1, 2, 1, 1, 5}));
}

}  // namespace
}  // namespace meshmux
