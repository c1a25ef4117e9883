// The scene of the ray-query examples (lidar.cpp, ambient_occlusion.cpp): a ground
// quad with boxes, pillars and a torus standing on it, every object a mesh. Also the
// --backend option both take.
#pragma once

#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>

#include <twinray/twinray.hpp>

namespace example {

using vec3 = glm::vec3;

// An axis-aligned box from lo to hi, 12 triangles.
inline twinray::Mesh<float> box(vec3 lo, vec3 hi) {
  twinray::Mesh<float> m;
  for (int i = 0; i < 8; ++i)
    m.vertices.push_back({i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z});
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                           {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) {
    m.triangles.push_back({q[0], q[1], q[2]});
    m.triangles.push_back({q[0], q[2], q[3]});
  }
  return m;
}

// A closed cylinder standing on the ground at (x, z): radius r, height h, n sides.
inline twinray::Mesh<float> pillar(float x, float z, float r, float h, int n) {
  twinray::Mesh<float> m;
  for (int i = 0; i < n; ++i) {
    double a = 6.283185307179586 * i / n;
    float cx = x + r * float(std::cos(a)), cz = z + r * float(std::sin(a));
    m.vertices.push_back({cx, 0.0f, cz});
    m.vertices.push_back({cx, h, cz});
  }
  m.vertices.push_back({x, 0.0f, z});
  m.vertices.push_back({x, h, z});
  const int bottom = 2 * n, top = 2 * n + 1;
  for (int i = 0; i < n; ++i) {
    int a = 2 * i, b = 2 * ((i + 1) % n);
    m.triangles.push_back({a, b, b + 1});
    m.triangles.push_back({a, b + 1, a + 1});
    m.triangles.push_back({bottom, b, a});
    m.triangles.push_back({top, a + 1, b + 1});
  }
  return m;
}

// A torus around the vertical axis through c: ring radius R, tube radius r.
inline twinray::Mesh<float> torus(vec3 c, float R, float r, int nu, int nv) {
  twinray::Mesh<float> m;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      double a = 6.283185307179586 * i / nu, b = 6.283185307179586 * j / nv;
      double rr = R + r * std::cos(b);
      m.vertices.push_back(
          c + vec3(float(rr * std::cos(a)), float(r * std::sin(b)), float(rr * std::sin(a))));
    }
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      int a = i * nv + j, b = ((i + 1) % nu) * nv + j;
      int c2 = ((i + 1) % nu) * nv + (j + 1) % nv, d = i * nv + (j + 1) % nv;
      m.triangles.push_back({a, c2, b});
      m.triangles.push_back({a, d, c2});
    }
  return m;
}

inline twinray::Scene<float> street() {
  twinray::Scene<float> s;
  s.materials.push_back({});
  twinray::Mesh<float> ground;
  ground.vertices = {{-30, 0, -30}, {30, 0, -30}, {30, 0, 30}, {-30, 0, 30}};
  ground.triangles = {{0, 2, 1}, {0, 3, 2}};
  s.add(ground);
  s.add(box({-6, 0, -9}, {-2, 3, -5}));
  s.add(box({3, 0, -8}, {9, 5, -4}));
  s.add(box({-9, 0, 2}, {-5, 2, 8}));
  s.add(box({-1.5f, 0, -3.5f}, {0.5f, 1.2f, -2.5f}));
  s.add(pillar(4, 3, 0.4f, 4, 24));
  s.add(pillar(6, 6, 0.6f, 2.5f, 32));
  s.add(pillar(-3, 5, 0.3f, 5, 16));
  s.add(torus({1.5f, 1.0f, 4.0f}, 1.2f, 0.45f, 48, 24));
  return s;
}

// A backend of that kind with the street packed and set: what both examples query.
inline std::unique_ptr<twinray::RenderBackend<float>> street_backend(twinray::Backend kind) {
  twinray::RenderOptions options;
  options.backend = kind;
  auto backend = twinray::make_backend<float>(options);
  backend->set_scene(twinray::share(twinray::pack_scene(street(), backend->pack_options())));
  return backend;
}

// --backend cpu|opencl and --output FILE; false (with a message) for anything else.
inline bool parse_args(int argc, char** argv, twinray::Backend* backend, std::string* output) {
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--backend" && i + 1 < argc) {
      std::string b = argv[++i];
      if (b == "cpu") {
        *backend = twinray::Backend::Cpu;
      } else if (b == "opencl") {
        *backend = twinray::Backend::OpenCL;
      } else {
        std::fprintf(stderr, "--backend: cpu or opencl, got %s\n", b.c_str());
        return false;
      }
    } else if (a == "--output" && i + 1 < argc) {
      *output = argv[++i];
    } else {
      std::fprintf(stderr, "usage: %s [--backend cpu|opencl] [--output FILE]\n", argv[0]);
      return false;
    }
  }
  return true;
}

}  // namespace example
