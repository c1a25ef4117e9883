// The demo scene of the original assignment, built through the C++ API (the
// `twinray render demo` scene, and examples/scenes/demo.json as a scene file).
//
// Choices the seed leaves open, written down:
// - "Up" is -y: the camera's up is (0, -1, 0) and the floor is the plane y = +1 with
//   normal (0, -1, 0), two units below the camera and three below the light.
// - Colors follow the named-color table (green, cyan, dark blue, lime, magenta); the
//   RGB table disagrees with it and would make the lime tetrahedron and the magenta
//   floor white.
// - The tetrahedron's fourth vertex, which the report does not give, is
//   v4 = (-1, -0.5, -0.6): 1.1 above the centroid of v1 v2 v3, so the tetrahedron stands
//   on its horizontal base 0.4 above the floor. The report's three faces are completed
//   by the fourth, v2 v3 v4.
// - The report's ka 0.6, kd 12, ks 9 belong to its own color scale; here ka 0.15,
//   kd 0.9, ks 0.6, shininess 65 with the light's inverse-square falloff give the same
//   look: well exposed, visible highlights, the floor's hot spot below the light just
//   under 1 (0.9 x 0.75 x 12/3^2 = 0.9), so nothing is blown out.
#pragma once

#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include <twinray/core/options.hpp>
#include <twinray/scene/camera.hpp>
#include <twinray/scene/scene.hpp>

namespace twinray {
namespace demo {

template <class T>
struct DemoSetup {
  twinray::Scene<T> scene;
  twinray::Camera<T> camera;
};

template <class T>
DemoSetup<T> make_demo_scene(int width = 400, int height = 400) {
  using vec3 = glm::vec<3, T>;
  DemoSetup<T> d;
  auto material = [&](T r, T g, T b, T glaze) {
    twinray::Material<T> m;
    m.color = vec3(r, g, b);
    m.ka = T(0.15), m.kd = T(0.9), m.ks = T(0.6), m.shininess = T(65), m.glaze = glaze;
    return d.scene.add_material(m);
  };
  int green = material(T(0.15), T(0.85), T(0.2), T(0));
  int cyan = material(T(0.15), T(0.8), T(0.9), T(0));
  int dark_blue = material(T(0.1), T(0.15), T(0.7), T(0));
  int lime = material(T(0.5), T(0.9), T(0.1), T(0));
  int magenta = material(T(0.75), T(0.1), T(0.65), T(0.4));

  d.scene.add(twinray::Sphere<T>{vec3(1, 0, -2), T(0.8), green});
  d.scene.add(twinray::Sphere<T>{vec3(2, 0.2, -0.5), T(0.4), cyan});
  d.scene.add(twinray::Sphere<T>{vec3(0.8, -0.3, -1), T(0.2), dark_blue});
  vec3 v1(-1, 0.6, -0.2), v2(0, 0.6, -0.8), v3(-2, 0.6, -0.8), v4(-1, -0.5, -0.6);
  d.scene.add(twinray::Triangle<T>{{v1, v2, v3}, lime});  // front
  d.scene.add(twinray::Triangle<T>{{v1, v2, v4}, lime});  // bottom
  d.scene.add(twinray::Triangle<T>{{v1, v3, v4}, lime});  // left
  d.scene.add(twinray::Triangle<T>{{v2, v3, v4}, lime});  // the fourth, closing it
  d.scene.add(twinray::Plane<T>{vec3(0, 1, 0), vec3(0, -1, 0), magenta});
  d.scene.add_light(twinray::Light<T>{vec3(-2, -2, 1), T(12), vec3(1, 1, 1)});

  d.camera.position = vec3(4, -1, 5);
  d.camera.look_at = vec3(0, 0, -1);
  d.camera.up = vec3(0, -1, 0);
  d.camera.viewplane_height = T(6);
  d.camera.width = width;
  d.camera.height = height;
  return d;
}

// The seed's comparison images: a name and what changes from the demo.
struct Variant {
  std::string name;
  unsigned terms = twinray::kAllTerms;
  bool shadows = true;
  bool glaze = true;
  bool all_glazed = false;
  bool orthographic = false;
};

inline std::vector<Variant> seed_variants() {
  return {
      {"demo", twinray::kAllTerms, true, true, false, false},
      {"ambient_only", twinray::kAmbient, true, true, false, false},
      {"diffuse_only", twinray::kDiffuse, true, true, false, false},
      {"specular_only", twinray::kSpecular, true, true, false, false},
      {"no_shadows", twinray::kAllTerms, false, true, false, false},
      {"no_glaze", twinray::kAllTerms, true, false, false, false},
      {"all_glazed", twinray::kAllTerms, true, true, true, false},
      {"orthographic", twinray::kAllTerms, true, true, false, true},
  };
}

template <class T>
void apply(const Variant& v, DemoSetup<T>& d, twinray::RenderOptions& options) {
  options.terms = v.terms;
  options.shadows = v.shadows;
  options.glaze = v.glaze;
  if (v.all_glazed)
    for (auto& m : d.scene.materials) m.glaze = T(0.4);
  if (v.orthographic) d.camera.projection = twinray::Projection::Orthographic;
}

}  // namespace demo
}  // namespace twinray
