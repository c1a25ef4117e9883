// The one parallel-for of the host side: the CPU backend's tiles, the adaptive passes,
// the BVH build and the benchmarks' ray counts all run through parallel_for().
//
// The thread count is set once for the process with set_thread_count() (0, the
// default: every hardware thread). Each call starts its workers and joins them before
// it returns; the calling thread works too. Starting a few threads costs tens of
// microseconds, far below one frame, and a call that holds no threads between calls
// cannot deadlock when a worker calls parallel_for again (the BVH build does). Work is
// handed out in chunks of `grain` indices from one atomic counter, so items of uneven
// cost (tiles with and without geometry) balance by themselves.
//
// No result may depend on the thread count: callers write to disjoint outputs, or
// combine per-chunk results in index order.
#pragma once

#include <algorithm>
#include <cstddef>
#include <atomic>
#include <exception>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <twinray/core/error.hpp>

namespace twinray {

namespace detail {
inline std::atomic<int>& thread_count_setting() {
  static std::atomic<int> setting{0};
  return setting;
}
// Whether this thread is running a parallel_for's body (as a worker, or as the caller
// that works too): large arrays made there are not faulted in on every thread
// (core/large_array.hpp).
inline bool& in_parallel_body() {
  thread_local bool inside = false;
  return inside;
}

// Marks this thread as running a parallel_for's body until it goes out of scope.
class ParallelBodyScope {
 public:
  ParallelBodyScope() : was_inside_(in_parallel_body()) { in_parallel_body() = true; }
  ~ParallelBodyScope() { in_parallel_body() = was_inside_; }
  ParallelBodyScope(const ParallelBodyScope&) = delete;
  ParallelBodyScope& operator=(const ParallelBodyScope&) = delete;

 private:
  bool was_inside_;
};
}  // namespace detail

// Threads every parallel_for uses from now on; 0: all hardware threads.
inline void set_thread_count(int threads) {
  if (threads < 0)
    throw invalid_input("threads: must be >= 0 (0 = all cores), got " + std::to_string(threads));
  detail::thread_count_setting().store(threads);
}

// The thread count in force: the setting, or the hardware's when it is 0.
inline int thread_count() {
  int n = detail::thread_count_setting().load();
  if (n > 0) return n;
  unsigned hw = std::thread::hardware_concurrency();
  return hw > 0 ? static_cast<int>(hw) : 1;
}

// Calls body(i) for every i in [0, count), in chunks of `grain` consecutive indices
// handed out dynamically to at most thread_count() threads (the caller among them).
// Returns when every call has returned. If calls throw, the rest of the work is
// skipped and the first exception is rethrown here.
template <class Body>
void parallel_for(int count, int grain, Body&& body) {
  if (count <= 0) return;
  grain = std::max(1, grain);
  const int chunks = (count - 1) / grain + 1;
  const int workers = std::min(thread_count(), chunks);
  if (workers <= 1) {
    detail::ParallelBodyScope inside;
    for (int i = 0; i < count; ++i) body(i);
    return;
  }
  std::atomic<int> next{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto work = [&]() {
    detail::ParallelBodyScope inside;
    try {
      for (int begin; !failed.load(std::memory_order_relaxed) &&
                      (begin = next.fetch_add(grain, std::memory_order_relaxed)) < count;)
        for (int i = begin, end = std::min(count, begin + grain); i < end; ++i) body(i);
    } catch (...) {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
      failed.store(true);
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(static_cast<size_t>(workers - 1));
  for (int t = 1; t < workers; ++t) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

// How many blocks of `block` consecutive indices cover [0, count).
inline size_t block_count(size_t count, size_t block) {
  return (count + block - 1) / block;
}

// Calls body(b, begin, end) for each block b = [begin, end) of `block` consecutive
// indices covering [0, count) (the last one may be shorter), on parallel_for's threads:
// for passes that keep one result per block and combine them in block order.
template <class Body>
void parallel_for_blocks(size_t count, size_t block, Body&& body) {
  parallel_for(static_cast<int>(block_count(count, block)), 1, [&](int b) {
    const size_t begin = static_cast<size_t>(b) * block;
    body(static_cast<size_t>(b), begin, std::min(count, begin + block));
  });
}

}  // namespace twinray
