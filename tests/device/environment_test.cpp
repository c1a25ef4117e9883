// The environment lookup (device/environment.h) called on the host: its atan2 against
// the C library's, where each direction lands on the image, the rotation and up
// vector, and the poles clamped rather than wrapped; and area light samples
// (device/area_light.h) inside their light, one per stratum.
#include <doctest/doctest.h>

#include <cmath>
#include <vector>

#include <twinray/scene/environment.hpp>

#include "device/device_test_util.hpp"

using namespace test;

TEST_CASE_TEMPLATE("tr_atan2 is within 1.5e-8 rad of atan2 in double, 3.5e-7 in float", T, float,
                   double) {
  // Evaluated in double, Cephes' atanf polynomial is off by about 1e-8 rad (8.1e-9 at
  // worst here); a float evaluation adds float's roundings (2.7e-7 at worst here, an ulp
  // of pi being 2.4e-7). Every quadrant, the axes and the diagonals.
  double worst = 0;
  const double allowed = sizeof(T) == 4 ? 3.5e-7 : 1.5e-8;
  for (int i = -400; i <= 400; ++i) {
    for (int j = -400; j <= 400; j += 7) {
      const T y = T(i) / T(100), x = T(j) / T(100) + T(0.003);
      const double want = std::atan2(double(y), double(x));
      const double got = double(K<T>::tr_atan2(y, x));
      worst = std::max(worst, std::fabs(got - want));
    }
  }
  CAPTURE(worst);
  CHECK(worst <= allowed);
  CHECK(K<T>::tr_atan2(T(0), T(0)) == T(0));
  CHECK(K<T>::tr_atan2(T(1), T(0)) == T(M_PI / 2));
  CHECK(K<T>::tr_atan2(T(0), T(-1)) == T(M_PI));
  CHECK(K<T>::tr_atan2(T(-1), T(0)) == T(-M_PI / 2));
}

namespace {

// A 4 x 2 environment: texel (x, y) holds (x, y, 10) (values above 1: an HDR image), and
// the scene reference that looks it up with the given rotation and up vector.
template <class T>
struct EnvFixture {
  typename Code<T>::Params params{};
  typename Code<T>::Texture texture{4, 2, 0, 0};
  std::vector<T> texels;
  typename Code<T>::SceneRef ref{};

  EnvFixture(T rotate_degrees, vec3<T> up) {
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 4; ++x) texels.insert(texels.end(), {T(x), T(y), T(10)});
    twinray::Environment<T> env;
    env.texture = 0;
    env.up = up;
    const auto frame = env.frame();
    params.environment = 0;
    params.env_right_x = frame.right.x, params.env_right_y = frame.right.y;
    params.env_right_z = frame.right.z;
    params.env_up_x = frame.up.x, params.env_up_y = frame.up.y, params.env_up_z = frame.up.z;
    params.env_forward_x = frame.forward.x, params.env_forward_y = frame.forward.y;
    params.env_forward_z = frame.forward.z;
    params.env_turns = rotate_degrees / T(360);
    params.env_intensity = T(2);
    params.features = TR_F_ENVIRONMENT;
    ref.params = &params;
    ref.textures = &texture;
    ref.texels = texels.data();
  }
  vec3<T> look(vec3<T> d) { return K<T>::tr_miss_rgb(&ref, glm::normalize(d)); }
};

}  // namespace

TEST_CASE_TEMPLATE("directions land on the equirectangular image as documented", T, float, double) {
  EnvFixture<T> env(T(0), vec3<T>(0, 1, 0));
  // Along -z: u = 1/2, the edge between columns 1 and 2 (their mean); v = 1/2, the
  // edge between the rows. Intensity 2 doubles every texel.
  vec3<T> c = env.look(vec3<T>(0, 0, -1));
  CHECK(c.x == doctest::Approx(2 * 1.5));
  CHECK(c.y == doctest::Approx(2 * 0.5));
  CHECK(c.z == doctest::Approx(20));
  // Toward +x: u = 3/4 (column 2.5), so right of the middle; toward -x: column 0.5.
  CHECK(env.look(vec3<T>(1, 0, 0)).x == doctest::Approx(2 * 2.5));
  CHECK(env.look(vec3<T>(-1, 0, 0)).x == doctest::Approx(2 * 0.5));
  // Straight up: the top row (y = 0), clamped, not mixed with the bottom one.
  CHECK(env.look(vec3<T>(0, 1, 0)).y == T(0));
  CHECK(env.look(vec3<T>(0, -1, 0)).y == T(2));
  CHECK(env.look(vec3<T>(0.2, 1, 0.1)).y == T(0));
  // Behind (+z): u = 0 or 1, the wrap between column 3 and column 0.
  CHECK(env.look(vec3<T>(0, 0, 1)).x == doctest::Approx(2 * 1.5));
  CHECK(env.look(vec3<T>(T(0.01), 0, 1)).x > T(2 * 1.5));   // u just below 1: more of column 3
  CHECK(env.look(vec3<T>(T(-0.01), 0, 1)).x < T(2 * 1.5));  // u just above 0: more of column 0
}

TEST_CASE_TEMPLATE("the rotation and the up vector turn the map", T, float, double) {
  // 90 degrees: what was seen along -x is seen along -z.
  EnvFixture<T> plain(T(0), vec3<T>(0, 1, 0));
  EnvFixture<T> turned(T(90), vec3<T>(0, 1, 0));
  CHECK(turned.look(vec3<T>(0, 0, -1)).x == doctest::Approx(plain.look(vec3<T>(-1, 0, 0)).x));
  CHECK(turned.look(vec3<T>(0, 0, -1)).x != doctest::Approx(plain.look(vec3<T>(0, 0, -1)).x));
  // Up -y: the top row is seen toward -y, and -z stays the middle column.
  EnvFixture<T> flipped(T(0), vec3<T>(0, -1, 0));
  CHECK(flipped.look(vec3<T>(0, -1, 0)).y == T(0));
  CHECK(flipped.look(vec3<T>(0, 1, 0)).y == T(2));
  CHECK(flipped.look(vec3<T>(0, 0, -1)).x == doctest::Approx(2 * 1.5));
  // The default frame is exactly +x, +y, -z: the lookup reads the direction unchanged.
  const auto frame = twinray::Environment<T>{}.frame();
  CHECK(frame.right == vec3<T>(1, 0, 0));
  CHECK(frame.up == vec3<T>(0, 1, 0));
  CHECK(frame.forward == vec3<T>(0, 0, -1));
  // An up along z takes forward from +x.
  twinray::Environment<T> z_up;
  z_up.up = vec3<T>(0, 0, 1);
  CHECK(z_up.frame().forward == vec3<T>(1, 0, 0));
}

TEST_CASE("without an environment a miss sees the background color") {
  EnvFixture<float> env(0.0f, vec3<float>(0, 1, 0));
  env.params.environment = -1;
  env.params.bg_r = 0.25f, env.params.bg_g = 0.5f, env.params.bg_b = 0.75f;
  CHECK(env.look(vec3<float>(0, 0, -1)) == vec3<float>(0.25f, 0.5f, 0.75f));
  env.params.environment = 0;
  env.params.features = 0;  // the bit off: the background, whatever the index says
  CHECK(env.look(vec3<float>(0, 0, -1)) == vec3<float>(0.25f, 0.5f, 0.75f));
}

TEST_CASE_TEMPLATE("area light samples lie on the light, one in each of its n x n cells", T, float,
                   double) {
  typename Code<T>::Params params{};
  params.features = TR_F_AREA_LIGHTS;
  typename Code<T>::Light lights[2] = {};
  // A rect from (1, 2, 3) with edges (2, 0, 0) and (0, 0, 4), 3 x 3 samples.
  lights[0].px = T(1), lights[0].py = T(2), lights[0].pz = T(3);
  lights[0].e1x = T(2), lights[0].e2z = T(4);
  lights[0].shape = TR_LIGHT_RECT, lights[0].samples = 3;
  // A sphere of radius 0.5 at the origin, 4 x 4 samples.
  lights[1].radius = T(0.5), lights[1].shape = TR_LIGHT_SPHERE, lights[1].samples = 4;
  typename Code<T>::SceneRef ref{};
  ref.params = &params;
  ref.lights = lights;
  CHECK(K<T>::tr_light_samples(&ref, 0) == 9);
  CHECK(K<T>::tr_light_samples(&ref, 1) == 16);
  for (unsigned seed : {0u, 1u, 0xdeadbeefu}) {
    CAPTURE(seed);
    int cells[9] = {};
    for (int k = 0; k < 9; ++k) {
      const vec3<T> p = K<T>::tr_light_sample_position(&ref, 0, k, seed, vec3<T>(0, 10, 0));
      CHECK(p.y == T(2));
      const T x = (p.x - T(1)) / T(2), z = (p.z - T(3)) / T(4);
      REQUIRE(x >= T(0));
      REQUIRE(x < T(1));
      REQUIRE(z >= T(0));
      REQUIRE(z < T(1));
      ++cells[int(z * 3) * 3 + int(x * 3)];
    }
    for (int cell : cells) CHECK(cell == 1);
    // The sphere's samples: on the disk through its center that faces the point.
    const vec3<T> at(3, 4, 0);
    for (int k = 0; k < 16; ++k) {
      const vec3<T> p = K<T>::tr_light_sample_position(&ref, 1, k, seed, at);
      CHECK(glm::length(p) <= T(0.5) * T(1 + 1e-6));
      CHECK(std::fabs(glm::dot(p, glm::normalize(at))) <= T(1e-6));
    }
  }
  // Other paths place them elsewhere; a point light is where it is.
  CHECK(K<T>::tr_light_sample_position(&ref, 0, 4, 1u, vec3<T>(0)) !=
        K<T>::tr_light_sample_position(&ref, 0, 4, 2u, vec3<T>(0)));
  lights[0].shape = TR_LIGHT_POINT;
  CHECK(K<T>::tr_light_samples(&ref, 0) == 1);
  CHECK(K<T>::tr_light_sample_position(&ref, 0, 0, 7u, vec3<T>(0)) == vec3<T>(1, 2, 3));
}
