// Glass on whole renders: what optics says a camera sees through it (Snell's shift of an
// edge behind a tilted slab, a slab's reflectance and transmittance with absorption,
// an index-1 sphere that leaves the image as it was, shadows tinted by transmission),
// and CPU against OpenCL bit for bit on glass scenes, by both of OpenCL's kernels.
#include <doctest/doctest.h>

#include <cmath>
#include <initializer_list>

#include <twinray/scene/demo_scene.hpp>

#include "backend/parity_util.hpp"
#include "support/scoped_env.hpp"

namespace {

using twinray::Backend;
using twinray::Camera;
using twinray::Image;
using twinray::Material;
using twinray::Plane;
using twinray::Projection;
using twinray::RenderOptions;
using twinray::Scene;
using twinray::Sphere;

template <class T>
using vec3 = glm::vec<3, T>;

// Clear glass: nothing but its interfaces (no surface terms).
template <class T>
Material<T> glass(T ior, T transmission = T(1), vec3<T> absorption = vec3<T>(0)) {
  Material<T> m;
  m.color = vec3<T>(1);
  m.ka = m.kd = m.ks = T(0);
  m.transmission = transmission;
  m.ior = ior;
  m.absorption = absorption;
  return m;
}

// A slab of thickness h behind the plane z = 0 tilted by `degrees` about y: its front
// face's outward normal is (sin, 0, cos), its back face's the opposite.
template <class T>
void add_slab(Scene<T>& scene, int material, T degrees, T h) {
  const T a = degrees * T(M_PI / 180);
  const vec3<T> n(std::sin(a), 0, std::cos(a));
  scene.add(Plane<T>{vec3<T>(0), n, material});
  scene.add(Plane<T>{-n * h, -n, material});
}

// An orthographic camera looking down -z from z = 5, `width` pixels of `pixel` world
// units across x, centered on x = 0 (three rows).
template <class T>
Camera<T> ortho_camera(int width, T pixel) {
  Camera<T> c;
  c.projection = Projection::Orthographic;
  c.position = vec3<T>(0, 0, 5);
  c.look_at = vec3<T>(0, 0, 0);
  c.up = vec3<T>(0, 1, 0);
  c.width = width;
  c.height = 3;
  c.viewplane_height = pixel * T(3);
  return c;
}

template <class T>
RenderOptions deep_options() {
  RenderOptions o;
  o.max_depth = 24;
  o.log = [](const std::string&) {};
  return o;
}

// The first column of the middle row whose red value is above one half.
template <class T>
int first_bright_column(const Image<T>& image) {
  for (int x = 0; x < image.width; ++x)
    if (image.pixel(x, 1)[0] > T(0.5)) return x;
  return -1;
}

}  // namespace

TEST_CASE_TEMPLATE("a tilted slab shifts an edge behind it by Snell's displacement", T, float,
                   double) {
  // Behind, at z = -10: black (an unlit triangle) for x < 0, the white background
  // for x > 0. A ray through a slab of thickness h at incidence theta leaves parallel
  // to itself, moved sideways by h sin(theta - theta_t) / cos(theta_t), with
  // sin(theta) = 1.5 sin(theta_t): the edge moves by as much in the image.
  const T pixel = T(0.005), h = T(1);
  for (T degrees : {T(20), T(40), T(60)}) {
    CAPTURE(degrees);
    Scene<T> scene;
    scene.background = vec3<T>(1);
    Material<T> black;
    black.color = vec3<T>(0);
    black.ka = black.kd = black.ks = T(0);
    int wall = scene.add_material(black);
    scene.add(twinray::Triangle<T>{
        {vec3<T>(0, -50, -10), vec3<T>(0, 50, -10), vec3<T>(-100, 0, -10)}, wall});
    const int width = 600;
    Camera<T> camera = ortho_camera<T>(width, pixel);
    const int plain =
        first_bright_column(test::render_with(scene, camera, deep_options<T>(), Backend::Cpu));
    CHECK(plain == width / 2);
    add_slab(scene, scene.add_material(glass<T>(T(1.5))), degrees, h);
    const Image<T> image = test::render_with(scene, camera, deep_options<T>(), Backend::Cpu);
    const int shifted = first_bright_column(image);
    const double theta = double(degrees) * M_PI / 180, theta_t = std::asin(std::sin(theta) / 1.5);
    const double want = double(h) * std::sin(theta - theta_t) / std::cos(theta_t);
    CHECK(std::fabs(std::fabs(shifted - plain) * double(pixel) - want) <= double(pixel));
    // The slab leans toward +x: inside, rays bend toward -x, so the wall's x = 0 is
    // seen by a ray that entered further toward +x.
    CHECK(shifted > plain);
  }
}

TEST_CASE_TEMPLATE("a slab reflects and transmits as the series of its interfaces says", T, float,
                   double) {
  // At normal incidence each interface reflects F = ((n - 1) / (n + 1))^2. Seen against
  // a white background on both sides, a slab of thickness d and absorption a shows
  // R + T = F + (1 - F)^2 (F tau^2 + tau) / (1 - F^2 tau^2), tau = e^(-a d) (the sum of
  // all its internal reflections). The render stops a ray below 2^-10 of weight, so it
  // may miss up to about 2^-9 of the light: that is the tolerance.
  const T ior = T(1.5);
  const vec3<T> absorption(T(0.5), T(1), T(2));
  for (T d : {T(0.25), T(0.5), T(1.5)}) {
    CAPTURE(d);
    Scene<T> scene;
    scene.background = vec3<T>(1);
    add_slab(scene, scene.add_material(glass<T>(ior, T(1), absorption)), T(0), d);
    const Image<T> image =
        test::render_with(scene, ortho_camera<T>(8, T(0.1)), deep_options<T>(), Backend::Cpu);
    const double f = std::pow((ior - 1.0) / (ior + 1.0), 2);
    for (int c = 0; c < 3; ++c) {
      const double tau = std::exp(-double(absorption[c]) * double(d));
      const double want = f + (1 - f) * (1 - f) * (f * tau * tau + tau) / (1 - f * f * tau * tau);
      CAPTURE(c);
      CHECK(std::fabs(double(image.pixel(4, 1)[c]) - want) <= 2.0 / 1024);
    }
    CHECK(image.pixel(4, 1)[2] < image.pixel(4, 1)[0]);  // blue absorbed most
  }
}

TEST_CASE_TEMPLATE("glass of index 1 with no surface terms leaves the image as it was", T, float,
                   double) {
  // A ray crosses an index-1 sphere unbent, but not to the bit: the refracted direction
  // is rebuilt from cos_t = sqrt(1 - sin_t^2), a few ulps from cos_i, and restarts from
  // an origin offset off the surface. So only pixels whose rays graze an edge behind the
  // sphere may change: at most 0.5% of the values by more than 1e-3, and every value
  // within 1e-2 elsewhere than there.
  auto demo = twinray::demo::make_demo_scene<T>(200, 200);
  RenderOptions options = deep_options<T>();
  const Image<T> plain = test::render_with(demo.scene, demo.camera, options, Backend::Cpu);
  demo.scene.add(
      Sphere<T>{vec3<T>(1.6, 0.1, 0.6), T(0.7), demo.scene.add_material(glass<T>(T(1)))});
  const Image<T> through = test::render_with(demo.scene, demo.camera, options, Backend::Cpu);
  size_t off = 0;
  for (size_t i = 0; i < plain.rgb.size(); ++i)
    off += std::fabs(plain.rgb[i] - through.rgb[i]) > T(1e-3);
  CHECK(off <= plain.rgb.size() / 200);
}

TEST_CASE_TEMPLATE("a glass shadow passes the transmission of each surface it crosses", T, float,
                   double) {
  // The floor point under a sphere between it and the light: its shadow ray crosses two
  // surfaces, so it gets ambient + transmission^2 x the direct light.
  auto floor_value = [](int blocker_kind) {
    Scene<T> scene;
    Material<T> white;
    white.color = vec3<T>(1);
    white.ka = T(0.1), white.kd = T(0.7), white.ks = T(0);
    scene.add(Plane<T>{vec3<T>(0), vec3<T>(0, 1, 0), scene.add_material(white)});
    if (blocker_kind > 0) {
      Material<T> m = blocker_kind == 1 ? white : glass<T>(T(1.5), T(0.6));
      scene.add(Sphere<T>{vec3<T>(0, 2, 0), T(0.5), scene.add_material(m)});
    }
    scene.add_light(twinray::Light<T>{vec3<T>(0, 5, 0), T(25), vec3<T>(1)});
    Camera<T> camera;
    camera.position = vec3<T>(0, 1, 5);
    camera.look_at = vec3<T>(0, 0, 0);
    camera.up = vec3<T>(0, 1, 0);
    camera.width = camera.height = 1;
    camera.viewplane_height = T(0.001);
    return double(test::render_with(scene, camera, deep_options<T>(), Backend::Cpu).rgb[0]);
  };
  const double open = floor_value(0), opaque = floor_value(1), glassy = floor_value(2);
  CHECK(opaque < glassy);
  CHECK(glassy < open);
  CHECK(std::fabs((glassy - opaque) - 0.36 * (open - opaque)) <= 1e-5 * open);
}

TEST_CASE_TEMPLATE("glass renders the same bits on the CPU and on OpenCL, by both kernels", T,
                   float, double) {
  // The demo with a clear sphere, an absorbing one with a glazed coat, a sphere of glass
  // inside glass and a tilted slab: refraction, total internal reflection, absorption
  // and tinted shadows on every path.
  auto demo = twinray::demo::make_demo_scene<T>(96, 96);
  Scene<T>& scene = demo.scene;
  int clear = scene.add_material(glass<T>(T(1.5)));
  Material<T> amber = glass<T>(T(1.45), T(0.9), vec3<T>(T(0.3), T(1.2), T(3)));
  amber.glaze = T(0.1), amber.ks = T(0.8), amber.shininess = T(200);
  int coated = scene.add_material(amber);
  scene.add(Sphere<T>{vec3<T>(2.2, 0.25, 0.9), T(0.55), clear});
  scene.add(Sphere<T>{vec3<T>(0.2, 0.55, 0.6), T(0.4), coated});
  scene.add(Sphere<T>{vec3<T>(0.2, 0.55, 0.6), T(0.2), clear});
  RenderOptions options;
  options.max_depth = 10;
  options.spp = 2;
  twinray::RenderInfo info;
  const Image<T> cpu = test::render_with(scene, demo.camera, options, Backend::Cpu, &info);
  test::check_kernel_parity(scene, demo.camera, options, cpu, "pixel");
  const twinray::RenderInfo blocks =
      test::check_kernel_parity(scene, demo.camera, options, cpu, "blocks");
  CHECK((blocks.features & TR_F_DIELECTRIC) != 0);  // the program compiled for glass
  // The slab scene too, through the generic program.
  test_support::ScopedEnv first_frame_blocks("TWINRAY_OPENCL_FIRST_FRAME", "blocks");
  Scene<T> slab;
  slab.background = vec3<T>(T(0.9), T(0.8), T(0.7));
  add_slab(slab, slab.add_material(glass<T>(T(1.5), T(1), vec3<T>(T(0.2)))), T(35), T(0.7));
  options.specialize = false;
  test::check_parity(slab, ortho_camera<T>(64, T(0.05)), options);
}

TEST_CASE("scenes without glass compile no glass") {
  auto demo = twinray::demo::make_demo_scene<float>(16, 16);
  twinray::RenderInfo info;
  test::render_with(demo.scene, demo.camera, RenderOptions{}, Backend::OpenCL, &info);
  CHECK((info.features & TR_F_DIELECTRIC) == 0);
  CHECK((info.features & TR_F_SPHERES) != 0);
}
