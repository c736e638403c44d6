// core/parallel.h: chunked loops and background tasks, the pieces every stage's use of the
// cores rests on (outputs may not depend on the thread count).
#include "core/parallel.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <stdexcept>
#include <vector>

namespace meshmux {
namespace {

// Why: every stage that splits work relies on each index being visited exactly once, whatever
// the thread count and however the chunks fall (the last one short here).
TEST(ParallelChunks, VisitsEveryIndexOnce) {
  std::vector<std::atomic<int>> seen(10007);
  parallel_chunks(seen.size(), 64, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) ++seen[i];
  });
  for (size_t i = 0; i < seen.size(); ++i) ASSERT_EQ(seen[i].load(), 1) << i;
}

// Why: a caller may size its work by the chunk it is handed (one row band, one piece of a PNG,
// one texel row of a table); one thread must hand over the same chunks as many, or such a caller
// does only its first chunk's work where MESHMUX_THREADS=1 (a renderer's lighting table once
// computed one row of sixteen there, and the package differed between 1 and 3 threads).
TEST(ParallelChunks, OneThreadGetsTheSameChunksAsMany) {
  auto chunks = [](const char* threads) {
    setenv("MESHMUX_THREADS", threads, 1);
    std::vector<std::atomic<int>> calls(100);  // per begin
    parallel_chunks(1000, 10, [&](size_t begin, size_t end) {
      EXPECT_EQ(end - begin, 10u);
      ++calls[begin / 10];
    });
    unsetenv("MESHMUX_THREADS");
    std::vector<int> out;
    for (const auto& c : calls) out.push_back(c.load());
    return out;
  };
  const std::vector<int> one = chunks("1");
  EXPECT_EQ(one, std::vector<int>(100, 1));
  EXPECT_EQ(one, chunks("3"));
}

// Why: an exception in a worker (out of memory in a bake) must reach the caller, not end the
// process.
TEST(ParallelChunks, RethrowsAWorkersException) {
  EXPECT_THROW(parallel_chunks(1000, 10,
                               [](size_t begin, size_t) {
                                 if (begin == 500) throw std::runtime_error("chunk 50");
                               }),
               std::runtime_error);
}

// Why: convert encodes model.glb and the multiplexer its mesh layers beside other work; the
// result must be there after wait(), and a failure on the thread must surface at wait().
TEST(Background, ResultIsThereAfterWaitAndExceptionsSurface) {
  int value = 0;
  Background task([&] { value = 42; });
  task.wait();
  EXPECT_EQ(value, 42);
  Background failing([] { throw std::runtime_error("out of memory"); });
  EXPECT_THROW(failing.wait(), std::runtime_error);
  EXPECT_NO_THROW(failing.wait());  // rethrown once
}

// Why: a caller that returns early (an error before it waits) must not leave the thread running
// over its locals: the destructor joins.
TEST(Background, DestructorJoins) {
  std::atomic<bool> done{false};
  {
    Background task([&] {
      volatile double x = 0;
      for (int i = 0; i < 2000000; ++i) x = x + 1;
      done = true;
    });
  }
  EXPECT_TRUE(done.load());
}

}  // namespace
}  // namespace meshmux
