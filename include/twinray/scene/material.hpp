// Material<T>: Blinn-Phong coefficients and glaze (mirror) reflectivity.
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
};

}  // namespace twinray
