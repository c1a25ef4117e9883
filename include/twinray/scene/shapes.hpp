// The primitives: Sphere<T>, Triangle<T>, Plane<T> (infinite) and Mesh<T> (indexed
// triangles, with optional vertex normals, texture coordinates and per-triangle materials). Each
// refers to a material by its index in Scene<T>::materials. Positions and lengths are in world
// units; every coordinate must be finite (validate() checks). `mask`: ray queries skip the
// object for a ray whose mask shares no bit with it (docs/ray-queries.md); renders see it.
#pragma once

#include <array>
#include <cstdint>
#include <vector>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

namespace twinray {

template <class T>
struct Sphere {
  glm::vec<3, T> center{};
  T radius = T(1);  // > 0
  int material = 0;
  uint32_t mask = 0xffffffffu;
};

// Two-sided: lit from whichever side is seen.
template <class T>
struct Triangle {
  std::array<glm::vec<3, T>, 3> vertices{};
  int material = 0;
  uint32_t mask = 0xffffffffu;
};

// The infinite plane through `point` with normal `normal` (any non-zero length).
template <class T>
struct Plane {
  glm::vec<3, T> point{};
  glm::vec<3, T> normal{T(0), T(1), T(0)};
  int material = 0;
  uint32_t mask = 0xffffffffu;
};

// Indexed triangle mesh; every triangle gets the mesh's object index. Normals and
// texture coordinates are indexed on their own, as OBJ files index them: triangle f's
// corner k has position vertices[triangles[f][k]], normal normals[normal_triangles[f][k]]
// and uv uvs[uv_triangles[f][k]].
template <class T>
struct Mesh {
  std::vector<glm::vec<3, T>> vertices;
  std::vector<std::array<int, 3>> triangles;  // indices into vertices
  int material = 0;

  // Shading normals (unit length), interpolated across each triangle; the geometric
  // normal still decides intersections and ray offsets. normal_triangles is empty (the
  // mesh is flat) or has one entry per triangle; an entry of {-1, -1, -1} leaves that
  // triangle flat.
  std::vector<glm::vec<3, T>> normals;
  std::vector<std::array<int, 3>> normal_triangles;

  // Texture coordinates (u right, v up, repeating outside [0, 1]); uv_triangles as
  // normal_triangles. A triangle without them reads the texture at (0, 0).
  std::vector<glm::vec<2, T>> uvs;
  std::vector<std::array<int, 3>> uv_triangles;

  // Empty (every triangle takes `material`) or one material index per triangle (an
  // OBJ file's `usemtl` groups).
  std::vector<int> triangle_materials;

  uint32_t mask = 0xffffffffu;

  int material_of(size_t triangle) const {
    return triangle_materials.empty() ? material : triangle_materials[triangle];
  }
};

}  // namespace twinray
