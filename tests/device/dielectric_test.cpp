// Glass (device/dielectric.h, trace.h tr_path_split): Fresnel reflectance against its
// closed forms, Snell's law, total internal reflection, the exact-op exponential, and
// how a path splits at a transmissive surface.
#include <doctest/doctest.h>

#include <cmath>
#include <initializer_list>
#include <limits>

#include "device/device_test_util.hpp"

using test::Code;
using test::K;
using test::vec3;

namespace {

template <class T>
T tolerance() {
  return std::is_same<T, float>::value ? T(2e-6) : T(1e-14);
}

// A scene of one transmissive material, for tr_path_split.
template <class T>
struct GlassFixture {
  typename Code<T>::Params params{};
  typename Code<T>::Material material{};
  typename Code<T>::SceneRef ref{};
  typename Code<T>::Hit hit = test::no_hit<T>();

  explicit GlassFixture(T ior, T transmission = T(1)) {
    material.transmission = transmission;
    material.ior = ior;
    material.texture = -1;
    params.features = TR_F_ALL;
    params.max_depth = 8;
    ref.params = &params;
    ref.materials = &material;
    hit.material = 0;
    hit.n = hit.ns = vec3<T>(0, 0, 1);  // the surface z = 0, outside above
    hit.p = hit.shadow_p = vec3<T>(0, 0, 0);
    hit.perr = hit.shadow_perr = vec3<T>(T(1e-6), T(1e-6), T(1e-6));
  }

  // The path of a ray along d arriving at the hit, after the split.
  typename Code<T>::Path split(vec3<T> d, typename Code<T>::RayStack* stack) {
    typename Code<T>::Path path;
    path.ray = test::make_ray<T>(vec3<T>(0, 0, 0) - d, d);
    path.color = vec3<T>(0, 0, 0);
    path.weight = vec3<T>(1, 1, 1);
    path.segments_left = 5;
    stack->n = 0;
    K<T>::tr_path_split(&ref, &path, stack, &hit);
    return path;
  }
};

}  // namespace

TEST_CASE_TEMPLATE("Fresnel reflectance of a dielectric against its closed forms", T, float,
                   double) {
  T cos_t = 0;
  // Normal incidence: ((eta - 1) / (eta + 1))^2, from either side.
  for (T eta : {T(1.5), T(1.33), T(2.4), T(1) / T(1.5)}) {
    CAPTURE(eta);
    T want = (eta - 1) * (eta - 1) / ((eta + 1) * (eta + 1));
    CHECK(std::fabs(K<T>::tr_fresnel_dielectric(T(1), eta, &cos_t) - want) <= tolerance<T>());
    CHECK(cos_t == T(1));
  }
  // The same interface crossed both ways reflects the same share (Stokes relations).
  for (T cos_i : {T(0.99), T(0.8), T(0.5), T(0.2), T(0.05)}) {
    CAPTURE(cos_i);
    T f_in = K<T>::tr_fresnel_dielectric(cos_i, T(1.5), &cos_t);
    T cos_back = 0;
    T f_out = K<T>::tr_fresnel_dielectric(cos_t, T(1) / T(1.5), &cos_back);
    CHECK(std::fabs(f_in - f_out) <= 50 * tolerance<T>());
    CHECK(std::fabs(cos_back - cos_i) <= 50 * tolerance<T>());
    // Snell: sin_i = eta sin_t.
    T sin_i = std::sqrt(1 - cos_i * cos_i), sin_t = std::sqrt(1 - cos_t * cos_t);
    CHECK(std::fabs(sin_i - T(1.5) * sin_t) <= 50 * tolerance<T>());
  }
  // Grazing incidence reflects everything; an index of 1 reflects nothing.
  CHECK(K<T>::tr_fresnel_dielectric(T(0), T(1.5), &cos_t) == doctest::Approx(1));
  CHECK(K<T>::tr_fresnel_dielectric(T(0.6), T(1), &cos_t) <= tolerance<T>());
}

TEST_CASE_TEMPLATE("total internal reflection past the critical angle", T, float, double) {
  // Inside glass of index 1.5 the critical angle is asin(1 / 1.5), 41.81 degrees.
  const T critical = std::asin(T(1) / T(1.5));
  T cos_t = T(-1);
  for (T degrees : {T(42), T(50), T(70), T(89.9)}) {
    T cos_i = std::cos(degrees * T(M_PI / 180));
    CHECK(K<T>::tr_fresnel_dielectric(cos_i, T(1) / T(1.5), &cos_t) == T(1));
    CHECK(cos_t == T(0));
  }
  T just_below = std::cos(critical - T(0.01));
  CHECK(K<T>::tr_fresnel_dielectric(just_below, T(1) / T(1.5), &cos_t) < T(1));
  CHECK(cos_t > T(0));
}

TEST_CASE_TEMPLATE("a path splits at glass: refracted on, reflected pending, none past TIR", T,
                   float, double) {
  GlassFixture<T> glass(T(1.5));
  typename Code<T>::RayStack stack;
  // From outside at 30 degrees: the refracted ray goes on, bent by Snell's law, with
  // weight 1 - F; the mirrored one waits with weight F.
  const T a = T(30 * M_PI / 180);
  vec3<T> d(std::sin(a), 0, -std::cos(a));
  auto path = glass.split(d, &stack);
  T cos_t = 0;
  T f = K<T>::tr_fresnel_dielectric(std::cos(a), T(1.5), &cos_t);
  CHECK(path.segments_left == 5);
  CHECK(path.ray.d.z < 0);  // into the glass
  CHECK(std::fabs(path.ray.d.x - std::sin(a) / T(1.5)) <= 10 * tolerance<T>());
  CHECK(path.ray.o.z < 0);  // the origin offset to the glass side
  CHECK(path.weight.x == T(1) - f);
  REQUIRE(stack.n == 1);
  CHECK(stack.ray[0].weight.y == f);
  CHECK(std::fabs(stack.ray[0].ray.d.z - std::cos(a)) <= 10 * tolerance<T>());
  CHECK(stack.ray[0].ray.o.z > 0);
  CHECK(stack.ray[0].segments_left == 5);
  // From inside at 60 degrees, past the critical angle: only the mirrored ray, with the
  // whole weight, and nothing pending.
  const T b = T(60 * M_PI / 180);
  path = glass.split(vec3<T>(std::sin(b), 0, std::cos(b)), &stack);
  CHECK(stack.n == 0);
  CHECK(path.weight.x == T(1));
  CHECK(path.ray.d.z < 0);  // back into the glass
  CHECK(std::fabs(path.ray.d.z + std::cos(b)) <= 10 * tolerance<T>());
  CHECK(path.ray.o.z < 0);
  // A full stack drops the reflected ray, never the refracted one.
  stack.n = 0;
  typename Code<T>::Path p2;
  p2.ray = test::make_ray<T>(vec3<T>(0, 0, 1), vec3<T>(0, 0, -1));
  p2.weight = vec3<T>(1, 1, 1);
  p2.segments_left = 3;
  stack.n = TR_RAY_STACK;
  K<T>::tr_path_split(&glass.ref, &p2, &stack, &glass.hit);
  CHECK(stack.n == TR_RAY_STACK);
  CHECK(p2.ray.d.z == T(-1));
  // A weight below 2^-10 is not traced: a weak reflection is never pushed.
  GlassFixture<T> faint(T(1.01));
  path = faint.split(vec3<T>(0, 0, -1), &stack);
  CHECK(stack.n == 0);  // F = (0.01 / 2.01)^2, about 2.5e-5
}

TEST_CASE_TEMPLATE("the exact-op exponential", T, float, double) {
  for (double x = -80; x <= 0; x += 0.173) {
    CAPTURE(x);
    T got = K<T>::tr_exp_neg(T(x));
    T want = std::exp(T(x));
    CHECK(std::fabs(got - want) <= 4 * tolerance<T>() * want);
  }
  CHECK(K<T>::tr_exp_neg(T(0)) == T(1));
  CHECK(K<T>::tr_exp_neg(T(-2000)) == T(0));
  CHECK(K<T>::tr_exp_neg(std::numeric_limits<T>::quiet_NaN()) == T(0));
  CHECK(K<T>::tr_exp_neg(-std::numeric_limits<T>::infinity()) == T(0));
}
