// Ray queries in packets (device/ray_query.h, tr_query_intersect_rays and
// tr_query_occluded_rays; cpu::QueryWalk): the CPU walks runs of consecutive rays whose
// directions share their signs as one packet, and each ray must get the very bytes the
// single-ray walk gives it, for any tmin, tmax and mask, on ties, from inside spheres,
// with bad rays among good ones and for batch sizes that are not whole packets. Each
// case also checks that most of its rays did go through the packet walk, and the last
// that the default walk takes a packet as one only where its directions are narrow.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include <twinray/backend/cpu.hpp>
#include <twinray/twinray.hpp>

#include "query/query_scenes.hpp"

using namespace twinray;
using query_test::vec3;

namespace {

template <class T>
PackedScene<T> packed8(const Scene<T>& scene) {
  PackOptions o;
  o.bvh = BvhPolicy::Always;
  o.bvh_width = 8;
  return pack_scene(scene, o);
}

// Answers of both walks for rays[0 .. n) in batches of `batch`: hits (with extras) and
// occluded's, and how many rays the packet walk took.
template <class T>
struct Answers {
  std::vector<Hit<T>> hits;
  std::vector<HitExtra<T>> extras;
  std::vector<uint8_t> blocked;
  size_t walked = 0;
};

template <class T>
Answers<T> answers(const PackedScene<T>& ps, const std::vector<Ray<T>>& rays, cpu::QueryWalk walk,
                   size_t batch) {
  Answers<T> a;
  const size_t n = rays.size();
  a.hits.assign(n, Hit<T>{});
  a.extras.assign(n, HitExtra<T>{});
  a.blocked.assign(n, 7);
  for (size_t at = 0; at < n; at += batch) {
    const size_t m = std::min(batch, n - at);
    a.walked += cpu::query_intersect(ps, rays.data() + at, m, a.hits.data() + at,
                                     TR_QUERY_SHADING_NORMAL | TR_QUERY_TEXTURE_UV,
                                     a.extras.data() + at, walk);
    a.walked += cpu::query_occluded(ps, rays.data() + at, m, a.blocked.data() + at, walk);
  }
  return a;
}

// The number of rays whose packet answers differ from the single-ray walk's, in any
// byte of the hit, the extras or occluded's answer, for each way of making packets and
// over several batch sizes (none a whole number of packets but 64 and 256); also checks
// that the walks that always make packets took at least `min_walked` of each batch's
// rays (both queries counted).
template <class T>
size_t differences(const PackedScene<T>& ps, const std::vector<Ray<T>>& rays, double min_walked) {
  const Answers<T> one = answers(ps, rays, cpu::QueryWalk::RayByRay, rays.size());
  CHECK(one.walked == 0);
  size_t wrong = 0;
  for (cpu::QueryWalk walk :
       {cpu::QueryWalk::Packets, cpu::QueryWalk::PacketsInOrder, cpu::QueryWalk::PacketsByOctant})
    for (size_t batch :
         {rays.size(), size_t(1), size_t(37), size_t(64), size_t(65), size_t(256), size_t(1000)}) {
      CAPTURE(static_cast<int>(walk));
      CAPTURE(batch);
      const Answers<T> pk = answers(ps, rays, walk, batch);
      // The default walk takes only narrow packets as one (the last case checks which).
      if (batch >= 37 && walk != cpu::QueryWalk::Packets)
        CHECK(double(pk.walked) >= min_walked * 2.0 * double(rays.size()));
      for (size_t i = 0; i < rays.size(); ++i)
        wrong += std::memcmp(&pk.hits[i], &one.hits[i], sizeof(Hit<T>)) != 0 ||
                 std::memcmp(&pk.extras[i], &one.extras[i], sizeof(HitExtra<T>)) != 0 ||
                 pk.blocked[i] != one.blocked[i];
    }
  return wrong;
}

// Rays from `eye` through a grid of points on the rectangle [lo, hi] of the plane z =
// plane_z, row by row: with eye above the rectangle on every axis, every direction has
// the signs (-, -, -), so every run of rays is a coherent packet.
template <class T>
std::vector<Ray<T>> grid_rays(vec3<T> eye, vec3<T> lo, vec3<T> hi, int nx, int ny) {
  std::vector<Ray<T>> rays;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const vec3<T> p(lo.x + (hi.x - lo.x) * (T(i) + T(0.5)) / T(nx),
                      lo.y + (hi.y - lo.y) * (T(j) + T(0.5)) / T(ny), lo.z);
      rays.push_back(make_ray<T>(eye, p - eye));
    }
  return rays;
}

template <class T>
size_t count_hits(const PackedScene<T>& ps, const std::vector<Ray<T>>& rays) {
  std::vector<Hit<T>> h(rays.size());
  cpu::query_intersect(ps, rays.data(), rays.size(), h.data(), 0, nullptr);
  size_t found = 0;
  for (const auto& x : h) found += x.object >= 0;
  return found;
}

}  // namespace

TEST_CASE_TEMPLATE("packets give each ray the single-ray walk's answer: intervals and masks", T,
                   float, double) {
  // The mixed scene (spheres, lone triangles, meshes with normals and uvs, a plane, a
  // duplicated triangle) with a mask on every object: object k's is 1 << (k % 3).
  Scene<T> s = query_test::mixed_scene<T>(5u, 200);
  for (size_t k = 0; k < s.objects.size(); ++k)
    std::visit([&](auto& o) { o.mask = 1u << (k % 3); }, s.objects[k]);
  const PackedScene<T> ps = packed8(s);
  REQUIRE((ps.features & TR_F_MASKS) != 0u);
  REQUIRE((ps.features & TR_F_BVH8) != 0u);
  std::vector<Ray<T>> rays =
      grid_rays<T>(vec3<T>(9, 8, 10), vec3<T>(-7, -7, -7), vec3<T>(6, 5, -7), 122, 106);
  std::mt19937 rng(4u);
  std::uniform_real_distribution<double> f(0.0, 1.0);
  for (size_t i = 0; i < rays.size(); ++i) {
    auto& r = rays[i];
    // t counts lengths of d: the rays reach the far side of the scene at t = 1.
    const T reach = T(1.25) * T(f(rng));
    switch ((i / 64) % 5) {  // one kind of interval for a packet's rays
      case 0:
        break;  // [0, inf)
      case 1:
        r.tmin = reach * T(0.5);
        break;  // from past the front
      case 2:
        r.tmax = reach * T(0.5);
        break;  // short
      case 3:
        r.tmin = reach * T(0.7), r.tmax = r.tmin + T(0.05);
        break;
      default:
        r.tmin = -reach, r.tmax = reach * T(0.6);
        break;  // negative tmin
    }
    r.mask = (i / 3) % 4 == 0 ? 0xffffffffu : 1u << ((i / 7) % 4);  // 8: sees nothing
  }
  // Many rays find something (with short intervals and masks, not most), and most do
  // not.
  const size_t found = count_hits(ps, rays);
  CHECK(found > rays.size() / 6);
  CHECK(found < rays.size() * 9 / 10);
  CHECK(differences(ps, rays, 0.9) == 0);
}

TEST_CASE_TEMPLATE("packets give each ray the single-ray walk's answer: ties", T, float, double) {
  // Rays at every vertex and along every edge of a closed mesh hit two or more faces at
  // the same t; the same mesh again as a later object, and the faces of a mesh twice,
  // tie on every hit; two coincident spheres tie where they are hit.
  Scene<T> s;
  s.materials.push_back({});
  const Mesh<T> ball = query_test::icosphere<T>(2, vec3<T>(0, 0, 0), T(2));
  s.add(ball);  // object 0
  Mesh<T> twice = ball;
  const size_t faces = twice.triangles.size();
  for (size_t i = 0; i < faces; ++i) twice.triangles.push_back(twice.triangles[i]);
  s.add(twice);                                     // object 1: every face twice
  s.add(Sphere<T>{vec3<T>(-4, 1, -1), T(1.5), 0});  // object 2
  s.add(Sphere<T>{vec3<T>(-4, 1, -1), T(1.5), 0});  // object 3, the same sphere
  s.add(ball);                                      // object 4
  const PackedScene<T> ps = packed8(s);
  const vec3<T> eye(12, 14, 16);
  std::vector<Ray<T>> rays;
  std::vector<vec3<T>> targets = ball.vertices;
  for (auto e : query_test::edges(ball)) {
    const vec3<T> a = ball.vertices[e.first], b = ball.vertices[e.second];
    targets.push_back((a + b) * T(0.5));
    targets.push_back(a + (b - a) * T(0.25));
  }
  for (const auto& p : targets) rays.push_back(make_ray<T>(eye, p - eye));  // t = 1 at p
  for (const auto& r : grid_rays<T>(eye, vec3<T>(-6, -1, -1), vec3<T>(-2, 3, -1), 24, 24))
    rays.push_back(r);
  // Intervals that end or start at exactly the tie: tmax = 1 and tmin = 1 at the targets.
  const size_t n_targets = targets.size();
  for (size_t i = 0; i < n_targets; ++i) {
    Ray<T> r = rays[i];
    r.tmax = T(1);
    rays.push_back(r);
    r.tmin = T(1);
    r.tmax = T(INFINITY);
    rays.push_back(r);
  }
  std::vector<Hit<T>> h(rays.size());
  cpu::query_intersect(ps, rays.data(), rays.size(), h.data(), 0, nullptr);
  size_t on_ball = 0, on_spheres = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    on_ball += h[i].object == 0;
    on_spheres += h[i].object == 2;
    CHECK(h[i].object != 1);  // the lower object wins every tie
    CHECK(h[i].object != 3);
    CHECK(h[i].object != 4);
  }
  CHECK(on_ball > n_targets);
  CHECK(on_spheres > 200);
  CHECK(differences(ps, rays, 0.9) == 0);
}

TEST_CASE_TEMPLATE("each hit's barycentrics belong to the face it reports, in every walk", T, float,
                   double) {
  // The walks keep the (u, v) of the test that found the nearest hit, and a tie that
  // goes to another face takes that face's. Object 2 is object 0's mesh with each
  // triangle's corners rotated, (p1, p2, p0): the same surface, found at the same t on
  // most rays, where object 0 wins the tie, but with other barycentrics. Rays at the
  // vertices and edges tie between faces of one mesh too. The point
  // (1 - u - v) p0 + u p1 + v p2 from the reported face's own corners must be where
  // the ray is at t; another face's (u, v) names another point of the triangle, or of
  // its neighbour: an edge length (about 0.6) away. Tolerance: a few roundings of
  // coordinates up to about 30 (the eye's distance), 256 ulps of 30.
  Scene<T> s;
  s.materials.push_back({});
  const Mesh<T> ball = query_test::icosphere<T>(2, vec3<T>(0, 0, 0), T(2));
  Mesh<T> rotated = ball;
  for (auto& tri : rotated.triangles) tri = {tri[1], tri[2], tri[0]};
  s.add(ball);                                      // object 0
  s.add(Sphere<T>{vec3<T>(-4, 1, -1), T(1.5), 0});  // object 1
  s.add(rotated);                                   // object 2
  const Mesh<T>* meshes[3] = {&ball, nullptr, &rotated};
  const PackedScene<T> ps = packed8(s);
  const vec3<T> eye(12, 14, 16);
  std::vector<vec3<T>> targets = ball.vertices;
  for (auto e : query_test::edges(ball)) {
    const vec3<T> a = ball.vertices[e.first], b = ball.vertices[e.second];
    targets.push_back((a + b) * T(0.5));
    targets.push_back(a + (b - a) * T(0.25));
  }
  std::vector<Ray<T>> rays;
  for (const auto& p : targets) rays.push_back(make_ray<T>(eye, p - eye));
  for (const auto& r : grid_rays<T>(eye, vec3<T>(-6, -3, -1), vec3<T>(3, 3, -1), 32, 32))
    rays.push_back(r);
  const T tolerance = T(256) * std::numeric_limits<T>::epsilon() * T(30);
  for (cpu::QueryWalk walk : {cpu::QueryWalk::RayByRay, cpu::QueryWalk::Packets,
                              cpu::QueryWalk::PacketsInOrder, cpu::QueryWalk::PacketsByOctant}) {
    CAPTURE(static_cast<int>(walk));
    std::vector<Hit<T>> h(rays.size());
    cpu::query_intersect(ps, rays.data(), rays.size(), h.data(), 0, nullptr, walk);
    size_t on_mesh[3] = {0, 0, 0}, off_face = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      if (h[i].object != 0 && h[i].object != 2) continue;
      ++on_mesh[h[i].object];
      const Mesh<T>& m = *meshes[h[i].object];
      const auto& tri = m.triangles[size_t(h[i].primitive)];
      const vec3<T> p = m.vertices[tri[0]] * (T(1) - h[i].u - h[i].v) +
                        m.vertices[tri[1]] * h[i].u + m.vertices[tri[2]] * h[i].v;
      const vec3<T> at = vec3<T>(rays[i].ox, rays[i].oy, rays[i].oz) +
                         vec3<T>(rays[i].dx, rays[i].dy, rays[i].dz) * h[i].t;
      off_face += glm::length(p - at) > tolerance;
    }
    CHECK(on_mesh[0] >= targets.size());  // object 0 wins most ties
    CHECK(off_face == 0);
  }
}

TEST_CASE_TEMPLATE("packets give each ray the single-ray walk's answer: from inside spheres", T,
                   float, double) {
  // Origins inside spheres: the hit is where the ray leaves, or with tmin past that, the
  // next sphere; tmin inside a sphere entered earlier gives its far side.
  Scene<T> s;
  s.materials.push_back({});
  std::mt19937 rng(12u);
  std::uniform_real_distribution<double> u(-4.0, 4.0), rad(0.3, 1.2);
  for (int i = 0; i < 150; ++i) s.add(Sphere<T>{query_test::draw3<T>(u, rng), T(rad(rng)), 0});
  s.add(Sphere<T>{vec3<T>(0, 0, 0), T(1), 0});
  const PackedScene<T> ps = packed8(s);
  std::vector<Ray<T>> rays;
  std::uniform_real_distribution<double> small(0.05, 0.5), jitter(-0.2, 0.2);
  for (int i = 0; i < 4000; ++i) {
    // From near the centre of the last sphere, directions with signs (+, +, -).
    const vec3<T> o = query_test::draw3<T>(jitter, rng);
    const vec3<T> d(T(small(rng)), T(small(rng)), -T(small(rng)));
    T tmin = i % 3 == 0 ? T(0) : T(small(rng)) * T(i % 3 * 4);
    rays.push_back(make_ray<T>(o, d, tmin));
  }
  const size_t found = count_hits(ps, rays);
  CHECK(found > rays.size() / 2);
  CHECK(differences(ps, rays, 0.9) == 0);
}

TEST_CASE_TEMPLATE("packets give each ray the single-ray walk's answer: bad rays among good ones",
                   T, float, double) {
  // Every seventh ray bad (each kind in turn); in a second batch also one ray in every
  // three packets with its direction's sign flipped on one axis (its packet then goes
  // ray by ray): the good rays of a packet keep their answers, the bad ones are misses.
  const Scene<T> s = query_test::mixed_scene<T>(8u, 100);
  const PackedScene<T> ps = packed8(s);
  std::vector<Ray<T>> rays =
      grid_rays<T>(vec3<T>(-9, 9, 11), vec3<T>(-5, -6, -6), vec3<T>(6, 5, -6), 47, 47);
  // Every direction has the signs (+, -, -).
  const T inf = std::numeric_limits<T>::infinity(), nan = std::numeric_limits<T>::quiet_NaN();
  for (size_t i = 0; i < rays.size(); i += 7) {
    auto& r = rays[i];
    switch ((i / 7) % 8) {
      case 0:
        r.dx = r.dy = r.dz = T(0);
        break;
      case 1:
        r.dy = nan;
        break;
      case 2:
        r.dz = -inf;
        break;
      case 3:
        r.ox = nan;
        break;
      case 4:
        r.tmin = T(3), r.tmax = T(2);
        break;
      case 5:
        r.tmax = T(-1), r.tmin = T(-2);
        break;
      case 6:
        r.tmin = nan;
        break;
      default:
        r.tmax = nan;
        break;
    }
  }
  const size_t n_bad = (rays.size() + 6) / 7;
  std::vector<Ray<T>> mixed = rays;
  for (size_t i = 5; i < mixed.size(); i += 3 * 64 + 1) mixed[i].dz = -mixed[i].dz;
  std::vector<Hit<T>> h(rays.size());
  std::vector<uint8_t> blocked(rays.size());
  cpu::query_intersect(ps, rays.data(), rays.size(), h.data(), 0, nullptr);
  cpu::query_occluded(ps, rays.data(), rays.size(), blocked.data());
  for (size_t i = 0; i < rays.size(); i += 7) {
    CHECK(h[i].object == -1);
    CHECK(blocked[i] == 0);
  }
  CHECK(count_hits(ps, rays) > rays.size() / 4);
  // Of the good rays, nine in ten go through the packet walk; with the flipped rays
  // somewhat fewer.
  const double good = double(rays.size() - n_bad) / double(rays.size());
  CHECK(differences(ps, rays, 0.9 * good) == 0);
  CHECK(differences(ps, mixed, 0.6 * good) == 0);
}

TEST_CASE_TEMPLATE("the default walk takes narrow packets as one and fanned rays one by one", T,
                   float, double) {
  const PackedScene<T> ps = packed8(query_test::mixed_scene<T>(5u, 200));
  // A camera's neighbouring rays: a 64 x 16 grid over a small patch, all (-, -, -).
  const std::vector<Ray<T>> narrow =
      grid_rays<T>(vec3<T>(9, 8, 10), vec3<T>(-1, -1, -7), vec3<T>(0, 0, -7), 64, 16);
  // Rays of the same octant fanned out from four points, 256 from each, as ambient
  // occlusion casts them.
  std::vector<Ray<T>> fanned;
  std::mt19937 rng(11u);
  std::uniform_real_distribution<double> f(0.05, 1.0);
  for (const vec3<T> eye :
       {vec3<T>(9, 8, 10), vec3<T>(8, 9, 9), vec3<T>(10, 7, 8), vec3<T>(7, 7, 11)})
    for (int k = 0; k < 256; ++k)
      fanned.push_back(make_ray<T>(eye, vec3<T>(T(-f(rng)), T(-f(rng)), T(-f(rng)))));
  CHECK(count_hits(ps, narrow) > narrow.size() / 2);
  CHECK(count_hits(ps, fanned) > fanned.size() / 10);
  CHECK(answers(ps, narrow, cpu::QueryWalk::Packets, narrow.size()).walked == 2 * narrow.size());
  CHECK(answers(ps, fanned, cpu::QueryWalk::Packets, fanned.size()).walked == 0);
  CHECK(answers(ps, fanned, cpu::QueryWalk::PacketsByOctant, fanned.size()).walked ==
        2 * fanned.size());
  // Whichever way they go, the answers are the single-ray walk's.
  CHECK(differences(ps, narrow, 0.9) == 0);
  CHECK(differences(ps, fanned, 0.9) == 0);
}

TEST_CASE_TEMPLATE("a run fans out where most neighbouring rays point apart", T, float, double) {
  using K = typename device::Code<T>::template Kernel<TR_F_ALL>;
  // A camera's neighbouring rays, and a LiDAR's beams from one point: close.
  const std::vector<Ray<T>> camera =
      grid_rays<T>(vec3<T>(9, 8, 10), vec3<T>(-7, -7, -7), vec3<T>(6, 5, -7), 64, 4);
  CHECK(K::tr_query_run_fanned(camera.data(), 256) == 0);
  CHECK(K::tr_query_run_fanned(camera.data(), 2) == 0);
  std::vector<Ray<T>> lidar;
  for (int k = 0; k < 256; ++k) {
    const double a = 0.01 * k;
    lidar.push_back(make_ray<T>(vec3<T>(1, 2, 3), vec3<T>(T(std::cos(a)), T(std::sin(a)), T(0.1))));
  }
  CHECK(K::tr_query_run_fanned(lidar.data(), 256) == 0);
  // Ambient occlusion's hemispheres from a few points, and one random bounce per point.
  std::mt19937 rng(5u);
  std::uniform_real_distribution<double> f(-1.0, 1.0);
  std::vector<Ray<T>> ao, diffuse;
  for (int k = 0; k < 256; ++k) {
    const vec3<T> d(T(f(rng)), T(f(rng)), T(0.05 + std::fabs(f(rng))));
    ao.push_back(make_ray<T>(vec3<T>(T(k / 16), 0, 0), d));
    diffuse.push_back(make_ray<T>(vec3<T>(T(k), T(2 * k), 0), d));
  }
  CHECK(K::tr_query_run_fanned(ao.data(), 256) == 1);
  CHECK(K::tr_query_run_fanned(diffuse.data(), 256) == 1);
  CHECK(K::tr_query_run_fanned(diffuse.data(), 37) == 1);
  // Sixteen pairs, evenly over the run, decide: more than half of them close, not fanned.
  std::vector<Ray<T>> mixed = camera;
  for (int k = 200; k < 256; ++k) mixed[k] = ao[k];  // 12 of 16 pairs close
  CHECK(K::tr_query_run_fanned(mixed.data(), 256) == 0);
  mixed = camera;
  for (int k = 60; k < 256; ++k) mixed[k] = ao[k];  // 3 of 16 close
  CHECK(K::tr_query_run_fanned(mixed.data(), 256) == 1);
  // One ray goes alone.
  CHECK(K::tr_query_run_fanned(camera.data(), 1) == 1);
}
