// The binary tree collapsed into W-wide nodes (W = 2, 4 or 8), the form
// device/bvh_traverse.h walks.
//
// Greedy: a W-wide node takes binary nodes below the one it stands for, opening the
// inner child with the largest surface area until it holds W children or only leaves
// (the greedy collapse of Embree's wide BVH builders and tinybvh's BVH4/BVH8
// converters): large boxes, the ones rays enter most often (the SAH's measure), are
// split first, and nodes come out nearly full.
//
// Fixed levels: the traversal's stack holds at most (inner children - 1) entries per
// wide node on a path; collapse() adds that up over every path and, where it would
// exceed the stack (device/bvh_traverse.h TR_BVH_STACK_SIZE), collapses the tree at
// fixed levels instead: a W = 2^L wide node then takes the binary nodes L levels down
// (Wald, Benthin, Boulos, "Getting Rid of Packets: Efficient SIMD Single-Ray Traversal
// using Multi-branching BVHs", RT 2008), which bounds every path by the binary depth cap.
#pragma once

#include <algorithm>
#include <cstddef>

#include <twinray/core/large_array.hpp>
#include <twinray/core/parallel.hpp>
#include <twinray/device/code.hpp>
#include <twinray/pack/bvh_constants.hpp>
#include <twinray/pack/bvh_nodes.hpp>

namespace twinray {
namespace bvh {

// The stack bound of a tree collapsed at fixed levels: W - 1 entries per inner wide node
// on a path, and a path holds at most floor((kMaxDepth - 1) / L) + 1 of them (see the
// top of this file). A greedy tree's need is measured instead (collapse()).
constexpr int stack_needed(int w) {
  return (w - 1) * ((kMaxDepth - 1) / log2_width(w) + 1);
}
static_assert(stack_needed(2) <= TR_BVH_STACK_SIZE && stack_needed(4) <= TR_BVH_STACK_SIZE &&
                  stack_needed(8) <= TR_BVH_STACK_SIZE,
              "BVH depth cap exceeds the traversal stack");
static_assert(TR_BVH_MAX_WIDTH == 8, "the walk's per-node arrays hold the widest node");

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
// the top of this file); returns how many. A leaf b stands for itself.
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
// A large tree's root subtrees are counted and collapsed side by side, which makes the
// collapse of mesh_1e6 about 40% faster on 2 threads (docs/performance.md). Returns
// the stack need (collapse_node).
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

}  // namespace bvh
}  // namespace twinray
