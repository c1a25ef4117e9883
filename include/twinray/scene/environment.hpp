// Environment<T>: an equirectangular image around the scene, seen by the rays that hit
// nothing in place of the background color (device/environment.h says how a direction
// maps onto it). It does not light the scene: in a Whitted model light comes from the
// lights alone.
#pragma once

#include <cmath>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace twinray {

template <class T>
struct Environment {
  int texture = -1;                     // index into Scene::textures; -1: no environment
  T rotate_degrees = T(0);              // turns the map about +y (finite)
  T intensity = T(1);                   // factor on its texels (>= 0)
  glm::vec<3, T> up{T(0), T(1), T(0)};  // the direction the image's top row is seen in (not 0)

  bool enabled() const { return texture >= 0; }

  // The frame a direction is taken into before it is mapped onto the image
  // (device/environment.h): unit up, forward (the part of -z normal to up, or of +x
  // where up is along z) and right = forward x up. Default: +x, +y, -z, exactly.
  struct Frame {
    glm::vec<3, T> right, up, forward;
  };
  Frame frame() const {
    Frame f;
    f.up = glm::normalize(up);
    glm::vec<3, T> minus_z(T(0), T(0), T(-1));
    glm::vec<3, T> guess = std::abs(f.up.z) < T(0.999) ? minus_z : glm::vec<3, T>(T(1), T(0), T(0));
    f.forward = glm::normalize(guess - f.up * glm::dot(guess, f.up));
    f.right = glm::cross(f.forward, f.up);
    return f;
  }
};

}  // namespace twinray
