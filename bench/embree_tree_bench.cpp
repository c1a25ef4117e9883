// twinray's walk over two trees of the same scene: its own (the binned SAH build
// collapsed into 8-wide nodes, pack/bvh.hpp) and one built by Embree's generic builder
// (rtcBuildBVH: binned SAH, 8-wide nodes made directly, the SAH counting leaves in
// blocks of 4 primitives as Embree's Triangle4 leaves do). Both are rendered by the
// CPU backend, frames alternated, so the ratio says what the tree alone is worth:
// whether Embree's lead on a scene comes from its tree or from the code that walks it.
// Closest hits do not depend on the tree (device/bvh_traverse.h, tr_offer_hit), so the
// two images must be the same bits; the program fails where they are not.
//
//   embree_tree_bench [--scenes a,b] [--pairs N] [--block B] [--obj-dir DIR]
//
// Scenes of one kind of primitive only (spheres or triangles: the packed arrays are
// reordered into the new tree's leaf order, which a mixed scene would also need in
// bvh_prims). Float, 1920x1080, the scene's own spp, the machine's threads. Prints one
// CSV line per scene: node and leaf counts and children per node of both trees, the
// median frame of each, and the median and quartiles of the per-pair ratio, Embree's
// tree over twinray's.
#include <embree3/rtcore.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "bench_runner.hpp"
#include "bench_stats.hpp"

namespace {
using twinray_bench::image_hash;
using twinray_bench::quantile;

using Nodes = twinray::bvh::WideNodes<float>;
constexpr int kWidth = 8;

// The tree rtcBuildBVH hands back, through its callbacks: inner nodes of up to 8
// children with their boxes, leaves listing primitive indices. Allocated from Embree's
// thread-local allocator, freed with the RTCBVH.
struct TreeNode {
  bool leaf;
  int n;  // children, or primitives of a leaf
};
struct Inner : TreeNode {
  const TreeNode* child[kWidth];
  RTCBounds box[kWidth];
};
struct Leaf : TreeNode {
  int prim[1];  // n of them
};

void* create_inner(RTCThreadLocalAllocator alloc, unsigned int n, void*) {
  auto* node = static_cast<Inner*>(rtcThreadLocalAlloc(alloc, sizeof(Inner), 16));
  node->leaf = false;
  node->n = static_cast<int>(n);
  return node;
}
void set_children(void* node, void** children, unsigned int n, void*) {
  for (unsigned int k = 0; k < n; ++k)
    static_cast<Inner*>(node)->child[k] = static_cast<const TreeNode*>(children[k]);
}
void set_bounds(void* node, const RTCBounds** bounds, unsigned int n, void*) {
  for (unsigned int k = 0; k < n; ++k) static_cast<Inner*>(node)->box[k] = *bounds[k];
}
void* create_leaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive* prims, size_t n, void*) {
  auto* leaf = static_cast<Leaf*>(rtcThreadLocalAlloc(alloc, sizeof(Leaf) + sizeof(int) * n, 16));
  leaf->leaf = true;
  leaf->n = static_cast<int>(n);
  for (size_t i = 0; i < n; ++i) leaf->prim[i] = static_cast<int>(prims[i].primID);
  return leaf;
}

// Writes `node` and, depth first, the nodes below it in twinray's layout; a leaf's
// primitives are appended to `order` (the new leaf order). Each box is padded and
// rounded outward by the rule twinray's builder applies to its own (Builder::set_box).
int write_node(const Inner& node, Nodes& out, std::vector<int>& order) {
  using Builder = twinray::bvh::detail::Builder<twinray::bvh::BinaryNode<float>, float>;
  const int self = out.size();
  out.resize(static_cast<size_t>(self) + 1);
  for (int k = 0; k < kWidth; ++k) {
    if (k >= node.n) {
      out.set_empty_child(self, k);
      continue;
    }
    const RTCBounds& b = node.box[k];
    twinray::bvh::Box exact;
    exact.lo[0] = b.lower_x, exact.lo[1] = b.lower_y, exact.lo[2] = b.lower_z;
    exact.hi[0] = b.upper_x, exact.hi[1] = b.upper_y, exact.hi[2] = b.upper_z;
    twinray::bvh::BinaryNode<float> padded;
    Builder::set_box(padded, exact);
    int first = 0, count = 0;
    if (node.child[k]->leaf) {
      const auto& leaf = *static_cast<const Leaf*>(node.child[k]);
      first = static_cast<int>(order.size());
      count = leaf.n;
      order.insert(order.end(), leaf.prim, leaf.prim + leaf.n);
    } else {
      first = write_node(*static_cast<const Inner*>(node.child[k]), out, order);
    }
    out.set_child(self, k, padded.bounds, first, count);  // after resize() moved the nodes
  }
  return self;
}

// Each primitive's box as twinray's builder makes it (bvh::primitive_box).
std::vector<RTCBuildPrimitive> primitive_boxes(const twinray::PackedScene<float>& ps) {
  const size_t n = ps.spheres.size() + ps.triangles.size();
  std::vector<RTCBuildPrimitive> prims(n);
  for (size_t i = 0; i < n; ++i) {
    const auto box =
        twinray::bvh::primitive_box<float>(ps.spheres, ps.triangles, static_cast<int>(i));
    RTCBuildPrimitive& r = prims[i];
    r.lower_x = box.lo[0], r.lower_y = box.lo[1], r.lower_z = box.lo[2];
    r.upper_x = box.hi[0], r.upper_y = box.hi[1], r.upper_z = box.hi[2];
    r.geomID = 0;
    r.primID = static_cast<unsigned int>(i);
  }
  return prims;
}

// ps with its BVH replaced by Embree's tree over the same primitives, and its
// primitives put in that tree's leaf order. Returns false where the tree does not fit
// the walk (a leaf at the root, or more stack than TR_BVH_STACK_SIZE).
bool use_embree_tree(twinray::PackedScene<float>& ps, RTCDevice device, int block,
                     double* build_ms) {
  std::vector<RTCBuildPrimitive> prims = primitive_boxes(ps);
  const size_t n = prims.size();
  RTCBVH bvh = rtcNewBVH(device);
  RTCBuildArguments args = rtcDefaultBuildArguments();
  args.buildQuality = RTC_BUILD_QUALITY_MEDIUM;
  args.maxBranchingFactor = kWidth;
  args.maxDepth = 16;  // 7 stack entries per level: within TR_BVH_STACK_SIZE
  args.sahBlockSize = static_cast<unsigned int>(block);
  args.minLeafSize = 1;
  args.maxLeafSize = 8;  // twinray's kMaxLeafSize
  args.traversalCost = 1.0f;
  args.intersectionCost = 1.0f;
  args.bvh = bvh;
  args.primitives = prims.data();
  args.primitiveCount = n;
  args.primitiveArrayCapacity = n;
  args.createNode = create_inner;
  args.setNodeChildren = set_children;
  args.setNodeBounds = set_bounds;
  args.createLeaf = create_leaf;
  const auto t0 = std::chrono::steady_clock::now();
  const auto* root = static_cast<const TreeNode*>(rtcBuildBVH(&args));
  *build_ms = twinray_bench::ms_since(t0);
  bool fits = root != nullptr && !root->leaf;
  if (fits) {
    Nodes nodes(kWidth);
    std::vector<int> order;
    order.reserve(n);
    write_node(*static_cast<const Inner*>(root), nodes, order);
    fits = order.size() == n && twinray::bvh::wide_stats(nodes).stack_need <= TR_BVH_STACK_SIZE;
    if (fits) {
      ps.bvh_nodes = std::move(nodes);
      auto permute = [&order](auto& array) {
        auto moved = array;
        for (size_t i = 0; i < order.size(); ++i) moved[i] = array[static_cast<size_t>(order[i])];
        array.swap(moved);
      };
      if (!ps.spheres.empty()) permute(ps.spheres);
      if (!ps.triangles.empty()) permute(ps.triangles);
      if (!ps.triangle_attrs.empty()) permute(ps.triangle_attrs);
    }
  }
  rtcReleaseBVH(bvh);
  return fits;
}

const char* usage =
    "usage: embree_tree_bench [--scenes a,b] [--pairs N] [--block B] [--obj-dir DIR]\n";

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> scenes = {"spheres_1e5", "spheres_1e6", "mesh_1e4", "mesh_1e6"};
  int pairs = 12, block = 4;
  std::string obj_dir = ".";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << usage;
      return 0;
    }
    if (i + 1 >= argc) {
      std::cerr << "embree_tree_bench: " << a << " needs a value\n";
      return 2;
    }
    const std::string v = argv[++i];
    if (a == "--scenes")
      scenes = twinray_bench::split(v);
    else if (a == "--pairs")
      pairs = std::max(2, std::atoi(v.c_str()));
    else if (a == "--block")
      block = std::max(1, std::atoi(v.c_str()));
    else if (a == "--obj-dir")
      obj_dir = v;
    else {
      std::cerr << "embree_tree_bench: unknown option " << a << "\n" << usage;
      return 2;
    }
  }
  std::cerr << "machine: " << twinray_bench::machine_description() << "\n";
  std::cout << "scene,twinray_nodes,twinray_leaves,twinray_children_per_node,embree_nodes,"
               "embree_leaves,embree_children_per_node,embree_build_ms,twinray_tree_ms,"
               "embree_tree_ms,ratio_median,ratio_q1,ratio_q3,same_bits"
            << std::endl;
  int status = 0;
  RTCDevice device = rtcNewDevice(nullptr);
  try {
    for (const std::string& name : scenes) {
      auto b = twinray_bench::make_scene<float>(name, 1920, 1080, obj_dir);
      twinray::RenderOptions options = b.options;
      options.backend = twinray::Backend::Cpu;
      options.spp = b.spp;
      auto backend = twinray::make_backend<float>(options);
      twinray::PackedScene<float> own = twinray::pack_scene(b.scene, backend->pack_options());
      twinray::PackedScene<float> other = twinray::pack_scene(b.scene, backend->pack_options());
      double build_ms = 0;
      if (own.bvh_nodes.empty() || own.spheres.empty() == own.triangles.empty() ||
          !use_embree_tree(other, device, block, &build_ms)) {
        std::cerr << "embree_tree_bench: " << name
                  << ": needs a BVH over spheres alone or triangles alone\n";
        status = 1;
        continue;
      }
      const auto st_own = twinray::bvh::wide_stats(own.bvh_nodes);
      const auto st_other = twinray::bvh::wide_stats(other.bvh_nodes);
      const std::shared_ptr<const twinray::PackedScene<float>> trees[2] = {
          twinray::share(std::move(own)), twinray::share(std::move(other))};
      twinray::Image<float> image;
      const twinray::RenderRequest<float> request{b.camera, b.scene.lights, options, {}};
      uint64_t hash[2] = {0, 0};
      bool same = true;
      std::vector<double> ms[2], ratio;
      for (int p = 0; p < pairs; ++p) {
        double pair_ms[2];
        for (int j = 0; j < 2; ++j) {
          const int t = p % 2 == 0 ? j : 1 - j;  // alternate which tree goes first
          backend->set_scene(trees[t]);
          backend->render_into(request, image);  // warm-up after the switch
          const auto t0 = std::chrono::steady_clock::now();
          backend->render_into(request, image);
          pair_ms[t] = twinray_bench::ms_since(t0);
          ms[t].push_back(pair_ms[t]);
          hash[t] = image_hash(image);
        }
        same = same && hash[0] == hash[1];
        ratio.push_back(pair_ms[1] / pair_ms[0]);
      }
      auto per_node = [](const twinray::bvh::Stats& st) {
        return double(st.nodes - 1 + st.leaves) / st.nodes;  // every node but the root is a child
      };
      std::printf("%s,%d,%d,%.2f,%d,%d,%.2f,%.1f,%.1f,%.1f,%.3f,%.3f,%.3f,%s\n", name.c_str(),
                  st_own.nodes, st_own.leaves, per_node(st_own), st_other.nodes, st_other.leaves,
                  per_node(st_other), build_ms, quantile(ms[0], 0.5), quantile(ms[1], 0.5),
                  quantile(ratio, 0.5), quantile(ratio, 0.25), quantile(ratio, 0.75),
                  same ? "yes" : "no");
      std::fflush(stdout);
      if (!same) {
        std::cerr << "embree_tree_bench: " << name << ": the two trees gave different images\n";
        status = 1;
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "embree_tree_bench: " << e.what() << "\n";
    status = 1;
  }
  rtcReleaseDevice(device);
  return status;
}
