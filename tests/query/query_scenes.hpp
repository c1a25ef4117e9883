// Scenes and rays for the ray-query tests: closed meshes (an icosphere and a torus) at
// any scale, a mixed scene of every shape, and random rays from a fixed seed.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <random>
#include <utility>
#include <vector>

#include <twinray/backend/backend.hpp>
#include <twinray/scene/scene.hpp>

namespace query_test {

template <class T>
using vec3 = glm::vec<3, T>;

// An icosahedron subdivided `levels` times, its vertices pushed onto the sphere of
// radius r around c: closed, every edge shared by exactly two triangles.
template <class T>
twinray::Mesh<T> icosphere(int levels, vec3<T> c, T r) {
  const double t = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<glm::dvec3> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                               {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                               {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (auto& p : v) p = glm::normalize(p);
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<int, int>, int> mid;
    auto midpoint = [&](int a, int b) {
      auto key = std::make_pair(std::min(a, b), std::max(a, b));
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back(glm::normalize(v[a] + v[b]));
      return mid[key] = static_cast<int>(v.size()) - 1;
    };
    std::vector<std::array<int, 3>> next;
    for (const auto& tri : f) {
      int a = midpoint(tri[0], tri[1]), b = midpoint(tri[1], tri[2]), d = midpoint(tri[2], tri[0]);
      next.push_back({tri[0], a, d});
      next.push_back({tri[1], b, a});
      next.push_back({tri[2], d, b});
      next.push_back({a, b, d});
    }
    f = std::move(next);
  }
  twinray::Mesh<T> m;
  for (const auto& p : v) m.vertices.push_back(c + vec3<T>(p) * r);
  m.triangles = f;
  return m;
}

// A torus around the z axis through c: ring radius R, tube radius r, nu x nv quads,
// each two triangles; closed.
template <class T>
twinray::Mesh<T> torus(int nu, int nv, vec3<T> c, T R, T r) {
  twinray::Mesh<T> m;
  const double two_pi = 6.283185307179586;
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      double a = two_pi * i / nu, b = two_pi * j / nv;
      double rr = double(R) + double(r) * std::cos(b);
      m.vertices.push_back(
          c + vec3<T>(T(rr * std::cos(a)), T(rr * std::sin(a)), T(double(r) * std::sin(b))));
    }
  auto at = [&](int i, int j) { return (i % nu) * nv + (j % nv); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      m.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      m.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  return m;
}

// The distinct edges of a mesh, each once.
template <class T>
std::vector<std::pair<int, int>> edges(const twinray::Mesh<T>& m) {
  std::map<std::pair<int, int>, int> seen;
  std::vector<std::pair<int, int>> out;
  for (const auto& tri : m.triangles)
    for (int k = 0; k < 3; ++k) {
      int a = tri[k], b = tri[(k + 1) % 3];
      auto key = std::make_pair(std::min(a, b), std::max(a, b));
      if (seen.emplace(key, 0).second) out.push_back(key);
    }
  return out;
}

// Three draws in order, x first (the order of a call's arguments is the compiler's
// choice, so one expression with three draws gives other points under g++ and clang).
template <class T, class D, class R>
vec3<T> draw3(D& d, R& rng) {
  const T x = T(d(rng)), y = T(d(rng)), z = T(d(rng));
  return vec3<T>(x, y, z);
}

// A scene of every shape: spheres, lone triangles, two meshes (one with vertex normals
// and uvs), a plane, and the triangle of object 3 again as the last object (ties).
template <class T>
twinray::Scene<T> mixed_scene(unsigned seed, int n_spheres = 300) {
  twinray::Scene<T> s;
  s.materials.push_back({});
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-4.0, 4.0), rad(0.05, 0.4);
  s.add(twinray::Plane<T>{vec3<T>(0, -5, 0), vec3<T>(0, 1, 0.125), 0});  // object 0
  s.add(twinray::Triangle<T>{{vec3<T>(-1, -1, 6), vec3<T>(1, -1, 6), vec3<T>(0, 1, 6)}, 0});
  twinray::Mesh<T> ball = icosphere<T>(2, vec3<T>(1.5, 0.5, -1), T(1.25));
  s.add(ball);  // 2
  s.add(twinray::Triangle<T>{{vec3<T>(-6, 2, -6), vec3<T>(6, 2, -6), vec3<T>(0, 2, 6)}, 0});
  twinray::Mesh<T> ring = torus<T>(24, 12, vec3<T>(-2, 0, 0), T(1.5), T(0.5));
  for (size_t i = 0; i < ring.vertices.size(); ++i) {
    ring.normals.push_back(glm::normalize(ring.vertices[i] - vec3<T>(-2, 0, 0)));
    ring.uvs.push_back({T(i % 7) / T(8), T(i % 5) / T(8)});
  }
  ring.normal_triangles = ring.triangles;
  ring.uv_triangles = ring.triangles;
  s.add(ring);  // 4
  for (int i = 0; i < n_spheres; ++i) {
    const vec3<T> c = draw3<T>(u, rng);
    s.add(twinray::Sphere<T>{c, T(rad(rng)), 0});
  }
  // The same triangle as object 3, once more: every ray through it ties.
  s.add(twinray::Triangle<T>{{vec3<T>(-6, 2, -6), vec3<T>(6, 2, -6), vec3<T>(0, 2, 6)}, 0});
  return s;
}

// n random rays: origins in a box around the scene, directions random (not unit),
// tmin 0 and tmax +inf unless `intervals`, then random intervals.
template <class T>
std::vector<twinray::Ray<T>> random_rays(size_t n, unsigned seed, bool intervals = false) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> o(-7.0, 7.0), d(-1.0, 1.0), t(0.0, 12.0);
  std::vector<twinray::Ray<T>> rays(n);
  for (auto& r : rays) {
    vec3<T> dir = draw3<T>(d, rng);
    if (dir == vec3<T>(0)) dir.z = T(1);
    T tmin = T(0), tmax = T(INFINITY);
    if (intervals) {
      tmin = T(t(rng) * 0.25);
      tmax = tmin + T(t(rng));
    }
    const vec3<T> origin = draw3<T>(o, rng);
    r = twinray::make_ray<T>(origin, dir, tmin, tmax);
  }
  return rays;
}

// FNV-1a over bytes: one number for a whole batch's answers.
inline uint64_t fnv1a(const void* data, size_t bytes, uint64_t h = 1469598103934665603ull) {
  const unsigned char* p = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < bytes; ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}

template <class V>
bool same_bytes(const std::vector<V>& a, const std::vector<V>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(V)) == 0;
}

}  // namespace query_test
