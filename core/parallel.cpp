// Chunked parallel loops (see parallel.h).
#include "core/parallel.h"

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace meshmux {

int worker_threads() {
  if (const char* e = std::getenv("MESHMUX_THREADS")) {
    const long v = std::strtol(e, nullptr, 10);
    if (v >= 1) return int(std::min(v, 64L));
  }
  return int(std::clamp(std::thread::hardware_concurrency(), 1u, 64u));
}

void parallel_chunks(size_t n, size_t chunk, const std::function<void(size_t, size_t)>& f) {
  chunk = std::max<size_t>(1, chunk);
  const size_t chunks = (n + chunk - 1) / chunk;
  const size_t threads = std::min<size_t>(size_t(worker_threads()), chunks);
  if (threads <= 1) {  // the same chunks, in order: a caller may size its work by them
    for (size_t c = 0; c < chunks; ++c) f(c * chunk, std::min(n, (c + 1) * chunk));
    return;
  }
  std::atomic<size_t> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto work = [&] {
    try {
      for (size_t c; !failed && (c = next.fetch_add(1)) < chunks;)
        f(c * chunk, std::min(n, (c + 1) * chunk));
    } catch (...) {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
      failed = true;
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(threads - 1);
  try {
    for (size_t t = 1; t < threads; ++t) pool.emplace_back(work);
  } catch (const std::system_error&) {
    // No more threads to be had (a process or memory limit): the ones started and this one do it.
  }
  work();
  for (std::thread& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

Background::Background(std::function<void()> f) : f_(std::move(f)) {
  try {
    thread_ = std::thread([this] { run(); });
  } catch (const std::system_error&) {  // no thread to be had: here, now
    run();
  }
}

Background::~Background() {
  if (thread_.joinable()) thread_.join();
}

void Background::run() {
  try {
    f_();
  } catch (...) {
    error_ = std::current_exception();
  }
}

void Background::wait() {
  if (thread_.joinable()) thread_.join();
  if (error_) {
    std::exception_ptr e = error_;
    error_ = nullptr;
    std::rethrow_exception(e);
  }
}

}  // namespace meshmux
