// The BVH's constants: when a scene gets a BVH at all, the SAH's parameters (leaf size,
// bins, the cost of an inner node), the sizes from which the build runs on several
// threads, and the node widths. A measured constant names, in one line, what it was
// measured against and where the benchmark is.
#pragma once

#include <twinray/device/code.hpp>

namespace twinray {
namespace bvh {

// Small scenes skip the BVH: linear loops are as fast there. The rule weighs a
// triangle as 4 spheres (the watertight triangle test costs several sphere tests) and
// builds the BVH from a weight of 8 on, where it starts to pay on both backends.
// Measured: --bvh on|off on 1-16 primitives (bench/twinray_bench.cpp, docs/performance.md).
constexpr int kTriangleWeight = 4;
constexpr long long kMinWeight = 8;

inline bool worth_building(long long n_spheres, long long n_triangles) {
  return n_spheres + kTriangleWeight * n_triangles >= kMinWeight;
}

constexpr int kMaxDepth = TR_BVH_MAX_DEPTH;  // leaf depth cap of the binary tree
constexpr int kMaxLeafSize = 8;              // SAH leaves hold at most this many primitives
constexpr int kBins = 16;                    // SAH bins
// The SAH's cost of visiting an inner node, relative to one primitive test: the walk
// tests both children's boxes there, each about as dear as a sphere test. At 1 the
// builder splits down to about one sphere per leaf; at 2 the tree has half the nodes,
// builds faster and renders no slower; at 4 it renders slower.
// Measured: costs 1-4 on the 1e5 and 1e6 scenes (bench/twinray_bench.cpp, docs/performance.md).
constexpr double kTraversalCost = 2.0;
// Scenes of spheres alone, fewer than kSmallSphereScene of them, split further, at a
// traversal cost of 1: the CPU backend tests a leaf's spheres for a packet's rays side
// by side, and over large spheres (hundreds of pixels each) smaller leaves spare those
// tests for rays that only crossed the leaf's box. From a million spheres on the longer
// build outweighs the gain, and meshes render slower at cost 1, so those keep 2.
// Measured: cost 1 vs 2, sphere and mesh scenes (bench/twinray_bench.cpp, docs/performance.md).
constexpr long long kSmallSphereScene = 1 << 17;
// Scenes of at least kLargeMeshScene triangles merge further, at a traversal cost of 3:
// their tree outgrows the caches, a node read from memory costs more than the
// triangles a packet's rays test side by side in a larger leaf, and at cost 3 mesh_1e6
// has 4.4 triangles per leaf instead of 2.8 and 66 k wide nodes instead of 115 k.
// Smaller meshes, whose tree stays in the caches, render slower at 3 and keep 2.
// Measured: costs 2-4 on mesh_1e4 and mesh_1e6 (bench/twinray_bench.cpp, docs/performance.md).
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

}  // namespace bvh
}  // namespace twinray
