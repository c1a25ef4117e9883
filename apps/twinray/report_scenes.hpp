// The scenes of `twinray report`: the demo (include/twinray/scene/demo_scene.hpp) and "edges", a
// scene made of edges: a Siemens star of 18 thin triangles (a mesh fanning out from one
// vertex), its shadow on a wall behind it, and five small spheres, two of them
// glazed, with sharp highlights. examples/scenes/report_edges.json is the same scene
// with the same numbers (`twinray render examples/scenes/report_edges.json`).
#pragma once

#include <string>

#include <glm/vec3.hpp>
#include <twinray/scene/camera.hpp>
#include <twinray/scene/scene.hpp>

#include <twinray/scene/demo_scene.hpp>

namespace twinray_cli {
namespace report {

template <class T>
struct ReportScene {
  std::string name;
  twinray::Scene<T> scene;
  twinray::Camera<T> camera;
  int max_depth = 4;
};

template <class T>
ReportScene<T> demo_scene(int size) {
  twinray::demo::DemoSetup<T> d = twinray::demo::make_demo_scene<T>(size, size);
  return {"demo", d.scene, d.camera, 4};
}

template <class T>
ReportScene<T> edges_scene(int size) {
  using vec3 = glm::vec<3, T>;
  ReportScene<T> r;
  r.name = "edges";
  r.max_depth = 3;
  twinray::Scene<T>& s = r.scene;
  s.background = vec3(T(0.02), T(0.02), T(0.05));
  auto material = [&](vec3 color, double ka, double kd, double ks, double shininess, double glaze) {
    twinray::Material<T> m;
    m.color = color;
    m.ka = T(ka), m.kd = T(kd), m.ks = T(ks), m.shininess = T(shininess), m.glaze = T(glaze);
    return s.add_material(m);
  };
  int white = material(vec3(T(0.9), T(0.9), T(0.85)), 0.1, 0.8, 0.3, 30, 0);
  int wall = material(vec3(T(0.35), T(0.45), T(0.6)), 0.15, 0.8, 0.1, 10, 0);
  int red = material(vec3(T(0.85), T(0.2), T(0.15)), 0.1, 0.7, 0.8, 80, 0.3);
  int blue = material(vec3(T(0.2), T(0.3), T(0.9)), 0.1, 0.7, 0.8, 80, 0);
  // Vertex 0 is the star's center; wedge i is (0, 2i + 1, 2i + 2), 10 degrees wide.
  static const double kStar[][3] = {
      {0.0, 0.0, 0.0},
      {2.4, 0.0, 0.0},
      {2.363539, 0.416756, 0.0},
      {2.255262, 0.820848, 0.0},
      {2.078461, 1.2, 0.0},
      {1.838507, 1.54269, 0.0},
      {1.54269, 1.838507, 0.0},
      {1.2, 2.078461, 0.0},
      {0.820848, 2.255262, 0.0},
      {0.416756, 2.363539, 0.0},
      {0.0, 2.4, 0.0},
      {-0.416756, 2.363539, 0.0},
      {-0.820848, 2.255262, 0.0},
      {-1.2, 2.078461, 0.0},
      {-1.54269, 1.838507, 0.0},
      {-1.838507, 1.54269, 0.0},
      {-2.078461, 1.2, 0.0},
      {-2.255262, 0.820848, 0.0},
      {-2.363539, 0.416756, 0.0},
      {-2.4, 0.0, 0.0},
      {-2.363539, -0.416756, 0.0},
      {-2.255262, -0.820848, 0.0},
      {-2.078461, -1.2, 0.0},
      {-1.838507, -1.54269, 0.0},
      {-1.54269, -1.838507, 0.0},
      {-1.2, -2.078461, 0.0},
      {-0.820848, -2.255262, 0.0},
      {-0.416756, -2.363539, 0.0},
      {-0.0, -2.4, 0.0},
      {0.416756, -2.363539, 0.0},
      {0.820848, -2.255262, 0.0},
      {1.2, -2.078461, 0.0},
      {1.54269, -1.838507, 0.0},
      {1.838507, -1.54269, 0.0},
      {2.078461, -1.2, 0.0},
      {2.255262, -0.820848, 0.0},
      {2.363539, -0.416756, 0.0},
  };
  twinray::Mesh<T> star;
  for (const auto& v : kStar) star.vertices.push_back(vec3(T(v[0]), T(v[1]), T(v[2])));
  for (int i = 0; i < 18; ++i) star.triangles.push_back({0, 2 * i + 1, 2 * i + 2});
  star.material = white;
  s.add(star);
  s.add(twinray::Sphere<T>{vec3(T(-2.3), T(-2.3), T(0.6)), T(0.45), red});
  s.add(twinray::Sphere<T>{vec3(T(0.0), T(-2.5), T(0.9)), T(0.3), blue});
  s.add(twinray::Sphere<T>{vec3(T(2.2), T(-2.2), T(0.4)), T(0.5), red});
  s.add(twinray::Sphere<T>{vec3(T(2.4), T(2.3), T(0.3)), T(0.35), blue});
  s.add(twinray::Sphere<T>{vec3(T(-2.5), T(2.4), T(0.2)), T(0.25), red});
  s.add(twinray::Plane<T>{vec3(T(0), T(0), T(-1.5)), vec3(T(0), T(0), T(1)), wall});
  s.add_light(twinray::Light<T>{vec3(T(2.5), T(3.5), T(6)), T(40), vec3(T(1), T(1), T(1))});
  r.camera.position = vec3(T(0.5), T(0.8), T(7));
  r.camera.look_at = vec3(T(0), T(0), T(0));
  r.camera.up = vec3(T(0), T(1), T(0));
  r.camera.viewplane_height = T(6);
  r.camera.width = size;
  r.camera.height = size;
  return r;
}

}  // namespace report
}  // namespace twinray_cli
