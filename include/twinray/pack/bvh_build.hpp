// The binned-SAH builder of the binary BVH (detail::Builder).
//
// The surface area heuristic (Goldsmith and Salmon, "Automatic Creation of Object
// Hierarchies for Ray Tracing", 1987; MacDonald and Booth, "Heuristics for ray tracing
// using space subdivision", 1990) prices a split of a node of box area A into sides of
// n_l and n_r primitives and areas A_l, A_r at
//   traversal_cost + (A_l n_l + A_r n_r) / A,
// in units of one primitive test: of uniformly distributed rays, those that enter a
// convex box enter a convex box inside it in the ratio of their surface areas (half
// areas here: only ratios count), and a leaf of n primitives costs n. Rather than
// every split position, Builder::sah_split weighs only the boundaries of kBins bins
// along the widest axis of the centroids (Wald, "On fast Construction of SAH-based
// Bounding Volume Hierarchies", 2007; pbrt-v4 BVHAggregate): nearly as good trees, in
// one linear pass per node.
//
// Guarantees the traversal relies on:
//  - depth: no binary leaf is deeper than kMaxDepth, so the traversal's stack never
//    overflows; near the cap the builder switches to median splits, which halve the
//    count, and it starts doing so early enough to end every branch in small leaves;
//  - bounds: every box contains what it bounds with a margin, rounded outward to the
//    scene's precision (Builder::set_box; primitives' boxes: pack/bvh_boxes.hpp), so
//    rounding in the primitive tests never makes a primitive report a hit through a box
//    the ray misses.
//
// The build runs subtrees on separate threads (parallel_for, core/parallel.hpp); the
// result does not depend on the thread count.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <limits>
#include <type_traits>

#include <twinray/core/large_array.hpp>
#include <twinray/core/parallel.hpp>
#include <twinray/device/code.hpp>
#include <twinray/pack/bvh_boxes.hpp>
#include <twinray/pack/bvh_build_passes.hpp>
#include <twinray/pack/bvh_constants.hpp>

namespace twinray {
namespace bvh {

namespace detail {

// The build's state: the primitive records it reorders into leaf order, the SAH's cost
// of an inner node, and the threads no subtree has taken yet.
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
    // alone, and the left side's thread sat idle while it faulted them in
    // (docs/performance.md, "Huge pages").
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
  // Binning all three axes below 4096 primitives found trees that rendered at most a
  // few percent faster, for a fifth more build time (docs/performance.md, "BVH build").
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
    // A mesh in spatial order builds about a fifth faster, primitives in random order a
    // little (docs/performance.md, "BVH build"). Few primitives keep one set, whose
    // set-up and merge would cost them more.
    // A chunk's bins are found in a loop of their own before any bin grows. Neighbouring
    // primitives often fall in one bin, where each update waits for the one before;
    // found in the same loop, each bin's conversions queued behind those updates
    // (mesh_1e6's pack was about a tenth slower; docs/performance.md).
    // Into `sets` sets of bins at `set`. A small node's pass bins straight into the
    // result: copying the first set out (1 KB) cost about a seventh of a split of 3-8
    // primitives.
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

}  // namespace bvh
}  // namespace twinray
