// Scenes for the BVH tests: random spheres and disjoint triangles (no shared edges, so
// no two primitives tie on t), a floor plane, lights, some glazed; and a folded grid
// whose shared edges do tie.
#pragma once

#include <cstdint>
#include <random>

#include <twinray/twinray.hpp>

namespace bvh_test {

template <class T>
twinray::Scene<T> random_scene(int n_spheres, int n_triangles, uint32_t seed, bool plane = true) {
  using vec3 = glm::vec<3, T>;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  twinray::Scene<T> scene;
  for (int i = 0; i < 4; ++i) {
    twinray::Material<T> m;
    m.color = vec3(T(0.2 + 0.2 * i), T(0.8 - 0.15 * i), T(0.5));
    m.glaze = i == 3 ? T(0.5) : T(0);
    scene.add_material(m);
  }
  for (int i = 0; i < n_spheres; ++i) {
    vec3 c(T(4 * u(rng)), T(1.5 * u(rng)), T(-3 + 2 * u(rng)));
    scene.add(twinray::Sphere<T>{c, T(0.05 + 0.15 * (u(rng) + 1)), i % 4});
  }
  for (int i = 0; i < n_triangles; ++i) {
    vec3 c(T(4 * u(rng)), T(1.5 * u(rng)), T(-3 + 2 * u(rng)));
    twinray::Triangle<T> t;
    for (auto& v : t.vertices) v = c + vec3(T(0.4 * u(rng)), T(0.4 * u(rng)), T(0.4 * u(rng)));
    t.material = (i + 1) % 4;
    scene.add(t);
  }
  if (plane) scene.add(twinray::Plane<T>{vec3(0, 2, 0), vec3(0, -1, 0), 3});
  scene.add_light(twinray::Light<T>{vec3(-2, -4, 2), T(30), vec3(1, 1, 1)});
  scene.add_light(twinray::Light<T>{vec3(3, -3, 0), T(10), vec3(1, 0.8, 0.6)});
  scene.background = vec3(T(0.1), T(0.1), T(0.2));
  return scene;
}

// A folded grid of 2 k^2 triangles sharing edges: rays through a shared edge hit both
// neighbours at the same t (ties).
template <class T>
twinray::Mesh<T> folded_grid(int k, int material) {
  using vec3 = glm::vec<3, T>;
  twinray::Mesh<T> mesh;
  for (int j = 0; j <= k; ++j)
    for (int i = 0; i <= k; ++i)
      mesh.vertices.push_back(
          vec3(T(-3 + 6.0 * i / k), T(0.5 * ((i + j) % 3) - 0.5), T(-4 + 4.0 * j / k)));
  for (int j = 0; j < k; ++j)
    for (int i = 0; i < k; ++i) {
      int a = j * (k + 1) + i;
      mesh.triangles.push_back({a, a + 1, a + k + 1});
      mesh.triangles.push_back({a + 1, a + k + 2, a + k + 1});
    }
  mesh.material = material;
  return mesh;
}

template <class T>
twinray::Camera<T> test_camera(int width, int height) {
  twinray::Camera<T> camera;
  camera.position = glm::vec<3, T>(0, -1, 6);
  camera.look_at = glm::vec<3, T>(0, 0, -2);
  camera.up = glm::vec<3, T>(0, -1, 0);
  camera.viewplane_height = T(6);
  camera.width = width;
  camera.height = height;
  return camera;
}

}  // namespace bvh_test
