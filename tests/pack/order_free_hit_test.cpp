// The nearest hit is the smallest (t, primitive id), so it does not depend on the order
// the BVH offers primitives in. Scenes full of exact ties (every sphere and triangle
// twice, at the same place, in another material; meshes with shared edges) render to
// the same bits with 2-, 4- and 8-wide BVHs, with each one's children and leaves
// shuffled, and with no BVH at all, in float and double, on both backends. Before hits were ordered
// by id, a shuffled tree picked the other copy of a tied pair and these images differed.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include <twinray/twinray.hpp>

#include "bvh_scenes.hpp"
#include "support/packing.hpp"

namespace {

template <class T>
twinray::Scene<T> scene_with_ties(uint32_t seed) {
  twinray::Scene<T> base = bvh_test::random_scene<T>(120, 120, seed);
  twinray::Scene<T> scene = base;
  // A second copy of every object in another material: every hit on them is a tie.
  for (const auto& object : base.objects) {
    if (auto* s = std::get_if<twinray::Sphere<T>>(&object)) {
      auto copy = *s;
      copy.material = (s->material + 1) % 4;
      scene.add(copy);
    } else if (auto* t = std::get_if<twinray::Triangle<T>>(&object)) {
      auto copy = *t;
      copy.material = (t->material + 2) % 4;
      scene.add(copy);
    }
  }
  scene.add(bvh_test::folded_grid<T>(10, 3));  // shared edges: ties between neighbours
  return scene;
}

// The same tree with the child slots of every node in a random order and every leaf's
// primitives in a random order: another traversal order over the same primitives.
template <class T>
twinray::PackedScene<T> shuffled(twinray::PackedScene<T> ps, uint32_t seed) {
  std::mt19937 rng(seed);
  const int w = ps.bvh_width();
  int moved = 0;
  for (int node = 0; node < ps.bvh_node_count(); ++node) {
    T* box = ps.bvh_nodes.boxes(node);
    int* link = ps.bvh_nodes.links(node);
    std::vector<int> perm(static_cast<size_t>(w));
    for (int k = 0; k < w; ++k) perm[static_cast<size_t>(k)] = k;
    std::shuffle(perm.begin(), perm.end(), rng);
    std::vector<T> old_box(box, box + 6 * w);
    std::vector<int> old_link(link, link + 2 * w);
    for (int k = 0; k < w; ++k) {
      const int from = perm[static_cast<size_t>(k)];
      moved += from != k;
      for (int plane = 0; plane < 6; ++plane)
        box[plane * w + k] = old_box[static_cast<size_t>(plane * w + from)];
      link[k] = old_link[static_cast<size_t>(from)];
      link[w + k] = old_link[static_cast<size_t>(w + from)];
      if (link[w + k] > 0) {
        auto first = ps.bvh_prims.begin() + link[k];
        std::shuffle(first, first + link[w + k], rng);
      }
    }
  }
  REQUIRE(moved > 10);
  return ps;
}

template <class T>
bool same_bits(const twinray::Image<T>& a, const twinray::Image<T>& b) {
  return a.rgb.size() == b.rgb.size() &&
         std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(T)) == 0;
}

bool have_opencl() {
#ifdef TWINRAY_WITH_OPENCL
  return twinray::opencl_available();
#else
  return false;
#endif
}

template <class T>
void check_order_free(twinray::Backend backend) {
  auto scene = scene_with_ties<T>(31u);
  auto pack = [&](int width) {
    twinray::PackOptions pack_options;
    pack_options.bvh = twinray::BvhPolicy::Always;
    pack_options.bvh_width = width;
    auto ps = twinray::pack_scene(scene, pack_options);
    REQUIRE((ps.features & TR_F_BVH) == twinray::bvh::width_feature(width));
    return ps;
  };
  auto camera = bvh_test::test_camera<T>(96, 72);
  for (auto output : {twinray::Output::Shaded, twinray::Output::ObjectIndex}) {
    twinray::RenderOptions options;
    options.output = output;
    auto linear = test_support::render_packed(test_support::without_bvh(pack(2)), camera,
                                              scene.lights, options, backend);
    for (int width : twinray::bvh::kWidths) {
      CAPTURE(width);
      auto bvh = pack(width);
      auto image = test_support::render_packed(bvh, camera, scene.lights, options, backend);
      CHECK(same_bits(image, linear));
      for (uint32_t seed : {1u, 2u}) {
        CAPTURE(seed);
        auto other = test_support::render_packed(shuffled(bvh, seed), camera, scene.lights, options,
                                                 backend);
        CHECK(same_bits(image, other));
      }
    }
  }
}

}  // namespace

TEST_CASE_TEMPLATE("order-free hits: CPU images do not depend on BVH width or traversal order", T,
                   float, double) {
  check_order_free<T>(twinray::Backend::Cpu);
}

TEST_CASE_TEMPLATE("order-free hits: OpenCL images do not depend on BVH width or traversal order",
                   T, float, double) {
  if (!have_opencl()) {
    MESSAGE("no OpenCL device: skipped");
    return;
  }
  check_order_free<T>(twinray::Backend::OpenCL);
}
