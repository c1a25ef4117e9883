// The plain values Python passes with each render: twinray.Camera, twinray.Light and the
// render options of Tracer.render(). Numbers are held in double, as Python has them,
// and rounded to the tracer's precision once per render.
#pragma once

#include <array>
#include <optional>
#include <string>

#include <twinray/core/error.hpp>
#include <twinray/core/options.hpp>
#include <twinray/scene/camera.hpp>
#include <twinray/scene/light.hpp>
#include <twinray/scene/validate.hpp>

namespace twinray_python {

using Vec3 = std::array<double, 3>;

template <class T>
glm::vec<3, T> as_vec(const Vec3& v) {
  return glm::vec<3, T>(static_cast<T>(v[0]), static_cast<T>(v[1]), static_cast<T>(v[2]));
}
inline Vec3 from_vec(const glm::dvec3& v) {
  return {v.x, v.y, v.z};
}

struct CameraSpec {
  Vec3 position{4, -1, 5};
  Vec3 look_at{0, 0, -1};
  Vec3 up{0, -1, 0};
  std::string projection = "perspective";  // or "orthographic"
  double viewplane_height = 6;
  std::optional<double> focal_length;
  int width = 400, height = 400;

  static CameraSpec from(const twinray::Camera<double>& c) {
    CameraSpec s;
    s.position = from_vec(c.position);
    s.look_at = from_vec(c.look_at);
    s.up = from_vec(c.up);
    s.projection =
        c.projection == twinray::Projection::Orthographic ? "orthographic" : "perspective";
    s.viewplane_height = c.viewplane_height;
    s.focal_length = c.focal_length;
    s.width = c.width, s.height = c.height;
    return s;
  }

  template <class T>
  twinray::Camera<T> as() const {
    twinray::Camera<T> c;
    if (projection != "perspective" && projection != "orthographic")
      throw twinray::invalid_input(
          "camera.projection: must be \"perspective\" or "
          "\"orthographic\", got \"" +
          projection + "\"");
    c.projection = projection == "orthographic" ? twinray::Projection::Orthographic
                                                : twinray::Projection::Perspective;
    c.position = as_vec<T>(position);
    c.look_at = as_vec<T>(look_at);
    c.up = as_vec<T>(up);
    c.viewplane_height = static_cast<T>(viewplane_height);
    if (focal_length) c.focal_length = static_cast<T>(*focal_length);
    c.width = width, c.height = height;
    return c;
  }
};

// shape: "point", "rect" (position is the corner) or "sphere" (position is the center).
struct LightSpec {
  Vec3 position{0, 0, 0};
  double intensity = 1;
  Vec3 color{1, 1, 1};
  std::string shape = "point";
  Vec3 edge1{0, 0, 0}, edge2{0, 0, 0};
  double radius = 0;
  int samples = 1;

  static LightSpec from(const twinray::Light<double>& l) {
    LightSpec s{from_vec(l.position), l.intensity, from_vec(l.color)};
    s.shape = l.shape == twinray::LightShape::Rect     ? "rect"
              : l.shape == twinray::LightShape::Sphere ? "sphere"
                                                       : "point";
    s.edge1 = from_vec(l.edge1);
    s.edge2 = from_vec(l.edge2);
    s.radius = l.radius;
    s.samples = l.samples;
    return s;
  }
  // Throws InvalidInput for an unknown shape; the rest is checked with the render.
  template <class T>
  twinray::Light<T> as(size_t i) const {
    twinray::Light<T> l;
    l.position = as_vec<T>(position);
    l.intensity = static_cast<T>(intensity);
    l.color = as_vec<T>(color);
    if (shape == "rect")
      l.shape = twinray::LightShape::Rect;
    else if (shape == "sphere")
      l.shape = twinray::LightShape::Sphere;
    else if (shape != "point")
      throw twinray::invalid_input(twinray::detail::at("lights", i) +
                                   ".shape: must be \"point\", \"rect\" or \"sphere\", got \"" +
                                   shape + "\"");
    l.edge1 = as_vec<T>(edge1);
    l.edge2 = as_vec<T>(edge2);
    l.radius = static_cast<T>(radius);
    l.samples = samples;
    return l;
  }
};

// What Tracer.render() overrides of the scene's render options; a negative number
// leaves the scene's (its file's `render` section, or the library's defaults).
struct RenderSpec {
  int spp = -1, max_depth = -1, shadows = -1, glaze = -1, seed = -1;
  std::string aov = "shaded";
  std::string sampler;  // empty: the scene's

  void apply(twinray::RenderOptions& o) const {
    if (spp >= 0) o.spp = spp;
    if (max_depth >= 0) o.max_depth = max_depth;
    if (shadows >= 0) o.shadows = shadows != 0;
    if (glaze >= 0) o.glaze = glaze != 0;
    if (seed >= 0) o.seed = seed;
    if (!sampler.empty()) {
      if (sampler == "grid")
        o.sampler = twinray::Sampler::Grid;
      else if (sampler == "stratified")
        o.sampler = twinray::Sampler::Stratified;
      else if (sampler == "r2")
        o.sampler = twinray::Sampler::R2;
      else
        throw twinray::invalid_input("sampler: must be \"grid\", \"stratified\" or \"r2\", got \"" +
                                     sampler + "\"");
    }
    if (aov == "shaded")
      o.output = twinray::Output::Shaded;
    else if (aov == "depth")
      o.output = twinray::Output::Depth;
    else if (aov == "normal")
      o.output = twinray::Output::Normal;
    else if (aov == "shading_normal" || aov == "shading-normal")
      o.output = twinray::Output::ShadingNormal;
    else if (aov == "uv")
      o.output = twinray::Output::Uv;
    else if (aov == "object")
      o.output = twinray::Output::ObjectIndex;
    else
      throw twinray::invalid_input(
          "aov: must be one of \"shaded\", \"depth\", \"normal\", "
          "\"shading_normal\", \"uv\", \"object\"; got \"" +
          aov + "\"");
  }
};

}  // namespace twinray_python
