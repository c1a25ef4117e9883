// Real-model shading on both backends: smooth vertex normals, textures, the
// shading-normal and uv AOVs. Each image is CPU == OpenCL bit for bit (parity_util.hpp),
// and each checks what the feature is for: smooth normals bring a coarse sphere mesh
// close to the true sphere, and the texture appears where its uvs say, bilinearly.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include <twinray/twinray.hpp>
#include <twinray/scene/mesh_normals.hpp>

#include "backend/parity_util.hpp"
#include "support/meshes.hpp"

using namespace twinray;
using test_support::uv_sphere;

namespace {

constexpr int kW = 80, kH = 60;

template <class T>
Camera<T> front_camera() {
  Camera<T> c;
  c.position = {T(0), T(0), T(4)};
  c.look_at = {T(0), T(0), T(0)};
  c.up = {T(0), T(1), T(0)};
  c.width = kW;
  c.height = kH;
  c.viewplane_height = T(1.2);
  c.focal_length = T(2);
  return c;
}

template <class T>
Scene<T> lit_scene() {
  Scene<T> s;
  s.add_light({{T(3), T(2), T(4)}, T(20), {T(1), T(1), T(1)}});
  s.add_light({{T(-4), T(1), T(1)}, T(8), {T(0.6), T(0.7), T(1)}});
  return s;
}

// 4 x 2 texels of distinct colours.
template <class T>
Texture<T> checker() {
  Texture<T> t;
  t.width = 4;
  t.height = 2;
  t.texels = {1, 0, 0, 0, 1, 0, 0, 0, 1, 1,      1,      0,
              0, 1, 1, 1, 0, 1, 1, 1, 1, T(0.2), T(0.2), T(0.2)};
  t.name = "checker";
  return t;
}

// Mean angle (radians) between two normal AOVs over the pixels both hit.
template <class T>
double mean_angle(const Image<T>& a, const Image<T>& b, int* pixels) {
  double sum = 0;
  int n = 0;
  for (size_t i = 0; i < a.rgb.size(); i += 3) {
    glm::dvec3 x(a.rgb[i], a.rgb[i + 1], a.rgb[i + 2]), y(b.rgb[i], b.rgb[i + 1], b.rgb[i + 2]);
    if (glm::dot(x, x) == 0 || glm::dot(y, y) == 0) continue;
    sum += std::acos(std::min(1.0, glm::dot(glm::normalize(x), glm::normalize(y))));
    ++n;
  }
  *pixels = n;
  return n ? sum / n : 0;
}

}  // namespace

TEST_CASE_TEMPLATE("smooth normals bring a coarse sphere mesh close to the true sphere", T, float,
                   double) {
  Scene<T> truth = lit_scene<T>();
  int white = truth.add_material(Material<T>{});
  truth.add(Sphere<T>{{T(0), T(0), T(0)}, T(1), white});
  Scene<T> mesh_scene = lit_scene<T>();
  mesh_scene.add_material(Material<T>{});
  Mesh<T> mesh = uv_sphere<T>({0, 0, 0}, 1.0, 8, 12);
  mesh.uvs.clear();
  mesh.uv_triangles.clear();
  mesh_scene.add(mesh);

  RenderOptions aov;
  aov.output = Output::ShadingNormal;
  Image<T> want = test::check_parity(truth, front_camera<T>(), aov);
  Image<T> flat = test::check_parity(mesh_scene, front_camera<T>(), aov);
  smooth_normals(std::get<Mesh<T>>(mesh_scene.objects[0]), 60.0);
  Image<T> smooth = test::check_parity(mesh_scene, front_camera<T>(), aov);
  int n_flat = 0, n_smooth = 0;
  double flat_error = mean_angle(want, flat, &n_flat);
  double smooth_error = mean_angle(want, smooth, &n_smooth);
  CAPTURE(flat_error);
  CAPTURE(smooth_error);
  CHECK(n_flat > kW * kH / 4);
  CHECK(smooth_error < flat_error / 4);

  // The geometric-normal AOV stays flat: shading normals do not move the surface.
  aov.output = Output::Normal;
  Image<T> geometric = test::check_parity(mesh_scene, front_camera<T>(), aov);
  CHECK(test::differing_values(geometric, flat) == 0);

  // Shaded, with shadows and a glazed floor reflecting the mesh: still the same bits.
  Material<T> mirror;
  mirror.glaze = T(0.5);
  int floor = mesh_scene.add_material(mirror);
  mesh_scene.add(Plane<T>{{T(0), T(-1), T(0)}, {T(0), T(1), T(0)}, floor});
  test::check_parity(mesh_scene, front_camera<T>(), RenderOptions{});
}

TEST_CASE_TEMPLATE("textures: the albedo is the bilinear texel at the hit's uv", T, float, double) {
  Scene<T> scene = lit_scene<T>();
  int tex = scene.add_texture(checker<T>());
  Material<T> textured;
  textured.color = {T(1), T(1), T(1)};
  textured.texture = tex;
  scene.add_material(textured);
  Mesh<T> sphere = uv_sphere<T>({0, 0, 0}, 1.0, 16, 24);
  smooth_normals(sphere, 60.0);
  scene.add(sphere);

  RenderOptions uv_aov;
  uv_aov.output = Output::Uv;
  Image<T> uv = test::check_parity(scene, front_camera<T>(), uv_aov);
  RenderOptions ambient_only;
  ambient_only.terms = kAmbient;
  Image<T> shaded = test::check_parity(scene, front_camera<T>(), ambient_only);
  Scene<T> plain = scene;
  plain.materials[0].texture = -1;
  Image<T> untextured = test::check_parity(plain, front_camera<T>(), ambient_only);

  // Ambient only: shaded = untextured x texture(uv), per pixel and channel. The reference
  // lookup is the bilinear repeat filter, written here in double.
  Texture<T> t = checker<T>();
  auto lookup = [&](double u, double v, int c) {
    double x = (u - std::floor(u)) * t.width - 0.5, y = (1 - (v - std::floor(v))) * t.height - 0.5;
    int x0 = int(std::floor(x)), y0 = int(std::floor(y));
    double ax = x - x0, ay = y - y0;
    auto texel = [&](int i, int j) {
      i = (i % t.width + t.width) % t.width;
      j = (j % t.height + t.height) % t.height;
      return double(t.texels[t.texel_index(i, j) + c]);
    };
    return (texel(x0, y0) * (1 - ax) + texel(x0 + 1, y0) * ax) * (1 - ay) +
           (texel(x0, y0 + 1) * (1 - ax) + texel(x0 + 1, y0 + 1) * ax) * ay;
  };
  int checked = 0, colours_seen = 0;
  double worst = 0;
  for (size_t i = 0; i < uv.rgb.size(); i += 3) {
    if (untextured.rgb[i] <= T(0)) continue;  // background
    for (int c = 0; c < 3; ++c) {
      double want = double(untextured.rgb[i + c]) * lookup(uv.rgb[i], uv.rgb[i + 1], c);
      worst = std::max(worst, std::fabs(double(shaded.rgb[i + c]) - want));
    }
    // The blue texel (u in [0.5, 0.75], upper half) faces the camera.
    colours_seen += shaded.rgb[i + 2] > 2 * (shaded.rgb[i] + shaded.rgb[i + 1]);
    ++checked;
  }
  // Float texels and uvs: a few ulps of difference against the double reference.
  CHECK(checked > kW * kH / 4);
  CHECK(colours_seen > 0);
  CHECK(worst < (sizeof(T) == 4 ? 1e-4 : 1e-12));

  // The uv AOV is (u, v, 0) inside [0, 1] on the mesh, 0 on the background.
  for (size_t i = 0; i < uv.rgb.size(); i += 3) {
    CHECK(uv.rgb[i + 2] == T(0));
    CHECK((uv.rgb[i] >= T(0) && uv.rgb[i] <= T(1)));
  }
}
