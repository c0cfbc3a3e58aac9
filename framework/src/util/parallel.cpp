#include "texdefrag/util/parallel.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace texdefrag {
namespace {
std::atomic<int> g_threads{0};  // 0 = every core
}  // namespace

int hardware_threads() { return static_cast<int>(std::max(1u, std::thread::hardware_concurrency())); }

void set_thread_count(int n) {
  if (n < 0) throw std::invalid_argument("threads = " + std::to_string(n) + " is negative (0 = every core)");
  g_threads = n;
}

int thread_count() {
  const int n = g_threads.load();
  return n > 0 ? n : hardware_threads();
}

void parallel_for(size_t n, const std::function<void(size_t)>& fn) { parallel_for(n, 0, fn); }

void parallel_for(size_t n, int threads, const std::function<void(size_t)>& fn) {
  if (threads <= 0) threads = thread_count();
  const size_t workers = std::min<size_t>(static_cast<size_t>(threads), n);
  if (workers <= 1) {
    for (size_t i = 0; i < n; ++i) fn(i);
    return;
  }
  // note: on a failure at item i, items below i still run and items above are skipped, so the
  // exception rethrown is always the one of the lowest failing item, whatever the thread count.
  std::atomic<size_t> next{0};
  std::atomic<size_t> first_failed{n};
  std::exception_ptr error;
  std::mutex mtx;
  const auto work = [&]() {
    for (;;) {
      const size_t i = next.fetch_add(1);
      if (i >= n || i > first_failed) return;
      try {
        fn(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mtx);
        if (i < first_failed) {
          first_failed = i;
          error = std::current_exception();
        }
      }
    }
  };
  // Item 0 is claimed before the pool starts, so it runs on the calling thread (parallel.h).
  const size_t first = next.fetch_add(1);
  std::vector<std::thread> pool;
  pool.reserve(workers - 1);
  for (size_t t = 1; t < workers; ++t) pool.emplace_back(work);
  try {
    fn(first);
  } catch (...) {
    std::lock_guard<std::mutex> lock(mtx);
    first_failed = first;
    error = std::current_exception();
  }
  work();
  for (std::thread& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace texdefrag
