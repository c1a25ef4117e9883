// The nodes of the BVH: the binary tree the builder makes (BinaryNode, BinaryBvh) and
// the W-wide nodes (W = 2, 4 or 8) that device/bvh_traverse.h walks on both backends
// (WideNodes, Bvh), with the statistics tests read from them.
//
// Layout (device/types.h, "The BVH"): node 0 is the root; each node holds its W
// children's boxes as structure of arrays and then a (first, count) link per child; a
// leaf's primitives are bvh_prims[first .. first + count). Primitive ids: spheres first
// (0 .. n_spheres - 1), then triangles.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <limits>
#include <utility>
#include <vector>

#include <twinray/core/large_array.hpp>
#include <twinray/device/code.hpp>

namespace twinray {
namespace bvh {

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
