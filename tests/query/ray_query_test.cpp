// Ray queries (docs/ray-queries.md): the answers to users' rays, their independence of
// batch, order, threads, BVH width and backend, watertightness, bad rays, masks and the
// OpenCL backend's device buffers.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <random>
#include <vector>

#include <twinray/twinray.hpp>
#ifdef TWINRAY_WITH_OPENCL
#include <twinray/backend/opencl/backend.hpp>
#endif

#include "query/query_scenes.hpp"
#include "support/scoped_env.hpp"

using namespace twinray;
using query_test::vec3;

namespace {

bool have_opencl() {
#ifdef TWINRAY_WITH_OPENCL
  return opencl_available();
#else
  return false;
#endif
}

// The backends to compare: the CPU, and OpenCL where there is a device.
std::vector<Backend> backends() {
  std::vector<Backend> b = {Backend::Cpu};
  if (have_opencl()) b.push_back(Backend::OpenCL);
  return b;
}

template <class T>
std::unique_ptr<RenderBackend<T>> backend_on(Backend kind,
                                             std::shared_ptr<const PackedScene<T>> ps) {
  RenderOptions options;
  options.backend = kind;
  options.log = [](const std::string&) {};
  auto b = make_backend<T>(options);
  b->set_scene(std::move(ps));
  return b;
}

template <class T>
std::shared_ptr<const PackedScene<T>> packed(const Scene<T>& scene, int width = 4,
                                             BvhPolicy bvh = BvhPolicy::Always) {
  PackOptions o;
  o.bvh = bvh;
  o.bvh_width = width;
  return share(pack_scene(scene, o));
}

template <class T>
std::vector<Hit<T>> hits_of(RenderBackend<T>& b, const std::vector<Ray<T>>& rays) {
  std::vector<Hit<T>> hits(rays.size());
  b.intersect(rays.data(), rays.size(), hits.data());
  return hits;
}

template <class T>
std::vector<uint8_t> blocked_of(RenderBackend<T>& b, const std::vector<Ray<T>>& rays) {
  std::vector<uint8_t> blocked(rays.size(), 7);
  b.occluded(rays.data(), rays.size(), blocked.data());
  return blocked;
}

// A camera on the mixed scene (query_scenes.hpp) from the front, width x height.
template <class T>
Camera<T> mixed_scene_camera(int width, int height) {
  Camera<T> camera;
  camera.position = vec3<T>(0, 1, 12);
  camera.look_at = vec3<T>(0, 0, 0);
  camera.width = width;
  camera.height = height;
  return camera;
}

template <class H>
bool is_miss(const H& h) {
  return std::isinf(h.t) && h.t > 0 && h.object == -1 && h.primitive == -1 && h.u == 0 &&
         h.v == 0 && h.nx == 0 && h.ny == 0 && h.nz == 0;
}

}  // namespace

TEST_CASE_TEMPLATE("a query reports t, object, primitive, barycentrics and a facing normal", T,
                   float, double) {
  Scene<T> s;
  s.materials.push_back({});
  s.add(Sphere<T>{vec3<T>(0, 0, -5), T(1), 0});  // object 0
  Mesh<T> m;                                     // object 1: two faces at z = -2
  m.vertices = {vec3<T>(10, 0, -2), vec3<T>(12, 0, -2), vec3<T>(10, 2, -2), vec3<T>(12, 2, -2)};
  m.triangles = {{0, 1, 2}, {1, 3, 2}};
  s.add(m);
  s.add(Plane<T>{vec3<T>(0, -10, 0), vec3<T>(0, 2, 0), 0});  // object 2
  for (Backend kind : backends()) {
    CAPTURE(static_cast<int>(kind));
    auto b = backend_on<T>(kind, packed(s));
    std::vector<Ray<T>> rays = {
        make_ray<T>(vec3<T>(0), vec3<T>(0, 0, -2)),                    // sphere, t in |d|s
        make_ray<T>(vec3<T>(T(11.5), T(1.5), 0), vec3<T>(0, 0, -1)),   // face 1
        make_ray<T>(vec3<T>(T(10.5), T(0.25), -4), vec3<T>(0, 0, 1)),  // face 0 from behind
        make_ray<T>(vec3<T>(0, 0, 0), vec3<T>(0, -1, 0)),              // the plane
        make_ray<T>(vec3<T>(0, 0, 0), vec3<T>(0, 1, 0)),               // nothing
        make_ray<T>(vec3<T>(0), vec3<T>(0, 0, -1), T(0), T(3.5)),      // tmax before it
        make_ray<T>(vec3<T>(0), vec3<T>(0, 0, -1), T(5), T(100)),      // tmin past the front
    };
    auto h = hits_of(*b, rays);
    CHECK(h[0].t == T(2));
    CHECK(h[0].object == 0);
    CHECK(h[0].primitive == 0);
    CHECK(h[0].nz == T(1));  // toward the origin
    CHECK(h[1].object == 1);
    CHECK(h[1].primitive == 1);
    CHECK(h[1].t == T(2));
    CHECK(h[1].nz == T(1));
    // On face 1 (p1 = (12,0), p2 = (10,2), p3 = (12,2) as 0,1,2): (11.5, 1.5) is
    // 0.25 p0 + 0.25 p1 + 0.5 p2 of vertices (12,0), (12,2), (10,2).
    CHECK(h[1].u == doctest::Approx(0.5).epsilon(1e-6));
    CHECK(h[1].v == doctest::Approx(0.25).epsilon(1e-6));
    CHECK(h[2].object == 1);
    CHECK(h[2].primitive == 0);
    CHECK(h[2].nz == T(-1));  // seen from behind: still toward the origin
    CHECK(h[2].u == doctest::Approx(0.25).epsilon(1e-6));
    CHECK(h[2].v == doctest::Approx(0.125).epsilon(1e-6));
    CHECK(h[3].object == 2);
    CHECK(h[3].t == T(10));
    CHECK(h[3].ny == T(1));
    CHECK(is_miss(h[4]));
    CHECK(is_miss(h[5]));
    CHECK(h[6].object == 0);
    CHECK(h[6].t == T(6));   // the back of the sphere
    CHECK(h[6].nz == T(1));  // the inside, seen from the origin
    auto blocked = blocked_of(*b, rays);
    CHECK(blocked == std::vector<uint8_t>{1, 1, 1, 1, 0, 0, 1});
  }
}

TEST_CASE_TEMPLATE("the interval is closed: a hit at exactly tmin or tmax counts", T, float,
                   double) {
  Scene<T> s;
  s.materials.push_back({});
  s.add(Plane<T>{vec3<T>(0, 0, -4), vec3<T>(0, 0, 1), 0});
  for (Backend kind : backends()) {
    auto b = backend_on<T>(kind, packed(s));
    std::vector<Ray<T>> rays = {make_ray<T>(vec3<T>(0), vec3<T>(0, 0, -1), T(0), T(4)),
                                make_ray<T>(vec3<T>(0), vec3<T>(0, 0, -1), T(4), T(9)),
                                make_ray<T>(vec3<T>(0), vec3<T>(0, 0, -1), T(4), T(4)),
                                make_ray<T>(vec3<T>(0), vec3<T>(0, 0, -1), T(0), T(3.9375)),
                                make_ray<T>(vec3<T>(0), vec3<T>(0, 0, -1), T(4.0625), T(9))};
    auto h = hits_of(*b, rays);
    CHECK(h[0].t == T(4));
    CHECK(h[1].t == T(4));
    CHECK(h[2].t == T(4));
    CHECK(is_miss(h[3]));
    CHECK(is_miss(h[4]));
    CHECK(blocked_of(*b, rays) == std::vector<uint8_t>{1, 1, 1, 0, 0});
  }
}

TEST_CASE_TEMPLATE("ties go to the smallest (object, primitive), whatever the BVH", T, float,
                   double) {
  // Object 3 and the last object of the mixed scene are the same triangle: every ray
  // through it hits both at the same t and must report object 3. A mesh of one face
  // twice: face 0.
  Scene<T> s = query_test::mixed_scene<T>(5u, 0);
  Mesh<T> twice;
  twice.vertices = {vec3<T>(-3, -3, 9), vec3<T>(3, -3, 9), vec3<T>(0, 3, 9)};
  twice.triangles = {{0, 1, 2}, {0, 1, 2}};
  const int twice_object = s.add(twice);
  std::vector<Ray<T>> rays;
  for (int i = 0; i < 64; ++i) {
    rays.push_back(
        make_ray<T>(vec3<T>(T(i % 8 - 4) * T(0.5), 3, T(i / 8 - 4) * T(0.5)), vec3<T>(0, -1, 0)));
    rays.push_back(make_ray<T>(vec3<T>(T(i % 8 - 4) * T(0.25), T(i / 8 - 4) * T(0.25), 12),
                               vec3<T>(0, 0, -1)));
  }
  for (Backend kind : backends())
    for (int width : {2, 4, 8}) {
      CAPTURE(width);
      auto b = backend_on<T>(kind, packed(s, width));
      auto h = hits_of(*b, rays);
      for (size_t i = 0; i < rays.size(); i += 2) {
        CHECK(h[i].object == 3);
        CHECK(h[i + 1].object == twice_object);
        CHECK(h[i + 1].primitive == 0);
      }
    }
}

TEST_CASE_TEMPLATE("a tie goes to the lower object index, not to the engine's primitive order", T,
                   float, double) {
  // A plane (object 0) and a triangle (object 1) in y = 2: rays straight down hit both
  // at t = 1 exactly. The engine numbers planes after triangles, so an order by its own
  // primitive ids would report the triangle.
  Scene<T> s;
  s.materials.push_back({});
  s.add(Plane<T>{vec3<T>(0, 2, 0), vec3<T>(0, 1, 0), 0});
  s.add(Triangle<T>{{vec3<T>(-4, 2, -4), vec3<T>(4, 2, -4), vec3<T>(0, 2, 4)}, 0});
  std::vector<Ray<T>> rays;
  for (int i = 0; i < 16; ++i)
    rays.push_back(
        make_ray<T>(vec3<T>(T(i % 4 - 2) * T(0.5), 3, T(i / 4 - 2) * T(0.5)), vec3<T>(0, -1, 0)));
  for (Backend kind : backends()) {
    auto b = backend_on<T>(kind, packed(s, 4, BvhPolicy::Never));
    for (const auto& h : hits_of(*b, rays)) {
      CHECK(h.t == T(1));
      CHECK(h.object == 0);
    }
  }
}

TEST_CASE_TEMPLATE("answers do not depend on batch, order, threads, BVH width or backend", T, float,
                   double) {
  const Scene<T> s = query_test::mixed_scene<T>(11u);
  const std::vector<Ray<T>> rays = query_test::random_rays<T>(20000, 3u, true);
  auto reference_backend = backend_on<T>(Backend::Cpu, packed(s, 2, BvhPolicy::Never));
  const auto ref_hits = hits_of(*reference_backend, rays);
  const auto ref_blocked = blocked_of(*reference_backend, rays);
  size_t found = 0;
  for (const auto& h : ref_hits) found += h.object >= 0;
  CHECK(found > rays.size() / 5);  // answers that are mostly misses would prove little
  CHECK(found < rays.size());

  // A permutation of the rays permutes the answers.
  std::vector<size_t> order(rays.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::shuffle(order.begin(), order.end(), std::mt19937(9u));
  std::vector<Ray<T>> shuffled(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) shuffled[i] = rays[order[i]];

  for (Backend kind : backends())
    for (int width : {2, 4, 8}) {
      CAPTURE(static_cast<int>(kind));
      CAPTURE(width);
      auto b = backend_on<T>(kind, packed(s, width));
      CHECK(query_test::same_bytes(hits_of(*b, rays), ref_hits));
      CHECK(blocked_of(*b, rays) == ref_blocked);
      auto h = hits_of(*b, shuffled);
      auto o = blocked_of(*b, shuffled);
      size_t wrong = 0;
      for (size_t i = 0; i < rays.size(); ++i)
        wrong += std::memcmp(&h[i], &ref_hits[order[i]], sizeof(Hit<T>)) != 0 ||
                 o[i] != ref_blocked[order[i]];
      CHECK(wrong == 0);
      // Batches of 1 (the first 200 rays), 7 and 1000 (the first 3000).
      for (size_t batch : {size_t(1), size_t(7), size_t(1000)}) {
        const size_t covered = batch == 1 ? 200 : 3000;
        std::vector<Hit<T>> pieces(covered);
        for (size_t at = 0; at < covered; at += batch)
          b->intersect(rays.data() + at, std::min(batch, covered - at), pieces.data() + at);
        CHECK(std::memcmp(pieces.data(), ref_hits.data(), covered * sizeof(Hit<T>)) == 0);
      }
    }
  // One thread and every thread.
  set_thread_count(1);
  auto one = backend_on<T>(Backend::Cpu, packed(s, 8));
  CHECK(query_test::same_bytes(hits_of(*one, rays), ref_hits));
  set_thread_count(0);
  CHECK(query_test::same_bytes(hits_of(*one, rays), ref_hits));
}

TEST_CASE_TEMPLATE("occluded is 1 exactly where intersect finds a hit in the interval", T, float,
                   double) {
  const Scene<T> s = query_test::mixed_scene<T>(17u);
  const std::vector<Ray<T>> rays = query_test::random_rays<T>(50000, 21u, true);
  for (Backend kind : backends()) {
    auto b = backend_on<T>(kind, packed(s, 4));
    auto h = hits_of(*b, rays);
    auto o = blocked_of(*b, rays);
    size_t disagree = 0, blocked = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      disagree += (h[i].object >= 0) != (o[i] == 1) || o[i] > 1;
      blocked += o[i];
      if (h[i].object >= 0)
        disagree += !(h[i].t >= rays[i].tmin && h[i].t <= rays[i].tmax && h[i].t > 0);
    }
    CHECK(disagree == 0);
    CHECK(blocked > rays.size() / 10);
    CHECK(blocked < rays.size() * 9 / 10);
  }
}

TEST_CASE_TEMPLATE("bad rays are defined misses, never occluded", T, float, double) {
  const Scene<T> s = query_test::mixed_scene<T>(2u);
  const T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
  const vec3<T> o(0, 0, 0), d(T(0.25), T(-1), T(0.125));
  std::vector<Ray<T>> bad = {
      make_ray<T>(o, vec3<T>(0)),                 // zero direction
      make_ray<T>(o, vec3<T>(nan, 1, 0)),         // NaN direction
      make_ray<T>(o, vec3<T>(inf, 1, 0)),         // infinite direction
      make_ray<T>(o, vec3<T>(-inf, -inf, -inf)),  // infinite direction
      make_ray<T>(vec3<T>(nan, 0, 0), d),         // NaN origin
      make_ray<T>(vec3<T>(0, -inf, 0), d),        // infinite origin
      make_ray<T>(o, d, T(2), T(1)),              // tmin > tmax
      make_ray<T>(o, d, T(-3), T(-1)),            // negative tmax
      make_ray<T>(o, d, nan, T(10)),              // NaN tmin
      make_ray<T>(o, d, T(0), nan),               // NaN tmax
      make_ray<T>(o, d, inf, inf),                // infinite tmin
      make_ray<T>(o, d, -inf, inf),               // infinite tmin
  };
  // Each one is a hit once it is repaired (so the miss is the rule, not the scene).
  auto repaired = make_ray<T>(o, d);
  for (Backend kind : backends()) {
    auto b = backend_on<T>(kind, packed(s, 4));
    auto h = hits_of(*b, bad);
    auto blocked = blocked_of(*b, bad);
    for (size_t i = 0; i < bad.size(); ++i) {
      CAPTURE(i);
      CHECK(is_miss(h[i]));
      CHECK(blocked[i] == 0);
    }
    CHECK(hits_of(*b, std::vector<Ray<T>>{repaired})[0].object >= 0);
    // A negative tmin is allowed: hits are looked for from t > 0 on.
    CHECK(hits_of(*b, std::vector<Ray<T>>{make_ray<T>(o, d, T(-5))})[0].t ==
          hits_of(*b, std::vector<Ray<T>>{repaired})[0].t);
    // An empty batch does nothing; null arrays with rays are refused.
    b->intersect(nullptr, 0, nullptr);
    b->occluded(nullptr, 0, nullptr);
    CHECK_THROWS_AS(b->intersect(nullptr, 1, nullptr), Error);
    std::vector<Hit<T>> one(1);
    CHECK_THROWS_AS(b->intersect(bad.data(), 1, one.data(), HitExtras::TextureUv, nullptr), Error);
  }
}

TEST_CASE_TEMPLATE("masks skip objects, cost renders nothing and change no render", T, float,
                   double) {
  Scene<T> s = query_test::mixed_scene<T>(7u, 60);
  const std::vector<Ray<T>> rays = query_test::random_rays<T>(4000, 8u);
  auto plain = pack_scene(s);
  CHECK((plain.features & TR_F_MASKS) == 0u);
  CHECK(plain.object_masks.empty());
  // Object k gets mask 1 << (k % 3); rays of mask 1 see only objects k % 3 == 0.
  for (size_t k = 0; k < s.objects.size(); ++k)
    std::visit([&](auto& o) { o.mask = 1u << (k % 3); }, s.objects[k]);
  Scene<T> only = s;  // the same scene without the objects mask 1 excludes, masks cleared
  only.objects.clear();
  std::vector<int> kept;
  for (size_t k = 0; k < s.objects.size(); ++k)
    if (k % 3 == 0) {
      only.objects.push_back(s.objects[k]);
      std::visit([](auto& o) { o.mask = 0xffffffffu; }, only.objects.back());
      kept.push_back(static_cast<int>(k));
    }
  auto masked = pack_scene(s);
  CHECK((masked.features & TR_F_MASKS) != 0u);
  std::vector<Ray<T>> ones = rays, all = rays, none = rays;
  for (auto& r : ones) r.mask = 1u;
  for (auto& r : none) r.mask = 8u;
  for (Backend kind : backends()) {
    auto b = backend_on<T>(kind, share(pack_scene(s)));
    auto reference = backend_on<T>(kind, share(pack_scene(only)));
    auto h = hits_of(*b, ones);
    auto r = hits_of(*reference, rays);
    size_t wrong = 0, found = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      int expected = r[i].object < 0 ? -1 : kept[static_cast<size_t>(r[i].object)];
      wrong += h[i].object != expected || std::memcmp(&h[i].t, &r[i].t, sizeof(T)) != 0;
      found += h[i].object >= 0;
    }
    CHECK(wrong == 0);
    CHECK(found > 100);
    auto unmasked = backend_on<T>(kind, share(pack_scene(query_test::mixed_scene<T>(7u, 60))));
    CHECK(query_test::same_bytes(hits_of(*b, all), hits_of(*unmasked, all)));
    for (uint8_t x : blocked_of(*b, none)) CHECK(x == 0);
    for (const auto& x : hits_of(*b, none)) CHECK(x.object == -1);
  }
  // A render of the masked scene is the render of the scene without masks, bit for bit.
  const Camera<T> camera = mixed_scene_camera<T>(64, 48);
  RenderOptions options;
  options.backend = Backend::Cpu;
  s.lights.push_back({vec3<T>(5, 8, 10), T(100), vec3<T>(1)});
  Scene<T> unmasked = query_test::mixed_scene<T>(7u, 60);
  unmasked.lights = s.lights;
  Image<T> a = render(s, camera, options), c = render(unmasked, camera, options);
  CHECK(std::memcmp(a.rgb.data(), c.rgb.data(), a.rgb.size() * sizeof(T)) == 0);
  // Its Features mask (the program's, on OpenCL) is that of the scene without masks.
  CHECK(pack_frame(masked.summary(), {camera, s.lights, options, {}}).features ==
        pack_frame(plain.summary(), {camera, s.lights, options, {}}).features);
}

TEST_CASE_TEMPLATE("extras: shading normals and texture coordinates on request", T, float, double) {
  const Scene<T> s = query_test::mixed_scene<T>(4u, 0);
  // Rays at the torus (object 4, vertex normals radial from its center, and uvs).
  std::vector<Ray<T>> rays;
  for (int i = 0; i < 200; ++i) {
    T a = T(i) * T(0.03125);
    rays.push_back(make_ray<T>(vec3<T>(-2, 0, 0) + vec3<T>(std::cos(a), std::sin(a), 0) * T(8),
                               vec3<T>(-std::cos(a), -std::sin(a), T(0.0625))));
  }
  for (Backend kind : backends()) {
    auto b = backend_on<T>(kind, packed(s));
    std::vector<Hit<T>> plain(rays.size()), h(rays.size());
    std::vector<HitExtra<T>> e(rays.size()), uv_only(rays.size());
    b->intersect(rays.data(), rays.size(), plain.data());
    b->intersect(rays.data(), rays.size(), h.data(),
                 HitExtras::ShadingNormal | HitExtras::TextureUv, e.data());
    b->intersect(rays.data(), rays.size(), h.data(), HitExtras::TextureUv, uv_only.data());
    CHECK(query_test::same_bytes(plain, h));  // extras change no hit
    size_t on_torus = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      if (h[i].object != 4) continue;
      ++on_torus;
      vec3<T> n(h[i].nx, h[i].ny, h[i].nz), sn(e[i].snx, e[i].sny, e[i].snz);
      CHECK(glm::length(sn) == doctest::Approx(1).epsilon(1e-5));
      CHECK(glm::dot(n, sn) > T(0));  // the geometric normal's side
      CHECK(glm::dot(n, sn) < T(1));  // smooth, not the flat normal
      CHECK(e[i].tex_u >= T(0));
      CHECK(e[i].tex_u <= T(0.75));
      CHECK(uv_only[i].tex_u == e[i].tex_u);
      CHECK(uv_only[i].tex_v == e[i].tex_v);
      CHECK(uv_only[i].snx == T(0));
    }
    CHECK(on_torus > 50);
  }
}

namespace {

// Rays at every vertex and at points along every edge of a closed mesh, from outside
// (at a distance `reach` along a direction within 60 degrees of the outward normal
// there) through the point: each must hit at or before the point.
template <class T, class Outward>
std::vector<Ray<T>> rays_at_vertices_and_edges(const Mesh<T>& m, T reach, int per_point,
                                               unsigned seed, Outward outward) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0), f(0.0, 1.0);
  std::vector<vec3<T>> points = m.vertices;
  for (auto e : query_test::edges(m)) {
    const vec3<T> a = m.vertices[e.first], b = m.vertices[e.second];
    points.push_back((a + b) * T(0.5));
    points.push_back(a + (b - a) * T(f(rng)));
  }
  std::vector<Ray<T>> rays;
  rays.reserve(points.size() * per_point);
  for (const auto& p : points) {
    const glm::dvec3 n = outward(glm::dvec3(p));
    for (int k = 0; k < per_point; ++k) {
      glm::dvec3 w;
      do w = query_test::draw3<double>(u, rng);
      while (glm::dot(w, w) > 1.0 || glm::dot(glm::normalize(w + n * 1.2), n) < 0.5);
      glm::dvec3 dir = glm::normalize(w + n * 1.2);
      vec3<T> origin = vec3<T>(glm::dvec3(p) + dir * double(reach));
      rays.push_back(make_ray<T>(origin, p - origin));  // reaches p at t = 1
    }
  }
  return rays;
}

template <class T>
size_t leaks(RenderBackend<T>& b, const std::vector<Ray<T>>& rays) {
  auto h = hits_of(b, rays);
  auto o = blocked_of(b, rays);
  size_t leaked = 0;
  for (size_t i = 0; i < rays.size(); ++i) leaked += !(h[i].t <= T(1.0009765625)) || o[i] != 1;
  return leaked;
}

}  // namespace

TEST_CASE_TEMPLATE("watertight: rays at the vertices and edges of closed meshes all hit", T, float,
                   double) {
  size_t total = 0;
  for (double scale : {1e-4, 1.0, 1e5}) {
    CAPTURE(scale);
    const vec3<T> c = vec3<T>(T(0.3 * scale), T(-0.2 * scale), T(0.1 * scale));
    const Mesh<T> ball = query_test::icosphere<T>(4, c, T(scale));
    const Mesh<T> ring = query_test::torus<T>(96, 48, c, T(scale), T(0.375 * scale));
    const glm::dvec3 cd(c);
    auto ball_out = [&](glm::dvec3 p) { return glm::normalize(p - cd); };
    auto ring_out = [&](glm::dvec3 p) {
      glm::dvec3 q = p - cd;
      glm::dvec3 axis = glm::normalize(glm::dvec3(q.x, q.y, 0)) * scale;
      return glm::normalize(q - axis);
    };
    for (int which = 0; which < 2; ++which) {
      Scene<T> s;
      s.materials.push_back({});
      s.add(which == 0 ? ball : ring);
      const auto rays =
          which == 0 ? rays_at_vertices_and_edges<T>(ball, T(0.5 * scale), 5, 13u, ball_out)
                     : rays_at_vertices_and_edges<T>(ring, T(0.25 * scale), 3, 14u, ring_out);
      for (Backend kind : backends()) {
        CAPTURE(which);
        CAPTURE(static_cast<int>(kind));
        auto b = backend_on<T>(kind, packed(s, 4));
        CHECK(leaks(*b, rays) == 0);
        total += rays.size();
      }
    }
  }
  MESSAGE("watertight: " << total << " rays at vertices and edges in " << sizeof(T) * 8
                         << "-bit reals");
  CHECK(total > 500000);
}

#ifdef TWINRAY_WITH_OPENCL
TEST_CASE_TEMPLATE("OpenCL: rays and hits in device buffers, and batches over many chunks", T,
                   float, double) {
  if (!have_opencl()) {
    MESSAGE("no OpenCL device: skipped");
    return;
  }
  const Scene<T> s = query_test::mixed_scene<T>(23u, 100);
  const size_t n = opencl::OpenCLBackend<T>::kQueryChunk * 2 + 777;  // three chunks
  const std::vector<Ray<T>> rays = query_test::random_rays<T>(n, 31u, true);
  auto ps = packed(s, 8);
  auto cpu = backend_on<T>(Backend::Cpu, ps);
  const auto ref = hits_of(*cpu, rays);
  const auto ref_blocked = blocked_of(*cpu, rays);
  opencl::OpenCLBackend<T> cl;
  cl.set_scene(ps);
  CHECK(query_test::same_bytes(hits_of(cl, rays), ref));
  CHECK(blocked_of(cl, rays) == ref_blocked);

  cl_context context = cl.context().context();
  cl_int err = CL_SUCCESS;
  cl_mem in = clCreateBuffer(context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, n * sizeof(Ray<T>),
                             const_cast<Ray<T>*>(rays.data()), &err);
  REQUIRE(err == CL_SUCCESS);
  cl_mem out = clCreateBuffer(context, CL_MEM_READ_WRITE, n * sizeof(Hit<T>), nullptr, &err);
  REQUIRE(err == CL_SUCCESS);
  cl_mem blocked = clCreateBuffer(context, CL_MEM_READ_WRITE, n, nullptr, &err);
  REQUIRE(err == CL_SUCCESS);
  cl.intersect_buffers(in, n, out);
  cl.occluded_buffers(in, n, blocked);
  std::vector<Hit<T>> h(n);
  std::vector<uint8_t> o(n);
  cl_command_queue queue = cl.context().queue();
  REQUIRE(clEnqueueReadBuffer(queue, out, CL_TRUE, 0, n * sizeof(Hit<T>), h.data(), 0, nullptr,
                              nullptr) == CL_SUCCESS);
  REQUIRE(clEnqueueReadBuffer(queue, blocked, CL_TRUE, 0, n, o.data(), 0, nullptr, nullptr) ==
          CL_SUCCESS);
  CHECK(query_test::same_bytes(h, ref));
  CHECK(o == ref_blocked);
  clReleaseMemObject(in);
  clReleaseMemObject(out);
  clReleaseMemObject(blocked);
}

// Bytes of an OpenCL buffer.
size_t mem_size(cl_mem m) {
  size_t size = 0;
  REQUIRE(clGetMemObjectInfo(m, CL_MEM_SIZE, sizeof size, &size, nullptr) == CL_SUCCESS);
  return size;
}

TEST_CASE_TEMPLATE("OpenCL: renders leave triangle_faces on the host, queries after them agree", T,
                   float, double) {
  if (!have_opencl()) {
    MESSAGE("no OpenCL device: skipped");
    return;
  }
  // Both ways a device gets the scene: wrapped in place (a CPU device) and copied.
  for (const char* in_place : {"1", "0"}) {
    CAPTURE(in_place);
    test_support::ScopedEnv env("TWINRAY_OPENCL_IN_PLACE", in_place);
    opencl::OpenCLBackend<T> cl;
    if (std::string(in_place) == "0") CHECK(!cl.shares_host_memory());
    Scene<T> s = query_test::mixed_scene<T>(11u, 80);
    s.lights.push_back({vec3<T>(5, 8, 10), T(100), vec3<T>(1)});
    const Camera<T> camera = mixed_scene_camera<T>(48, 32);
    RenderOptions options;
    options.backend = Backend::Cpu;
    const Image<T> expected = render(s, camera, options);
    options.backend = Backend::OpenCL;
    const std::vector<Ray<T>> rays = query_test::random_rays<T>(20000, 12u, true);
    for (int width : {8, 2}) {  // a second scene replaces the first
      CAPTURE(width);
      auto ps = packed(s, width);
      const size_t face_bytes = ps->triangle_faces.size() * sizeof(int);
      REQUIRE(face_bytes > 0);
      auto cpu = backend_on<T>(Backend::Cpu, ps);
      const auto ref = hits_of(*cpu, rays);
      const auto ref_blocked = blocked_of(*cpu, rays);
      // Some hits are on mesh triangles other than the first: their faces matter.
      CHECK(std::count_if(ref.begin(), ref.end(), [](const Hit<T>& h) { return h.primitive > 0; }) >
            100);

      cl.set_scene(ps);
      auto render_once = [&] {
        Image<T> image = cl.render({camera, s.lights, options, {}});
        REQUIRE(image.rgb.size() == expected.rgb.size());
        CHECK(std::memcmp(image.rgb.data(), expected.rgb.data(), image.rgb.size() * sizeof(T)) ==
              0);
      };
      render_once();
      // The render sent every array but triangle_faces; its kernel got a placeholder.
      CHECK(!cl.scene_buffers().has_faces());
      CHECK(cl.scene_buffers().scene_bytes() == ps->bytes() - face_bytes);
      CHECK(mem_size(cl.scene_buffers().args()[opencl::kSceneArgs - 1]) == 16);
      // The first query sends them; later renders and queries keep them.
      CHECK(query_test::same_bytes(hits_of(cl, rays), ref));
      CHECK(cl.scene_buffers().has_faces());
      CHECK(cl.scene_buffers().scene_bytes() == ps->bytes());
      CHECK(mem_size(cl.scene_buffers().args()[opencl::kSceneArgs - 1]) == face_bytes);
      render_once();
      CHECK(blocked_of(cl, rays) == ref_blocked);
      CHECK(query_test::same_bytes(hits_of(cl, rays), ref));
    }
  }
}
#endif
