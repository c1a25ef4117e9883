// Each Blinn-Phong term against a hand-computed value, shadows, and the exact-op pow.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <initializer_list>
#include <limits>

#include "device/device_test_util.hpp"

using test::Code;
using test::K;
using test::vec3;

namespace {

// A one-light scene for tr_shade: a unit material, optional blocker sphere.
template <class T>
struct ShadeFixture {
  typename Code<T>::Params params{};
  // color (0.5, 0.25, 1), ka 0.1, kd 0.5, ks 0.25, shininess 10, opaque, no texture.
  typename Code<T>::Material material{T(0.5), T(0.25), T(1), T(0.1), T(0.5), T(0.25), T(10), T(0),
                                      T(0),   T(1.5),  T(0), T(0),   T(0),   -1,      0};
  typename Code<T>::Light light{};
  typename Code<T>::Sphere blocker{};
  typename Code<T>::SceneRef ref{};

  ShadeFixture(vec3<T> light_pos, T intensity, unsigned features) {
    light.px = light_pos.x, light.py = light_pos.y, light.pz = light_pos.z;
    light.r = light.g = light.b = intensity;
    params.n_lights = 1;
    params.features = static_cast<int>(features);
    ref.params = &params;
    ref.materials = &material;
    ref.lights = &light;
    ref.spheres = &blocker;
  }
  void add_blocker(vec3<T> c, T r) {
    blocker = {c.x, c.y, c.z, r, 0, 1, 0, 0};
    params.n_spheres = 1;
  }
  vec3<T> shade() {
    auto hit = test::no_hit<T>();
    hit.t = 1;
    hit.p = vec3<T>(0, 0, 0);
    hit.n = vec3<T>(0, 0, 1);
    hit.perr = vec3<T>(0, 0, 0);
    hit.ns = hit.n;
    hit.shadow_p = hit.p;
    hit.shadow_perr = hit.perr;
    hit.material = 0;
    return K<T>::tr_shade(&ref, &hit, vec3<T>(0, 0, -1), 0u);
  }
};

constexpr unsigned kAllTerms = TR_F_AMBIENT | TR_F_DIFFUSE | TR_F_SPECULAR;

}  // namespace

// Light at (2, 0, 2), intensity 8: d^2 = 8 so E = 1; l = (1,0,1)/sqrt2, n.l = 1/sqrt2;
// v = (0,0,1), h = normalize(l + v) so n.h = cos(22.5 deg). Material C = (0.5, 0.25, 1),
// ka 0.1, kd 0.5, ks 0.25, shininess 10.
TEST_CASE_TEMPLATE("Blinn-Phong terms match the hand-computed values", T, float, double) {
  const double n_dot_l = 1.0 / std::sqrt(2.0);
  const double n_dot_h = std::cos(M_PI / 8.0);
  const double C[3] = {0.5, 0.25, 1.0};
  const double tol = std::is_same<T, float>::value ? 2e-6 : 1e-14;
  SUBCASE("ambient only") {
    ShadeFixture<T> f({2, 0, 2}, 8, TR_F_AMBIENT);
    vec3<T> c = f.shade();
    for (int i = 0; i < 3; ++i) CHECK(c[i] == doctest::Approx(0.1 * C[i]).epsilon(tol));
  }
  SUBCASE("diffuse only") {
    ShadeFixture<T> f({2, 0, 2}, 8, TR_F_DIFFUSE);
    vec3<T> c = f.shade();
    for (int i = 0; i < 3; ++i) CHECK(c[i] == doctest::Approx(0.5 * C[i] * n_dot_l).epsilon(tol));
  }
  SUBCASE("specular only") {
    ShadeFixture<T> f({2, 0, 2}, 8, TR_F_SPECULAR);
    vec3<T> c = f.shade();
    for (int i = 0; i < 3; ++i)
      CHECK(c[i] == doctest::Approx(0.25 * std::pow(n_dot_h, 10.0)).epsilon(tol * 8));
  }
  SUBCASE("all three add up") {
    ShadeFixture<T> f({2, 0, 2}, 8, kAllTerms);
    vec3<T> c = f.shade();
    for (int i = 0; i < 3; ++i)
      CHECK(c[i] ==
            doctest::Approx(0.1 * C[i] + 0.5 * C[i] * n_dot_l + 0.25 * std::pow(n_dot_h, 10.0))
                .epsilon(tol * 8));
  }
  SUBCASE("inverse-square falloff: twice as far, a quarter of the light") {
    ShadeFixture<T> f({4, 0, 4}, 8, TR_F_AMBIENT);
    vec3<T> c = f.shade();
    CHECK(c[0] == doctest::Approx(0.1 * 0.5 / 4).epsilon(tol));
  }
}

TEST_CASE_TEMPLATE("a blocked light leaves the ambient term only, shadows off ignore it", T, float,
                   double) {
  ShadeFixture<T> f({2, 0, 2}, 8, kAllTerms | TR_F_SHADOWS);
  f.add_blocker({1, 0, 1}, T(0.25));
  vec3<T> shadowed = f.shade();
  CHECK(shadowed[0] == doctest::Approx(0.1 * 0.5));
  CHECK(shadowed[2] == doctest::Approx(0.1 * 1.0));
  f.params.features = static_cast<int>(kAllTerms);  // shadow rays switched off
  vec3<T> lit = f.shade();
  CHECK(lit[0] > shadowed[0] * 5);
}

TEST_CASE_TEMPLATE("light behind the surface gives the ambient term only", T, float, double) {
  ShadeFixture<T> f({0, 0, -2}, 4, kAllTerms | TR_F_SHADOWS);
  vec3<T> c = f.shade();
  // The normal is turned toward the viewer (+z); the light is at -z.
  CHECK(c[1] == doctest::Approx(0.1 * 0.25));
}

TEST_CASE_TEMPLATE("tr_pow_unit agrees with pow within its error bound, any real exponent", T,
                   float, double) {
  const T eps = std::numeric_limits<T>::epsilon();
  const T xs[] = {T(0), T(1e-3), T(0.25), T(0.5), T(0.9), T(0.999), T(1)};
  const T ps[] = {T(0), T(0.5), T(1), T(2.5), T(10), T(65), T(65.3), T(1000.75), T(1e4)};
  for (T x : xs)
    for (T p : ps) {
      long double want = std::pow(static_cast<long double>(x), static_cast<long double>(p));
      T got = K<T>::tr_pow_unit(x, p);
      CAPTURE(x);
      CAPTURE(p);
      REQUIRE(std::isfinite(got));
      if (want < std::numeric_limits<T>::min()) {
        CHECK(got <= std::numeric_limits<T>::min() * 4);  // underflow: zero or subnormal
      } else {
        // Any multiplication chain for x^n rounds n - 1 times in the worst case, so the
        // relative error is bounded by about (p + digits) u; the root chain adds one
        // rounding per binary digit of the fraction.
        long double rel = std::fabs(static_cast<long double>(got) - want) / want;
        CHECK(rel <= (static_cast<long double>(p) + 64) * static_cast<long double>(eps));
      }
    }
  CHECK(K<T>::tr_pow_unit(T(0), T(0)) == T(1));  // max(0, n.h)^0 = 1
}

TEST_CASE_TEMPLATE("a block's specular powers are tr_pow_unit's, to the bit", T, float, double) {
  // tr_specular_powers runs tr_pow_unit's steps for all hits at once where they share a
  // whole exponent; every result must be the one tr_pow_unit gives the hit alone, for
  // shared exponents, fractional and huge ones (hit by hit), and mixed materials.
  typename Code<T>::Material materials[2] = {};
  typename Code<T>::Params params{};
  typename Code<T>::SceneRef ref{};
  ref.params = &params;
  ref.materials = materials;
  const T xs[] = {
      T(0),   T(1),     std::numeric_limits<T>::denorm_min(),     T(1e-30), T(0.125), T(0.5),
      T(0.9), T(0.999), T(1) - std::numeric_limits<T>::epsilon(), T(0.7071)};
  const T shininess[][2] = {
      {0, 0},       {1, 1},     {2, 2},   {65, 65}, {1000, 1000}, {16777215, 16777215},
      {65.3, 65.3}, {3e7, 3e7}, {65, 64}, {10, 2.5}};
  for (const auto& e : shininess)
    for (int n : {1, 7, TR_PACKET_MAX}) {
      materials[0].shininess = e[0];
      materials[1].shininess = e[1];
      typename Code<T>::Hit hits[TR_PACKET_MAX];
      int specular[TR_PACKET_MAX];
      T n_dot_h[TR_PACKET_MAX], power[TR_PACKET_MAX];
      for (int r = 0; r < n; ++r) {
        hits[r] = test::no_hit<T>();
        hits[r].material = r % 3 == 2 ? 1 : 0;
        specular[r] = r % 5 != 3;  // some hits without a specular term
        n_dot_h[r] = xs[r % 10];
        power[r] = T(-1);
      }
      K<T>::tr_specular_powers(&ref, hits, specular, n_dot_h, n, power);
      for (int r = 0; r < n; ++r) {
        if (!specular[r]) continue;
        const T want = K<T>::tr_pow_unit(n_dot_h[r], materials[hits[r].material].shininess);
        CAPTURE(e[0]);
        CAPTURE(e[1]);
        CAPTURE(n);
        CAPTURE(r);
        CHECK(std::memcmp(&power[r], &want, sizeof(T)) == 0);
      }
    }
}
