// The framework's one thread setting and its parallel loop (docs/framework.md, "Threads").
//
// Why a small pool of std::thread and not oneTBB: every parallel loop in texdefrag is coarse (a
// texture page, an image to encode, a block of OBJ lines: tens to thousands of items of
// milliseconds each), so work stealing buys nothing; what matters is that results do not depend on
// the thread count, which this loop guarantees by construction (item i writes only its own slot,
// the caller combines slots in index order). It also adds no shared library to a process whose
// start-up cost counts (batches run thousands of small tiles).
#pragma once

#include <cstddef>
#include <functional>

namespace texdefrag {

/// Sets the number of threads parallel loops use: n >= 1 that many, 0 = every core
/// (std::thread::hardware_concurrency). Process-wide; `texdefrag run/bench/batch --threads N`.
/// Throws std::invalid_argument for n < 0.
void set_thread_count(int n);
/// The threads parallel loops use now (>= 1): the last set_thread_count, else every core.
int thread_count();
/// Hardware threads of this machine (>= 1).
int hardware_threads();

/// Calls fn(i) for every i in [0, n) on up to thread_count() threads (the calling thread is one of
/// them); items are handed out one at a time in index order, so put the biggest first when sizes
/// differ. Item 0 always runs on the calling thread (so it may call what must stay on that
/// thread, e.g. a progress callback into Python). Returns when every call has returned. When calls throw, the exception of the lowest
/// failing index is rethrown (items above it are skipped, items below it still run), so errors
/// too do not depend on the thread count.
/// Deterministic use: fn(i) writes only what belongs to item i; combine the items' results in
/// index order afterwards. With one thread (or n <= 1) every call runs on the calling thread.
void parallel_for(size_t n, const std::function<void(size_t)>& fn);

/// Same with an explicit thread count (>= 1; 0 = thread_count()).
void parallel_for(size_t n, int threads, const std::function<void(size_t)>& fn);

}  // namespace texdefrag
