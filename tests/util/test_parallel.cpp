// util/parallel.h: every item once, errors independent of the thread count, the thread setting.
#include "texdefrag/util/parallel.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

using namespace texdefrag;

namespace {
struct RestoreThreads {
  ~RestoreThreads() { set_thread_count(0); }
};
}  // namespace

TEST(Parallel, EveryItemRunsOnceForAnyThreadCount) {
  for (int threads : {1, 2, 3, 8}) {
    std::vector<std::atomic<int>> hits(1000);
    parallel_for(hits.size(), threads, [&](size_t i) { hits[i]++; });
    for (size_t i = 0; i < hits.size(); ++i) EXPECT_EQ(hits[i].load(), 1) << "item " << i << ", " << threads << " threads";
  }
  int calls = 0;
  parallel_for(0, 4, [&](size_t) { ++calls; });
  EXPECT_EQ(calls, 0);
}

TEST(Parallel, UsesSeveralThreadsWhenAsked) {
  std::mutex m;
  std::set<std::thread::id> ids;
  std::atomic<int> arrived{0};
  parallel_for(4, 4, [&](size_t) {
    {
      std::lock_guard<std::mutex> lock(m);
      ids.insert(std::this_thread::get_id());
    }
    // Wait (bounded) until a second item started: with one thread this would never happen.
    arrived++;
    for (int k = 0; k < 2000 && arrived < 2; ++k) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  });
  EXPECT_GE(ids.size(), 2u);
  ids.clear();
  parallel_for(50, 1, [&](size_t) { ids.insert(std::this_thread::get_id()); });
  ASSERT_EQ(ids.size(), 1u);
  EXPECT_EQ(*ids.begin(), std::this_thread::get_id());
}

TEST(Parallel, ItemZeroRunsOnTheCallingThread) {
  // Many times, with the pool's threads started first: item 0 is never taken by them.
  const std::thread::id caller = std::this_thread::get_id();
  for (int rep = 0; rep < 200; ++rep) {
    std::thread::id first;
    parallel_for(8, 4, [&](size_t i) {
      if (i == 0) first = std::this_thread::get_id();
    });
    ASSERT_EQ(first, caller) << "repetition " << rep;
  }
  // A failure of item 0 is still rethrown, and items above it may be skipped.
  EXPECT_THROW(parallel_for(4, 2, [](size_t i) { if (i == 0) throw std::runtime_error("item 0"); }),
               std::runtime_error);
}

TEST(Parallel, TheLowestFailingItemsErrorIsRethrownWhateverTheThreadCount) {
  for (int threads : {1, 2, 4}) {
    std::vector<std::atomic<int>> ran(200);
    try {
      parallel_for(ran.size(), threads, [&](size_t i) {
        ran[i]++;
        if (i == 37 || i == 150 || i == 151) throw std::runtime_error("item " + std::to_string(i));
      });
      ADD_FAILURE() << "no exception with " << threads << " threads";
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()), "item 37") << threads << " threads";
    }
    for (size_t i = 0; i <= 37; ++i) EXPECT_EQ(ran[i].load(), 1) << "item " << i << " below the failure must run";
  }
}

TEST(Parallel, ThreadSetting) {
  RestoreThreads restore;
  EXPECT_GE(hardware_threads(), 1);
  set_thread_count(0);
  EXPECT_EQ(thread_count(), hardware_threads());
  set_thread_count(3);
  EXPECT_EQ(thread_count(), 3);
  EXPECT_THROW(set_thread_count(-1), std::invalid_argument);
  EXPECT_EQ(thread_count(), 3);
}
