// Bitwise parity: every image here is rendered on the CPU backend and on the OpenCL
// backend (PoCL) and the float framebuffers must be identical, bit for bit, in float and
// in double, over every switch of the shading (terms, shadows, glaze, depth), both
// cameras, several samples per pixel, meshes, several lights and the AOVs.
#include <doctest/doctest.h>

#include <twinray/twinray.hpp>

#include "backend/parity_util.hpp"
#include <twinray/scene/demo_scene.hpp>

using namespace twinray;

namespace {
constexpr int kW = 96, kH = 72;  // small: the suite stays fast; every code path still runs
}

TEST_CASE_TEMPLATE("parity: the demo and each of the seed's comparisons", T, float, double) {
  for (const twinray::demo::Variant& v : twinray::demo::seed_variants()) {
    CAPTURE(v.name);
    auto d = twinray::demo::make_demo_scene<T>(kW, kH);
    RenderOptions options;
    twinray::demo::apply(v, d, options);
    test::check_parity(d.scene, d.camera, options);
  }
}

TEST_CASE_TEMPLATE("parity: reflection depth 1 and 8, orthographic glazed", T, float, double) {
  for (int depth : {1, 2, 8}) {
    CAPTURE(depth);
    auto d = twinray::demo::make_demo_scene<T>(kW, kH);
    for (auto& m : d.scene.materials) m.glaze = T(0.5);
    RenderOptions options;
    options.max_depth = depth;
    test::check_parity(d.scene, d.camera, options);
    d.camera.projection = Projection::Orthographic;
    test::check_parity(d.scene, d.camera, options);
  }
}

TEST_CASE_TEMPLATE("parity: several samples per pixel", T, float, double) {
  for (int spp : {2, 4, 9}) {
    CAPTURE(spp);
    auto d = twinray::demo::make_demo_scene<T>(kW, kH);
    RenderOptions options;
    options.spp = spp;
    test::check_parity(d.scene, d.camera, options);
  }
}

TEST_CASE_TEMPLATE("parity: a mesh, three colored lights, a background, no shadows", T, float,
                   double) {
  using vec3 = glm::vec<3, T>;
  Scene<T> scene;
  scene.background = vec3(T(0.1), T(0.15), T(0.3));
  Material<T> m;
  m.color = vec3(T(0.9), T(0.6), T(0.2));
  m.shininess = T(12.5);  // non-integer exponent: the fractional pow path
  int gold = scene.add_material(m);
  m.color = vec3(T(0.4), T(0.4), T(0.45));
  m.glaze = T(0.3);
  int floor = scene.add_material(m);
  // An octahedron as an indexed mesh.
  Mesh<T> mesh;
  mesh.vertices = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  mesh.triangles = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                    {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  mesh.material = gold;
  scene.add(mesh);
  scene.add(Sphere<T>{vec3(T(1.6), T(-0.5), T(0.4)), T(0.5), gold});
  scene.add(Plane<T>{vec3(0, -1, 0), vec3(0, 1, 0), floor});
  scene.add_light({vec3(3, 4, 2), T(30), vec3(1, T(0.9), T(0.8))});
  scene.add_light({vec3(-4, 2, 1), T(10), vec3(T(0.3), T(0.5), 1)});
  scene.add_light({vec3(0, 6, -3), T(20), vec3(1, 1, 1)});
  Camera<T> cam;
  cam.position = vec3(T(0.5), T(1.5), 5);
  cam.look_at = vec3(0, 0, 0);
  cam.up = vec3(0, 1, 0);
  cam.width = kW, cam.height = kH;
  RenderOptions options;
  test::check_parity(scene, cam, options);
  options.shadows = false;
  test::check_parity(scene, cam, options);
  options.terms = kDiffuse | kSpecular;
  options.spp = 4;
  test::check_parity(scene, cam, options);
}

TEST_CASE_TEMPLATE("parity: depth, normal and object AOVs", T, float, double) {
  auto d = twinray::demo::make_demo_scene<T>(kW, kH);
  for (Output out : {Output::Depth, Output::Normal, Output::ObjectIndex}) {
    RenderOptions options;
    options.output = out;
    Image<T> cpu = test::check_parity(d.scene, d.camera, options);
    if (out == Output::ObjectIndex) {
      // The spheres, the two tetrahedron faces turned to the camera and the floor are
      // seen (the base, object 3, faces the floor); the sky is -1.
      std::vector<int> seen(8, 0);
      int sky = 0;
      for (size_t i = 0; i < cpu.rgb.size(); i += 3) {
        int id = static_cast<int>(cpu.rgb[i]);
        if (id < 0)
          ++sky;
        else if (id < 8)
          seen[id] = 1;
      }
      CHECK(sky > 0);
      for (int id : {0, 1, 2, 4, 5, 7}) CHECK(seen[id] == 1);  // spheres, two faces, floor
    }
  }
}

TEST_CASE("the library was compiled without floating-point contraction") {
  // The CMake target carries -ffp-contract=off; without it the CPU image would differ.
  CHECK_FALSE(fp_contraction_detected());
}

// Placed objects are ordinary objects once placed; an arbitrary rotation (not a quarter
// turn, so every coordinate is rounded) and a shear still give the same bits.
TEST_CASE_TEMPLATE("parity: objects placed by transforms", T, float, double) {
  auto d = twinray::demo::make_demo_scene<T>(kW, kH);
  auto turn = Transform::scale_rotate_translate({0.7, 0.7, 0.7}, {1, 2, 3}, 37, {0.3, -0.2, 0.1});
  for (auto& object : d.scene.objects)
    if (!std::holds_alternative<Plane<T>>(object)) place(object, turn);
  const double shear[4][4] = {{1, 0.3, 0, 0}, {0, 1, 0, 0.1}, {0, 0.2, 1, 0}, {0, 0, 0, 1}};
  for (auto& object : d.scene.objects)
    if (std::holds_alternative<Plane<T>>(object)) place(object, Transform::from_rows(shear));
  test::check_parity(d.scene, d.camera, RenderOptions{});
}
