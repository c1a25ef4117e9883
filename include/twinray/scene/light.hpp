// PointLight<T>: an isotropic point light. Its irradiance at distance d is
// intensity x color / d^2 (inverse-square law), see device/shading.h.
#pragma once

#include <glm/vec3.hpp>

namespace twinray {

template <class T>
struct PointLight {
  glm::vec<3, T> position{};
  T intensity = T(1);                      // >= 0
  glm::vec<3, T> color{T(1), T(1), T(1)};  // linear RGB, >= 0 (above 1 allowed)
};

}  // namespace twinray
