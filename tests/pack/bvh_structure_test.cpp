// The BVH's structure at every width (every primitive reachable once, boxes contain
// what they bound, depth within the traversal stack) and its traversal against the linear loops:
// the closest hit and the any-hit answer of every ray agree exactly.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <set>
#include <vector>

#include <twinray/twinray.hpp>

#include "bench_scenes.hpp"
#include "bvh_scenes.hpp"
#include "support/page_flags.hpp"
#include "support/packing.hpp"

namespace {

using twinray::PackedScene;
template <class T>
using Code = twinray::device::Code<T>;
template <class T>
using K = typename Code<T>::template Kernel<TR_F_ALL>;

template <class T>
PackedScene<T> pack_with_bvh(const twinray::Scene<T>& scene, int threads = 0, int width = 8) {
  twinray::set_thread_count(threads);
  twinray::PackOptions options;
  options.bvh = twinray::BvhPolicy::Always;
  options.bvh_width = width;
  PackedScene<T> ps = twinray::pack_scene(scene, options);
  twinray::set_thread_count(0);
  return ps;
}

// Bounds of primitive `id` (spheres first, then triangles), as stored.
template <class T>
void prim_bounds(const PackedScene<T>& ps, int id, T lo[3], T hi[3]) {
  int ns = static_cast<int>(ps.spheres.size());
  if (id < ns) {
    const auto& s = ps.spheres[id];
    T c[3] = {s.cx, s.cy, s.cz};
    for (int a = 0; a < 3; ++a) lo[a] = c[a] - s.radius, hi[a] = c[a] + s.radius;
    return;
  }
  const auto& t = ps.triangles[id - ns];
  T p[3][3] = {{t.p0x, t.p0y, t.p0z}, {t.p1x, t.p1y, t.p1z}, {t.p2x, t.p2y, t.p2z}};
  for (int a = 0; a < 3; ++a) {
    lo[a] = std::min({p[0][a], p[1][a], p[2][a]});
    hi[a] = std::max({p[0][a], p[1][a], p[2][a]});
  }
}

// Walks the whole tree: every node reached once, children's boxes inside the box
// their parent keeps for them, leaves around their primitives, every primitive in
// exactly one leaf, empty slots empty and the stack bound kept.
template <class T>
void check_structure(const PackedScene<T>& ps) {
  const int w = ps.bvh_width();
  REQUIRE(twinray::bvh::valid_width(w));
  const int n_nodes = ps.bvh_node_count();
  int n = static_cast<int>(ps.spheres.size() + ps.triangles.size());
  REQUIRE(n_nodes > 0);
  REQUIRE(ps.bvh_nodes.width() == w);
  REQUIRE(ps.bvh_nodes.bytes() ==
          static_cast<size_t>(n_nodes) * (6 * w * sizeof(T) + 2 * w * sizeof(int)));
  REQUIRE(reinterpret_cast<std::uintptr_t>(ps.bvh_nodes.data()) % 64 == 0);
  REQUIRE(static_cast<int>(ps.bvh_prims.size()) == n);
  // Spheres alone or triangles alone are listed in their packed order: the walks take id
  // i at position i there and do not read bvh_prims (device/bvh_traverse.h, tr_bvh_prim).
  if (ps.spheres.empty() || ps.triangles.empty())
    for (int i = 0; i < n; ++i) REQUIRE(ps.bvh_prims[i] == i);
  CHECK(ps.summary().n_bvh_nodes == n_nodes);
  CHECK((ps.features & TR_F_BVH) == twinray::bvh::width_feature(w));
  auto box = [&](int node, int plane, int k) { return ps.bvh_nodes.boxes(node)[plane * w + k]; };
  std::vector<int> seen_node(static_cast<size_t>(n_nodes), 0), seen_prim(static_cast<size_t>(n), 0);
  // (node, inner nodes on the path including it, the parent's slot holding it, the
  // stack entries its ancestors may have pushed: inner children - 1 each)
  struct Todo {
    int node, depth, parent, slot, stack;
  };
  std::vector<Todo> todo{{0, 1, -1, 0, 0}};
  int max_depth = 0, max_stack = 0;
  while (!todo.empty()) {
    Todo t = todo.back();
    todo.pop_back();
    REQUIRE(t.node >= 0);
    REQUIRE(t.node < n_nodes);
    seen_node[t.node]++;
    max_depth = std::max(max_depth, t.depth);
    const int* first = ps.bvh_nodes.links(t.node);
    const int* count = first + w;
    CHECK(count[0] >= 0);  // no node is empty
    const int stack = t.stack + std::max(int(std::count(count, count + w, 0)) - 1, 0);
    max_stack = std::max(max_stack, stack);
    for (int k = 0; k < w; ++k) {
      if (count[k] < 0) {
        for (int a = 0; a < 3; ++a) {
          CHECK(box(t.node, TR_BVH_MIN_X + a, k) == std::numeric_limits<T>::infinity());
          CHECK(box(t.node, TR_BVH_MAX_X + a, k) == -std::numeric_limits<T>::infinity());
        }
        continue;
      }
      if (t.parent >= 0) {
        for (int a = 0; a < 3; ++a) {
          CHECK(box(t.parent, TR_BVH_MIN_X + a, t.slot) <= box(t.node, TR_BVH_MIN_X + a, k));
          CHECK(box(t.parent, TR_BVH_MAX_X + a, t.slot) >= box(t.node, TR_BVH_MAX_X + a, k));
        }
      }
      if (count[k] == 0) {
        todo.push_back({first[k], t.depth + 1, t.node, k, stack});
        continue;
      }
      REQUIRE(first[k] + count[k] <= n);
      for (int i = first[k]; i < first[k] + count[k]; ++i) {
        int id = ps.bvh_prims[i];
        REQUIRE(id >= 0);
        REQUIRE(id < n);
        seen_prim[id]++;
        T lo[3], hi[3];
        prim_bounds(ps, id, lo, hi);
        for (int a = 0; a < 3; ++a) {
          CHECK(box(t.node, TR_BVH_MIN_X + a, k) < lo[a]);
          CHECK(box(t.node, TR_BVH_MAX_X + a, k) > hi[a]);
        }
      }
    }
  }
  CHECK(std::all_of(seen_node.begin(), seen_node.end(), [](int c) { return c == 1; }));
  CHECK(std::all_of(seen_prim.begin(), seen_prim.end(), [](int c) { return c == 1; }));
  // The traversal goes on into one inner child and pushes the others: the stack never
  // holds more than the largest sum over a path, which must fit.
  const twinray::bvh::Stats st = twinray::bvh::wide_stats(ps.bvh_nodes);
  CHECK(max_depth == st.max_depth);
  CHECK(max_stack == st.stack_need);
  CHECK(max_stack <= TR_BVH_STACK_SIZE);
}

// Rays from random origins inside and around the scene in random directions, plus the
// camera's rays: the BVH gives the same closest hit (bit for bit) and any-hit answer as
// the linear loops.
template <class T>
void check_traversal(PackedScene<T> ps, int n_rays, uint32_t seed) {
  PackedScene<T> linear = test_support::without_bvh(ps);
  auto camera = bvh_test::test_camera<T>(32, 24);
  auto scene = bvh_test::random_scene<T>(0, 0, 1u);  // lights only
  twinray::RenderOptions options;
  auto frame_b = twinray::pack_frame(ps.summary(), {camera, scene.lights, options, {}});
  auto frame_l = twinray::pack_frame(linear.summary(), {camera, scene.lights, options, {}});
  auto sb = frame_b.ref(ps);
  auto sl = frame_l.ref(linear);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int hits = 0, mismatches = 0, any_mismatches = 0;
  for (int r = 0; r < n_rays; ++r) {
    typename Code<T>::Ray ray;
    ray.o = glm::vec<3, T>(T(5 * u(rng)), T(2.5 * u(rng)), T(-3 + 5 * u(rng)));
    glm::vec<3, double> d(u(rng), u(rng), u(rng));
    if (r % 7 == 0) d.x = 0;  // axis-parallel components: infinite 1/d in the box test
    if (glm::length(d) < 1e-3) continue;
    d = glm::normalize(d);
    ray.d = glm::vec<3, T>(T(d.x), T(d.y), T(d.z));
    T tmax = r % 3 == 0 ? T(INFINITY) : T(1 + 4 * (u(rng) + 1));
    auto hb = K<T>::tr_no_hit(), hl = K<T>::tr_no_hit();
    int fb = K<T>::tr_closest_hit(&sb, &ray, tmax, &hb);
    int fl = K<T>::tr_closest_hit(&sl, &ray, tmax, &hl);
    hits += fl;
    bool same = fb == fl && hb.t == hl.t && hb.object == hl.object && hb.p == hl.p &&
                hb.n == hl.n && hb.perr == hl.perr && hb.material == hl.material;
    mismatches += same ? 0 : 1;
    any_mismatches += K<T>::tr_any_hit(&sb, &ray, tmax) != K<T>::tr_any_hit(&sl, &ray, tmax);
  }
  CHECK(hits > n_rays / 100);  // the rays do hit things
  CHECK(mismatches == 0);
  CHECK(any_mismatches == 0);
}

}  // namespace

TEST_CASE_TEMPLATE("bvh: every primitive is reachable and boxes contain what they bound", T, float,
                   double) {
  for (int w : twinray::bvh::kWidths)
    for (int n : {1, 2, 9, 100, 3000}) {
      CAPTURE(w);
      CAPTURE(n);
      check_structure(pack_with_bvh(bvh_test::random_scene<T>(n, n / 2 + 1, 7u + n), 0, w));
      check_structure(pack_with_bvh(bvh_test::random_scene<T>(n, 0, 8u + n), 0, w));
      check_structure(pack_with_bvh(bvh_test::random_scene<T>(0, n, 9u + n), 0, w));
    }
}

// The greedy collapse opens the largest box first until a node is full; only nodes over
// small subtrees (fewer than W leaves under them) stay part empty, and SAH trees end in
// many of those (3000 spheres and triangles: 2.9 children per 4-wide node, 3.9 per
// 8-wide). Each width must still cut the node count and hold more children than the
// last, and the greedy tree must have fewer nodes than the fixed-level one.
TEST_CASE("bvh: wider nodes are fewer and fuller") {
  auto scene = bvh_test::random_scene<float>(3000, 3000, 5u);
  int nodes[9] = {};
  double last_fill = 0;
  for (int w : twinray::bvh::kWidths) {
    auto ps = pack_with_bvh(scene, 0, w);
    twinray::bvh::Stats st = twinray::bvh::wide_stats(ps.bvh_nodes);
    nodes[w] = st.nodes;
    // Children per node: (nodes - 1) inner children plus the leaves, over the nodes.
    double fill = double(st.nodes - 1 + st.leaves) / st.nodes;
    CAPTURE(w);
    CHECK(fill > 0.45 * w);
    CHECK(fill > last_fill + 0.8);
    last_fill = fill;
    if (w > 2) {
      const auto binary = twinray::bvh::build_binary<float>(ps.spheres, ps.triangles);
      const auto fixed =
          twinray::bvh::collapse(binary, w, twinray::bvh::detail::Collapse::FixedLevels);
      CHECK(st.nodes < fixed.node_count());
    }
  }
  CHECK(nodes[4] < 0.6 * nodes[2]);
  CHECK(nodes[8] < 0.7 * nodes[4]);
}

TEST_CASE("bvh: the build does not depend on the thread count") {
  auto scene = bvh_test::random_scene<float>(20000, 20000, 3u);
  auto a = pack_with_bvh(scene, 1), b = pack_with_bvh(scene, 2), c = pack_with_bvh(scene, 4);
  check_structure(c);
  CHECK(a.bvh_prims == b.bvh_prims);
  CHECK(a.bvh_prims == c.bvh_prims);
  CHECK(a.bvh_nodes == b.bvh_nodes);
  CHECK(a.bvh_nodes == c.bvh_nodes);
}

// A large tree's root subtrees are counted and collapsed side by side, each written at
// the index its count places it (collapse_tree); one thread collapses the whole tree
// in one recursion. Both must give the same bytes at every width, greedy and at fixed
// levels.
TEST_CASE("bvh: the collapse on several threads gives the one-thread tree") {
  auto ps = pack_with_bvh(bvh_test::random_scene<float>(60000, 50000, 29u), 1);
  const auto binary = twinray::bvh::build_binary<float>(ps.spheres, ps.triangles);
  REQUIRE(binary.nodes.size() >= twinray::bvh::detail::kParallelCollapseNodes);
  for (int w : twinray::bvh::kWidths) {
    CAPTURE(w);
    twinray::set_thread_count(1);
    const auto one = twinray::bvh::collapse(binary, w);
    using twinray::bvh::detail::Collapse;
    const auto fixed_one = twinray::bvh::collapse(binary, w, Collapse::FixedLevels);
    for (int threads : {2, 3}) {
      CAPTURE(threads);
      twinray::set_thread_count(threads);
      const auto several = twinray::bvh::collapse(binary, w);
      CHECK(several.nodes == one.nodes);
      const auto fixed_several = twinray::bvh::collapse(binary, w, Collapse::FixedLevels);
      CHECK(fixed_several.nodes == fixed_one.nodes);
    }
    twinray::set_thread_count(0);
    // Every node reached once from the root, and every primitive through the leaves.
    std::vector<int> todo{0}, reached(static_cast<size_t>(one.node_count()), 0);
    long long prims = 0;
    while (!todo.empty()) {
      const int node = todo.back();
      todo.pop_back();
      ++reached[static_cast<size_t>(node)];
      const int* link = one.nodes.links(node);
      for (int k = 0; k < w; ++k) {
        if (link[w + k] == 0) todo.push_back(link[k]);
        if (link[w + k] > 0) prims += link[w + k];
      }
    }
    CHECK(std::count(reached.begin(), reached.end(), 1) == one.node_count());
    CHECK(prims == static_cast<long long>(ps.spheres.size() + ps.triangles.size()));
  }
}

TEST_CASE("bvh: the root's passes on every thread give what one pass gives") {
  // More primitives than three blocks of the root's parallel passes, so the blocks'
  // bins and boxes are merged; threads 1 and 3 hand the blocks out differently.
  auto ps = pack_with_bvh(bvh_test::random_scene<float>(150000, 60000, 11u), 0, 2);
  const int n_spheres = static_cast<int>(ps.spheres.size());
  const int n = n_spheres + static_cast<int>(ps.triangles.size());
  REQUIRE(n > 3 * twinray::bvh::kParallelPassPrims);
  auto refs = twinray::bvh::primitive_refs<float>(ps.spheres, ps.triangles);
  // Boxes compared bit for bit (a -0 for a +0 would count).
  auto same = [](const twinray::bvh::Box& a, const twinray::bvh::Box& b) {
    return std::memcmp(a.lo, b.lo, sizeof a.lo) == 0 && std::memcmp(a.hi, b.hi, sizeof a.hi) == 0;
  };
  using Builder = twinray::bvh::detail::Builder<twinray::bvh::BinaryNode<float>, float>;
  twinray::bvh::Box box, cbox;
  twinray::bvh::detail::bounds_of(refs, 0, n, &box, &cbox, false);
  auto serial_refs = refs;
  Builder serial(serial_refs, 2.0);
  twinray::bvh::Box serial_box[2], serial_cbox[2];
  const int serial_mid = serial.sah_split(0, n, box, cbox, serial_box, serial_cbox, false);
  REQUIRE(serial_mid > 0);
  REQUIRE(serial_mid < n);
  for (int threads : {1, 3}) {
    CAPTURE(threads);
    twinray::set_thread_count(threads);
    twinray::bvh::Box all_box, all_cbox;
    twinray::bvh::detail::bounds_of(refs, 0, n, &all_box, &all_cbox, true);
    CHECK(same(all_box, box));
    CHECK(same(all_cbox, cbox));
    auto all_refs = refs;
    Builder all(all_refs, 2.0);
    twinray::bvh::Box all_child_box[2], all_child_cbox[2];
    const int all_mid = all.sah_split(0, n, box, cbox, all_child_box, all_child_cbox, true);
    twinray::set_thread_count(0);
    CHECK(all_mid == serial_mid);
    for (int side = 0; side < 2; ++side) {
      CHECK(same(all_child_box[side], serial_box[side]));
      CHECK(same(all_child_cbox[side], serial_cbox[side]));
    }
    bool same_order = true;
    for (int i = 0; i < n; ++i)
      same_order = same_order &&
                   all_refs[static_cast<size_t>(i)].id == serial_refs[static_cast<size_t>(i)].id;
    CHECK(same_order);
  }
}

TEST_CASE("bvh: a split hands each child the bounds of the primitives it holds") {
  // The children's boxes and centroid bounds come from the bins, not from a pass over
  // each side: they must be what such a pass finds, for nodes with fewer primitives
  // than bins, with all of them, and at the root's parallel passes.
  auto ps = pack_with_bvh(bvh_test::random_scene<float>(3000, 2000, 23u), 0, 2);
  const int n = static_cast<int>(ps.spheres.size() + ps.triangles.size());
  auto refs = twinray::bvh::primitive_refs<float>(ps.spheres, ps.triangles);
  auto same = [](const twinray::bvh::Box& a, const twinray::bvh::Box& b) {
    return std::memcmp(a.lo, b.lo, sizeof a.lo) == 0 && std::memcmp(a.hi, b.hi, sizeof a.hi) == 0;
  };
  using Builder = twinray::bvh::detail::Builder<twinray::bvh::BinaryNode<float>, float>;
  int splits = 0;
  for (int count : {9, 40, 1000, n - 100})
    for (bool all_threads : {false, true}) {
      CAPTURE(count);
      CAPTURE(all_threads);
      const int begin = 100, end = begin + count;
      REQUIRE(end <= n);
      twinray::bvh::Box box, cbox;
      twinray::bvh::detail::bounds_of(refs, begin, end, &box, &cbox);
      auto split_refs = refs;
      Builder builder(split_refs, 2.0);
      twinray::bvh::Box child_box[2], child_cbox[2];
      const int mid = builder.sah_split(begin, end, box, cbox, child_box, child_cbox, all_threads);
      if (mid < 0) continue;  // a leaf: no children
      ++splits;
      REQUIRE(mid > begin);
      REQUIRE(mid < end);
      const int side_begin[2] = {begin, mid}, side_end[2] = {mid, end};
      for (int side = 0; side < 2; ++side) {
        twinray::bvh::Box pass_box, pass_cbox;
        twinray::bvh::detail::bounds_of(split_refs, side_begin[side], side_end[side], &pass_box,
                                        &pass_cbox);
        CHECK(same(child_box[side], pass_box));
        CHECK(same(child_cbox[side], pass_cbox));
      }
    }
  CHECK(splits >= 6);
}

// Checks the split of refs[begin, end) against the SAH as the builder states it: along
// the widest centroid axis, min(n, kBins) bins of equal width; the cost of the boundary
// after bin k is area(left) count(left) + area(right) count(right), with both sides
// non-empty, and the first of equally cheap boundaries wins. Recomputed here over the
// primitives with boxes grown in double, so the builder's bins, its sweep and its
// partition must agree with it. Returns the boundary taken.
template <class R>
int check_cheapest_split(const twinray::LargeVector<twinray::bvh::PrimRef<R>>& refs, int begin,
                         int end, bool all_threads) {
  using twinray::bvh::Box;
  using Builder = twinray::bvh::detail::Builder<twinray::bvh::BinaryNode<R>, R>;
  const int count = end - begin;
  Box box, cbox;
  twinray::bvh::detail::bounds_of(refs, begin, end, &box, &cbox);
  const int axis = Builder::widest_axis(cbox);
  const int n_bins = std::min(twinray::bvh::kBins, count);
  const double scale = n_bins / (cbox.hi[axis] - cbox.lo[axis]);
  auto bin_of = [&](const twinray::bvh::PrimRef<R>& r) {
    return std::min(n_bins - 1, static_cast<int>((r.centroid(axis) - cbox.lo[axis]) * scale));
  };
  double best_cost = std::numeric_limits<double>::infinity();
  int best = -1;
  for (int k = 0; k + 1 < n_bins; ++k) {
    Box left, right;
    int n_left = 0, n_right = 0;
    for (int i = begin; i < end; ++i) {
      const auto& r = refs[static_cast<size_t>(i)];
      if (bin_of(r) <= k) {
        left.grow(r.box);
        ++n_left;
      } else {
        right.grow(r.box);
        ++n_right;
      }
    }
    if (n_left == 0 || n_right == 0) continue;
    double cost = left.half_area() * n_left + right.half_area() * n_right;
    if (cost < best_cost) best_cost = cost, best = k;
  }
  REQUIRE(best >= 0);
  auto split_refs = refs;
  Builder builder(split_refs, 2.0);
  Box child_box[2], child_cbox[2];
  const int mid = builder.sah_split(begin, end, box, cbox, child_box, child_cbox, all_threads);
  REQUIRE(mid > begin);  // more than a leaf holds, or a split cheaper than the leaf
  REQUIRE(mid < end);
  // The left side holds exactly the bins up to `best`.
  int left_max = -1, right_min = n_bins, n_left = 0;
  for (int i = begin; i < mid; ++i)
    left_max = std::max(left_max, bin_of(split_refs[static_cast<size_t>(i)]));
  for (int i = mid; i < end; ++i)
    right_min = std::min(right_min, bin_of(split_refs[static_cast<size_t>(i)]));
  for (int i = begin; i < end; ++i) n_left += bin_of(refs[static_cast<size_t>(i)]) <= best;
  CHECK(left_max <= best);
  CHECK(right_min > best);
  CHECK(mid - begin == n_left);
  return best;
}

TEST_CASE("bvh: a split takes the cheapest bin boundary") {
  auto ps = pack_with_bvh(bvh_test::random_scene<float>(3000, 2000, 29u), 0, 2);
  const int n = static_cast<int>(ps.spheres.size() + ps.triangles.size());
  auto refs = twinray::bvh::primitive_refs<float>(ps.spheres, ps.triangles);
  for (int count : {9, 15, 16, 17, 40, 1000, n - 100})
    for (bool all_threads : {false, true}) {
      CAPTURE(count);
      CAPTURE(all_threads);
      REQUIRE(50 + count <= n);
      check_cheapest_split(refs, 50, 50 + count, all_threads);
    }
}

TEST_CASE_TEMPLATE("bvh: a node the area bound calls a leaf is one the SAH makes a leaf", R, float,
                   double) {
  // The builder skips binning where a lower bound of the split cost already picks a
  // leaf (Builder::leaf_by_bound); the tree stays the same only if sah_split agrees on
  // every such node. Runs of neighbouring primitives in leaf order, as the build meets
  // them near the leaves, at each traversal cost the builder uses.
  using Builder = twinray::bvh::detail::Builder<twinray::bvh::BinaryNode<R>, R>;
  // Scattered primitives, and a grid of neighbouring triangles as a mesh's.
  auto scene = bvh_test::random_scene<R>(1500, 1500, 31u);
  scene.add(bvh_test::folded_grid<R>(40, 1));
  auto ps = pack_with_bvh(scene, 0, 2);
  auto refs = twinray::bvh::primitive_refs<R>(ps.spheres, ps.triangles);
  const int n = static_cast<int>(refs.size());
  for (double traversal : {1.0, 2.0, 3.0}) {
    int by_bound[twinray::bvh::kMaxLeafSize + 1] = {};
    int splits = 0;
    for (int count = 2; count <= twinray::bvh::kMaxLeafSize + 1; ++count)
      for (int begin = 0; begin + count <= n; begin += 3) {
        const int end = begin + count;
        twinray::bvh::Box box, cbox;
        twinray::bvh::detail::bounds_of(refs, begin, end, &box, &cbox);
        auto split_refs = refs;
        Builder builder(split_refs, traversal);
        twinray::bvh::Box child_box[2], child_cbox[2];
        const int mid = builder.sah_split(begin, end, box, cbox, child_box, child_cbox);
        splits += mid >= 0;
        if (!builder.leaf_by_bound(begin, end, box)) continue;
        CAPTURE(traversal);
        CAPTURE(count);
        CAPTURE(begin);
        REQUIRE(count <= twinray::bvh::kMaxLeafSize);
        CHECK(mid == -1);
        ++by_bound[count];
      }
    CAPTURE(traversal);
    // The bound decides many small nodes here, as it must to spare the build any time:
    // pairs at every cost (from 2 on every pair), and triples from cost 2 on.
    CHECK(by_bound[2] > 500);
    if (traversal >= 2.0) CHECK(by_bound[3] > 100);
    CHECK(splits > 1000);  // and the SAH still splits the rest
  }
}

TEST_CASE_TEMPLATE("bvh: least_where finds the first value of R where a threshold is reached", R,
                   float, double) {
  // Thresholds on both sides of zero, at zero of either sign, among subnormals and at
  // the ends of the range: the answer is the threshold itself (each is a value of R).
  const R inf = std::numeric_limits<R>::infinity();
  const R tiny = std::numeric_limits<R>::denorm_min();
  const R big = std::numeric_limits<R>::max();
  struct Case {
    R lo, hi, threshold;
  };
  const Case cases[] = {{R(-1e6), R(1e6), R(0.375)},
                        {R(-1e6), R(1e6), std::nextafter(R(0), -inf)},
                        {R(-1e6), R(1e6), tiny},
                        {R(-1e6), R(1e6), R(3) * tiny},
                        {R(-1), R(1), std::nextafter(R(1), -inf)},
                        {R(-1), R(1), R(1)},
                        {R(-1), R(1), std::nextafter(R(-1), inf)},
                        {-big, big, R(-7.25)},
                        {R(2), R(4), R(3)},
                        {R(-4), R(-2), std::nextafter(R(-3), inf)}};
  for (const Case& c : cases) {
    CAPTURE(c.threshold);
    R found = twinray::bvh::least_where(c.lo, c.hi, [&](R v) { return v >= c.threshold; });
    CHECK(found == c.threshold);
  }
  // At zero: -0 and +0 compare equal, so the first value at or above 0 is -0.
  R zero = twinray::bvh::least_where(R(-1), R(1), [](R v) { return v >= R(0); });
  CHECK(zero == R(0));
  CHECK(std::signbit(zero));
}

TEST_CASE_TEMPLATE("bvh: a split puts centroids a unit apart on the sides of their bins", R, float,
                   double) {
  // Centroids on consecutive values of R: every bin boundary falls between two
  // neighbouring centroids, so a partition that misplaced the boundary by one unit in the
  // last place would move a primitive to the side it was not counted on. Each box is
  // flat in x and symmetric in y and z (its centroid is (x, 0, 0) exactly); random
  // heights in y and z move the cheapest boundary from node to node.
  std::mt19937 rng(31u);
  std::uniform_real_distribution<double> height(0.01, 4.0);
  std::set<int> boundaries;
  for (int trial = 0; trial < 24; ++trial) {
    CAPTURE(trial);
    const int count = trial % 2 == 0 ? 3000 : 77;
    twinray::LargeVector<twinray::bvh::PrimRef<R>> refs(static_cast<size_t>(count));
    R x = R(1.5) + R(trial);
    for (int i = 0; i < count; ++i) {
      auto& r = refs[static_cast<size_t>(i)];
      R h = static_cast<R>(height(rng));
      r.box.lo[0] = r.box.hi[0] = x;
      r.box.lo[1] = r.box.lo[2] = -h;
      r.box.hi[1] = r.box.hi[2] = h;
      r.id = i;
      x = std::nextafter(x, std::numeric_limits<R>::infinity());
    }
    std::shuffle(refs.begin(), refs.end(), rng);
    boundaries.insert(check_cheapest_split(refs, 0, count, false));
  }
  CHECK(boundaries.size() >= 4);  // the test reached several boundaries
}

TEST_CASE("bvh: a large scene's primitives and nodes ask for huge pages") {
  if (!twinray::detail::kMapsHugePages || !twinray_test::page_flags_known()) {
    MESSAGE("skipped: no transparent huge pages or no /proc/self/smaps here");
    return;
  }
  // 200000 triangles: 8.8 MB of them, and more than 2 MiB of 8-wide nodes (the nodes
  // are reserved at their exact count).
  auto ps = pack_with_bvh(bvh_test::random_scene<float>(0, 200000, 5u, false), 0, 8);
  REQUIRE(ps.triangles.size() * sizeof(ps.triangles[0]) >= twinray::kHugePageBytes);
  REQUIRE(ps.bvh_nodes.bytes() >= twinray::kHugePageBytes);
  CHECK(twinray_test::advised_huge(ps.triangles.data()));
  CHECK(twinray_test::advised_huge(ps.bvh_nodes.data()));
  // A small array stays on the heap.
  CHECK_FALSE(twinray_test::advised_huge(ps.materials.data()));
}

TEST_CASE("bvh: depth stays within the stack on degenerate input") {
  using vec3 = glm::vec<3, double>;
  // Centers at +-20^i: each SAH split can peel off only the outermost sphere, deeper
  // than the cap allows; and many spheres at one point, where no split separates
  // centroids.
  twinray::Scene<double> chain, clump;
  chain.add_material({});
  clump.add_material({});
  for (int i = 0; i < 120; ++i)
    chain.add(
        twinray::Sphere<double>{vec3((i % 2 ? -1 : 1) * std::pow(20.0, i / 2), 0, 0), 0.25, 0});
  for (int i = 0; i < 1000; ++i) clump.add(twinray::Sphere<double>{vec3(1, 2, 3), 0.5, 0});
  auto binary_depth = [](const PackedScene<double>& ps) {
    return twinray::bvh::stats(twinray::bvh::build_binary<double>(ps.spheres, ps.triangles).nodes)
        .max_depth;
  };
  for (auto* scene : {&chain, &clump})
    for (int w : twinray::bvh::kWidths) {
      auto ps = pack_with_bvh(*scene, 0, w);
      check_structure(ps);
      CHECK(binary_depth(ps) <= twinray::bvh::kMaxDepth);
    }
  // The chain is deep enough to reach the cap, and its 8-wide tree the stack bound.
  auto deep = pack_with_bvh(chain, 0, 8);
  const int binary = binary_depth(deep);
  CHECK(binary >= twinray::bvh::kMaxDepth - 8);
  // The greedy collapse opens the chain's next link in each node, so an 8-wide node takes
  // up to 7 links of it. With one sphere per leaf (small sphere scenes split further:
  // bvh::traversal_cost) the root splits the chain into its two sides (the centres
  // alternate in sign), and each wide node then advances both sides' chains, each by
  // about half as many links: the tree is still over 4 times shallower than the binary
  // one (47 levels: 11) and needs little stack (9 of 112 entries).
  const twinray::bvh::Stats st = twinray::bvh::wide_stats(deep.bvh_nodes);
  CHECK(st.max_depth <= binary / 4 + 1);
  CHECK(st.stack_need <= 10);
}

TEST_CASE("bvh: small scenes of spheres alone are split into smaller leaves") {
  using twinray::bvh::kSmallSphereScene;
  using twinray::bvh::kTraversalCost;
  using twinray::bvh::traversal_cost;
  CHECK(traversal_cost(1000, 0) == 1.0);
  CHECK(traversal_cost(kSmallSphereScene - 1, 0) == 1.0);
  CHECK(traversal_cost(kSmallSphereScene, 0) == kTraversalCost);
  CHECK(traversal_cost(1000, 1) == kTraversalCost);
  // The same 3000 spheres (random_scene draws them first), alone and with one triangle.
  auto alone = pack_with_bvh(bvh_test::random_scene<float>(3000, 0, 21u));
  auto mixed = pack_with_bvh(bvh_test::random_scene<float>(3000, 1, 21u));
  check_structure(alone);
  const double alone_per_leaf = 3000.0 / twinray::bvh::wide_stats(alone.bvh_nodes).leaves;
  const double mixed_per_leaf = 3001.0 / twinray::bvh::wide_stats(mixed.bvh_nodes).leaves;
  MESSAGE("primitives per leaf: alone ", alone_per_leaf, ", with a triangle ", mixed_per_leaf);
  CHECK(alone_per_leaf < 2.0);
  CHECK(mixed_per_leaf > 2.5);
}

TEST_CASE("bvh: large meshes merge into larger leaves") {
  using twinray::bvh::kLargeMeshScene;
  using twinray::bvh::kLargeMeshTraversalCost;
  using twinray::bvh::kTraversalCost;
  using twinray::bvh::traversal_cost;
  CHECK(traversal_cost(0, kLargeMeshScene - 1) == kTraversalCost);
  CHECK(traversal_cost(0, kLargeMeshScene) == kLargeMeshTraversalCost);
  CHECK(traversal_cost(10, kLargeMeshScene) == kLargeMeshTraversalCost);
  CHECK(kLargeMeshTraversalCost > kTraversalCost);
  // One triangle across the threshold: the same bumpy closed surface of small
  // triangles (mesh_<N>'s, bench_scenes.hpp), cut to 2^17 triangles and to one fewer,
  // splits into fewer, larger leaves.
  auto blob_scene = [](long long n_triangles) {
    twinray::Mesh<float> blob = twinray_bench::blob_mesh<float>(4 * 182 * 182, 0);
    REQUIRE(blob.triangles.size() > static_cast<size_t>(n_triangles));
    blob.triangles.resize(static_cast<size_t>(n_triangles));
    twinray::Scene<float> scene;
    scene.add_material(twinray::Material<float>{});
    scene.add(blob);
    return scene;
  };
  const int n = static_cast<int>(kLargeMeshScene);
  auto below = pack_with_bvh(blob_scene(n - 1));
  auto at = pack_with_bvh(blob_scene(n));
  REQUIRE(at.triangles.size() == static_cast<size_t>(n));
  check_structure(at);
  const double below_per_leaf = (n - 1.0) / twinray::bvh::wide_stats(below.bvh_nodes).leaves;
  const double at_per_leaf = static_cast<double>(n) / twinray::bvh::wide_stats(at.bvh_nodes).leaves;
  MESSAGE("triangles per leaf: ", below_per_leaf, " below the threshold, ", at_per_leaf, " at it");
  CHECK(at_per_leaf > below_per_leaf * 1.3);
}

TEST_CASE_TEMPLATE("bvh: traversal finds exactly the linear loops' closest hit", T, float, double) {
  for (int w : twinray::bvh::kWidths) {
    CAPTURE(w);
    check_traversal(pack_with_bvh(bvh_test::random_scene<T>(300, 300, 11u), 0, w), 20000, 5u);
    check_traversal(pack_with_bvh(bvh_test::random_scene<T>(40, 0, 12u), 0, w), 5000, 6u);
    check_traversal(pack_with_bvh(bvh_test::random_scene<T>(0, 60, 13u, false), 0, w), 5000, 7u);
  }
}

TEST_CASE("bvh: pack builds one from the threshold on, and not below it") {
  twinray::RenderOptions options;
  auto camera = bvh_test::test_camera<float>(8, 8);
  auto has_bvh = [&](int n_spheres, int n_triangles) {
    auto ps = test_support::pack(bvh_test::random_scene<float>(n_spheres, n_triangles, 1u), camera,
                                 options);
    CHECK(ps.params().n_bvh_nodes == ps.scene.bvh_node_count());
    CHECK(((ps.frame.features & TR_F_BVH) != 0u) == !ps.scene.bvh_nodes.empty());
    return !ps.scene.bvh_nodes.empty();
  };
  const int w = static_cast<int>(twinray::bvh::kMinWeight);
  const int tw = twinray::bvh::kTriangleWeight;
  CHECK(!has_bvh(w - 1, 0));
  CHECK(has_bvh(w, 0));
  CHECK(!has_bvh(0, (w - 1) / tw));
  CHECK(has_bvh(0, (w + tw - 1) / tw));
  CHECK(has_bvh(3, 4));  // the demo's spheres and triangles
}

// A binary tree made so that the greedy collapse needs more stack than the traversal
// has: at every level a chain of large boxes, each with a small inner sibling, fills an
// 8-wide node with 8 inner children, while the next level hangs off a small box one
// binary level down. The collapse must then fall back to fixed levels.
TEST_CASE("bvh: a greedy tree that would overflow the stack is collapsed at fixed levels") {
  using Node = twinray::bvh::BinaryNode<float>;
  twinray::LargeVector<Node> nodes;
  auto box = [](float size) {
    Node n{{0, 0, 0, size, size, size}, 0, 1};  // a leaf until split
    return n;
  };
  auto split = [&](int i, float left, float right) {
    const int first = static_cast<int>(nodes.size());
    nodes.push_back(box(left));
    nodes.push_back(box(right));
    nodes[static_cast<size_t>(i)].first = first;
    nodes[static_cast<size_t>(i)].count = 0;
    return first;
  };
  nodes.push_back(box(4000));
  int level = 0;
  for (int d = 0; d < 20; ++d) {
    const int first = split(level, 1, 2000);
    int chain = first + 1;
    for (int k = 0; k < 6; ++k) {
      const int g = split(chain, 0.5f, 1000.0f - float(k));
      split(g, 0.25f, 0.25f);  // the small sibling: inner, two leaves
      chain = g + 1;
    }
    split(chain, 0.25f, 0.25f);
    level = first;
  }
  split(level, 0.25f, 0.25f);
  twinray::bvh::BinaryBvh<float> binary{nodes, {}};
  REQUIRE(twinray::bvh::stats(binary.nodes).max_depth <= twinray::bvh::kMaxDepth);

  using twinray::bvh::detail::Collapse;
  twinray::bvh::Bvh<float> greedy;
  greedy.nodes = twinray::bvh::WideNodes<float>(8);
  const int greedy_stack =
      twinray::bvh::detail::collapse_tree(binary.nodes, Collapse::Greedy, greedy.nodes);
  CHECK(greedy_stack > TR_BVH_STACK_SIZE);
  CHECK(twinray::bvh::wide_stats(greedy.nodes).stack_need == greedy_stack);

  const auto chosen = twinray::bvh::collapse(binary, 8);
  const auto fixed = twinray::bvh::collapse(binary, 8, Collapse::FixedLevels);
  CHECK(chosen.nodes == fixed.nodes);
  CHECK(twinray::bvh::wide_stats(chosen.nodes).stack_need <= twinray::bvh::stack_needed(8));
}

TEST_CASE_TEMPLATE("bvh: the builder's rounding step is std::nextafter's", R, float, double) {
  const R inf = std::numeric_limits<R>::infinity();
  std::vector<R> values = {R(0),
                           -R(0),
                           std::numeric_limits<R>::denorm_min(),
                           -std::numeric_limits<R>::denorm_min(),
                           std::numeric_limits<R>::min(),
                           -std::numeric_limits<R>::min(),
                           std::numeric_limits<R>::max(),
                           -std::numeric_limits<R>::max(),
                           R(1),
                           R(-1),
                           inf,
                           -inf};
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> mantissa(-1, 1);
  std::uniform_int_distribution<int> exponent(-140, 120);
  for (int i = 0; i < 20000; ++i)
    values.push_back(static_cast<R>(std::ldexp(mantissa(rng), exponent(rng))));
  for (R r : values)
    for (int toward : {-1, 1}) {
      if (r == R(toward) * inf) continue;  // already the infinity it steps toward
      const R want = std::nextafter(r, R(toward) * inf);
      const R got = twinray::bvh::step_toward(r, toward);
      CAPTURE(r);
      CAPTURE(toward);
      CHECK(std::memcmp(&want, &got, sizeof(R)) == 0);
    }
}

TEST_CASE("bvh: the block partition puts every left element first and loses none") {
  std::mt19937 rng(7);
  // Sizes around the 64-element blocks and their pairs; left shares from none to all.
  for (int n :
       {0, 1, 2, 3, 17, 63, 64, 65, 127, 128, 129, 147, 150, 191, 256, 1000, 4099, 100000}) {
    for (double share : {0.0, 0.01, 0.5, 0.97, 1.0}) {
      std::vector<int> v(static_cast<size_t>(n));
      for (int i = 0; i < n; ++i) v[static_cast<size_t>(i)] = i;
      std::shuffle(v.begin(), v.end(), rng);
      const int threshold = static_cast<int>(share * n);
      auto is_left = [threshold](int x) { return x < threshold; };
      // A sub-range, as the builder partitions one node's primitives in place.
      const int begin = n / 7, end = n - n / 5;
      std::vector<int> before = v;
      const int mid = twinray::bvh::detail::block_partition(v, begin, end, is_left);
      CAPTURE(n);
      CAPTURE(share);
      REQUIRE(mid >= begin);
      REQUIRE(mid <= end);
      // The same order as a plain Hoare loop, which the builder's trees were made with.
      std::vector<int> hoare = before;
      int i = begin, j = end - 1;
      for (;;) {
        while (i <= j && is_left(hoare[static_cast<size_t>(i)])) ++i;
        while (i <= j && !is_left(hoare[static_cast<size_t>(j)])) --j;
        if (i >= j) break;
        std::swap(hoare[static_cast<size_t>(i++)], hoare[static_cast<size_t>(j--)]);
      }
      CHECK(mid == i);
      CHECK(v == hoare);
      CHECK(std::all_of(v.begin() + begin, v.begin() + mid, is_left));
      CHECK(std::none_of(v.begin() + mid, v.begin() + end, is_left));
      CHECK(std::equal(v.begin(), v.begin() + begin, before.begin()));
      CHECK(std::equal(v.begin() + end, v.end(), before.begin() + end));
      std::sort(v.begin() + begin, v.begin() + end);
      std::sort(before.begin() + begin, before.begin() + end);
      CHECK(v == before);
    }
  }
}
