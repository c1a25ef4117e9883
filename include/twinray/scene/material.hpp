// Material<T>: Blinn-Phong coefficients, glaze (mirror) reflectivity, transmission (glass)
// and an optional diffuse texture.
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
  // A dielectric (glass, water): the share of light that crosses the surface, in
  // [0, 1 - glaze]; 0 = opaque. Of it, the Fresnel reflectance F is reflected and 1 - F
  // refracted by Snell's law (device/dielectric.h).
  T transmission = T(0);
  T ior = T(1.5);  // index of refraction inside, > 0 (outside is air, 1)
  // Beer-Lambert absorption inside, per world unit and channel, >= 0: light that has
  // crossed a length d inside keeps e^(-absorption d).
  glm::vec<3, T> absorption{T(0), T(0), T(0)};
  // Index into Scene::textures, or -1. With a texture the albedo is color x the texture's
  // value at the hit's uv (device/texture.h); only mesh triangles with uvs have one.
  int texture = -1;
};

}  // namespace twinray
