// Ray/sphere, ray/triangle and ray/plane against analytic answers, in float and double:
// hit, miss, tangent, ray starting inside, object behind the ray, ray parallel to a plane.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "device/device_test_util.hpp"

using test::Code;
using test::K;
using test::make_ray;
using test::vec3;

namespace {

template <class T>
typename Code<T>::Sphere sphere(T x, T y, T z, T r) {
  return {x, y, z, r, 0, 7, 0, 0};
}

template <class T>
typename Code<T>::Triangle triangle(vec3<T> a, vec3<T> b, vec3<T> c) {
  return {a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z, 0, 3};
}

template <class T>
typename Code<T>::Plane plane(vec3<T> p, vec3<T> n) {
  return {p.x, p.y, p.z, n.x, n.y, n.z, 0, 5};
}

template <class T>
T inf() {
  return std::numeric_limits<T>::infinity();
}

// Tolerance of a computed distance: a few ulps of the value (the formulas round a
// handful of times; exact answers here are small integers).
template <class T>
void check_close(T got, T want) {
  CHECK(std::fabs(got - want) <= T(8) * std::numeric_limits<T>::epsilon() * std::fabs(want));
}

}  // namespace

TEST_CASE_TEMPLATE("sphere: hit from outside gives the near root, outward normal", T, float,
                   double) {
  auto s = sphere<T>(0, 0, -5, 1);
  auto hit = test::no_hit<T>();
  REQUIRE(K<T>::tr_intersect_sphere(&s, make_ray<T>({0, 0, 0}, {0, 0, -1}), inf<T>(), &hit));
  check_close(hit.t, T(4));
  CHECK(hit.n.z == doctest::Approx(1.0));
  CHECK(hit.p.z == doctest::Approx(-4.0));
  CHECK(hit.object == 7);
  // The hit point lies within its own error bound of the sphere.
  T dist = std::sqrt(hit.p.x * hit.p.x + hit.p.y * hit.p.y + (hit.p.z + 5) * (hit.p.z + 5));
  CHECK(std::fabs(dist - 1) <= hit.perr.z + std::numeric_limits<T>::epsilon() * 8);
}

TEST_CASE_TEMPLATE("sphere: miss, behind, beyond tmax", T, float, double) {
  auto s = sphere<T>(0, 0, -5, 1);
  auto hit = test::no_hit<T>();
  CHECK_FALSE(K<T>::tr_intersect_sphere(&s, make_ray<T>({0, 0, 0}, {0, 1, 0}), inf<T>(), &hit));
  CHECK_FALSE(K<T>::tr_intersect_sphere(&s, make_ray<T>({0, 0, 0}, {0, 0, 1}), inf<T>(), &hit));
  CHECK_FALSE(K<T>::tr_intersect_sphere(&s, make_ray<T>({0, 0, 0}, {0, 0, -1}), T(3.5), &hit));
  // Offset sideways by more than the radius.
  CHECK_FALSE(
      K<T>::tr_intersect_sphere(&s, make_ray<T>({T(1.001), 0, 0}, {0, 0, -1}), inf<T>(), &hit));
  CHECK(hit.object == -1);  // untouched on a miss
}

TEST_CASE_TEMPLATE("sphere: tangent ray touches once", T, float, double) {
  auto s = sphere<T>(0, 0, -5, 1);
  auto hit = test::no_hit<T>();
  REQUIRE(K<T>::tr_intersect_sphere(&s, make_ray<T>({1, 0, 0}, {0, 0, -1}), inf<T>(), &hit));
  check_close(hit.t, T(5));
  CHECK(hit.n.x == doctest::Approx(1.0));
}

TEST_CASE_TEMPLATE("sphere: ray starting inside hits the far side", T, float, double) {
  auto s = sphere<T>(0, 0, -5, 2);
  auto hit = test::no_hit<T>();
  REQUIRE(K<T>::tr_intersect_sphere(&s, make_ray<T>({0, 0, -5}, {0, 0, -1}), inf<T>(), &hit));
  check_close(hit.t, T(2));
  CHECK(hit.n.z == doctest::Approx(-1.0));  // outward, the shading turns it to the ray
}

TEST_CASE_TEMPLATE("triangle: hit inside, barycentric point, unit normal", T, float, double) {
  auto tri = triangle<T>({-1, -1, -3}, {1, -1, -3}, {0, 1, -3});
  auto hit = test::no_hit<T>();
  REQUIRE(K<T>::tr_intersect_triangle(&tri, make_ray<T>({0, 0, 0}, {0, 0, -1}), inf<T>(), &hit));
  check_close(hit.t, T(3));
  CHECK(hit.p.z == doctest::Approx(-3.0));
  CHECK(std::fabs(hit.n.z) == doctest::Approx(1.0));
  CHECK(hit.object == 3);
}

TEST_CASE_TEMPLATE("triangle: miss outside, behind, parallel, degenerate", T, float, double) {
  auto tri = triangle<T>({-1, -1, -3}, {1, -1, -3}, {0, 1, -3});
  auto hit = test::no_hit<T>();
  vec3<T> outside = glm::normalize(vec3<T>(2, 0, -3));
  CHECK_FALSE(K<T>::tr_intersect_triangle(&tri, make_ray<T>({0, 0, 0}, outside), inf<T>(), &hit));
  CHECK_FALSE(K<T>::tr_intersect_triangle(&tri, make_ray<T>({0, 0, 0}, {0, 0, 1}), inf<T>(), &hit));
  // In the triangle's plane, through it edge-on.
  CHECK_FALSE(
      K<T>::tr_intersect_triangle(&tri, make_ray<T>({-5, 0, -3}, {1, 0, 0}), inf<T>(), &hit));
  // Beyond tmax.
  CHECK_FALSE(K<T>::tr_intersect_triangle(&tri, make_ray<T>({0, 0, 0}, {0, 0, -1}), T(2.5), &hit));
  // Zero area: collinear vertices are never hit.
  auto line = triangle<T>({-1, 0, -3}, {0, 0, -3}, {1, 0, -3});
  CHECK_FALSE(
      K<T>::tr_intersect_triangle(&line, make_ray<T>({0, 0, 0}, {0, 0, -1}), inf<T>(), &hit));
  CHECK(hit.object == -1);
}

TEST_CASE_TEMPLATE("triangle: a ray through a shared edge or vertex hits one of the neighbours", T,
                   float, double) {
  // Two triangles sharing the diagonal of a quad; rays through points on the diagonal
  // and through the shared vertices must never slip between them (Woop et al. 2013).
  vec3<T> a(T(-1.3), T(-0.7), -3), b(T(1.1), T(-0.9), T(-3.2)), c(T(0.9), T(1.3), T(-2.9)),
      d(T(-1.2), T(1.1), T(-3.1));
  auto t1 = triangle<T>(a, b, c);
  auto t2 = triangle<T>(a, c, d);
  int misses = 0;
  for (int i = 1; i < 1000; ++i) {  // the quad's corners are convex: a ray may pass outside
    T s = T(i) / T(1000);
    vec3<T> target = a + (c - a) * s;
    vec3<T> dir = glm::normalize(target - vec3<T>(T(0.1), T(0.2), 0));
    auto ray = make_ray<T>({T(0.1), T(0.2), 0}, dir);
    auto hit = test::no_hit<T>();
    bool h1 = K<T>::tr_intersect_triangle(&t1, ray, inf<T>(), &hit);
    bool h2 = K<T>::tr_intersect_triangle(&t2, ray, inf<T>(), &hit);
    if (!h1 && !h2) ++misses;
  }
  CHECK(misses == 0);
}

TEST_CASE_TEMPLATE("triangle: rays through the shared vertex of a closed fan never slip through", T,
                   float, double) {
  // Eight triangles around a center vertex off the origin; rays from many origins are
  // aimed exactly at the center: with watertight edge functions one triangle must hit.
  const T pi = T(3.14159265358979323846);
  vec3<T> center(T(3.7), T(-2.1), T(-10.3));
  std::vector<typename Code<T>::Triangle> fan;
  for (int k = 0; k < 8; ++k) {
    T a0 = T(2) * pi * T(k) / T(8), a1 = T(2) * pi * T(k + 1) / T(8);
    fan.push_back(
        triangle<T>(center, center + vec3<T>(std::cos(a0), std::sin(a0), T(0.1) * k),
                    center + vec3<T>(std::cos(a1), std::sin(a1), T(0.1) * (k + 1) * (k < 7))));
  }
  int misses = 0;
  for (int i = 0; i < 200; ++i) {
    vec3<T> origin(T(-3) + T(0.031) * i, T(1.7) - T(0.017) * i, T(0.5) * T(i % 7));
    auto ray = make_ray<T>(origin, glm::normalize(center - origin));
    bool any = false;
    for (const auto& tri : fan) {
      auto hit = test::no_hit<T>();
      any = any || K<T>::tr_intersect_triangle(&tri, ray, inf<T>(), &hit);
    }
    if (!any) ++misses;
  }
  CHECK(misses == 0);
}

TEST_CASE_TEMPLATE("plane: hit, parallel, behind, ray lying in the plane", T, float, double) {
  auto pl = plane<T>({0, -1, 0}, {0, 1, 0});
  auto hit = test::no_hit<T>();
  REQUIRE(K<T>::tr_intersect_plane(&pl, make_ray<T>({0, 0, 0}, {0, -1, 0}), inf<T>(), &hit));
  check_close(hit.t, T(1));
  CHECK(hit.p.y == T(-1));  // projected exactly onto the plane
  CHECK(hit.n.y == T(1));
  CHECK(hit.object == 5);
  hit = test::no_hit<T>();
  CHECK_FALSE(K<T>::tr_intersect_plane(&pl, make_ray<T>({0, 0, 0}, {1, 0, 0}), inf<T>(), &hit));
  CHECK_FALSE(K<T>::tr_intersect_plane(&pl, make_ray<T>({0, 0, 0}, {0, 1, 0}), inf<T>(), &hit));
  CHECK_FALSE(K<T>::tr_intersect_plane(&pl, make_ray<T>({0, -1, 0}, {1, 0, 0}), inf<T>(), &hit));
  CHECK(hit.object == -1);
  // Oblique hit: t = 1 / cos(angle).
  vec3<T> d = glm::normalize(vec3<T>(1, -1, 0));
  REQUIRE(K<T>::tr_intersect_plane(&pl, make_ray<T>({0, 0, 0}, d), inf<T>(), &hit));
  CHECK(hit.t == doctest::Approx(std::sqrt(2.0)).epsilon(1e-6));
}

TEST_CASE_TEMPLATE("ray offset moves the origin off the surface, to the side the ray leaves", T,
                   float, double) {
  auto s = sphere<T>(T(1000), 0, T(-5), 1);
  auto hit = test::no_hit<T>();
  REQUIRE(K<T>::tr_intersect_sphere(&s, make_ray<T>({T(1000), 0, 0}, {0, 0, -1}), inf<T>(), &hit));
  vec3<T> out = K<T>::tr_offset_ray_origin(hit.p, hit.perr, hit.n, hit.n);
  vec3<T> in = K<T>::tr_offset_ray_origin(hit.p, hit.perr, hit.n, -hit.n);
  CHECK(out.z > hit.p.z);
  CHECK(in.z < hit.p.z);
  // A ray leaving outward from the offset origin does not hit the sphere again.
  auto again = test::no_hit<T>();
  CHECK_FALSE(K<T>::tr_intersect_sphere(&s, make_ray<T>(out, hit.n), inf<T>(), &again));
}

// The moved origin must lie at least as far off the surface as p + o, the offset
// |n| . perr along n, in exact arithmetic: rounding p + o can fall back toward the
// surface, and the origin's rule (ray_offset.h) grows o so that it never does. Checked
// on hits of every magnitude, in long double: exact for float, and for double exact
// where p and the origin are close, elsewhere off by far less than the margin tested.
TEST_CASE_TEMPLATE("ray offset: the rounded origin is never nearer the surface than p + o", T,
                   float, double) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), expo(-30.0, 30.0);
  const T u = std::numeric_limits<T>::epsilon() / 2;
  int moved = 0;
  for (int i = 0; i < 200000; ++i) {
    vec3<T> p(T(unit(rng) * std::exp2(expo(rng))), T(unit(rng) * std::exp2(expo(rng))),
              T(unit(rng) * std::exp2(expo(rng))));
    vec3<T> n = glm::normalize(vec3<T>(T(unit(rng)), T(unit(rng)), T(unit(rng))));
    // perr as the hit records make it: a few units of roundoff of |p|.
    vec3<T> perr = glm::abs(p) * (T(7) * u);
    vec3<T> w(T(unit(rng)), T(unit(rng)), T(unit(rng)));
    vec3<T> po = K<T>::tr_offset_ray_origin(p, perr, n, w);
    T dist = glm::dot(glm::abs(n), perr);
    vec3<T> o = n * dist;
    if (glm::dot(w, n) < T(0)) o = -o;
    for (int k = 0; k < 3; ++k) {
      if (o[k] == T(0)) {
        CHECK(po[k] == p[k]);
        continue;
      }
      long double moved_by = (static_cast<long double>(po[k]) - p[k]) * (o[k] > 0 ? 1 : -1);
      if (!(moved_by >= std::fabs(static_cast<long double>(o[k])))) {
        FAIL_CHECK("component " << k << " of p = " << p[k] << " moved " << moved_by
                                << " for an offset of " << o[k]);
        break;
      }
      ++moved;
    }
  }
  CHECK(moved > 500000);
}
