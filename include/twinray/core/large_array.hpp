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
//
// Recycling. The first write to a page costs a page fault, and the kernel zeroes the
// page; for 2 MiB pages it may first compact memory to find one. The BVH build frees
// arrays (the builder's records, its binary nodes) just before it asks for others of
// the same order (the wide nodes, the leaf-ordered primitives), and a fresh mapping
// faults every page in again: on a VM each MiB took 0.1-3.4 ms, a third of a
// 1e6-triangle build. While a LargeArrayRecycling scope is open (pack_scene holds
// one), freed mappings are kept, resident, and handed to the next large arrays: a
// mapping large enough is split, smaller ones are moved side by side with mremap,
// which moves their pages (whole 2 MiB pages where aligned) without copying or
// faulting them. When the last scope closes, what is left is unmapped.
//
// Fresh pages on every thread. A fresh mapping of kFaultInBytes or more is faulted in
// at once, its pages split between parallel_for's threads, unless it is made inside a
// parallel_for body (the build's side-by-side subtrees, whose own threads fault their
// arrays as they write them). On a virtual machine that hands freed memory back to its
// host (virtio-balloon free page reporting), a page not touched for a few seconds costs
// a fault in the host as well: 2.2 ms per MiB in 2 MiB pages on one thread, 1.2 on two
// (a KVM guest with 2 vCPUs), where a page freed a moment before costs 0.1. The
// vector's own first write, value-initialization or a copy, is one thread's loop, and
// met those faults one after another: the first 1e6-sphere build in a process took
// 1.3-1.9 times as long as the next (docs/performance.md, "Huge pages").
#pragma once

#include <algorithm>
#include <cstddef>
#include <mutex>
#include <new>
#include <utility>
#include <vector>

#include <twinray/core/parallel.hpp>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace twinray {

// Arrays this large or larger are mapped in huge pages (where the system has them).
inline constexpr std::size_t kHugePageBytes = std::size_t(2) << 20;

namespace detail {

#if defined(__linux__) && defined(MADV_HUGEPAGE)
// `bytes` rounded up to whole huge pages.
inline std::size_t huge_pages_size(std::size_t bytes) {
  return (bytes + kHugePageBytes - 1) & ~(kHugePageBytes - 1);
}
// `bytes` rounded up to whole huge pages, from a mapping of its own that starts on a
// huge-page boundary (the unaligned head and tail of a larger mapping are returned).
inline void* map_huge(std::size_t bytes) {
  const std::size_t size = huge_pages_size(bytes);
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
  munmap(p, huge_pages_size(bytes));
}

// Mappings (or fresh parts of them) of at least this size are faulted in as they are
// made, on every thread (see "Fresh pages" above).
inline constexpr std::size_t kFaultInBytes = std::size_t(8) << 20;

// Faults in the pages of [p, p + bytes), which start on a huge-page boundary, on
// parallel_for's threads; nothing inside a parallel_for body. MADV_POPULATE_WRITE
// (Linux 5.14) faults pages in without writing them; where the kernel lacks it, one
// zero byte per 4 KiB page does the same to fresh anonymous memory.
inline void fault_in(void* p, std::size_t bytes) {
  if (bytes < kFaultInBytes || in_parallel_body()) return;
  char* base = static_cast<char*>(p);
  const int pages = static_cast<int>(huge_pages_size(bytes) / kHugePageBytes);
  parallel_for(pages, 1, [&](int i) {
    char* page = base + static_cast<std::size_t>(i) * kHugePageBytes;
#if defined(MADV_POPULATE_WRITE)
    if (madvise(page, kHugePageBytes, MADV_POPULATE_WRITE) == 0) return;
#endif
    for (std::size_t k = 0; k < kHugePageBytes; k += 4096) static_cast<volatile char*>(page)[k] = 0;
  });
}

// The mappings freed while a LargeArrayRecycling scope is open, for the next large
// arrays. Every address and size is a multiple of kHugePageBytes.
class HugePagePool {
 public:
  static HugePagePool& instance() {
    static HugePagePool pool;
    return pool;
  }

  void open() {
    std::lock_guard<std::mutex> lock(mutex_);
    ++scopes_;
  }
  void close() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (--scopes_ > 0) return;
    for (const Chunk& c : chunks_) munmap(c.first, c.second);
    chunks_.clear();
  }

  // Keeps the mapping [p, p + bytes) for a later take(); false (the caller unmaps
  // it) where no scope is open.
  bool give(void* p, std::size_t bytes) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (scopes_ == 0) return false;
    chunks_.emplace_back(static_cast<char*>(p), huge_pages_size(bytes));
    return true;
  }

  // A mapping of `bytes` (rounded up to whole huge pages) made of kept pages as far as
  // they go, its first *kept bytes of them (the rest fresh); nullptr where none are
  // kept. The smallest kept mapping that is large enough gives its head; else a fresh
  // range is mapped and the largest kept mappings are moved into it from its start,
  // the rest of it left fresh. (mremap moves a range of one mapping only: a kept range
  // that was itself put together from several fails to move, and its share of the new
  // range stays fresh.)
  void* take(std::size_t bytes, std::size_t* kept) {
    const std::size_t size = huge_pages_size(bytes);
    std::lock_guard<std::mutex> lock(mutex_);
    if (chunks_.empty()) return nullptr;
    auto fits = chunks_.end();
    for (auto c = chunks_.begin(); c != chunks_.end(); ++c)
      if (c->second >= size && (fits == chunks_.end() || c->second < fits->second)) fits = c;
    if (fits != chunks_.end()) {
      *kept = size;
      return take_head(fits, size);
    }
    char* range = static_cast<char*>(map_huge(size));
    std::sort(chunks_.begin(), chunks_.end(),
              [](const Chunk& a, const Chunk& b) { return a.second < b.second; });
    std::size_t filled = 0;
    while (filled < size && !chunks_.empty()) {
      Chunk& c = chunks_.back();  // the largest
      const std::size_t n = std::min(c.second, size - filled);
      if (mremap(c.first, n, n, MREMAP_MAYMOVE | MREMAP_FIXED, range + filled) == MAP_FAILED)
        break;  // the rest of the range stays fresh
      filled += n;
      c.first += n;
      c.second -= n;
      if (c.second == 0) chunks_.pop_back();
    }
    *kept = filled;
    return range;
  }

  std::size_t kept_bytes() {
    std::lock_guard<std::mutex> lock(mutex_);
    std::size_t sum = 0;
    for (const Chunk& c : chunks_) sum += c.second;
    return sum;
  }

 private:
  using Chunk = std::pair<char*, std::size_t>;

  void* take_head(std::vector<Chunk>::iterator c, std::size_t size) {
    char* p = c->first;
    c->first += size;
    c->second -= size;
    if (c->second == 0) chunks_.erase(c);
    return p;
  }

  std::mutex mutex_;
  int scopes_ = 0;
  std::vector<Chunk> chunks_;
};

// Outside the pool's lock: another thread's allocation need not wait for the faults.
inline void* allocate_huge(std::size_t bytes) {
  std::size_t kept = 0;
  char* p = static_cast<char*>(HugePagePool::instance().take(bytes, &kept));
  if (!p) p = static_cast<char*>(map_huge(bytes));
  fault_in(p + kept, huge_pages_size(bytes) - kept);
  return p;
}
inline void free_huge(void* p, std::size_t bytes) {
  if (!HugePagePool::instance().give(p, bytes)) unmap_huge(p, bytes);
}
inline std::size_t recycled_bytes_kept() {
  return HugePagePool::instance().kept_bytes();
}
inline void open_recycling() {
  HugePagePool::instance().open();
}
inline void close_recycling() {
  HugePagePool::instance().close();
}
inline constexpr bool kMapsHugePages = true;
#else
inline void* allocate_huge(std::size_t) {
  throw std::bad_alloc();
}
inline void free_huge(void*, std::size_t) {}
inline std::size_t recycled_bytes_kept() {
  return 0;
}
inline void open_recycling() {}
inline void close_recycling() {}
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
    if (maps(n)) return static_cast<T*>(detail::allocate_huge(n * sizeof(T)));
    return static_cast<T*>(::operator new(n * sizeof(T), std::align_val_t(alignof(T))));
  }
  void deallocate(T* p, std::size_t n) noexcept {
    if (maps(n))
      detail::free_huge(p, n * sizeof(T));
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

// While one is open anywhere in the process, freed large arrays are kept for the next
// ones (see "Recycling" above); when the last one closes, what is kept is unmapped.
// Open one around work that frees and allocates large arrays in turn.
class LargeArrayRecycling {
 public:
  LargeArrayRecycling() { detail::open_recycling(); }
  ~LargeArrayRecycling() { detail::close_recycling(); }
  LargeArrayRecycling(const LargeArrayRecycling&) = delete;
  LargeArrayRecycling& operator=(const LargeArrayRecycling&) = delete;
};

// The vector of the packed scene's and the BVH's arrays.
template <class T>
using LargeVector = std::vector<T, LargeArrayAllocator<T>>;

}  // namespace twinray
