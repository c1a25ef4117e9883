// Large arrays in huge pages (core/large_array.hpp).
#include <doctest/doctest.h>

#include <cstdint>

#include <twinray/core/large_array.hpp>

#include "support/page_flags.hpp"

TEST_CASE("a large array is mapped on a huge-page boundary and asks for huge pages") {
  if (!twinray::detail::kMapsHugePages || !twinray_test::page_flags_known()) {
    MESSAGE("skipped: no transparent huge pages or no /proc/self/smaps here");
    return;
  }
  const size_t n = twinray::kHugePageBytes / sizeof(float) + 1;  // just over one huge page
  twinray::LargeVector<float> big(n, 1.5f);
  CHECK(reinterpret_cast<std::uintptr_t>(big.data()) % twinray::kHugePageBytes == 0);
  CHECK(twinray_test::advised_huge(big.data()));
  CHECK(twinray_test::advised_huge(big.data() + n - 1));  // the whole array, to its last element
  CHECK(big[n - 1] == 1.5f);

  twinray::LargeVector<float> small(1000, 2.0f);
  CHECK_FALSE(twinray::LargeArrayAllocator<float>::maps(small.size()));
  CHECK(small[999] == 2.0f);
}

TEST_CASE("a large array keeps its elements as it grows past the huge-page size and back") {
  twinray::LargeVector<int> v;
  const int n = static_cast<int>(3 * twinray::kHugePageBytes / sizeof(int));
  for (int i = 0; i < n; ++i) v.push_back(i);  // from operator new into mappings
  bool same = true;
  for (int i = 0; i < n; ++i) same = same && v[static_cast<size_t>(i)] == i;
  CHECK(same);
  v.resize(10);
  v.shrink_to_fit();  // back to operator new
  CHECK(v.size() == 10);
  CHECK(v[9] == 9);
  twinray::LargeVector<int> copy = v;
  CHECK(copy == v);
}

#if defined(__linux__)
#include <sys/mman.h>
#include <unistd.h>

#include <mutex>
#include <vector>

#include <twinray/core/parallel.hpp>

namespace {

// Whether every page of [p, p + bytes) is resident (mincore(2)): pages a fresh mapping
// has not yet written are not, so a resident range that nothing wrote was recycled.
bool resident(const void* p, size_t bytes) {
  const size_t page = static_cast<size_t>(sysconf(_SC_PAGESIZE));
  std::vector<unsigned char> in((bytes + page - 1) / page);
  if (mincore(const_cast<void*>(p), bytes, in.data()) != 0) return false;
  for (unsigned char c : in)
    if (!(c & 1)) return false;
  return true;
}

constexpr size_t kMiB = size_t(1) << 20;

}  // namespace

TEST_CASE("outside a recycling scope a freed large array is unmapped, and a new one is fresh") {
  if (!twinray::detail::kMapsHugePages) return;
  { twinray::LargeVector<char> a(4 * kMiB, 'a'); }
  CHECK(twinray::detail::recycled_bytes_kept() == 0);
  twinray::LargeVector<char> b;
  b.reserve(4 * kMiB);
  CHECK_FALSE(resident(b.data(), 4 * kMiB));  // nothing has written it yet
}

TEST_CASE("inside a recycling scope freed large arrays serve the next ones, resident") {
  if (!twinray::detail::kMapsHugePages) return;
  {
    twinray::LargeArrayRecycling recycling;
    const char* first = nullptr;
    {
      twinray::LargeVector<char> a(6 * kMiB, 'a');
      first = a.data();
    }
    CHECK(twinray::detail::recycled_bytes_kept() == 6 * kMiB);

    // A smaller array takes the head of the kept mapping, its pages already there.
    twinray::LargeVector<char> b;
    b.reserve(4 * kMiB);
    CHECK(b.data() == first);
    CHECK(resident(b.data(), 4 * kMiB));
    CHECK(twinray::detail::recycled_bytes_kept() == 2 * kMiB);

    // Larger ones than any kept mapping: the kept ones are moved side by side into
    // them (c takes the 2 MiB left of a, and 2 fresh).
    {
      twinray::LargeVector<char> c(4 * kMiB, 'c'), d(4 * kMiB, 'd');
      CHECK(twinray::detail::recycled_bytes_kept() == 0);
    }
    CHECK(twinray::detail::recycled_bytes_kept() == 8 * kMiB);
    twinray::LargeVector<char> e;
    e.reserve(12 * kMiB);
    CHECK(reinterpret_cast<std::uintptr_t>(e.data()) % twinray::kHugePageBytes == 0);
    CHECK(resident(e.data(), 8 * kMiB));  // c's and d's pages, moved in
    CHECK(twinray::detail::recycled_bytes_kept() == 0);
    if (twinray_test::page_flags_known()) {
      CHECK(twinray_test::advised_huge(e.data()));
      CHECK(twinray_test::advised_huge(e.data() + 12 * kMiB - 1));
    }
    e.assign(12 * kMiB, 'e');  // writable to its end, the fresh part included
    CHECK(e[12 * kMiB - 1] == 'e');

    // An array freed in the scope is kept until the scope closes.
    b = twinray::LargeVector<char>();
    CHECK(twinray::detail::recycled_bytes_kept() == 4 * kMiB);
  }
  CHECK(twinray::detail::recycled_bytes_kept() == 0);
}

TEST_CASE("a fresh large array is faulted in as it is made, except inside a parallel_for body") {
  if (!twinray::detail::kMapsHugePages) return;
  const size_t big = twinray::detail::kFaultInBytes;
  {
    twinray::LargeVector<char> a;
    a.reserve(big);  // nothing writes it
    CHECK(resident(a.data(), big));
  }
  {
    twinray::LargeVector<char> below;  // smaller ones fault as they are written
    below.reserve(big - twinray::kHugePageBytes);
    CHECK_FALSE(resident(below.data(), big - twinray::kHugePageBytes));
  }
  // Inside a parallel_for body (the build's subtrees), on one thread or on several, the
  // thread that writes the array faults it.
  for (int threads : {1, 2}) {
    twinray::set_thread_count(threads);
    bool any_resident = false;
    std::mutex m;
    twinray::parallel_for(2, 1, [&](int) {
      twinray::LargeVector<char> inside;
      inside.reserve(big);
      const bool r = resident(inside.data(), big);
      std::lock_guard<std::mutex> lock(m);
      any_resident = any_resident || r;
    });
    CHECK_FALSE(any_resident);
  }
  twinray::set_thread_count(0);
  // After the body, the flag is back: a fresh array is faulted in again.
  twinray::LargeVector<char> after;
  after.reserve(big);
  CHECK(resident(after.data(), big));
}

TEST_CASE("the fresh part of a recycled range is faulted in as it is made") {
  if (!twinray::detail::kMapsHugePages) return;
  twinray::LargeArrayRecycling recycling;
  { twinray::LargeVector<char> a(2 * kMiB, 'a'); }
  REQUIRE(twinray::detail::recycled_bytes_kept() == 2 * kMiB);
  const size_t size = 2 * kMiB + twinray::detail::kFaultInBytes;
  twinray::LargeVector<char> b;
  b.reserve(size);  // a's 2 MiB moved in, the rest fresh
  CHECK(twinray::detail::recycled_bytes_kept() == 0);
  CHECK(resident(b.data(), size));
  b.assign(size, 'b');
  CHECK(b[size - 1] == 'b');
}

TEST_CASE("recycling scopes nest: what is kept is unmapped when the last one closes") {
  if (!twinray::detail::kMapsHugePages) return;
  {
    twinray::LargeArrayRecycling outer;
    {
      twinray::LargeArrayRecycling inner;
      twinray::LargeVector<char> a(2 * kMiB, 'a');
    }
    CHECK(twinray::detail::recycled_bytes_kept() == 2 * kMiB);
  }
  CHECK(twinray::detail::recycled_bytes_kept() == 0);
}
#endif
