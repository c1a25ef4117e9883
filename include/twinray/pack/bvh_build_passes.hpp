// The passes the BVH builder (pack/bvh_build.hpp) makes over its primitive records:
// reduce_range, one pass split into blocks for every thread with the result of a single
// pass; bounds_of, a range's bounds and centroid bounds; block_partition, the
// partition of a node's primitives without a branch on which side each goes; and
// least_where, the bisection over a float's bit patterns that turns a bin boundary into
// one comparison per centroid.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>
#include <utility>
#include <vector>

#include <twinray/core/large_array.hpp>
#include <twinray/core/parallel.hpp>
#include <twinray/pack/bvh_boxes.hpp>
#include <twinray/pack/bvh_constants.hpp>

namespace twinray {
namespace bvh {

namespace detail {

// `out` set to the result of pass(begin, end, out), one pass over [begin, end). With
// all_threads, the range goes in blocks of kParallelPassPrims to parallel_for's
// threads, and the blocks' results are merged in block order by merge(into, from).
// Passes that take minima and maxima and count give the same result either way: min,
// max and integer sums are exact, and merging in order keeps, among equal values, the
// one a single pass meets first. Each pass accumulates in locals and writes them once:
// accumulators side by side in one array, written at every step, would share cache
// lines between the threads (the root's bounds took twice as long that way). The
// result is written in place, not returned: the SAH's bins are a kilobyte, whose copy
// on return was up to a sixth of a small node's split (Builder::sah_split).
template <class Acc, class Pass, class Merge>
void reduce_range(int begin, int end, bool all_threads, Acc& out, const Pass& pass,
                  const Merge& merge) {
  if (!all_threads) return pass(begin, end, out);
  const size_t n = static_cast<size_t>(end - begin);
  std::vector<Acc> parts(block_count(n, kParallelPassPrims));
  parallel_for_blocks(n, kParallelPassPrims, [&](size_t block, size_t b, size_t e) {
    pass(begin + static_cast<int>(b), begin + static_cast<int>(e), parts[block]);
  });
  out = parts[0];
  for (size_t i = 1; i < parts.size(); ++i) merge(out, parts[i]);
}

// Bounds and centroid bounds of refs[begin, end), in one pass.
template <class R>
void bounds_of(const LargeVector<PrimRef<R>>& refs, int begin, int end, Box* box, Box* cbox,
               bool all_threads = false) {
  struct Bounds {
    BasicBox<R> box, cbox;  // grown in R, converted once (exactly) at the end
  };
  auto pass = [&refs](int b, int e, Bounds& out) {
    BasicBox<R> box, cbox;
    for (int i = b; i < e; ++i) {
      R c[3];
      refs[static_cast<size_t>(i)].centroid(c);
      box.grow(refs[static_cast<size_t>(i)].box);
      cbox.grow(c);
    }
    out = Bounds{box, cbox};
  };
  auto merge = [](Bounds& into, const Bounds& from) {
    into.box.grow(from.box);
    into.cbox.grow(from.cbox);
  };
  Bounds all;
  reduce_range(begin, end, all_threads, all, pass, merge);
  *box = all.box.template as<double>();
  *cbox = all.cbox.template as<double>();
}

// Moves the elements of v[begin, end) for which is_left holds before the others and
// returns where the others start. Block partitioning after Edelkamp and Weiss,
// "BlockQuicksort: How Branch Mispredictions don't affect Quicksort" (ESA 2016): the
// misplaced elements of a block at each end are found first, with no branch on the
// predicate, then swapped pairwise. On primitives in random order a plain Hoare loop
// mispredicts every other element, and this one makes the binary build of 1e6 spheres
// in random order about a fifth faster (docs/performance.md, "BVH build").
// Either way the result is a plain Hoare loop's, element for element: the k-th element
// that is misplaced on the left, counted from `begin`, trades places with the k-th one
// misplaced on the right, counted from `end`.
template <class Array, class IsLeft>
int block_partition(Array& v, int begin, int end, const IsLeft& is_left) {
  constexpr int kBlock = 64;
  if (end - begin < 2 * kBlock) {
    // Too few for blocks at both ends (most nodes of a large tree): the predicate once
    // per element, then the misplaced ones listed on each side of the boundary it
    // gives, all without a branch on the predicate.
    const int n = end - begin;
    unsigned char left[2 * kBlock], wrong_left[2 * kBlock], wrong_right[2 * kBlock];
    int n_left = 0;
    for (int k = 0; k < n; ++k) {
      left[k] = is_left(v[static_cast<size_t>(begin + k)]) ? 1 : 0;
      n_left += left[k];
    }
    int swaps = 0, found = 0;
    for (int k = 0; k < n_left; ++k) {
      wrong_left[swaps] = static_cast<unsigned char>(k);
      swaps += 1 - left[k];
    }
    for (int k = n - 1; k >= n_left; --k) {
      wrong_right[found] = static_cast<unsigned char>(k);
      found += left[k];
    }
    for (int k = 0; k < swaps; ++k)
      std::swap(v[static_cast<size_t>(begin + wrong_left[k])],
                v[static_cast<size_t>(begin + wrong_right[k])]);
    return begin + n_left;
  }
  unsigned char wrong_left[kBlock], wrong_right[kBlock];
  int n_left = 0, n_right = 0, start_left = 0, start_right = 0;
  int l = begin, r = end;  // v[begin, l) is left, v[r, end) is right
  while (r - l >= 2 * kBlock) {
    if (n_left == 0) {
      start_left = 0;
      for (int k = 0; k < kBlock; ++k) {
        wrong_left[n_left] = static_cast<unsigned char>(k);
        n_left += !is_left(v[static_cast<size_t>(l + k)]);
      }
    }
    if (n_right == 0) {
      start_right = 0;
      for (int k = 0; k < kBlock; ++k) {
        wrong_right[n_right] = static_cast<unsigned char>(k);
        n_right += is_left(v[static_cast<size_t>(r - 1 - k)]);
      }
    }
    const int swaps = std::min(n_left, n_right);
    for (int k = 0; k < swaps; ++k)
      std::swap(v[static_cast<size_t>(l + wrong_left[start_left + k])],
                v[static_cast<size_t>(r - 1 - wrong_right[start_right + k])]);
    n_left -= swaps, n_right -= swaps;
    start_left += swaps, start_right += swaps;
    if (n_left == 0) l += kBlock;
    if (n_right == 0) r -= kBlock;
  }
  // The rest, a block's leftovers included, in a plain Hoare loop.
  int i = l, j = r - 1;
  for (;;) {
    while (i <= j && is_left(v[static_cast<size_t>(i)])) ++i;
    while (i <= j && !is_left(v[static_cast<size_t>(j)])) --j;
    if (i >= j) break;
    std::swap(v[static_cast<size_t>(i)], v[static_cast<size_t>(j)]);
    ++i;
    --j;
  }
  return i;
}

}  // namespace detail

// The least value of R in (lo, hi] where `holds` is true, for finite lo < hi, a
// monotonic `holds` (false up to some value, true from there on), false at lo and true
// at hi. A bisection over the values' bit patterns, mapped to unsigned integers in the
// order of the values they encode: at most as many steps as R has bits.
template <class R, class Pred>
R least_where(R lo, R hi, const Pred& holds) {
  using Bits = typename std::conditional<sizeof(R) == 4, std::uint32_t, std::uint64_t>::type;
  constexpr Bits sign = Bits(1) << (8 * sizeof(R) - 1);
  auto key = [](R v) {
    Bits b;
    std::memcpy(&b, &v, sizeof b);
    return (b & sign) != 0 ? Bits(~b) : Bits(b | sign);
  };
  auto value = [](Bits k) {
    Bits b = (k & sign) != 0 ? Bits(k & ~sign) : Bits(~k);
    R v;
    std::memcpy(&v, &b, sizeof v);
    return v;
  };
  Bits false_at = key(lo), true_at = key(hi);
  while (true_at - false_at > 1) {
    Bits mid = false_at + (true_at - false_at) / 2;
    if (holds(value(mid)))
      true_at = mid;
    else
      false_at = mid;
  }
  return value(true_at);
}

}  // namespace bvh
}  // namespace twinray
