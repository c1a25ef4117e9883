// Meshes the tests build in code.
#pragma once

#include <array>
#include <cmath>

#include <glm/glm.hpp>

#include <twinray/scene/shapes.hpp>

namespace test_support {

// A latitude-longitude sphere of `rings` x `segments` quads (two triangles each, the
// poles' fans included), counter-clockwise from outside, with uvs (u around, v up).
// Positions repeat along the seam (u = 0 and u = 1), as exported models do.
template <class T>
twinray::Mesh<T> uv_sphere(glm::dvec3 center, double radius, int rings, int segments) {
  twinray::Mesh<T> m;
  const double pi = 3.14159265358979323846;
  for (int r = 0; r <= rings; ++r)
    for (int s = 0; s <= segments; ++s) {
      double theta = pi * r / rings, phi = 2 * pi * s / segments;
      glm::dvec3 d(std::sin(theta) * std::cos(phi), std::cos(theta),
                   -std::sin(theta) * std::sin(phi));
      m.vertices.push_back(glm::vec<3, T>(center + radius * d));
      m.uvs.push_back(glm::vec<2, T>(T(double(s) / segments), T(1.0 - double(r) / rings)));
    }
  auto at = [&](int r, int s) { return r * (segments + 1) + s; };
  for (int r = 0; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      std::array<int, 3> a{at(r, s), at(r + 1, s), at(r + 1, s + 1)};
      std::array<int, 3> b{at(r, s), at(r + 1, s + 1), at(r, s + 1)};
      // The first ring's b and the last ring's a would have two corners at a pole.
      for (const auto& tri : {a, b}) {
        if ((&tri == &a && r + 1 == rings) || (&tri == &b && r == 0)) continue;
        m.triangles.push_back(tri);
        m.uv_triangles.push_back(tri);
      }
    }
  return m;
}

}  // namespace test_support
