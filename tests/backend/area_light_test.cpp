// Area lights and the environment on whole renders: the penumbra a straight edge casts
// is as wide as the geometry of the light says, a light shrunk to a point renders as
// the point light, the environment is what missing rays see (in mirrors and through
// glass too), and CPU against OpenCL bit for bit on such scenes, by every kernel, in
// float and double, with adaptive sampling and on any thread count.
#include <doctest/doctest.h>

#include <cmath>
#include <vector>

#include <twinray/scene/demo_scene.hpp>

#include "backend/parity_util.hpp"

namespace {

using twinray::Backend;
using twinray::Camera;
using twinray::Image;
using twinray::Light;
using twinray::Material;
using twinray::Plane;
using twinray::Projection;
using twinray::RenderOptions;
using twinray::Scene;
using twinray::Sphere;
using twinray::Triangle;

template <class T>
using vec3 = glm::vec<3, T>;

template <class T>
RenderOptions quiet() {
  RenderOptions o;
  o.log = [](const std::string&) {};
  return o;
}

// A white diffuse floor (y = 0), lit by `light` alone (no ambient or specular term),
// under an opaque half-plane at height h = 1 over x < 0 (when `blocked`).
template <class T>
Scene<T> floor_under_edge(const Light<T>& light, bool blocked) {
  Scene<T> scene;
  Material<T> white;
  white.color = vec3<T>(1);
  white.ka = white.ks = T(0);
  white.kd = T(1);
  const int m = scene.add_material(white);
  scene.add(Plane<T>{vec3<T>(0), vec3<T>(0, 1, 0), m});
  if (blocked)
    scene.add(Triangle<T>{{vec3<T>(0, 1, -50), vec3<T>(0, 1, 50), vec3<T>(-100, 1, 0)}, m});
  scene.add_light(light);
  return scene;
}

// That floor seen from below the half-plane straight down by an orthographic camera:
// `width` x `height` pixels of `pixel` world units, centered on x = 0.
template <class T>
Camera<T> floor_camera(int width, int height, T pixel) {
  Camera<T> camera;
  camera.projection = Projection::Orthographic;
  camera.position = vec3<T>(0, T(0.5), 0);
  camera.look_at = vec3<T>(0);
  camera.up = vec3<T>(0, 0, -1);
  camera.width = width;
  camera.height = height;
  camera.viewplane_height = pixel * T(height);
  return camera;
}

// The width of the penumbra on the floor, in world units: the pixels of the middle row
// whose light is between 5% and 95% of what they get with no blocker (the same
// samples, so the ratio is the share of the light they see), over 0.9.
template <class T>
double penumbra_width(const Light<T>& light) {
  const int width = 400;
  const T pixel = T(0.005);
  const Camera<T> camera = floor_camera(width, 3, pixel);
  const Image<T> open =
      test::render_with(floor_under_edge(light, false), camera, quiet<T>(), Backend::Cpu);
  const Image<T> shaded =
      test::render_with(floor_under_edge(light, true), camera, quiet<T>(), Backend::Cpu);
  int partial = 0;
  for (int x = 0; x < width; ++x) {
    const double seen = double(shaded.pixel(x, 1)[0]) / double(open.pixel(x, 1)[0]);
    partial += seen > 0.05 && seen < 0.95;
  }
  return partial * double(pixel) / 0.9;
}

// A light of height 4 over the floor, centered on the blocker's edge (x = 0).
template <class T>
Light<T> rect_light(T size, int samples) {
  return Light<T>::rect(vec3<T>(-size / 2, 4, -size / 2), vec3<T>(size, 0, 0), vec3<T>(0, 0, size),
                        T(16), samples);
}

// A small HDR environment: a horizontal gradient with a bright spot (values above 1).
template <class T>
twinray::Texture<T> sky_texture() {
  twinray::Texture<T> t;
  t.width = 16;
  t.height = 8;
  t.hdr = true;
  t.name = "sky";
  for (int y = 0; y < t.height; ++y)
    for (int x = 0; x < t.width; ++x) {
      const bool sun = x == 5 && y == 2;
      t.texels.insert(t.texels.end(), {sun ? T(30) : T(x) / T(16), T(y) / T(8), T(0.5)});
    }
  return t;
}

// The demo with a rect and a sphere light in place of its point light, a glass sphere
// and the environment (rotated, its up along the demo's -y).
template <class T>
twinray::demo::DemoSetup<T> lit_demo(int size) {
  auto demo = twinray::demo::make_demo_scene<T>(size, size);
  Scene<T>& scene = demo.scene;
  scene.lights.clear();
  scene.add_light(
      Light<T>::rect(vec3<T>(T(-2.5), -2, T(0.5)), vec3<T>(1, 0, 0), vec3<T>(0, 0, 1), T(8), 3));
  scene.add_light(Light<T>::sphere(vec3<T>(3, -2, 2), T(0.4), T(6), 2, vec3<T>(1, T(0.9), T(0.7))));
  Material<T> glass;
  glass.color = vec3<T>(1);
  glass.ka = glass.kd = T(0);
  glass.transmission = T(1);
  glass.ior = T(1.5);
  scene.add(Sphere<T>{vec3<T>(T(2.2), T(0.25), T(0.9)), T(0.55), scene.add_material(glass)});
  scene.environment.texture = scene.add_texture(sky_texture<T>());
  scene.environment.rotate_degrees = T(40);
  scene.environment.up = vec3<T>(0, -1, 0);
  return demo;
}

}  // namespace

TEST_CASE_TEMPLATE("the penumbra of a straight edge is as wide as the light's geometry says", T,
                   float, double) {
  // A rect light of width L at height H over the floor, the blocker's edge at h: a floor
  // point sees all of it, part of it or none over a band of width L h / (H - h) = L / 3,
  // its share growing linearly across it, so the 5%-95% pixels span 0.9 of the band. A
  // sphere light of radius r is seen as a disk of diameter 2 r: the share a straight
  // edge leaves of it is a circular segment's, between 5% and 95% over 2 r (1 - c) of
  // the diameter, c the segment height of 5% (in radii). Pixels are 0.005 wide, with
  // 8 x 8 stratified samples each: within 5% of the widths.
  for (T size : {T(0.6), T(1.5)}) {
    CAPTURE(size);
    const double want = double(size) / 3;
    CHECK(std::fabs(penumbra_width(rect_light(size, 8)) - want) <= 0.05 * want);
  }
  auto segment = [](double c) {  // the share of a unit disk beyond a chord c from its edge
    return (std::acos(1 - c) - (1 - c) * std::sqrt(2 * c - c * c)) / M_PI;
  };
  double lo = 0, hi = 1;
  for (int i = 0; i < 60; ++i) (segment((lo + hi) / 2) < 0.05 ? lo : hi) = (lo + hi) / 2;
  const T radius = T(0.45);
  const double disk = 2 * double(radius) * (1 - lo) / 3 / 0.9;
  const double sphere = penumbra_width(Light<T>::sphere(vec3<T>(0, 4, 0), radius, T(16), 8));
  CAPTURE(disk);
  CHECK(std::fabs(sphere - disk) <= 0.05 * disk);
  // The larger light's penumbra is wider, and a point light's is one pixel at most.
  CHECK(penumbra_width(rect_light(T(1.5), 8)) > penumbra_width(rect_light(T(0.6), 8)));
  CHECK(penumbra_width(Light<T>{vec3<T>(0, 4, 0), T(16), vec3<T>(1)}) <= 0.005 / 0.9 + 1e-12);
}

TEST_CASE("adaptive sampling refines the penumbra of an area light") {
  // One sample per pixel with 2 x 2 light samples is noisy inside the penumbra and
  // nowhere else: the pixels refined there are many more than the one or two a point
  // light's sharp edge asks for in each row.
  auto refined = [](const Light<float>& light) {
    RenderOptions options = quiet<float>();
    options.sampler = twinray::Sampler::R2;
    options.adaptive_spp = 16;
    options.adaptive_threshold = 0.02;
    twinray::RenderInfo info;
    test::render_with(floor_under_edge(light, true), floor_camera(200, 8, 0.01f), options,
                      Backend::Cpu, &info);
    return info.refined_pixels;
  };
  const long long soft = refined(rect_light(1.5f, 2));
  const long long hard = refined(Light<float>{vec3<float>(0, 4, 0), 16.0f, vec3<float>(1)});
  CAPTURE(soft);
  CAPTURE(hard);
  CHECK(hard <= 3 * 8);
  CHECK(soft > 10 * hard);
  CHECK(soft > 200);
}

TEST_CASE_TEMPLATE("an area light shrunk to a point renders as the point light", T, float, double) {
  // The demo's light as a rect of side 1e-5 and as a sphere of radius 1e-5: every
  // sample is within 1e-5 of the point, so each irradiance is within a relative 1e-5
  // or so of the point's (the lights are about 3 units away), and the samples' shares
  // sum to the point's intensity. Only shadow rays grazing an edge within 1e-5 may
  // change: at most 0.2% of the values by more than 1e-4.
  auto demo = twinray::demo::make_demo_scene<T>(160, 160);
  const Light<T> point = demo.scene.lights.at(0);
  const Image<T> want = test::render_with(demo.scene, demo.camera, quiet<T>(), Backend::Cpu);
  const T e = T(1e-5);
  for (const Light<T>& small :
       {Light<T>::rect(point.position - vec3<T>(e / 2, 0, e / 2), vec3<T>(e, 0, 0),
                       vec3<T>(0, 0, e), point.intensity, 3, point.color),
        Light<T>::sphere(point.position, e, point.intensity, 3, point.color)}) {
    demo.scene.lights = {small};
    twinray::RenderInfo info;
    const Image<T> got =
        test::render_with(demo.scene, demo.camera, quiet<T>(), Backend::Cpu, &info);
    CHECK((info.features & TR_F_AREA_LIGHTS) != 0);
    size_t off = 0;
    for (size_t i = 0; i < want.rgb.size(); ++i)
      off += std::fabs(double(want.rgb[i]) - double(got.rgb[i])) > 1e-4;
    CHECK(off <= want.rgb.size() / 500);
  }
}

TEST_CASE_TEMPLATE("the environment is what rays that hit nothing see, at any depth", T, float,
                   double) {
  // A camera ray that misses sees the texel its direction maps to (device tests check
  // the mapping); one mirrored off a glazed floor sees the environment too, dimmed by
  // the glaze; intensity scales every value; and no light comes from it: a diffuse
  // floor with no light is black under any environment.
  Scene<T> scene;
  scene.environment.texture = scene.add_texture(sky_texture<T>());
  Camera<T> camera;
  camera.position = vec3<T>(0, 1, 0);
  camera.look_at = vec3<T>(0, 1, -1);
  camera.up = vec3<T>(0, 1, 0);
  camera.width = camera.height = 16;
  const Image<T> sky = test::render_with(scene, camera, quiet<T>(), Backend::Cpu);
  scene.environment.intensity = T(2);
  const Image<T> twice = test::render_with(scene, camera, quiet<T>(), Backend::Cpu);
  for (size_t i = 0; i < sky.rgb.size(); ++i) CHECK(twice.rgb[i] == T(2) * sky.rgb[i]);
  CHECK(sky.pixel(8, 8)[2] == T(0.5));  // the blue channel is 0.5 everywhere
  // A mirror floor seen from above reflects the sky upward: the bottom half of the
  // image is the mirror image of the top half, times the glaze.
  Material<T> mirror;
  mirror.color = vec3<T>(0);
  mirror.ka = mirror.kd = mirror.ks = T(0);
  mirror.glaze = T(0.5);
  scene.environment.intensity = T(1);
  scene.add(Plane<T>{vec3<T>(0), vec3<T>(0, 1, 0), scene.add_material(mirror)});
  camera.position = vec3<T>(0, 1, 0);
  camera.look_at = vec3<T>(0, 1, -1);
  const Image<T> reflected = test::render_with(scene, camera, quiet<T>(), Backend::Cpu);
  size_t nonzero = 0;
  for (T v : reflected.rgb) nonzero += v > T(0);
  CHECK(nonzero == reflected.rgb.size());
  // The floor's pixels see the environment's lower half mirrored: its blue is 0.5 x 0.5.
  CHECK(reflected.pixel(8, 15)[2] == doctest::Approx(0.25));
  // Through glass: a slab of index 1 with no surface terms in front of the camera
  // leaves the sky as it was, the refracted rays missing everything behind it and
  // seeing it, up to the few ulps the refracted direction is rebuilt with.
  Scene<T> slab;
  slab.environment.texture = slab.add_texture(sky_texture<T>());
  Material<T> clear;
  clear.color = vec3<T>(1);
  clear.ka = clear.kd = clear.ks = T(0);
  clear.transmission = T(1);
  clear.ior = T(1);
  const int index1 = slab.add_material(clear);
  slab.add(Plane<T>{vec3<T>(0, 0, T(-0.5)), vec3<T>(0, 0, 1), index1});
  slab.add(Plane<T>{vec3<T>(0, 0, T(-0.7)), vec3<T>(0, 0, -1), index1});
  camera.position = vec3<T>(0, 1, 0);
  camera.look_at = vec3<T>(0, 1, -1);
  RenderOptions deep = quiet<T>();
  deep.max_depth = 8;
  const Image<T> through = test::render_with(slab, camera, deep, Backend::Cpu);
  for (size_t i = 0; i < sky.rgb.size(); ++i)
    CHECK(std::fabs(double(through.rgb[i]) - double(sky.rgb[i])) <=
          1e-4 * (1 + double(sky.rgb[i])));
  // Diffuse floor, no lights: black wherever the floor is seen.
  Scene<T> dark;
  dark.environment.texture = dark.add_texture(sky_texture<T>());
  Material<T> white;
  white.color = vec3<T>(1);
  dark.add(Plane<T>{vec3<T>(0), vec3<T>(0, 1, 0), dark.add_material(white)});
  const Image<T> unlit = test::render_with(dark, camera, quiet<T>(), Backend::Cpu);
  for (int c = 0; c < 3; ++c) CHECK(unlit.pixel(8, 15)[c] == T(0));
}

TEST_CASE_TEMPLATE("area lights and the environment render the same bits on the CPU and OpenCL", T,
                   float, double) {
  auto demo = lit_demo<T>(80);
  RenderOptions options = quiet<T>();
  options.max_depth = 6;
  options.spp = 2;
  options.sampler = twinray::Sampler::Stratified;
  twinray::RenderInfo info;
  const Image<T> cpu = test::render_with(demo.scene, demo.camera, options, Backend::Cpu, &info);
  CHECK((info.features & TR_F_AREA_LIGHTS) != 0);
  CHECK((info.features & TR_F_ENVIRONMENT) != 0);
  test::check_kernel_parity(demo.scene, demo.camera, options, cpu, "pixel");
  test::check_kernel_parity(demo.scene, demo.camera, options, cpu, "blocks");
  // One CPU thread: the same bits (each path's samples come from its pixel, not its
  // thread).
  twinray::set_thread_count(1);
  const Image<T> one = test::render_with(demo.scene, demo.camera, options, Backend::Cpu);
  twinray::set_thread_count(0);
  CHECK(test::differing_values(cpu, one) == 0);
  // Adaptive sampling refines the penumbrae: its kernels too, through the generic
  // program.
  options.adaptive_spp = 8;
  options.adaptive_threshold = 0.02;
  options.specialize = false;
  test::check_parity(demo.scene, demo.camera, options);
}

TEST_CASE("scenes without area lights or an environment compile neither") {
  auto demo = twinray::demo::make_demo_scene<float>(16, 16);
  twinray::RenderInfo info;
  test::render_with(demo.scene, demo.camera, RenderOptions{}, Backend::OpenCL, &info);
  CHECK((info.features & (TR_F_AREA_LIGHTS | TR_F_ENVIRONMENT)) == 0);
}
