// Large arrays in 2 MiB pages: the allocator of the packed scene, the BVH and the
// builder's records.
//
// A BVH walk and the SAH builder read tens of megabytes in an order no prefetcher
// follows, and with 4 KiB pages most of those reads also miss the TLB. Linux backs
// memory with transparent huge pages only where the program asks for them
// (madvise(MADV_HUGEPAGE)) when THP is in "madvise" mode, Debian's default. So an
// array of at least kHugePageBytes is mapped on its own, aligned to 2 MiB and marked;
// Embree asks for huge pages the same way for its BVH. The BVH builds of the 1e6
// benchmark scenes take a tenth to a fifth less time (docs/performance.md, "Huge
// pages"). Smaller arrays, and every array on other systems, come from operator new.
//
// The array's bytes are the same either way; only the page size under them changes,
// so no image or tree depends on it.
#pragma once

#include <cstddef>
#include <new>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace twinray {

// Arrays this large or larger are mapped in huge pages (where the system has them).
inline constexpr std::size_t kHugePageBytes = std::size_t(2) << 20;

namespace detail {

#if defined(__linux__) && defined(MADV_HUGEPAGE)
// `bytes` rounded up to whole huge pages, from a mapping of its own that starts on a
// huge-page boundary (the unaligned head and tail of a larger mapping are returned).
inline void* map_huge(std::size_t bytes) {
  const std::size_t size = (bytes + kHugePageBytes - 1) & ~(kHugePageBytes - 1);
  void* raw = mmap(nullptr, size + kHugePageBytes, PROT_READ | PROT_WRITE,
                   MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) throw std::bad_alloc();
  const std::size_t start = reinterpret_cast<std::size_t>(raw);
  const std::size_t aligned = (start + kHugePageBytes - 1) & ~(kHugePageBytes - 1);
  if (aligned > start) munmap(raw, aligned - start);
  const std::size_t tail = start + size + kHugePageBytes - (aligned + size);
  if (tail > 0) munmap(reinterpret_cast<void*>(aligned + size), tail);
  void* p = reinterpret_cast<void*>(aligned);
  madvise(p, size, MADV_HUGEPAGE);  // a hint: without THP the pages stay 4 KiB
  return p;
}
inline void unmap_huge(void* p, std::size_t bytes) {
  munmap(p, (bytes + kHugePageBytes - 1) & ~(kHugePageBytes - 1));
}
inline constexpr bool kMapsHugePages = true;
#else
inline void* map_huge(std::size_t) {
  throw std::bad_alloc();
}
inline void unmap_huge(void*, std::size_t) {}
inline constexpr bool kMapsHugePages = false;
#endif

}  // namespace detail

// A std::allocator that maps arrays of kHugePageBytes or more in huge pages.
template <class T>
struct LargeArrayAllocator {
  using value_type = T;

  LargeArrayAllocator() = default;
  template <class U>
  LargeArrayAllocator(const LargeArrayAllocator<U>&) noexcept {}

  // Whether an array of n elements gets a mapping of its own.
  static bool maps(std::size_t n) {
    return detail::kMapsHugePages && n >= kHugePageBytes / sizeof(T);
  }

  T* allocate(std::size_t n) {
    if (n > static_cast<std::size_t>(-1) / sizeof(T)) throw std::bad_array_new_length();
    if (maps(n)) return static_cast<T*>(detail::map_huge(n * sizeof(T)));
    return static_cast<T*>(::operator new(n * sizeof(T), std::align_val_t(alignof(T))));
  }
  void deallocate(T* p, std::size_t n) noexcept {
    if (maps(n))
      detail::unmap_huge(p, n * sizeof(T));
    else
      ::operator delete(p, std::align_val_t(alignof(T)));
  }

  template <class U>
  friend bool operator==(const LargeArrayAllocator&, const LargeArrayAllocator<U>&) {
    return true;
  }
  template <class U>
  friend bool operator!=(const LargeArrayAllocator&, const LargeArrayAllocator<U>&) {
    return false;
  }
};

// The vector of the packed scene's and the BVH's arrays.
template <class T>
using LargeVector = std::vector<T, LargeArrayAllocator<T>>;

}  // namespace twinray
