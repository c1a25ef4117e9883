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
