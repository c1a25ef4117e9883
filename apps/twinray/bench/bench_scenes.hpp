// The benchmark scenes, built through the C++ API so twinray and the Embree
// comparison program render exactly the same geometry, materials, lights and camera:
//   demo          the seed's demo scene (include/twinray/scene/demo_scene.hpp)
//   spheres_<N>   N random spheres over the demo's glazed floor plane; the radius
//                 shrinks as N^(-1/3), so the spheres fill the same share of the volume
//                 at every N and the image stays alike while N grows
//   mesh_<N>      a bumpy closed blob of about N triangles over the same floor
//   obj_<N>       mesh_<N> written to an OBJ file and read back by io/obj_mesh.hpp
//   forest_<K>x<N> mesh_<N>'s blob as one asset, placed by K instances (a two-level BVH)
// N is written 1e3, 1e5, 1e6 (or plain digits). Every scene has one point light, shadow
// rays and reflections off the glazed floor (and the glazed quarter of the spheres).
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdlib>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <twinray/twinray.hpp>

#include <twinray/io/obj_mesh.hpp>
#include <twinray/scene/demo_scene.hpp>
#include <twinray/scene/transform.hpp>

namespace twinray_bench {

// "1e6" -> 1000000, "2000" -> 2000; -1 if it is not a count.
inline long long parse_count(const std::string& s) {
  try {
    size_t used = 0;
    double v = std::stod(s, &used);
    if (used != s.size() || !(v >= 1) || v > 1e9) return -1;
    return static_cast<long long>(std::llround(v));
  } catch (...) {
    return -1;
  }
}

template <class T>
struct BenchScene {
  std::string name;
  twinray::Scene<T> scene;
  twinray::Camera<T> camera;
  int spp = 1;
  // Render options other than backend, spp and threads (scene files bring their own:
  // max_depth, shadows, glaze, terms). Default: shadows on, up to 4 ray segments.
  twinray::RenderOptions options;
  double load_ms = 0;  // OBJ parse time, obj_* scenes only
};

template <class T>
void add_floor_and_light(twinray::Scene<T>& scene) {
  using vec3 = glm::vec<3, T>;
  twinray::Material<T> floor;
  floor.color = vec3(T(0.75), T(0.1), T(0.65));
  floor.ka = T(0.15), floor.kd = T(0.9), floor.ks = T(0.6), floor.shininess = T(65);
  floor.glaze = T(0.4);
  int m = scene.add_material(floor);
  scene.add(twinray::Plane<T>{vec3(0, 1, 0), vec3(0, -1, 0), m});
  scene.add_light(twinray::Light<T>{vec3(-2, -2, 1), T(12), vec3(1, 1, 1)});
}

template <class T>
twinray::Camera<T> demo_camera(int width, int height) {
  return twinray::demo::make_demo_scene<T>(width, height).camera;
}

template <class T>
BenchScene<T> random_spheres(long long n, int width, int height) {
  using vec3 = glm::vec<3, T>;
  BenchScene<T> b;
  b.camera = demo_camera<T>(width, height);
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double colors[4][3] = {
      {0.15, 0.85, 0.2}, {0.15, 0.8, 0.9}, {0.1, 0.15, 0.7}, {0.5, 0.9, 0.1}};
  for (int i = 0; i < 4; ++i) {
    twinray::Material<T> m;
    m.color = vec3(T(colors[i][0]), T(colors[i][1]), T(colors[i][2]));
    m.ka = T(0.15), m.kd = T(0.9), m.ks = T(0.6), m.shininess = T(65);
    m.glaze = i == 3 ? T(0.4) : T(0);
    b.scene.add_material(m);
  }
  // Box x in [-4, 3], y in [-1.4, 0.95] (the floor is y = 1), z in [-5, 1]: about 100
  // cubic units; radius 0.14 at 1000 spheres (3% of the volume), shrinking as N^-1/3.
  double radius = 0.14 * std::cbrt(1000.0 / static_cast<double>(n));
  b.scene.objects.reserve(static_cast<size_t>(n) + 1);
  for (long long i = 0; i < n; ++i) {
    double x = -4 + 7 * u(rng), y = -1.4 + 2.35 * u(rng), z = -5 + 6 * u(rng);
    double r = radius * (0.5 + u(rng));
    y = std::min(y, 1 - r);
    b.scene.add(twinray::Sphere<T>{vec3(T(x), T(y), T(z)), T(r), static_cast<int>(i % 4)});
  }
  add_floor_and_light(b.scene);
  return b;
}

// A closed, bumpy blob: a UV sphere of `rows` x `2 rows` quads with its radius
// displaced by a product of sines; 4 rows^2 triangles.
template <class T>
twinray::Mesh<T> blob_mesh(long long n_triangles, int material) {
  using vec3 = glm::vec<3, T>;
  int rows = std::max(2, static_cast<int>(std::lround(std::sqrt(n_triangles / 4.0))));
  int cols = 2 * rows;
  twinray::Mesh<T> mesh;
  mesh.material = material;
  const double pi = 3.14159265358979323846;
  const double cx = -0.2, cy = -0.3, cz = -1.6, radius = 1.2;
  for (int j = 0; j <= rows; ++j) {
    double theta = pi * j / rows;
    for (int i = 0; i < cols; ++i) {
      double phi = 2 * pi * i / cols;
      double r = radius * (1 + 0.12 * std::sin(6 * theta) * std::sin(5 * phi) +
                           0.03 * std::sin(40 * theta) * std::sin(37 * phi));
      mesh.vertices.push_back(vec3(T(cx + r * std::sin(theta) * std::cos(phi)),
                                   T(cy - r * std::cos(theta)),
                                   T(cz + r * std::sin(theta) * std::sin(phi))));
    }
  }
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) {
      int a = j * cols + i, b = j * cols + (i + 1) % cols;
      int c = a + cols, d = b + cols;
      mesh.triangles.push_back({a, b, c});
      mesh.triangles.push_back({b, d, c});
    }
  return mesh;
}

template <class T>
BenchScene<T> blob_scene(const twinray::Mesh<T>& mesh) {
  using vec3 = glm::vec<3, T>;
  BenchScene<T> b;
  twinray::Material<T> m;
  m.color = vec3(T(0.5), T(0.9), T(0.1));
  m.ka = T(0.15), m.kd = T(0.9), m.ks = T(0.6), m.shininess = T(65), m.glaze = T(0);
  b.scene.add_material(m);
  b.scene.add(mesh);
  add_floor_and_light(b.scene);
  return b;
}

// A forest: blob_mesh(n_triangles) as one asset, placed k times on a square grid over
// the floor (spacing 0.3, each turned about the vertical and scaled by 0.08-0.12 at
// random, standing on the floor), in front of the demo camera.
template <class T>
BenchScene<T> forest_scene(long long k, long long n_triangles) {
  BenchScene<T> b = blob_scene<T>(blob_mesh<T>(n_triangles, 0));
  twinray::Asset<T> tree;
  tree.name = "tree";
  tree.objects.push_back(b.scene.objects[0]);
  b.scene.objects.erase(b.scene.objects.begin());
  const int asset = b.scene.add_asset(tree);
  const int side = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(k))));
  std::mt19937_64 rng(777);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  glm::dmat4 to_origin(1.0);
  to_origin[3] = glm::dvec4(0.2, 0.3, 1.6, 1.0);  // the blob's center (blob_mesh) to 0
  for (long long i = 0; i < k; ++i) {
    const double scale = 0.08 + 0.04 * u(rng), degrees = 360.0 * u(rng);
    const double x = -0.3 * side / 2 + 0.3 * static_cast<double>(i % side);
    const double z = 1.0 - 0.3 * static_cast<double>(i / side);
    const double y = 1.0 - 1.2 * 1.15 * scale;  // on the floor (y = 1, up is -y)
    twinray::Transform t = twinray::Transform::scale_rotate_translate(
        {scale, scale, scale}, {0, 1, 0}, degrees, {x, y, z});
    b.scene.add_instance(asset, t.m * to_origin);
  }
  return b;
}

// Writes a mesh as a Wavefront OBJ (v and f lines, 1-based indices).
template <class T>
void write_obj(const std::string& path, const twinray::Mesh<T>& mesh) {
  std::ofstream f(path);
  if (!f) throw std::runtime_error("cannot write " + path);
  char line[128];
  for (const auto& v : mesh.vertices) {
    std::snprintf(line, sizeof line, "v %.9g %.9g %.9g\n", double(v.x), double(v.y), double(v.z));
    f << line;
  }
  for (const auto& t : mesh.triangles)
    f << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
  if (!f) throw std::runtime_error("cannot write " + path);
}

// A scene by name (see the top of this file); throws std::invalid_argument if unknown.
// obj_* scenes write their OBJ file into obj_dir.
template <class T>
BenchScene<T> make_scene(const std::string& name, int width, int height,
                         const std::string& obj_dir = ".") {
  BenchScene<T> b;
  auto starts = [&](const char* prefix, std::string* rest) {
    size_t n = std::string(prefix).size();
    if (name.compare(0, n, prefix) != 0) return false;
    *rest = name.substr(n);
    return true;
  };
  std::string rest;
  if (name == "demo" || name == "demo_4spp") {
    auto d = twinray::demo::make_demo_scene<T>(width, height);
    b.scene = d.scene;
    b.camera = d.camera;
    b.spp = name == "demo" ? 1 : 4;
  } else if (starts("spheres_", &rest) && parse_count(rest) > 0) {
    b = random_spheres<T>(parse_count(rest), width, height);
  } else if (starts("mesh_", &rest) && parse_count(rest) > 0) {
    b = blob_scene<T>(blob_mesh<T>(parse_count(rest), 0));
  } else if (starts("forest_", &rest) && rest.find('x') != std::string::npos &&
             parse_count(rest.substr(0, rest.find('x'))) > 0 &&
             parse_count(rest.substr(rest.find('x') + 1)) > 0) {
    b = forest_scene<T>(parse_count(rest.substr(0, rest.find('x'))),
                        parse_count(rest.substr(rest.find('x') + 1)));
  } else if (starts("obj_", &rest) && parse_count(rest) > 0) {
    std::string path = obj_dir + "/twinray_bench_blob_" + rest + ".obj";
    write_obj(path, blob_mesh<T>(parse_count(rest), 0));
    auto t0 = std::chrono::steady_clock::now();
    twinray::Mesh<T> mesh = twinray::io::load_obj_mesh<T>(path);
    double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    b = blob_scene<T>(mesh);
    b.load_ms = ms;
  } else {
    throw std::invalid_argument(
        "unknown benchmark scene '" + name +
        "' (demo, demo_4spp, spheres_<N>, mesh_<N>, obj_<N>, forest_<K>x<N>)");
  }
  b.name = name;
  b.camera = demo_camera<T>(width, height);
  return b;
}

// The box around a scene's spheres and meshes, in lo and hi (planes have none; empty,
// lo > hi, where there is neither).
template <class T>
void bounded_box(const twinray::Scene<T>& scene, glm::vec<3, T>& lo, glm::vec<3, T>& hi) {
  lo = glm::vec<3, T>(std::numeric_limits<T>::infinity());
  hi = -lo;
  for (const auto& o : scene.objects) {
    if (auto* s = std::get_if<twinray::Sphere<T>>(&o)) {
      lo = glm::min(lo, s->center - s->radius);
      hi = glm::max(hi, s->center + s->radius);
    } else if (auto* m = std::get_if<twinray::Mesh<T>>(&o)) {
      for (const auto& p : m->vertices) lo = glm::min(lo, p), hi = glm::max(hi, p);
    }
  }
}

// The built-in set.
inline std::vector<std::string> default_scenes() {
  return {"demo",        "demo_4spp", "spheres_1e3", "spheres_1e5",
          "spheres_1e6", "mesh_1e4",  "mesh_1e6",    "obj_1e6"};
}

}  // namespace twinray_bench
