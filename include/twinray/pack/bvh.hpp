// The BVH over a packed scene's spheres and triangles (planes are unbounded and stay
// outside it): a binned-SAH build of a binary tree, collapsed into the W-wide node
// arrays (W = 2, 4 or 8) that device/bvh_traverse.h walks on both backends. build()
// returns the nodes and the order of the primitives in the leaves; pack() reorders the
// scene's arrays by it (pack/pack.hpp).
//
// This header holds the entry points (build_binary, collapse, build); the parts, in the
// order a build uses them:
//   pack/bvh_constants.hpp     when a scene gets a BVH; the SAH's costs; widths
//   pack/bvh_nodes.hpp         binary and wide nodes, the built trees, their statistics
//   pack/bvh_boxes.hpp         primitives' boxes, rounded outward
//   pack/bvh_build_passes.hpp  parallel reductions and the branch-free partition
//   pack/bvh_build.hpp         the binned-SAH builder of the binary tree
//   pack/bvh_collapse.hpp      the binary tree collapsed into W-wide nodes
#pragma once

#include <utility>

#include <twinray/core/large_array.hpp>
#include <twinray/device/code.hpp>
#include <twinray/pack/bvh_boxes.hpp>
#include <twinray/pack/bvh_build.hpp>
#include <twinray/pack/bvh_build_passes.hpp>
#include <twinray/pack/bvh_collapse.hpp>
#include <twinray/pack/bvh_constants.hpp>
#include <twinray/pack/bvh_nodes.hpp>

namespace twinray {
namespace bvh {

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

// The binary tree's nodes collapsed into `width`-wide nodes (2, 4 or 8): greedily, or at
// fixed levels where the greedy tree would need more stack than the traversal has
// (pack/bvh_collapse.hpp). The order is left to the caller.
template <class T>
Bvh<T> collapse(const BinaryBvh<T>& binary, int width,
                detail::Collapse how = detail::Collapse::Greedy) {
  Bvh<T> out;
  out.nodes = WideNodes<T>(width);
  if (binary.nodes.empty()) return out;
  if (detail::collapse_tree(binary.nodes, how, out.nodes) > TR_BVH_STACK_SIZE) {
    // At fixed levels the need is at most stack_needed(width) (pack/bvh_collapse.hpp).
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

}  // namespace bvh
}  // namespace twinray
