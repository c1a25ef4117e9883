// Packets of rays (device/bvh_packet.h) give each ray exactly what its own walk gives.
//  - Queries: tr_packet_bvh's nearest (t, primitive) and blocked flags equal
//    tr_bvh_walk's, ray by ray, for coherent packets (the masked walk; camera rays and
//    a beam far wider than its rays) and incoherent ones (ray by ray), at every width
//    (tr_packet_bvh walks packets on 8-wide trees only).
//  - The masked walk alone, at every width, for any subset of a coherent packet's rays:
//    each ray in the subset gets its own walk's answer, and the others are left as
//    they were.
//  - Images: the CPU backend, which traces 8x8 blocks a segment at a time
//    (tr_render_block), gives the same bits as tr_render_pixel pixel by pixel: BVH
//    widths 2, 4 and 8, float and double, perspective and orthographic, several samples
//    from each sampler, a pixel rectangle whose blocks are cut at its edges, and more
//    lights than the 32 whose shadow rays are traced in packets.
//  - Shadow queries: tr_any_hit_packet's answers equal tr_any_hit's, in a scene of a
//    few spheres and in a dense cloud of half a million.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <variant>
#include <vector>

#include <twinray/twinray.hpp>

#include "bvh_scenes.hpp"
#include "device/device_test_util.hpp"

namespace {

using test::Code;
using test::K;
using test::vec3;

template <class T>
twinray::Scene<T> test_scene() {
  auto scene = bvh_test::random_scene<T>(300, 300, 7u);
  scene.add(bvh_test::folded_grid<T>(12, 2));
  return scene;
}

template <class T>
twinray::PackedScene<T> packed(const twinray::Scene<T>& scene, int width) {
  twinray::PackOptions options;
  options.bvh = twinray::BvhPolicy::Always;
  options.bvh_width = width;
  return twinray::pack_scene(scene, options);
}

template <class T>
typename Code<T>::Ray ray(vec3<T> o, vec3<T> d) {
  typename Code<T>::Ray r;
  r.o = o;
  r.d = glm::normalize(d);
  return r;
}

enum Outcome { kMaskedWalk, kRayByRay };

// The rays of a test packet, of one of three kinds: 0, camera rays (one origin,
// directions a few pixels apart); 1, origins spread over the whole scene, nearly
// parallel; 2, all directions (not coherent).
template <class T>
std::vector<typename Code<T>::Ray> test_rays(int kind, int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const vec3<T> eye(T(u(rng)), T(-1 + 0.3 * u(rng)), T(6));
  const vec3<T> target(T(3 * u(rng)), T(u(rng)), T(-2));
  std::vector<typename Code<T>::Ray> rays;
  for (int i = 0; i < n; ++i) {
    const T a = T(0.01 * (i % 8)), b = T(0.01 * (i / 8));
    if (kind == 0)
      rays.push_back(ray<T>(eye, target - eye + vec3<T>(a, b, 0)));
    else if (kind == 1)
      rays.push_back(ray<T>(vec3<T>(T(4 * u(rng)), T(1.5 * u(rng)), T(-3 + 2 * u(rng))),
                            vec3<T>(T(-0.5), T(-0.6), T(0.4 + a))));
    else
      rays.push_back(ray<T>(eye, vec3<T>(T(u(rng)), T(u(rng)), T(u(rng)))));
  }
  return rays;
}

// Checks that ray r of the packet holds what its own walk (tr_bvh_walk, from tmax)
// finds: the same nearest t and primitive, or the same blocked flag. Returns whether
// that walk found a hit (or a blocker).
template <class T, class Packet>
bool check_own_walk(const typename Code<T>::SceneRef& ref, const Packet& pk, int r, T tmax,
                    bool any_hit) {
  typename Code<T>::Nearest own;
  own.t = tmax;
  own.prim = -1;
  const int blocked = K<T>::tr_bvh_walk(&ref, pk.ray[r], &own, any_hit ? 1 : 0);
  if (any_hit) {
    CHECK((pk.t[r] < T(0)) == (blocked != 0));
    return blocked != 0;
  }
  CHECK(pk.prim[r] == own.prim);
  CHECK(std::memcmp(&pk.t[r], &own.t, sizeof(T)) == 0);
  return own.prim >= 0;
}

// Runs the packet query and each ray's own walk, and checks they agree ray by ray.
// Returns how the packet was walked.
template <class T>
Outcome check_packet(const twinray::PackedScene<T>& ps,
                     const std::vector<typename Code<T>::Ray>& rays, bool any_hit) {
  twinray::RenderOptions options;
  const auto frame =
      twinray::pack_frame(ps.summary(), {bvh_test::test_camera<T>(8, 8), {}, options});
  const auto ref = frame.ref(ps);
  const int mode = any_hit ? 1 : 0;
  const T tmax = any_hit ? T(5) : T(INFINITY);
  auto scratch = std::make_unique<typename Code<T>::BlockScratch>();
  auto& pk = scratch->packet;
  pk.n = static_cast<int>(rays.size());
  for (int r = 0; r < pk.n; ++r) {
    pk.ray[r] = rays[static_cast<size_t>(r)];
    pk.t[r] = tmax;
    pk.prim[r] = -1;
  }
  const int coherent = K<T>::tr_packet_begin(&pk);
  const Outcome outcome = coherent && ps.bvh_width() == 8 ? kMaskedWalk : kRayByRay;
  K<T>::tr_packet_bvh(&ref, &pk, coherent, mode);
  for (int r = 0; r < pk.n; ++r) {
    CAPTURE(r);
    check_own_walk(ref, pk, r, tmax, any_hit);
  }
  return outcome;
}

template <class T>
void check_queries(int width) {
  const auto ps = packed(test_scene<T>(), width);
  std::mt19937 rng(11u);
  int outcomes[2] = {0, 0};
  for (int trial = 0; trial < 60; ++trial) {
    // Full packets, and packets cut at an image's edge.
    const auto rays = test_rays<T>(trial % 3, trial % 4 == 3 ? 41 : 64, rng);
    for (bool any_hit : {false, true}) ++outcomes[check_packet(ps, rays, any_hit)];
  }
  CAPTURE(outcomes[kMaskedWalk]);
  CAPTURE(outcomes[kRayByRay]);
  if (width == 8) CHECK(outcomes[kMaskedWalk] > 0);  // both ways are taken
  CHECK(outcomes[kRayByRay] > 0);
}

// The masked walk alone (tr_packet_walk_masked) on the packets check_queries makes,
// for random subsets of their rays: each ray in the subset gets exactly its own walk's
// answer (nearest t and primitive, or blocked), and the rays outside it keep their
// values untouched.
template <class T>
void check_masked_walk(int width) {
  const auto ps = packed(test_scene<T>(), width);
  twinray::RenderOptions options;
  const auto frame =
      twinray::pack_frame(ps.summary(), {bvh_test::test_camera<T>(8, 8), {}, options});
  const auto ref = frame.ref(ps);
  std::mt19937 rng(23u);
  auto scratch = std::make_unique<typename Code<T>::BlockScratch>();
  auto& pk = scratch->packet;
  int answered = 0, untouched = 0, hits = 0, coherent_packets = 0;
  for (int trial = 0; trial < 30; ++trial) {
    const bool any_hit = (trial / 3) % 2 == 1;
    const T tmax = any_hit ? T(5) : T(INFINITY);
    // A block cut at the image's edge, too.
    const auto rays = test_rays<T>(trial % 3, trial % 5 == 4 ? 37 : TR_PACKET_MAX, rng);
    pk.n = static_cast<int>(rays.size());
    unsigned long long active = 0;
    for (int r = 0; r < pk.n; ++r) {
      pk.ray[r] = rays[static_cast<size_t>(r)];
      pk.t[r] = tmax;
      pk.prim[r] = -1;
      if (rng() % 4 != 0) active |= 1ull << r;  // about three rays in four
    }
    if (!K<T>::tr_packet_begin(&pk)) continue;  // the walk takes coherent packets only
    ++coherent_packets;
    K<T>::tr_packet_walk_masked(&ref, &pk, active, any_hit ? 1 : 0, width, 0, nullptr);
    for (int r = 0; r < pk.n; ++r) {
      CAPTURE(trial);
      CAPTURE(r);
      if (!((active >> r) & 1ull)) {
        CHECK(std::memcmp(&pk.t[r], &tmax, sizeof(T)) == 0);
        CHECK(pk.prim[r] == -1);
        ++untouched;
        continue;
      }
      hits += check_own_walk(ref, pk, r, tmax, any_hit);
      ++answered;
    }
  }
  CHECK(untouched > 0);
  CHECK(hits > 0);
  CHECK(hits < answered);  // misses too
  CHECK(coherent_packets >= 10);
}

// Shadow queries, tr_any_hit_packet, give each ray what its own any-hit query gives: in a
// scene of n_spheres small spheres, packets of rays from a small patch toward a light
// (a block's shadow rays).
template <class T>
void check_shadow_packets(int n_spheres) {
  auto scene = bvh_test::random_scene<T>(0, 0, 3u);  // materials, lights and the plane
  std::mt19937 rng(5u);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < n_spheres; ++i)
    scene.add(twinray::Sphere<T>{vec3<T>(T(4 * u(rng)), T(1.5 * u(rng)), T(-3 + 2 * u(rng))),
                                 T(0.004), i % 4});
  const auto ps = packed(scene, 8);
  twinray::RenderOptions options;
  const auto frame =
      twinray::pack_frame(ps.summary(), {bvh_test::test_camera<T>(8, 8), {}, options});
  const auto ref = frame.ref(ps);
  auto scratch = std::make_unique<typename Code<T>::BlockScratch>();
  auto& pk = scratch->packet;
  int blocked[TR_PACKET_MAX];
  int answers[2] = {0, 0};
  const vec3<T> light(T(-2), T(-4), T(2));
  for (int trial = 0; trial < 12; ++trial) {
    const vec3<T> patch(T(3.5 * u(rng)), T(1.2 * u(rng)), T(-3 + 1.5 * u(rng)));
    T tmax[TR_PACKET_MAX];
    pk.n = TR_PACKET_MAX;
    for (int r = 0; r < pk.n; ++r) {
      const vec3<T> o = patch + vec3<T>(T(0.01 * (r % 8)), T(0.01 * (r / 8)), T(0));
      pk.ray[r] = ray<T>(o, light - o);
      tmax[r] = pk.t[r] = T(glm::length(light - o));
    }
    K<T>::tr_any_hit_packet(&ref, &pk, blocked);
    for (int r = 0; r < pk.n; ++r) {
      CAPTURE(trial);
      CAPTURE(r);
      CHECK(blocked[r] == K<T>::tr_any_hit(&ref, &pk.ray[r], tmax[r]));
      ++answers[blocked[r] != 0];
    }
  }
  CHECK(answers[0] > 0);  // both answers occur
  CHECK(answers[1] > 0);
}

// tr_packet_hits_boxes's `ahead` bit, which lets the lanes skip the triangle test's
// straddle bound (device/intersect_triangle.h), is set only where that bound could reject
// nothing: for every ray of the packet, each vertex of each triangle in the leaf lies at
// a positive ray-space depth as tr_triangle_hit_at computes it (the vertex's offset from
// the origin on the ray's dominant axis, times that axis's reciprocal). Checked at every
// node of the tree for camera packets, beams of nearly parallel rays, and shadow packets
// that leave a triangle of the folded grid (whose own leaf straddles their origins).
template <class T>
void check_leaves_ahead() {
  auto scene = bvh_test::random_scene<T>(0, 400, 9u);
  scene.add(bvh_test::folded_grid<T>(24, 2));
  const auto ps = packed(scene, 8);
  twinray::RenderOptions options;
  const auto frame =
      twinray::pack_frame(ps.summary(), {bvh_test::test_camera<T>(8, 8), {}, options});
  const auto ref = frame.ref(ps);
  const int n_spheres = ref.params->n_spheres, n_nodes = ref.params->n_bvh_nodes;
  auto scratch = std::make_unique<typename Code<T>::BlockScratch>();
  auto& pk = scratch->packet;
  std::mt19937 rng(31u);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const vec3<T> light(T(-2), T(-4), T(2));
  int ahead_leaves = 0, straddled_leaves = 0, packets = 0;
  for (int trial = 0; trial < 36; ++trial) {
    std::vector<typename Code<T>::Ray> rays;
    if (trial % 3 < 2) {
      rays = test_rays<T>(trial % 3, TR_PACKET_MAX, rng);
    } else {  // from points inside one triangle of the grid toward the light
      const auto& mesh = std::get<twinray::Mesh<T>>(scene.objects.back());
      const auto& f = mesh.triangles[rng() % mesh.triangles.size()];
      const vec3<T> a = mesh.vertices[static_cast<size_t>(f[0])],
                    b = mesh.vertices[static_cast<size_t>(f[1])],
                    c = mesh.vertices[static_cast<size_t>(f[2])];
      for (int r = 0; r < TR_PACKET_MAX; ++r) {
        const T wa = T(0.1 + 0.8 * u(rng)), wb = T((1 - wa) * u(rng));
        const vec3<T> o = a + wb * (b - a) + (T(1) - wa - wb) * (c - a);
        rays.push_back(ray<T>(o, light - o));
      }
    }
    pk.n = static_cast<int>(rays.size());
    for (int r = 0; r < pk.n; ++r) {
      pk.ray[r] = rays[static_cast<size_t>(r)];
      pk.t[r] = T(INFINITY);
      pk.prim[r] = -1;
    }
    if (!K<T>::tr_packet_begin(&pk)) continue;  // the masked walk takes coherent packets
    ++packets;
    for (int index = 0; index < n_nodes; ++index) {
      const T* boxes = K<T>::tr_bvh_node(&ref, index, 8);
      const int* first = K<T>::tr_bvh_node_links(boxes, 8);
      const int* count = first + 8;
      T t_entry[8];
      unsigned ahead = 0u;
      K<T>::tr_packet_hits_boxes(boxes, &pk, T(INFINITY), 8, t_entry, &ahead);
      for (int k = 0; k < 8; ++k) {
        if (count[k] <= 0) continue;  // an inner child or an empty slot
        bool positive = true;
        for (int i = first[k]; i < first[k] + count[k]; ++i) {
          const auto* tri = &ref.triangles[K<T>::tr_bvh_prim(&ref, i) - n_spheres];
          for (const vec3<T> p :
               {K<T>::tr_triangle_p0(tri), K<T>::tr_triangle_p1(tri), K<T>::tr_triangle_p2(tri)})
            for (int r = 0; r < pk.n; ++r) {
              const int kz = pk.tri_kz[r];
              const vec3<T> o(pk.ox[r], pk.oy[r], pk.oz[r]);
              const T depth = pk.tri_sz[r] * (p[kz] - o[kz]);
              positive = positive && depth > T(0);
            }
        }
        CAPTURE(trial);
        CAPTURE(index);
        CAPTURE(k);
        if ((ahead >> k) & 1u) {
          CHECK(positive);
          ++ahead_leaves;
        } else if (!positive) {
          ++straddled_leaves;
        }
      }
    }
  }
  CHECK(packets >= 20);
  CHECK(ahead_leaves > 0);
  CHECK(straddled_leaves > 0);
}

template <class T>
twinray::Image<T> per_pixel(const twinray::PackedScene<T>& ps,
                            const twinray::RenderRequest<T>& request) {
  const auto frame = twinray::pack_frame(ps.summary(), request);
  const auto ref = frame.ref(ps);
  const auto& p = frame.params;
  twinray::Image<T> image;
  image.resize(p.rect_w, p.rect_h);
  for (int y = 0; y < p.rect_h; ++y)
    for (int x = 0; x < p.rect_w; ++x)
      K<T>::tr_store_rgb(image.rgb.data(), p.rect_w, x, y,
                         K<T>::tr_render_pixel(&ref, p.rect_x + x, p.rect_y + y));
  return image;
}

template <class T>
bool same_bits(const twinray::Image<T>& a, const twinray::Image<T>& b) {
  return a.rgb.size() == b.rgb.size() && !a.rgb.empty() &&
         std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(T)) == 0;
}

template <class T>
void check_images() {
  auto scene = test_scene<T>();
  for (int width : twinray::bvh::kWidths) {
    CAPTURE(width);
    const auto ps = std::make_shared<const twinray::PackedScene<T>>(packed(scene, width));
    twinray::RenderOptions options;
    options.backend = twinray::Backend::Cpu;
    options.specialize = false;  // the instantiation per_pixel calls (TR_F_ALL)
    options.log = [](const std::string&) {};
    auto cpu = twinray::make_backend<T>(options);
    cpu->set_scene(ps);
    auto check = [&](const twinray::RenderRequest<T>& request) {
      const auto image = cpu->render(request);
      CHECK(same_bits(image, per_pixel(*ps, request)));
    };
    auto camera = bvh_test::test_camera<T>(61, 45);
    // The image's middle column and row cross the axes: those blocks go ray by ray.
    camera.look_at = vec3<T>(camera.position.x, camera.position.y, T(-2));
    check({camera, scene.lights, options});
    auto jittered = options;
    jittered.spp = 3;
    jittered.sampler = twinray::Sampler::Stratified;
    jittered.seed = 5;
    check({bvh_test::test_camera<T>(40, 30), scene.lights, jittered});
    // Each sampler: the grid places a sample alike in every pixel, the others do not.
    auto grid = options;
    grid.spp = 4;
    grid.sampler = twinray::Sampler::Grid;
    check({bvh_test::test_camera<T>(24, 20), scene.lights, grid});
    auto r2 = grid;
    r2.spp = 2;
    r2.sampler = twinray::Sampler::R2;
    check({bvh_test::test_camera<T>(24, 20), scene.lights, r2});
    auto ortho = bvh_test::test_camera<T>(40, 30);
    ortho.projection = twinray::Projection::Orthographic;
    check({ortho, scene.lights, options});
    check({bvh_test::test_camera<T>(64, 48), scene.lights, options, {13, 7, 27, 19}});
    std::vector<twinray::Light<T>> many;  // 34 lights, more than a 32-bit mask holds
    for (int i = 0; i < 34; ++i)
      many.push_back(
          {vec3<T>(T(-4 + 0.25 * i), T(-3 - 0.05 * i), T(2 - 0.1 * i)), T(1), vec3<T>(1, 1, 1)});
    check({bvh_test::test_camera<T>(24, 20), many, options});
  }
}

}  // namespace

TEST_CASE_TEMPLATE("packet queries give each ray what its own walk gives", T, float, double) {
  for (int width : twinray::bvh::kWidths) {
    CAPTURE(width);
    check_queries<T>(width);
  }
}

TEST_CASE_TEMPLATE("the masked walk gives each ray in its mask what its own walk gives", T, float,
                   double) {
  for (int width : twinray::bvh::kWidths) {
    CAPTURE(width);
    check_masked_walk<T>(width);
  }
}

TEST_CASE_TEMPLATE("blocks traced a segment at a time give the per-pixel image's bits", T, float,
                   double) {
  check_images<T>();
}

TEST_CASE_TEMPLATE("shadow packets give each ray its own answer, in sparse and dense scenes", T,
                   float, double) {
  check_shadow_packets<T>(3000);
  check_shadow_packets<T>(524289);
}

TEST_CASE_TEMPLATE("a leaf marked ahead of a packet lies ahead of each of its rays", T, float,
                   double) {
  check_leaves_ahead<T>();
}
