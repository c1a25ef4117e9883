// Material<T>: Blinn-Phong coefficients, glaze (mirror) reflectivity and an optional
// diffuse texture.
#pragma once

#include <glm/vec3.hpp>

namespace twinray {

template <class T>
struct Material {
  glm::vec<3, T> color{T(0.8), T(0.8), T(0.8)};  // linear RGB albedo, each channel in [0, 1]
  T ka = T(0.1);                                 // ambient coefficient, >= 0
  T kd = T(0.7);                                 // diffuse coefficient, >= 0
  T ks = T(0.5);                                 // specular coefficient, >= 0
  T shininess = T(65);                           // Blinn-Phong exponent, any real >= 0
  T glaze = T(0);                                // mirror reflectivity in [0, 1]; 0 = not glazed
  // Index into Scene::textures, or -1. With a texture the albedo is color x the texture's
  // value at the hit's uv (device/texture.h); only mesh triangles with uvs have one.
  int texture = -1;
};

}  // namespace twinray
