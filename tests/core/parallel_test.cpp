// The one parallel-for (core/parallel.hpp).
#include <doctest/doctest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include <twinray/core/parallel.hpp>

using twinray::parallel_for;

namespace {
struct ThreadCount {
  explicit ThreadCount(int n) { twinray::set_thread_count(n); }
  ~ThreadCount() { twinray::set_thread_count(0); }
};
}  // namespace

TEST_CASE("parallel_for: every index once, for any count, grain and thread count") {
  for (int threads : {1, 2, 3, 8}) {
    ThreadCount tc(threads);
    for (int count : {0, 1, 7, 64, 1000}) {
      for (int grain : {1, 3, 64, 5000}) {
        std::vector<std::atomic<int>> seen(static_cast<size_t>(count));
        parallel_for(count, grain, [&](int i) { seen[static_cast<size_t>(i)]++; });
        int wrong = 0;
        for (auto& s : seen) wrong += s.load() != 1;
        CHECK(wrong == 0);
      }
    }
  }
}

TEST_CASE("parallel_for_blocks: consecutive blocks cover every index once") {
  for (int threads : {1, 3}) {
    ThreadCount tc(threads);
    for (size_t count : {0, 1, 7, 64, 1000}) {
      for (size_t block : {1, 3, 64, 5000}) {
        CAPTURE(count);
        CAPTURE(block);
        const size_t blocks = twinray::block_count(count, block);
        CHECK(blocks * block >= count);
        CHECK((blocks == 0 || (blocks - 1) * block < count));
        std::vector<std::atomic<int>> seen(count), calls(blocks);
        int misplaced = 0;
        std::mutex m;
        twinray::parallel_for_blocks(count, block, [&](size_t b, size_t begin, size_t end) {
          calls[b]++;
          if (begin != b * block || end != std::min(count, begin + block) || begin >= end) {
            std::lock_guard<std::mutex> lock(m);
            ++misplaced;
          }
          for (size_t i = begin; i < end; ++i) seen[i]++;
        });
        int wrong = 0;
        for (auto& s : seen) wrong += s.load() != 1;
        for (auto& c : calls) wrong += c.load() != 1;
        CHECK(wrong == 0);
        CHECK(misplaced == 0);
      }
    }
  }
}

TEST_CASE("parallel_for: uses the thread count set, and the caller is one of them") {
  ThreadCount tc(3);
  CHECK(twinray::thread_count() == 3);
  std::mutex m;
  std::set<std::thread::id> ids;
  std::atomic<int> running{0};
  std::atomic<int> most{0};
  parallel_for(60, 1, [&](int) {
    int now = ++running;
    for (int seen = most.load(); now > seen && !most.compare_exchange_weak(seen, now);) {
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    {
      std::lock_guard<std::mutex> lock(m);
      ids.insert(std::this_thread::get_id());
    }
    --running;
  });
  CHECK(ids.size() <= 3);
  CHECK(ids.size() >= 2);
  CHECK(most.load() <= 3);
  CHECK(ids.count(std::this_thread::get_id()) == 1);
}

TEST_CASE("parallel_for: the default is every hardware thread, negative counts are refused") {
  twinray::set_thread_count(0);
  unsigned hw = std::thread::hardware_concurrency();
  CHECK(twinray::thread_count() == (hw > 0 ? static_cast<int>(hw) : 1));
  CHECK_THROWS_AS(twinray::set_thread_count(-1), twinray::Error);
}

TEST_CASE("parallel_for: an exception in the body reaches the caller, after every thread ends") {
  ThreadCount tc(4);
  std::atomic<int> calls{0};
  CHECK_THROWS_WITH_AS(parallel_for(1000, 1,
                                    [&](int i) {
                                      ++calls;
                                      if (i == 10) throw std::runtime_error("body failed");
                                      std::this_thread::sleep_for(std::chrono::microseconds(200));
                                    }),
                       "body failed", std::runtime_error);
  CHECK(calls.load() < 1000);  // the rest of the work was skipped
}

TEST_CASE("parallel_for: nested calls finish") {
  ThreadCount tc(2);
  std::atomic<int> total{0};
  parallel_for(4, 1, [&](int) { parallel_for(50, 5, [&](int) { ++total; }); });
  CHECK(total.load() == 200);
}
