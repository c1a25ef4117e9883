// The primitives: Sphere<T>, Triangle<T>, Plane<T> (infinite) and Mesh<T> (indexed
// triangles). Each refers to a material by its index in Scene<T>::materials. Positions
// and lengths are in world units; every coordinate must be finite (validate() checks).
#pragma once

#include <array>
#include <vector>
#include <glm/vec3.hpp>

namespace twinray {

template <class T>
struct Sphere {
  glm::vec<3, T> center{};
  T radius = T(1);  // > 0
  int material = 0;
};

// Two-sided: lit from whichever side is seen.
template <class T>
struct Triangle {
  std::array<glm::vec<3, T>, 3> vertices{};
  int material = 0;
};

// The infinite plane through `point` with normal `normal` (any non-zero length).
template <class T>
struct Plane {
  glm::vec<3, T> point{};
  glm::vec<3, T> normal{T(0), T(1), T(0)};
  int material = 0;
};

// Indexed triangle mesh; every triangle gets the mesh's material and object index.
template <class T>
struct Mesh {
  std::vector<glm::vec<3, T>> vertices;
  std::vector<std::array<int, 3>> triangles;  // indices into vertices
  int material = 0;
};

}  // namespace twinray
