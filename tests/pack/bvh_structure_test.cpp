// The BVH's structure (every primitive reachable once, boxes contain what they bound,
// depth within the traversal stack) and its traversal against the linear loops: the
// closest hit and the any-hit answer of every ray agree exactly.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include <twinray/twinray.hpp>

#include "bvh_scenes.hpp"
#include "support/packing.hpp"

namespace {

using twinray::PackedScene;
template <class T>
using Code = twinray::device::Code<T>;
template <class T>
using K = typename Code<T>::template Kernel<TR_F_ALL>;

template <class T>
PackedScene<T> pack_with_bvh(const twinray::Scene<T>& scene, int threads = 0) {
  twinray::set_thread_count(threads);
  PackedScene<T> ps = twinray::pack_scene(scene, twinray::BvhPolicy::Always);
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

template <class Node>
bool contains(const Node& outer, const Node& inner) {
  for (int a = 0; a < 3; ++a)
    if (!(outer.bounds[TR_BVH_MIN_X + a] <= inner.bounds[TR_BVH_MIN_X + a] &&
          outer.bounds[TR_BVH_MAX_X + a] >= inner.bounds[TR_BVH_MAX_X + a]))
      return false;
  return true;
}

// Walks the whole tree: every node reached once, children inside parents, leaves
// around their primitives, every primitive in exactly one leaf.
template <class T>
void check_structure(const PackedScene<T>& ps) {
  const auto& nodes = ps.bvh_nodes;
  int n = static_cast<int>(ps.spheres.size() + ps.triangles.size());
  REQUIRE(!nodes.empty());
  REQUIRE(static_cast<int>(ps.bvh_prims.size()) == n);
  CHECK(ps.summary().n_bvh_nodes == static_cast<int>(nodes.size()));
  CHECK((ps.features & TR_F_BVH) != 0u);
  std::vector<int> seen_node(nodes.size(), 0), seen_prim(static_cast<size_t>(n), 0);
  std::vector<std::pair<int, int>> todo{{0, 0}};
  int max_depth = 0;
  while (!todo.empty()) {
    auto [i, depth] = todo.back();
    todo.pop_back();
    REQUIRE(i >= 0);
    REQUIRE(i < static_cast<int>(nodes.size()));
    seen_node[i]++;
    const auto& node = nodes[i];
    if (node.count > 0) {
      max_depth = std::max(max_depth, depth);
      REQUIRE(node.first + node.count <= n);
      for (int k = node.first; k < node.first + node.count; ++k) {
        int id = ps.bvh_prims[k];
        REQUIRE(id >= 0);
        REQUIRE(id < n);
        seen_prim[id]++;
        T lo[3], hi[3];
        prim_bounds(ps, id, lo, hi);
        for (int a = 0; a < 3; ++a) {
          CHECK(node.bounds[TR_BVH_MIN_X + a] < lo[a]);
          CHECK(node.bounds[TR_BVH_MAX_X + a] > hi[a]);
        }
      }
    } else {
      REQUIRE(node.count >= -2);
      REQUIRE(node.first + 1 < static_cast<int>(nodes.size()));
      CHECK(contains(node, nodes[node.first]));
      CHECK(contains(node, nodes[node.first + 1]));
      todo.push_back({node.first, depth + 1});
      todo.push_back({node.first + 1, depth + 1});
    }
  }
  CHECK(std::all_of(seen_node.begin(), seen_node.end(), [](int c) { return c == 1; }));
  CHECK(std::all_of(seen_prim.begin(), seen_prim.end(), [](int c) { return c == 1; }));
  // The traversal holds at most depth + 1 entries on its stack.
  CHECK(max_depth <= twinray::bvh::kMaxDepth);
  CHECK(max_depth + 1 <= TR_BVH_STACK_SIZE);
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
    int fb = K<T>::tr_closest_hit(&sb, ray, tmax, &hb);
    int fl = K<T>::tr_closest_hit(&sl, ray, tmax, &hl);
    hits += fl;
    bool same = fb == fl && hb.t == hl.t && hb.object == hl.object && hb.p == hl.p &&
                hb.n == hl.n && hb.perr == hl.perr && hb.material == hl.material;
    mismatches += same ? 0 : 1;
    any_mismatches += K<T>::tr_any_hit(&sb, ray, tmax) != K<T>::tr_any_hit(&sl, ray, tmax);
  }
  CHECK(hits > n_rays / 100);  // the rays do hit things
  CHECK(mismatches == 0);
  CHECK(any_mismatches == 0);
}

}  // namespace

TEST_CASE_TEMPLATE("bvh: every primitive is reachable and boxes contain what they bound", T, float,
                   double) {
  for (int n : {1, 2, 9, 100, 3000}) {
    CAPTURE(n);
    check_structure(pack_with_bvh(bvh_test::random_scene<T>(n, n / 2 + 1, 7u + n)));
  }
}

TEST_CASE("bvh: the build does not depend on the thread count") {
  auto scene = bvh_test::random_scene<float>(20000, 20000, 3u);
  auto a = pack_with_bvh(scene, 1), b = pack_with_bvh(scene, 2), c = pack_with_bvh(scene, 4);
  check_structure(c);
  REQUIRE(a.bvh_nodes.size() == b.bvh_nodes.size());
  REQUIRE(a.bvh_nodes.size() == c.bvh_nodes.size());
  CHECK(a.bvh_prims == b.bvh_prims);
  CHECK(a.bvh_prims == c.bvh_prims);
  CHECK(std::memcmp(a.bvh_nodes.data(), c.bvh_nodes.data(),
                    a.bvh_nodes.size() * sizeof a.bvh_nodes[0]) == 0);
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
  for (auto* scene : {&chain, &clump}) {
    auto ps = pack_with_bvh(*scene);
    check_structure(ps);
    CHECK(twinray::bvh::stats(ps.bvh_nodes).max_depth <= twinray::bvh::kMaxDepth);
  }
  // The chain is deep enough to reach the cap.
  CHECK(twinray::bvh::stats(pack_with_bvh(chain).bvh_nodes).max_depth >=
        twinray::bvh::kMaxDepth - 8);
}

TEST_CASE_TEMPLATE("bvh: traversal finds exactly the linear loops' closest hit", T, float, double) {
  check_traversal(pack_with_bvh(bvh_test::random_scene<T>(300, 300, 11u)), 20000, 5u);
  check_traversal(pack_with_bvh(bvh_test::random_scene<T>(40, 0, 12u)), 5000, 6u);
  check_traversal(pack_with_bvh(bvh_test::random_scene<T>(0, 60, 13u, false)), 5000, 7u);
}

TEST_CASE("bvh: pack builds one from the threshold on, and not below it") {
  twinray::RenderOptions options;
  auto camera = bvh_test::test_camera<float>(8, 8);
  auto has_bvh = [&](int n_spheres, int n_triangles) {
    auto ps = test_support::pack(bvh_test::random_scene<float>(n_spheres, n_triangles, 1u), camera,
                                 options);
    CHECK(ps.params().n_bvh_nodes == static_cast<int>(ps.scene.bvh_nodes.size()));
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
