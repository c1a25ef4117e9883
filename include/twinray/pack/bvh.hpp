// The BVH over a packed scene's spheres and triangles (planes are unbounded and stay
// outside it): a binned-SAH build of a binary tree (Wald, "On fast Construction of
// SAH-based Bounding Volume Hierarchies", 2007; pbrt-v4 BVHAggregate), collapsed into
// the W-wide node arrays (W = 2, 4 or 8) that device/bvh_traverse.h walks on both
// backends.
//
// Layout (device/types.h, "The BVH"): node 0 is the root; each node holds its W
// children's boxes as structure of arrays and then a (first, count) link per child
// (WideNodes); a leaf's
// primitives are bvh_prims[first .. first + count). Primitive ids: spheres first
// (0 .. n_spheres - 1), then triangles. build() returns the nodes and the order of the
// primitives in the leaves; pack() reorders the scene's arrays by it.
//
// Collapse: a W-wide node takes binary nodes below the one it stands for, opening the
// inner child with the largest surface area until it holds W children or only leaves
// (the greedy collapse of Embree's wide BVH builders and tinybvh's BVH4/BVH8
// converters): large boxes, the ones rays enter most often, are split first, and nodes
// come out nearly full. The traversal's stack holds at most (inner children - 1) entries
// per wide node on a path; collapse() adds that up over every path and, where it would
// exceed the stack (device/bvh_traverse.h TR_BVH_STACK_SIZE), collapses the tree at
// fixed levels instead: a W = 2^L wide node then takes the binary nodes L levels down
// (Wald, Benthin, Boulos, "Getting Rid of Packets: Efficient SIMD Single-Ray Traversal
// using Multi-branching BVHs", RT 2008), which bounds every path by the binary depth cap.
//
// Guarantees the traversal relies on:
//  - depth: no binary leaf is deeper than kMaxDepth, so the traversal's stack never
//    overflows; near the cap the builder switches to median splits, which halve the
//    count, and it starts doing so early enough to end every branch in small leaves;
//  - bounds: every box contains what it bounds with a margin, rounded outward to the
//    scene's precision, so rounding in the primitive tests never makes a primitive
//    report a hit through a box the ray misses.
//
// The build runs subtrees on separate threads (parallel_for, core/parallel.hpp); the
// result does not depend on the thread count.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>
#include <vector>

#include <twinray/core/large_array.hpp>
#include <twinray/core/parallel.hpp>
#include <twinray/device/code.hpp>

namespace twinray {

namespace bvh {

// Small scenes skip the BVH: linear loops are faster there. The rule weighs a
// triangle as 4 spheres (the watertight triangle test costs several sphere tests) and
// builds the BVH from a weight of 8 on. Measured on the 2-core build machine with
// bench/twinray_bench.cpp --bvh on|off at 640x360, both backends (docs/performance.md,
// "The BVH and its threshold"):
// 1-8 spheres break even within the noise, 16 spheres gain 1.3-1.7x, 16 triangles
// 3.5-4x, the demo's 3 spheres + 4 triangles 1.7-2x.
constexpr int kTriangleWeight = 4;
constexpr long long kMinWeight = 8;

inline bool worth_building(long long n_spheres, long long n_triangles) {
  return n_spheres + kTriangleWeight * n_triangles >= kMinWeight;
}

constexpr int kMaxDepth = TR_BVH_MAX_DEPTH;  // leaf depth cap of the binary tree
constexpr int kMaxLeafSize = 8;              // SAH leaves hold at most this many primitives
constexpr int kBins = 16;                    // SAH bins
// SAH cost of visiting an inner node, relative to one primitive test: the walk tests
// both children's boxes there, each about as dear as a sphere test. At 1 the builder
// split down to 1.19 spheres per leaf (1.7M nodes for 1e6 spheres); at 2 leaves hold
// about 2.4 and the tree has half the nodes, builds 25-30% faster and renders no
// slower (bench/twinray_bench.cpp, spheres_1e5/1e6 and mesh_1e4/1e6, costs 1, 1.5, 2, 3, 4
// interleaved on the noisy 2-core machine; 4 rendered slower).
constexpr double kTraversalCost = 2.0;
// Scenes of spheres alone, fewer than kSmallSphereScene of them, split further, at a
// traversal cost of 1: the CPU backend tests a leaf's spheres for a packet's rays side
// by side, and over large spheres (hundreds of pixels each) smaller leaves spare those
// tests for rays that only crossed the leaf's box. Against cost 2 (AMD EPYC, paired
// A/B, same bits): spheres_1e3 0.88-0.91 of the frame in three runs, spheres_1e5 0.97;
// spheres_1e6 0.94, 0.94 and 1.01 while its build took 1.4-1.55 times as long, and
// the meshes rendered 2-8% slower, so those keep 2 (docs/performance.md).
constexpr long long kSmallSphereScene = 1 << 17;
// Scenes of at least kLargeMeshScene triangles merge further, at a traversal cost of 3:
// their tree outgrows the caches, a node read from memory costs more than the
// triangles a packet's rays test side by side in a larger leaf, and at cost 3 mesh_1e6
// has 4.4 triangles per leaf instead of 2.8 and 66 k wide nodes instead of 115 k.
// Against cost 2 (AMD EPYC, Zen 5 class, paired A/B of both load orders, same bits):
// mesh_1e6 0.94-0.96 of the frame; mesh_1e4 at cost 3 1.005-1.047, at cost 4 1.064
// (mesh_1e6 0.975), so smaller meshes keep 2 (docs/performance.md).
constexpr long long kLargeMeshScene = 1 << 17;
constexpr double kLargeMeshTraversalCost = 3.0;
inline double traversal_cost(long long n_spheres, long long n_triangles) {
  if (n_triangles >= kLargeMeshScene) return kLargeMeshTraversalCost;
  return n_triangles == 0 && n_spheres < kSmallSphereScene ? 1.0 : kTraversalCost;
}
constexpr int kParallelMinPrims = 16384;  // smaller subtrees are built on the calling thread
// The root's passes over its primitives (bounds, bins, the two sides' centroid bounds)
// run on every thread in blocks of this many, before any subtree has a thread of its own.
constexpr int kParallelPassPrims = 65536;
// Nodes of at least this many primitives are partitioned by comparing each centroid with
// one value found by a bisection (Builder::sah_split); smaller ones by their bins.
constexpr int kPartitionByValuePrims = 128;
// Nodes (or blocks of the root's pass) of at least kBinSetsMinPrims primitives are
// binned into kBinSets sets of bins, merged after (Builder::sah_split).
constexpr int kBinSets = 4;
constexpr int kBinSetsMinPrims = 256;
static_assert(kBinSets > 0 && (kBinSets & (kBinSets - 1)) == 0,
              "kBinSets: a power of two (a primitive's set is its index masked)");

// The widths a BVH can have, and the fastest on each backend (measured with
// bench/twinray_bench.cpp --bvh-width, docs/performance.md "BVH width").
constexpr int kWidths[] = {2, 4, 8};
constexpr int kCpuWidth = 8;
constexpr int kOpenClWidth = 8;

constexpr bool valid_width(int w) {
  return w == 2 || w == 4 || w == 8;
}
constexpr int log2_width(int w) {
  return w == 8 ? 3 : w == 4 ? 2 : 1;
}
// The feature bit of a width (device/features.h).
constexpr unsigned width_feature(int w) {
  return w == 8 ? TR_F_BVH8 : w == 4 ? TR_F_BVH4 : TR_F_BVH2;
}
// The nodes of a `width`-wide tree as the device code reads them (device/types.h, "The
// BVH"): node after node, each its W children's boxes (6 W reals, plane by plane) and
// then their links (first[W], count[W]), in one block, so that a walk finds a node's
// boxes and links in the same cache lines. The block starts on a 64-byte boundary; 2-,
// 4- and 8-wide float nodes fill whole cache lines. Bytes, not a vector of T: a node
// holds reals and ints side by side, each read through its own type.
template <class T>
class WideNodes {
 public:
  WideNodes() = default;
  explicit WideNodes(int width) : width_(width) {}

  static constexpr size_t node_bytes(int width) {
    return 6 * static_cast<size_t>(width) * sizeof(T) +
           2 * static_cast<size_t>(width) * sizeof(int);
  }
  int width() const { return width_; }
  int size() const { return nodes_; }  // nodes
  bool empty() const { return nodes_ == 0; }
  size_t bytes() const { return static_cast<size_t>(nodes_) * node_bytes(width_); }
  const void* data() const { return lines_.data(); }

  // Room for `nodes` nodes of zero bytes, the old ones kept. Pointers from boxes() and
  // links() may move.
  void resize(size_t nodes) {
    lines_.resize(lines_for(nodes));
    nodes_ = static_cast<int>(nodes);
  }
  void clear() {
    lines_.clear();
    nodes_ = 0;
  }

  // Node i's boxes (6 W reals: min x of the W children, then min y, ... max z) and
  // links (first[W], then count[W]).
  T* boxes(int i) { return reinterpret_cast<T*>(node(i)); }
  const T* boxes(int i) const { return reinterpret_cast<const T*>(node(i)); }
  int* links(int i) { return reinterpret_cast<int*>(node(i) + 6 * width_ * sizeof(T)); }
  const int* links(int i) const {
    return reinterpret_cast<const int*>(node(i) + 6 * width_ * sizeof(T));
  }
  // Child k of node i: its bounds (min x, y, z, max x, y, z) and its link (first,
  // count: count > 0 a leaf, 0 an inner node).
  void set_child(int i, int k, const T bounds[6], int first, int count) {
    for (int plane = 0; plane < 6; ++plane) boxes(i)[plane * width_ + k] = bounds[plane];
    links(i)[k] = first;
    links(i)[width_ + k] = count;
  }
  // Child k of node i as an empty slot: a box no ray enters, and count -1.
  void set_empty_child(int i, int k) {
    for (int a = 0; a < 3; ++a) {
      boxes(i)[(TR_BVH_MIN_X + a) * width_ + k] = std::numeric_limits<T>::infinity();
      boxes(i)[(TR_BVH_MAX_X + a) * width_ + k] = -std::numeric_limits<T>::infinity();
    }
    links(i)[k] = 0;
    links(i)[width_ + k] = -1;
  }

  // The same width and the same bytes.
  friend bool operator==(const WideNodes& a, const WideNodes& b) {
    return a.width_ == b.width_ && a.nodes_ == b.nodes_ &&
           (a.nodes_ == 0 || std::memcmp(a.data(), b.data(), a.bytes()) == 0);
  }

 private:
  struct alignas(64) Line {
    unsigned char bytes[64];
  };
  size_t lines_for(size_t nodes) const { return (nodes * node_bytes(width_) + 63) / 64; }
  unsigned char* node(int i) {
    return reinterpret_cast<unsigned char*>(lines_.data()) +
           static_cast<size_t>(i) * node_bytes(width_);
  }
  const unsigned char* node(int i) const {
    return reinterpret_cast<const unsigned char*>(lines_.data()) +
           static_cast<size_t>(i) * node_bytes(width_);
  }

  LargeVector<Line> lines_;
  int width_ = 0;
  int nodes_ = 0;
};

// The stack bound of a tree collapsed at fixed levels: W - 1 entries per inner wide node
// on a path, and a path holds at most floor((kMaxDepth - 1) / L) + 1 of them (see the
// collapse above). A greedy tree's need is measured instead (collapse()).
constexpr int stack_needed(int w) {
  return (w - 1) * ((kMaxDepth - 1) / log2_width(w) + 1);
}
static_assert(stack_needed(2) <= TR_BVH_STACK_SIZE && stack_needed(4) <= TR_BVH_STACK_SIZE &&
                  stack_needed(8) <= TR_BVH_STACK_SIZE,
              "BVH depth cap exceeds the traversal stack");
static_assert(TR_BVH_MAX_WIDTH == 8, "the walk's per-node arrays hold the widest node");

// Half the surface area of the box [lo, hi] (3 values each), 0 for an empty one (lo[0] >
// hi[0]): the SAH's measure, in double whatever R is. Boxes and the builder's bins
// (Builder::sah_split) both take it from here, so their areas are the same bits.
template <class R>
double half_area_of(const R* lo, const R* hi) {
  if (lo[0] > hi[0]) return 0;
  double dx = double(hi[0]) - lo[0], dy = double(hi[1]) - lo[1], dz = double(hi[2]) - lo[2];
  return dx * dy + dy * dz + dz * dx;
}

// An axis-aligned box. The builder keeps primitives' boxes in the scene's precision
// (R = T), rounded outward, so a million float primitives stream through each level of
// the build as 28-byte records; bins, centroid bounds and SAH costs are in double.
template <class R>
struct BasicBox {
  R lo[3] = {std::numeric_limits<R>::infinity(), std::numeric_limits<R>::infinity(),
             std::numeric_limits<R>::infinity()};
  R hi[3] = {-std::numeric_limits<R>::infinity(), -std::numeric_limits<R>::infinity(),
             -std::numeric_limits<R>::infinity()};
  template <class S>
  void grow(const BasicBox<S>& b) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = b.lo[a] < lo[a] ? R(b.lo[a]) : lo[a];
      hi[a] = b.hi[a] > hi[a] ? R(b.hi[a]) : hi[a];
    }
  }
  template <class S>
  void grow(const S p[3]) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = p[a] < lo[a] ? R(p[a]) : lo[a];
      hi[a] = p[a] > hi[a] ? R(p[a]) : hi[a];
    }
  }
  bool empty() const { return lo[0] > hi[0]; }
  double half_area() const { return half_area_of(lo, hi); }
  // The box converted to another precision, lane by lane (exact from float to double).
  template <class S>
  BasicBox<S> as() const {
    BasicBox<S> b;
    for (int a = 0; a < 3; ++a) b.lo[a] = S(lo[a]), b.hi[a] = S(hi[a]);
    return b;
  }
};
using Box = BasicBox<double>;

// One primitive as the builder sees it: its bounds, outward-rounded to R, and its id.
// The centroid is recomputed from the bounds where needed, in R, halved before the sum
// (no overflow). It need not be the exact midpoint: binning, partitioning and the
// centroid bounds all compute it with this one function.
template <class R>
struct PrimRef {
  BasicBox<R> box;
  int id;
  void centroid(R c[3]) const {
    for (int a = 0; a < 3; ++a) c[a] = midpoint(box.lo[a], box.hi[a]);
  }
  R centroid(int a) const { return midpoint(box.lo[a], box.hi[a]); }
  // The one centroid formula: binning, partitioning and the centroid bounds must agree
  // on it to the bit.
  static R midpoint(R lo, R hi) { return R(0.5) * lo + R(0.5) * hi; }
};

// The neighbour of r toward -inf (toward = -1) or +inf (+1), as std::nextafter gives it,
// for an r that is not NaN and not already the infinity it steps toward: one integer
// step of its bits. Inline, where glibc's nextafter is a call: the builder rounds six
// values per primitive and per node, and the calls were most of its first pass.
template <class R>
R step_toward(R r, int toward) {
  using Bits = typename std::conditional<sizeof(R) == 4, std::uint32_t, std::uint64_t>::type;
  if (r == R(0)) return R(toward) * std::numeric_limits<R>::denorm_min();
  Bits bits;
  std::memcpy(&bits, &r, sizeof bits);
  // Away from zero is one more in magnitude.
  const bool away = (r > R(0)) == (toward > 0);
  bits = away ? bits + 1 : bits - 1;
  std::memcpy(&r, &bits, sizeof bits);
  return r;
}

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

// v rounded to R toward -inf (down) or +inf (up): a box stays around what it bounds.
template <class R>
R round_down(double v) {
  R r = static_cast<R>(v);
  return static_cast<double>(r) > v ? step_toward(r, -1) : r;
}
template <class R>
R round_up(double v) {
  R r = static_cast<R>(v);
  return static_cast<double>(r) < v ? step_toward(r, +1) : r;
}

// A node of the binary tree the builder makes before the collapse: bounds min x, y, z,
// max x, y, z; a leaf has count > 0 primitives from `first`, an inner node count = 0
// and its children at first and first + 1.
template <class R>
struct BinaryNode {
  R bounds[6];
  int first, count;
};

// Node and leaf counts, the most primitives in a leaf, and the deepest path in inner
// nodes (the root counts 1).
struct Stats {
  int nodes = 0, leaves = 0, max_depth = 0, max_leaf = 0;
  // Wide trees: the most traversal stack entries a walk can hold, the largest sum over a
  // path of (inner children - 1) per node.
  int stack_need = 0;
};

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
// mispredicts every other element; with this one the binary build of 1e6 spheres in
// random order took 290 ms instead of 350-370 on 2 threads (docs/performance.md).
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

template <class Node, class R>
struct Builder {
  LargeVector<PrimRef<R>>& refs;
  double traversal_cost;  // the SAH's cost of an inner node (traversal_cost())
  std::atomic<int> spare_threads;

  Builder(LargeVector<PrimRef<R>>& r, double traversal)
      : refs(r), traversal_cost(traversal), spare_threads(thread_count() - 1) {}

  // Fills nodes[self] for refs[begin, end), whose bounds and centroid bounds are box
  // and cbox, and appends its descendants to `nodes`. A split hands each child its
  // bounds (from the bins and the partition pass), so no level re-reads its
  // primitives just to bound them.
  void build(LargeVector<Node>& nodes, int self, int begin, int end, int depth, const Box& box,
             const Box& cbox) {
    int n = end - begin;
    set_box(nodes[self], box);

    int mid = -1;
    Box child_box[2], child_cbox[2];
    // Levels left below this node if every further split halves the count.
    int halvings = 0;
    for (int m = n; m > kMaxLeafSize; m = (m + 1) / 2) ++halvings;
    bool near_cap = depth + halvings >= kMaxDepth - 1;
    if (n <= 1 || leaf_by_bound(begin, end, box)) {
      mid = -1;
    } else if (near_cap) {
      mid = n <= kMaxLeafSize ? -1 : median_split(begin, end, cbox, child_box, child_cbox);
    } else {
      mid = sah_split(begin, end, box, cbox, child_box, child_cbox, depth == 0);
    }
    if (mid < 0 || depth >= kMaxDepth) {
      make_leaf(nodes[self], begin, n);
      return;
    }

    int first = static_cast<int>(nodes.size());
    nodes[self].first = first;
    nodes[self].count = 0;
    nodes.emplace_back();
    nodes.emplace_back();
    bool parallel = std::min(mid - begin, end - mid) >= kParallelMinPrims && take_thread();
    if (!parallel) {
      build(nodes, first, begin, mid, depth + 1, child_box[0], child_cbox[0]);
      build(nodes, first + 1, mid, end, depth + 1, child_box[1], child_cbox[1]);
      return;
    }
    // The two subtrees side by side (parallel_for with one index each): the left one
    // appended to `nodes` as a serial build appends it (until parallel_for returns,
    // nothing else touches `nodes`), the right one into an array of its own, spliced
    // in after it. The result does not depend on the thread count, and only the right
    // half's nodes take fresh pages and a copy.
    // The side that finishes first hands its thread back at once, so that the other
    // side's splits can take it: held until both were done, it sat idle for as long as
    // the larger side outlasted the smaller (an SAH split need not halve the work).
    // The right side's array holds as many nodes as primitives, as for the whole tree
    // (build_binary): growing by doubling copied the nodes and touched fresh pages
    // again. It is reserved before the two sides start, so that its fresh pages are
    // faulted in on every thread (core/large_array.hpp, "Fresh pages"; not inside
    // another split's sides). Reserved by the right side itself, they were its thread's
    // alone: a million spheres' right side took 16-32 ms longer than the left, whose
    // thread sat idle for most of it (docs/performance.md, "Huge pages").
    LargeVector<Node> right(1);
    right.reserve(static_cast<size_t>(end - mid));
    std::atomic<bool> handed_back{false};
    auto hand_back = [&] {
      if (!handed_back.exchange(true)) spare_threads.fetch_add(1);
    };
    parallel_for(2, 1, [&](int side) {
      if (side == 0) {
        build(nodes, first, begin, mid, depth + 1, child_box[0], child_cbox[0]);
        hand_back();
        return;
      }
      build(right, 0, mid, end, depth + 1, child_box[1], child_cbox[1]);
      hand_back();
    });
    splice(nodes, first + 1, right);
  }

  // Moves a subtree built on its own (root at sub[0]) to nodes[slot] and the end.
  static void splice(LargeVector<Node>& nodes, int slot, const LargeVector<Node>& sub) {
    int offset = static_cast<int>(nodes.size()) - 1;  // sub[i] lands at offset + i, i >= 1
    auto relocate = [offset](Node node) {
      if (node.count <= 0) node.first += offset;
      return node;
    };
    nodes[slot] = relocate(sub[0]);
    for (size_t i = 1; i < sub.size(); ++i) nodes.push_back(relocate(sub[i]));
  }

  bool take_thread() {
    int s = spare_threads.load();
    while (s > 0)
      if (spare_threads.compare_exchange_weak(s, s - 1)) return true;
    return false;
  }

  // True where sah_split is sure to make refs[begin, end) a leaf, found without binning
  // them. A node of n <= kMaxLeafSize primitives becomes a leaf when n is at most its
  // split cost, traversal_cost + (A_l n_l + A_r n_r) / A. Whatever the boundary, each
  // primitive lies in a side whose box holds its own, so A_l n_l + A_r n_r is at least
  // the sum of the primitives' own areas, and the split cost at least traversal_cost +
  // sum / A. Where that bound reaches n, sah_split returns a leaf too, so the tree is the
  // same bits. The areas are computed as sah_split computes them, and the rounding is
  // monotonic, so a side's area is never below one of its primitives'; the 2^-30 margin
  // covers the roundings of the sums (a few units in the last place each). Most of a
  // large tree's nodes are this small: mesh_1e6 asks for 180 000 splits of 2 primitives
  // and 80 000 of 3, and all but 160 of them end as leaves.
  bool leaf_by_bound(int begin, int end, const Box& box) const {
    const int n = end - begin;
    if (n > kMaxLeafSize) return false;
    if (n <= traversal_cost) return true;  // the split cost is at least traversal_cost
    const double area = box.half_area();
    if (!(area > 0)) return true;  // sah_split's split cost is then traversal_cost + n
    double own_areas = 0;
    for (int i = begin; i < end; ++i) own_areas += refs[static_cast<size_t>(i)].box.half_area();
    return own_areas / area * (1 - 0x1p-30) >= n - traversal_cost;
  }

  static void make_leaf(Node& node, int begin, int n) {
    node.first = begin;
    node.count = n;
  }

  // Outward rounding with a margin: the box grows by 2^-20 of its largest coordinate
  // magnitude (about 8 float ulps), then rounds away from its center in the
  // precision of the scene.
  static void set_box(Node& node, const Box& b) {
    using real = typename std::remove_reference<decltype(node.bounds[0])>::type;
    double mag = 0;
    for (int a = 0; a < 3; ++a) mag = std::max({mag, std::fabs(b.lo[a]), std::fabs(b.hi[a])});
    double pad = mag * 0x1p-20 + std::numeric_limits<double>::denorm_min();
    for (int a = 0; a < 3; ++a) {
      node.bounds[TR_BVH_MIN_X + a] = round_down<real>(b.lo[a] - pad);
      node.bounds[TR_BVH_MAX_X + a] = round_up<real>(b.hi[a] + pad);
    }
  }

  static int widest_axis(const Box& b) {
    double ext[3] = {b.hi[0] - b.lo[0], b.hi[1] - b.lo[1], b.hi[2] - b.lo[2]};
    return ext[0] >= ext[1] ? (ext[0] >= ext[2] ? 0 : 2) : (ext[1] >= ext[2] ? 1 : 2);
  }

  // Splits at the median centroid along the widest centroid axis (ties by id, so the
  // result is deterministic); lower half first.
  int median_split(int begin, int end, const Box& cbox, Box child_box[2], Box child_cbox[2]) {
    int a = widest_axis(cbox);
    int mid = begin + (end - begin) / 2;
    std::nth_element(refs.begin() + begin, refs.begin() + mid, refs.begin() + end,
                     [a](const PrimRef<R>& x, const PrimRef<R>& y) {
                       double cx = x.centroid(a), cy = y.centroid(a);
                       return cx < cy || (cx == cy && x.id < y.id);
                     });
    bounds_of(refs, begin, mid, &child_box[0], &child_cbox[0]);
    bounds_of(refs, mid, end, &child_box[1], &child_cbox[1]);
    return mid;
  }

  // Binned SAH along the widest axis of the centroids, as pbrt-v4's BVHAggregate does.
  // Binning all three axes below 4096 primitives found trees that rendered at most
  // about 2% faster, for 13-20% more build time (docs/performance.md, "BVH build").
  // Returns the split position, or -1 for "make a leaf" (allowed only at
  // kMaxLeafSize primitives or fewer); on a split, the children's bounds and centroid
  // bounds. all_threads: the passes over the primitives run on every thread
  // (reduce_range), for the root, while nothing else runs.
  int sah_split(int begin, int end, const Box& box, const Box& cbox, Box child_box[2],
                Box child_cbox[2], bool all_threads = false) {
    int n = end - begin;
    // Each bin bounds its primitives and their centroids: the children's centroid
    // bounds are then unions of bins, as their boxes are, and need no pass of their
    // own after the partition. Four lanes per bound, the fourth unused, so that g++
    // grows a bin with whole-vector minima and maxima (vminps/vmaxps): as scalars,
    // twelve loads and stores per primitive, the binning cost more than the pass it
    // saves (docs/performance.md, "BVH build").
    struct Bin {
      R lo[4], hi[4], clo[4], chi[4];
      int count;
      // The bin grown by a box [plo, phi] and a centroid box [pclo, pchi], lane by
      // lane, in one loop (g++ left two loops of this shape scalar).
      void grow(const R* plo, const R* phi, const R* pclo, const R* pchi) {
        for (int l = 0; l < 4; ++l) {
          lo[l] = plo[l] < lo[l] ? plo[l] : lo[l];
          hi[l] = phi[l] > hi[l] ? phi[l] : hi[l];
          clo[l] = pclo[l] < clo[l] ? pclo[l] : clo[l];
          chi[l] = pchi[l] > chi[l] ? pchi[l] : chi[l];
        }
      }
      void grow(const Bin& b) { grow(b.lo, b.hi, b.clo, b.chi); }
      // The box alone grown by another bin's (the SAH sweep's accumulators).
      void grow_box(const Bin& b) {
        for (int l = 0; l < 4; ++l) {
          lo[l] = b.lo[l] < lo[l] ? b.lo[l] : lo[l];
          hi[l] = b.hi[l] > hi[l] ? b.hi[l] : hi[l];
        }
      }
      static Bin empty() {
        Bin b;
        for (int l = 0; l < 4; ++l) {
          b.lo[l] = b.clo[l] = std::numeric_limits<R>::infinity();
          b.hi[l] = b.chi[l] = -std::numeric_limits<R>::infinity();
        }
        b.count = 0;
        return b;
      }
      BasicBox<R> box() const { return bounds(lo, hi); }
      double half_area() const { return half_area_of(lo, hi); }
      BasicBox<R> cbox() const { return bounds(clo, chi); }
      static BasicBox<R> bounds(const R* l, const R* h) {
        BasicBox<R> b;
        for (int k = 0; k < 3; ++k) b.lo[k] = l[k], b.hi[k] = h[k];
        return b;
      }
    };
    struct Bins {
      Bin bin[kBins];
    };
    // A node of n < kBins primitives gets n bins: most nodes are small (a tree of a
    // million primitives has about half a million of them), and setting up and
    // sweeping 16 bins cost them more than binning their primitives (measured:
    // 30-40% of a 1e6-sphere build).
    const int n_bins = std::min(kBins, n);
    // Where no bin boundary separates the primitives: a leaf if they fit, else halves.
    auto no_sah_split = [&] {
      return n <= kMaxLeafSize ? -1 : median_split(begin, end, cbox, child_box, child_cbox);
    };
    const int a = widest_axis(cbox);
    const double extent = cbox.hi[a] - cbox.lo[a];
    if (!(extent > 0)) return no_sah_split();  // all centroids coincide
    const double scale = n_bins / extent;
    const double lo = cbox.lo[a];
    // The one bin computation: binning calls it, and the partition below splits where
    // it does, so each primitive goes to the side it was counted on.
    auto bin_of_centroid = [&](R centroid) {
      return std::min(n_bins - 1, static_cast<int>((centroid - lo) * scale));
    };
    auto merge = [n_bins](Bins& into, const Bins& from) {
      for (int k = 0; k < n_bins; ++k) {
        Bin& t = into.bin[k];
        const Bin& f = from.bin[k];
        t.count += f.count;
        t.grow(f);
      }
    };
    // kBinSets sets of bins, primitive k in set k mod kBinSets, merged at the end: where
    // neighbours fall in one bin (a mesh in spatial order), each update of a bin waits
    // for the last one's store; spread over four copies, four updates overlap. Minima,
    // maxima and counts are exact, so the merged bins, and the tree, are the same bits.
    // mesh_1e6's build took 0.78-0.85 of its time with one set, spheres_1e6's (random
    // order) 0.91-1.00 (docs/performance.md, "BVH build"). Few primitives keep one set,
    // whose set-up and merge would cost them more.
    // A chunk's bins are found in a loop of their own before any bin grows. Neighbouring
    // primitives often fall in one bin, where each update waits for the one before;
    // found in the same loop, each bin's conversions queued behind those updates
    // (mesh_1e6's pack took about 1.1 times as long; docs/performance.md).
    // Into `sets` sets of bins at `set`. A small node's pass bins straight into the
    // result: copying the first set out (1 KB) cost 50-60 of the 330-530 cycles of a
    // split of 3-8 primitives (Intel Xeon).
    auto bin_into = [&](int b, int e, Bins* set, int sets) {
      for (int s = 0; s < sets; ++s)
        for (int k = 0; k < n_bins; ++k) set[s].bin[k] = Bin::empty();
      const int set_mask = sets - 1;
      constexpr int kChunk = 64;
      int bin_index[kChunk];
      for (int chunk = b; chunk < e; chunk += kChunk) {
        const int m = std::min(kChunk, e - chunk);
        for (int k = 0; k < m; ++k)
          bin_index[k] = bin_of_centroid(refs[static_cast<size_t>(chunk + k)].centroid(a));
        for (int k = 0; k < m; ++k) {
          const BasicBox<R>& box = refs[static_cast<size_t>(chunk + k)].box;
          const R lo4[4] = {box.lo[0], box.lo[1], box.lo[2], box.lo[0]};
          const R hi4[4] = {box.hi[0], box.hi[1], box.hi[2], box.hi[0]};
          R c[4];  // c[a] is PrimRef::centroid(a), as binned
          for (int l = 0; l < 4; ++l) c[l] = PrimRef<R>::midpoint(lo4[l], hi4[l]);
          Bin& bin = set[k & set_mask].bin[bin_index[k]];
          bin.count++;
          bin.grow(lo4, hi4, c, c);
        }
      }
      for (int s = 1; s < sets; ++s) merge(set[0], set[s]);
    };
    auto bin_pass = [&](int b, int e, Bins& out) {
      if (e - b < kBinSetsMinPrims) return bin_into(b, e, &out, 1);
      Bins set[kBinSets];
      bin_into(b, e, set, kBinSets);
      out = set[0];
    };
    Bins set;
    reduce_range(begin, end, all_threads, set, bin_pass, merge);
    const Bin* bins = set.bin;
    // Sweep from the right for the right-side areas, then from the left. The sides'
    // bounds grow in R lanes as the bins do and are converted for their areas only
    // (min and max are exact, so the areas are those of bounds grown in double).
    double best_cost = std::numeric_limits<double>::infinity();
    int split = -1;
    std::array<double, kBins> right_area;
    std::array<int, kBins> right_count;
    Bin acc = Bin::empty();
    int count = 0;
    for (int b = n_bins - 1; b > 0; --b) {
      acc.grow_box(bins[b]);
      count += bins[b].count;
      right_area[b] = acc.half_area();
      right_count[b] = count;
    }
    acc = Bin::empty();
    count = 0;
    for (int b = 0; b < n_bins - 1; ++b) {
      acc.grow_box(bins[b]);
      count += bins[b].count;
      double cost = acc.half_area() * count + right_area[b + 1] * right_count[b + 1];
      // Selects, not a branch: which bin wins is data the predictor cannot learn.
      bool better = count > 0 && right_count[b + 1] > 0 && cost < best_cost;
      best_cost = better ? cost : best_cost;
      split = better ? b : split;
    }
    double area = box.half_area();
    double leaf_cost = static_cast<double>(n);
    if (split < 0) return no_sah_split();  // every primitive fell in one bin
    double split_cost = traversal_cost + (area > 0 ? best_cost / area : static_cast<double>(n));
    if (n <= kMaxLeafSize && leaf_cost <= split_cost) return -1;
    // The children's boxes and centroid bounds are unions of their bins' (grown in R,
    // converted once: min and max are exact, so these are the bounds a pass over each
    // side would find).
    Bin sides[2] = {Bin::empty(), Bin::empty()};
    for (int b = 0; b < n_bins; ++b) sides[b <= split ? 0 : 1].grow(bins[b]);
    for (int side = 0; side < 2; ++side) {
      child_box[side] = sides[side].box().template as<double>();
      child_cbox[side] = sides[side].cbox().template as<double>();
    }
    // Partition by bin_of_centroid, the function that counted each primitive in its
    // bin. For a large node, with one compare per centroid: bin_of_centroid is monotonic
    // (each of its steps rounds monotonically), so the left side's centroids are
    // exactly those below the least value whose bin is past `split`, which lies in
    // (least centroid, greatest centroid], the first in bin 0 and the second past
    // `split`. Finding it costs a bisection, which a small node does not repay.
    if (n < kPartitionByValuePrims) {
      auto left_side = [&](const PrimRef<R>& r) { return bin_of_centroid(r.centroid(a)) <= split; };
      return block_partition(refs, begin, end, left_side);
    }
    const R first_right =
        least_where(static_cast<R>(cbox.lo[a]), static_cast<R>(cbox.hi[a]),
                    [&](R centroid) { return bin_of_centroid(centroid) > split; });
    auto left_side = [&](const PrimRef<R>& r) { return r.centroid(a) < first_right; };
    return block_partition(refs, begin, end, left_side);
  }
};

}  // namespace detail

// The binary tree as the builder makes it, and the primitive ids in leaf order
// (order[i] is the id of the i-th primitive the leaves list: spheres first,
// 0 .. n_spheres - 1, then triangles).
template <class T>
struct BinaryBvh {
  LargeVector<BinaryNode<T>> nodes;
  LargeVector<int> order;
};

// A built BVH as the device code reads it (device/types.h, "The BVH"): `width`
// children per node, boxes and links node by node, and the leaf order of the
// primitives, by which pack() reorders the scene's arrays (pack/pack.hpp).
template <class T>
struct Bvh {
  WideNodes<T> nodes;
  LargeVector<int> order;
  int width() const { return nodes.width(); }
  int node_count() const { return nodes.size(); }
};

// A primitive's box, computed in double and rounded outward to T, so it contains the
// primitive as the tests see it.
template <class T>
BasicBox<T> rounded_box(const Box& box) {
  BasicBox<T> rounded;
  for (int a = 0; a < 3; ++a) {
    rounded.lo[a] = round_down<T>(box.lo[a]);
    rounded.hi[a] = round_up<T>(box.hi[a]);
  }
  return rounded;
}
template <class T>
BasicBox<T> primitive_box(const typename device::Code<T>::Sphere& s) {
  double c[3] = {s.cx, s.cy, s.cz}, rad = s.radius;
  Box box;
  for (int a = 0; a < 3; ++a) {
    box.lo[a] = c[a] - rad;
    box.hi[a] = c[a] + rad;
  }
  return rounded_box<T>(box);
}
template <class T>
BasicBox<T> primitive_box(const typename device::Code<T>::Triangle& t) {
  double p[3][3] = {{t.p0x, t.p0y, t.p0z}, {t.p1x, t.p1y, t.p1z}, {t.p2x, t.p2y, t.p2z}};
  Box box;
  for (auto& v : p) box.grow(v);
  return rounded_box<T>(box);
}
// The box of primitive i (spheres first, then triangles).
template <class T>
BasicBox<T> primitive_box(const LargeVector<typename device::Code<T>::Sphere>& spheres,
                          const LargeVector<typename device::Code<T>::Triangle>& triangles, int i) {
  const int n_spheres = static_cast<int>(spheres.size());
  return i < n_spheres ? primitive_box<T>(spheres[static_cast<size_t>(i)])
                       : primitive_box<T>(triangles[static_cast<size_t>(i - n_spheres)]);
}

// The builder's record of every primitive (spheres first, then triangles): its id and
// its box (primitive_box), filled on every thread.
template <class T>
LargeVector<PrimRef<T>> primitive_refs(
    const LargeVector<typename device::Code<T>::Sphere>& spheres,
    const LargeVector<typename device::Code<T>::Triangle>& triangles) {
  const int n = static_cast<int>(spheres.size() + triangles.size());
  LargeVector<PrimRef<T>> refs(static_cast<size_t>(n));
  parallel_for(n, 4096, [&](int i) {
    PrimRef<T>& r = refs[static_cast<size_t>(i)];
    r.id = i;
    r.box = primitive_box<T>(spheres, triangles, i);
  });
  return refs;
}

// Builds the binary SAH tree of the primitives `refs` records (ids 0 .. n_spheres - 1
// spheres, the rest triangles, as primitive_refs numbers them); touches nothing else.
// Runs on the threads of parallel_for (core/parallel.hpp); the result does not depend
// on how many.
template <class T>
BinaryBvh<T> build_binary(LargeVector<PrimRef<T>> refs, int n_spheres) {
  using Node = BinaryNode<T>;
  const int n = static_cast<int>(refs.size());
  BinaryBvh<T> bvh;
  if (n == 0) return bvh;
  detail::Builder<Node, T> builder(refs, traversal_cost(n_spheres, n - n_spheres));
  Box root_box, root_cbox;
  detail::bounds_of(refs, 0, n, &root_box, &root_cbox, true);
  bvh.nodes.reserve(static_cast<size_t>(n));
  bvh.nodes.emplace_back();
  builder.build(bvh.nodes, 0, 0, n, 0, root_box, root_cbox);
  bvh.order.resize(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) bvh.order[static_cast<size_t>(i)] = refs[static_cast<size_t>(i)].id;
  return bvh;
}

// The binary tree over the packed spheres and triangles.
template <class T>
BinaryBvh<T> build_binary(const LargeVector<typename device::Code<T>::Sphere>& spheres,
                          const LargeVector<typename device::Code<T>::Triangle>& triangles) {
  return build_binary<T>(primitive_refs<T>(spheres, triangles), static_cast<int>(spheres.size()));
}

namespace detail {

enum class Collapse { Greedy, FixedLevels };

// Half the surface area of a binary node's box (the SAH's measure of how often a ray
// enters it).
template <class T>
double half_area(const BinaryNode<T>& node) {
  double d[3];
  for (int a = 0; a < 3; ++a)
    d[a] = double(node.bounds[TR_BVH_MAX_X + a]) - double(node.bounds[TR_BVH_MIN_X + a]);
  return d[0] * d[1] + d[1] * d[2] + d[2] * d[0];
}

// The binary nodes the w-wide node for binary node b holds, in left-to-right order (see
// the collapse at the top of this file); returns how many. A leaf b stands for itself.
template <class T>
int gather_children(const LargeVector<BinaryNode<T>>& binary, int b, int w, Collapse how,
                    int* children) {
  children[0] = b;
  int n = 1;
  if (how == Collapse::FixedLevels) {
    for (int level = 0; level < log2_width(w); ++level) {
      int next[TR_BVH_MAX_WIDTH], m = 0;
      for (int i = 0; i < n; ++i) {
        const BinaryNode<T>& node = binary[static_cast<size_t>(children[i])];
        if (node.count > 0) {
          next[m++] = children[i];
        } else {
          next[m++] = node.first;
          next[m++] = node.first + 1;
        }
      }
      std::copy(next, next + m, children);
      n = m;
    }
    return n;
  }
  // Greedy; the first of equal areas is opened, so the result is deterministic. Each
  // child's area is computed once, as it joins (-1: a leaf, never opened).
  auto area_of = [&](int b) {
    const BinaryNode<T>& node = binary[static_cast<size_t>(b)];
    return node.count > 0 ? -1.0 : half_area(node);
  };
  double areas[TR_BVH_MAX_WIDTH];
  areas[0] = area_of(b);
  while (n < w) {
    int best = -1;
    double best_area = -1;
    for (int i = 0; i < n; ++i)
      if (areas[i] >= 0 && (best < 0 || areas[i] > best_area)) best = i, best_area = areas[i];
    if (best < 0) break;
    const int first = binary[static_cast<size_t>(children[best])].first;
    std::copy_backward(children + best + 1, children + n, children + n + 1);
    std::copy_backward(areas + best + 1, areas + n, areas + n + 1);
    children[best] = first;
    children[best + 1] = first + 1;
    areas[best] = area_of(first);
    areas[best + 1] = area_of(first + 1);
    ++n;
  }
  return n;
}

// The inner nodes among the n binary nodes children[], in their order, into inner[];
// returns how many there are.
template <class T>
int inner_children(const LargeVector<BinaryNode<T>>& binary, const int* children, int n,
                   int* inner) {
  int n_inner = 0;
  for (int k = 0; k < n; ++k)
    if (binary[static_cast<size_t>(children[k])].count == 0) inner[n_inner++] = children[k];
  return n_inner;
}

// How many wide nodes collapse_node writes for binary node b: the same gathers, no
// writes.
template <class T>
size_t count_wide_nodes(const LargeVector<BinaryNode<T>>& binary, int b, int w, Collapse how) {
  int children[TR_BVH_MAX_WIDTH], inner[TR_BVH_MAX_WIDTH];
  const int n = gather_children(binary, b, w, how, children);
  const int n_inner = inner_children(binary, children, n, inner);
  size_t count = 1;
  for (int i = 0; i < n_inner; ++i) count += count_wide_nodes(binary, inner[i], w, how);
  return count;
}

// Trees of fewer binary nodes are collapsed on the calling thread.
constexpr size_t kParallelCollapseNodes = 2 * kParallelMinPrims;

// Writes the wide node for binary node b at index `self` of `out` and, depth first, the
// nodes below it from self + 1 on: each inner child's subtree in turn, so node indices
// are a preorder (out holds room for them: count_wide_nodes). Returns the index after
// the last node written, and in *stack the most traversal stack entries a walk from
// this node can hold: (inner children - 1) here, plus the most of any inner child.
// Given `inner_counts`, the node counts of the inner children's subtrees in order, each
// subtree knows where it starts, and they are collapsed side by side (parallel_for):
// the same bytes as one after the other. Recursion depth is bounded by kMaxDepth.
template <class T>
int collapse_node(const LargeVector<BinaryNode<T>>& binary, int b, Collapse how, WideNodes<T>& out,
                  int self, int* stack, const size_t* inner_counts = nullptr) {
  const int w = out.width();
  int children[TR_BVH_MAX_WIDTH], inner[TR_BVH_MAX_WIDTH];
  const int n = gather_children(binary, b, w, how, children);
  const int n_inner = inner_children(binary, children, n, inner);
  int start[TR_BVH_MAX_WIDTH] = {}, child_stack[TR_BVH_MAX_WIDTH] = {};
  int next = self + 1;
  if (inner_counts) {
    int largest_first[TR_BVH_MAX_WIDTH];
    for (int i = 0; i < n_inner; ++i) {
      start[i] = next;
      next += static_cast<int>(inner_counts[i]);
      largest_first[i] = i;
    }
    // The largest subtrees first, so that the threads finish together.
    std::stable_sort(largest_first, largest_first + n_inner,
                     [&](int x, int y) { return inner_counts[x] > inner_counts[y]; });
    parallel_for(n_inner, 1, [&](int j) {
      const int i = largest_first[j];
      collapse_node(binary, inner[i], how, out, start[i], &child_stack[i]);
    });
  } else {
    for (int i = 0; i < n_inner; ++i) {
      start[i] = next;
      next = collapse_node(binary, inner[i], how, out, next, &child_stack[i]);
    }
  }
  int below = 0;
  for (int k = 0, i = 0; k < w; ++k) {
    if (k >= n) {
      out.set_empty_child(self, k);
      continue;
    }
    const BinaryNode<T>& child = binary[static_cast<size_t>(children[k])];
    int first = child.first;
    if (child.count == 0) {
      first = start[i];
      below = std::max(below, child_stack[i++]);
    }
    out.set_child(self, k, child.bounds, first, child.count);
  }
  *stack = std::max(n_inner - 1, 0) + below;
  return next;
}

// The wide nodes of the binary tree into `out`, resized to their exact count, counted
// first: growing copied the arrays and touched fresh pages again, and a bound (one wide
// node per inner binary node) reserved too much (3.1 times the count for mesh_1e6 at
// width 8), which recycled pages (core/large_array.hpp) would have filled for nothing.
// A large tree's root subtrees are counted and collapsed side by side, which took the
// collapse of mesh_1e6 from 18 to 11 ms on 2 threads (docs/performance.md). Returns the
// stack need (collapse_node).
template <class T>
int collapse_tree(const LargeVector<BinaryNode<T>>& binary, Collapse how, WideNodes<T>& out) {
  const int w = out.width();
  int stack = 0;
  if (binary.size() < kParallelCollapseNodes || thread_count() < 2) {
    out.resize(count_wide_nodes(binary, 0, w, how));
    collapse_node(binary, 0, how, out, 0, &stack);
    return stack;
  }
  int children[TR_BVH_MAX_WIDTH], inner[TR_BVH_MAX_WIDTH];
  const int n = gather_children(binary, 0, w, how, children);
  const int n_inner = inner_children(binary, children, n, inner);
  size_t counts[TR_BVH_MAX_WIDTH];
  parallel_for(n_inner, 1, [&](int i) { counts[i] = count_wide_nodes(binary, inner[i], w, how); });
  size_t total = 1;
  for (int i = 0; i < n_inner; ++i) total += counts[i];
  out.resize(total);
  collapse_node(binary, 0, how, out, 0, &stack, counts);
  return stack;
}

}  // namespace detail

// The binary tree's nodes collapsed into `width`-wide nodes (2, 4 or 8): greedily, or at
// fixed levels where the greedy tree would need more stack than the traversal has (see
// the top of this file). The order is left to the caller.
template <class T>
Bvh<T> collapse(const BinaryBvh<T>& binary, int width,
                detail::Collapse how = detail::Collapse::Greedy) {
  Bvh<T> out;
  out.nodes = WideNodes<T>(width);
  if (binary.nodes.empty()) return out;
  if (detail::collapse_tree(binary.nodes, how, out.nodes) > TR_BVH_STACK_SIZE) {
    // At fixed levels the need is at most stack_needed(width) (static_assert above).
    out.nodes.clear();
    detail::collapse_tree(binary.nodes, detail::Collapse::FixedLevels, out.nodes);
  }
  return out;
}

// Builds the `width`-wide BVH of the primitives `refs` records (build_binary, collapse).
template <class T>
Bvh<T> build(LargeVector<PrimRef<T>> refs, int n_spheres, int width) {
  BinaryBvh<T> binary = build_binary<T>(std::move(refs), n_spheres);
  Bvh<T> bvh = collapse(binary, width);
  bvh.order = std::move(binary.order);
  return bvh;
}
template <class T>
Bvh<T> build(const LargeVector<typename device::Code<T>::Sphere>& spheres,
             const LargeVector<typename device::Code<T>::Triangle>& triangles, int width) {
  return build<T>(primitive_refs<T>(spheres, triangles), static_cast<int>(spheres.size()), width);
}

// Depth, node and leaf counts of the binary tree (for tests).
template <class T>
Stats stats(const LargeVector<BinaryNode<T>>& nodes) {
  Stats st;
  if (nodes.empty()) return st;
  st.nodes = static_cast<int>(nodes.size());
  std::vector<std::pair<int, int>> todo{{0, 0}};
  while (!todo.empty()) {
    auto [i, d] = todo.back();
    todo.pop_back();
    const BinaryNode<T>& node = nodes[static_cast<size_t>(i)];
    if (node.count > 0) {
      st.leaves++;
      st.max_depth = std::max(st.max_depth, d);
      st.max_leaf = std::max(st.max_leaf, node.count);
    } else {
      todo.push_back({node.first, d + 1});
      todo.push_back({node.first + 1, d + 1});
    }
  }
  return st;
}

// The same of a wide tree; max_depth counts inner nodes on a path.
template <class T>
Stats wide_stats(const WideNodes<T>& nodes) {
  Stats st;
  if (nodes.empty()) return st;
  const int width = nodes.width();
  st.nodes = nodes.size();
  struct Visit {
    int node, depth, stack;  // stack: entries the ancestors may have pushed
  };
  std::vector<Visit> todo{{0, 1, 0}};
  while (!todo.empty()) {
    const Visit v = todo.back();
    todo.pop_back();
    st.max_depth = std::max(st.max_depth, v.depth);
    const int* link = nodes.links(v.node);
    int inner = 0;
    for (int k = 0; k < width; ++k) inner += link[width + k] == 0;
    const int stack = v.stack + std::max(inner - 1, 0);
    st.stack_need = std::max(st.stack_need, stack);
    for (int k = 0; k < width; ++k) {
      if (link[width + k] > 0) {
        st.leaves++;
        st.max_leaf = std::max(st.max_leaf, link[width + k]);
      } else if (link[width + k] == 0) {
        todo.push_back({link[k], v.depth + 1, stack});
      }
    }
  }
  return st;
}

}  // namespace bvh
}  // namespace twinray
