// Independent work on both cores (and more): a range split into chunks that threads take in
// turn. The caller's function writes only its own part of the output, so the result is the
// same whatever the thread count and the order chunks ran in (deterministic output).
#pragma once

#include <cstddef>
#include <exception>
#include <functional>
#include <thread>

namespace meshmux {

// Threads for such work: MESHMUX_THREADS when set (meshmux batch gives each conversion its
// share of the cores), else the machine's cores; at least 1, at most 64.
int worker_threads();

// Calls f(begin, end) for consecutive chunks of `chunk` items covering [0, n), on up to
// worker_threads() threads (the caller's own among them); the same chunks on one thread as on
// many. An exception thrown by f stops the
// remaining chunks and is rethrown here (the first one). O(n / chunk) scheduling.
void parallel_chunks(size_t n, size_t chunk, const std::function<void(size_t, size_t)>& f);

// Runs f on a thread of its own, beside the caller's work (for instance model.glb's encoding
// beside the simplifier), or at once on the caller's thread when no thread can be had. wait()
// joins it and rethrows what f threw; the destructor joins too, so no way out of the caller's
// scope leaves it running. f must only read what the caller touches meanwhile.
class Background {
 public:
  explicit Background(std::function<void()> f);
  ~Background();
  Background(const Background&) = delete;
  Background& operator=(const Background&) = delete;
  void wait();

 private:
  void run();
  std::function<void()> f_;
  std::thread thread_;
  std::exception_ptr error_;
};

}  // namespace meshmux
