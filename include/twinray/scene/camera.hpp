// Camera<T>: perspective or orthographic, set up as the original assignment describes.
//   W = normalize(position - look_at), U = normalize(up x W), V = W x U
//   view plane: height viewplane_height, width = height x width/height (pixels)
//   upper left = (position - W focal) - viewplane_u/2 - viewplane_v/2, viewplane_v
//   pointing down the image (row 0 at the top); first pixel center = upper left +
//   (du + dv)/2. Perspective: focal length defaults to |position - look_at|;
//   orthographic: focal length 0 and every ray goes along -W.
#pragma once

#include <cmath>
#include <optional>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

namespace twinray {

enum class Projection { Perspective = 0, Orthographic = 1 };

template <class T>
struct CameraFrame {
  glm::vec<3, T> origin, first_pixel, du, dv, ortho_dir;
  glm::vec<3, T> u, v, w;  // the orthonormal basis
  T focal_length;
};

template <class T>
struct Camera {
  using vec3 = glm::vec<3, T>;
  Projection projection = Projection::Perspective;
  vec3 position{T(4), T(-1), T(5)};  // world units
  vec3 look_at{T(0), T(0), T(-1)};   // world units; differs from position
  vec3 up{T(0), T(-1), T(0)};        // any length, not parallel to look_at - position
  std::optional<T> focal_length;     // perspective only; default |position - look_at|
  T viewplane_height = T(6);         // world units, > 0
  // Pixels, in [1, Limits::max_image_side], width x height <= Limits::max_pixels.
  int width = 400;
  int height = 400;

  T effective_focal_length() const {
    if (projection == Projection::Orthographic) return T(0);
    return focal_length ? *focal_length : glm::length(position - look_at);
  }

  // The view plane and basis. Call validate() (scene/validate.hpp) first: an up vector
  // parallel to the view direction has no basis.
  CameraFrame<T> frame() const {
    CameraFrame<T> f;
    f.w = glm::normalize(position - look_at);
    f.u = glm::normalize(glm::cross(up, f.w));
    f.v = glm::cross(f.w, f.u);
    T vp_height = viewplane_height;
    T vp_width = vp_height * T(width) / T(height);
    vec3 vp_u = f.u * vp_width;
    vec3 vp_v = -f.v * vp_height;
    f.du = vp_u / T(width);
    f.dv = vp_v / T(height);
    f.focal_length = effective_focal_length();
    vec3 upper_left = (position - f.w * f.focal_length) - vp_u / T(2) - vp_v / T(2);
    f.first_pixel = upper_left + (f.du + f.dv) * T(0.5);
    f.origin = position;
    f.ortho_dir = -f.w;
    return f;
  }
};

}  // namespace twinray
