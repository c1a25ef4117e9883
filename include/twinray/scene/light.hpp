// Light<T>: a point light, or an area light (a rectangle or a sphere) that shading sees as
// samples x samples point lights spread over it, each of 1/samples^2 of its intensity,
// placed anew in every path by stratified jitter (device/area_light.h). A point light's
// irradiance at distance d is intensity x color / d^2 (inverse-square law), and so is
// each sample's, over samples^2: a light shrunk to a point becomes the point light of
// the same intensity. Lights are not seen by rays: they light the scene only.
#pragma once

#include <glm/vec3.hpp>

namespace twinray {

enum class LightShape {
  Point = 0,   // at `position`
  Rect = 1,    // the parallelogram position + x edge1 + y edge2, x and y in [0, 1]
  Sphere = 2,  // centered at `position`, of `radius`
};

// An aggregate whose first three members are a point light's: Light<T>{position,
// intensity, color} is one.
template <class T>
struct Light {
  glm::vec<3, T> position{};               // a point's position, a rect's corner, a sphere's center
  T intensity = T(1);                      // >= 0
  glm::vec<3, T> color{T(1), T(1), T(1)};  // linear RGB, >= 0 (above 1 allowed)
  LightShape shape = LightShape::Point;
  glm::vec<3, T> edge1{}, edge2{};  // a rect's edges (not parallel)
  T radius = T(0);                  // a sphere's (> 0)
  int samples = 1;  // an area light's shadow samples per side, in [1, kMaxLightSamples]

  static Light point(glm::vec<3, T> position, T intensity,
                     glm::vec<3, T> color = glm::vec<3, T>(T(1))) {
    Light l;
    l.position = position;
    l.intensity = intensity;
    l.color = color;
    return l;
  }
  static Light rect(glm::vec<3, T> corner, glm::vec<3, T> edge1, glm::vec<3, T> edge2, T intensity,
                    int samples, glm::vec<3, T> color = glm::vec<3, T>(T(1))) {
    Light l = point(corner, intensity, color);
    l.shape = LightShape::Rect;
    l.edge1 = edge1;
    l.edge2 = edge2;
    l.samples = samples;
    return l;
  }
  static Light sphere(glm::vec<3, T> center, T radius, T intensity, int samples,
                      glm::vec<3, T> color = glm::vec<3, T>(T(1))) {
    Light l = point(center, intensity, color);
    l.shape = LightShape::Sphere;
    l.radius = radius;
    l.samples = samples;
    return l;
  }
};

// Shadow samples per side of an area light: at most 64 x 64 shadow rays per light and hit.
constexpr int kMaxLightSamples = 64;
// The samples per side an area light takes where a scene file does not say.
constexpr int kDefaultLightSamples = 4;

// The name lights had when they were points only, kept so that code written with it builds.
template <class T>
using PointLight = Light<T>;

}  // namespace twinray
