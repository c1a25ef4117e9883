// Animation<T>: what moves from frame to frame, evaluated on the host before a frame is
// packed, so every backend renders the same scene for frame K.
//
//   twinray::Animation<float> anim;
//   anim.frames = 120;
//   anim.camera = twinray::Orbit<float>{};           // circle the look-at point
//   anim.camera->center = camera.look_at;
//   anim.camera->angle_step = 0.015f;                 // radians per frame (the seed's)
//   twinray::Orbit<float> circle;                     // objects[0] on a circle
//   anim.paths.push_back({{twinray::object_target(0)}, circle});
//   for (int k = 0; k < anim.frames; ++k) {
//     twinray::Frame<float> f = twinray::animate(scene, camera, anim, k);
//     twinray::Image<float> image = twinray::render(f.scene, f.camera, options);
//   }
//
// Motion is a translation: a path gives a point for every frame, and its targets
// (objects and lights) move together so that their anchor sits on that point. The
// anchor is the center of the axis-aligned box around the targets' points as the
// scene holds them (a sphere's center, the vertices of a triangle or mesh, a plane's
// point, a light's position): a sphere's center, a light's position, a mesh's box
// center follow the path exactly.
//
// Two kinds of path, each evaluated in double and rounded to T once:
// - Orbit (a circle): center + axis * height + radius (cos a e1 + sin a e2) with
//   a = start_angle + angle_step * frame, counter-clockwise seen from the tip of
//   `axis` (right-hand rule). e1 is the unit vector nearest +x that is perpendicular to
//   the axis (nearest +z when the axis is within 26 degrees of x), e2 = axis x e1.
//   For an axis of (0, 1, 0) or (0, -1, 0), angle 0 points along +x.
// - Keyframes: positions at given frames, linear in between; before the first key the
//   first position; after the last one the last position (Repeat::Hold), or the keys
//   again from the first (Loop), or backwards and forwards (Bounce).
// The camera can follow an orbit too; it then looks at `camera_look_at` (default: the
// orbit's center) and keeps its up vector.
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <variant>
#include <vector>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <twinray/core/error.hpp>
#include <twinray/scene/camera.hpp>
#include <twinray/scene/scene.hpp>

namespace twinray {

template <class T>
struct Orbit {
  using vec3 = glm::vec<3, T>;
  vec3 center{};
  vec3 axis{T(0), T(1), T(0)};  // normal of the circle's plane, any non-zero length
  T radius = T(1);              // > 0
  T height = T(0);              // offset of the circle's plane from center, along axis
  T start_angle = T(0);         // radians, at frame 0
  T angle_step = T(0.015);      // radians per frame

  // Unit axis and the in-plane basis e1, e2 described at the top of this file.
  void basis(glm::dvec3& a, glm::dvec3& e1, glm::dvec3& e2) const {
    a = glm::normalize(glm::dvec3(axis));
    glm::dvec3 ref = std::fabs(a.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 0, 1);
    e1 = glm::normalize(ref - a * glm::dot(ref, a));
    e2 = glm::cross(a, e1);
  }

  vec3 point(long long frame) const {
    glm::dvec3 a, e1, e2;
    basis(a, e1, e2);
    double angle = double(start_angle) + double(angle_step) * double(frame);
    glm::dvec3 p = glm::dvec3(center) + a * double(height) +
                   double(radius) * (std::cos(angle) * e1 + std::sin(angle) * e2);
    return vec3(p);
  }

  // Radius, height and start angle that put frame 0 at `p` (keeping center and axis).
  // The radius is 0 when p lies on the axis.
  void pass_through(const vec3& p, bool set_radius, bool set_height, bool set_angle) {
    glm::dvec3 a, e1, e2;
    basis(a, e1, e2);
    glm::dvec3 d = glm::dvec3(p) - glm::dvec3(center);
    double h = glm::dot(d, a);
    glm::dvec3 in_plane = d - a * h;
    if (set_radius) radius = T(glm::length(in_plane));
    if (set_height) height = T(h);
    if (set_angle) start_angle = T(std::atan2(glm::dot(in_plane, e2), glm::dot(in_plane, e1)));
  }
};

enum class Repeat { Hold, Loop, Bounce };

template <class T>
struct Keyframe {
  long long frame = 0;
  glm::vec<3, T> position{};
};

template <class T>
struct Keyframes {
  std::vector<Keyframe<T>> keys;  // at least one, frames strictly increasing
  Repeat repeat = Repeat::Hold;

  glm::vec<3, T> point(long long frame) const {
    if (keys.empty()) throw invalid_input("keyframes: no keys");
    const long long first = keys.front().frame, last = keys.back().frame;
    const long long span = last - first;
    long long f = frame;
    if (span > 0 && repeat != Repeat::Hold && (f < first || f > last)) {
      long long period = repeat == Repeat::Loop ? span : 2 * span;
      long long m = (f - first) % period;
      if (m < 0) m += period;
      f = first + (m <= span ? m : period - m);
    }
    if (f <= first) return keys.front().position;
    if (f >= last) return keys.back().position;
    auto next = std::upper_bound(keys.begin(), keys.end(), f,
                                 [](long long v, const Keyframe<T>& k) { return v < k.frame; });
    const Keyframe<T>& b = *next;
    const Keyframe<T>& a = *(next - 1);
    double t = double(f - a.frame) / double(b.frame - a.frame);
    glm::dvec3 p = glm::dvec3(a.position) + (glm::dvec3(b.position) - glm::dvec3(a.position)) * t;
    return glm::vec<3, T>(p);
  }
};

// What a path moves: objects[index] or lights[index] of the scene.
struct Target {
  enum Kind { Object, Light } kind = Object;
  int index = 0;
  std::string name() const {
    return std::string(kind == Object ? "objects[" : "lights[") + std::to_string(index) + "]";
  }
  bool operator==(const Target& o) const { return kind == o.kind && index == o.index; }
};
inline Target object_target(int index) {
  return Target{Target::Object, index};
}
inline Target light_target(int index) {
  return Target{Target::Light, index};
}

template <class T>
struct Path {
  std::vector<Target> targets;  // moved together
  std::variant<Orbit<T>, Keyframes<T>> motion;

  glm::vec<3, T> point(long long frame) const {
    return std::visit([frame](const auto& m) { return m.point(frame); }, motion);
  }
};

template <class T>
struct Animation {
  int frames = 1;     // >= 1; frames 0 to frames - 1
  double fps = 30.0;  // > 0, for movies and the viewer's playback
  std::optional<Orbit<T>> camera;
  std::optional<glm::vec<3, T>> camera_look_at;  // default: camera->center
  std::vector<Path<T>> paths;
};

template <class T>
struct Frame {
  Scene<T> scene;
  Camera<T> camera;
};

namespace detail {

template <class T>
void check_target(const Scene<T>& scene, const Target& t) {
  size_t count = t.kind == Target::Object ? scene.objects.size() : scene.lights.size();
  if (t.index < 0 || static_cast<size_t>(t.index) >= count)
    throw invalid_input("animation: " + t.name() + " does not exist (the scene has " +
                        std::to_string(count) +
                        (t.kind == Target::Object ? " objects)" : " lights)"));
}

// Calls f(point) for every point that defines where a target is.
template <class T, class F>
void for_each_point(const Scene<T>& scene, const Target& t, F&& f) {
  if (t.kind == Target::Light) return f(scene.lights[t.index].position);
  std::visit(
      [&](const auto& o) {
        using O = std::decay_t<decltype(o)>;
        if constexpr (std::is_same<O, Sphere<T>>::value) {
          f(o.center);
        } else if constexpr (std::is_same<O, Plane<T>>::value) {
          f(o.point);
        } else if constexpr (std::is_same<O, Instance<T>>::value) {
          f(glm::vec<3, T>(o.to_world[3]));  // where the asset's origin is placed
        } else {
          for (const auto& v : o.vertices) f(v);
        }
      },
      scene.objects[t.index]);
}

template <class T>
void translate(Scene<T>& scene, const Target& t, const glm::vec<3, T>& d) {
  if (t.kind == Target::Light) {
    scene.lights[t.index].position += d;
    return;
  }
  std::visit(
      [&](auto& o) {
        using O = std::decay_t<decltype(o)>;
        if constexpr (std::is_same<O, Sphere<T>>::value) {
          o.center += d;
        } else if constexpr (std::is_same<O, Plane<T>>::value) {
          o.point += d;
        } else if constexpr (std::is_same<O, Instance<T>>::value) {
          o.to_world[3] += glm::dvec4(glm::dvec3(d), 0.0);
        } else {
          for (auto& v : o.vertices) v += d;
        }
      },
      scene.objects[t.index]);
}

}  // namespace detail

// The center of the axis-aligned box around the targets' points in `scene`.
template <class T>
glm::vec<3, T> anchor(const Scene<T>& scene, const std::vector<Target>& targets) {
  glm::dvec3 lo(INFINITY), hi(-INFINITY);
  for (const Target& t : targets) {
    detail::check_target(scene, t);
    detail::for_each_point(scene, t, [&](const glm::vec<3, T>& p) {
      lo = glm::min(lo, glm::dvec3(p));
      hi = glm::max(hi, glm::dvec3(p));
    });
  }
  if (!(lo.x <= hi.x)) return glm::vec<3, T>(T(0));
  return glm::vec<3, T>((lo + hi) * 0.5);
}

// Frame `frame` in place: `scene` and `camera` hold a copy of `base` and `base_camera`
// (from any earlier frame too: only what the animation moves is written, from the
// base), so a large static mesh is not copied per frame.
template <class T>
void animate_into(const Scene<T>& base, const Camera<T>& base_camera, const Animation<T>& animation,
                  long long frame, Scene<T>& scene, Camera<T>& camera) {
  if (animation.camera) {
    camera.position = animation.camera->point(frame);
    camera.look_at =
        animation.camera_look_at ? *animation.camera_look_at : animation.camera->center;
    camera.up = base_camera.up;
  }
  for (const Path<T>& path : animation.paths) {
    glm::vec<3, T> d = path.point(frame) - anchor(base, path.targets);
    for (const Target& t : path.targets) {
      // Restore the base, then move: the result does not depend on earlier frames.
      if (t.kind == Target::Light)
        scene.lights[t.index].position = base.lights[t.index].position;
      else
        scene.objects[t.index] = base.objects[t.index];
      detail::translate(scene, t, d);
    }
  }
}

// Whether the animation moves objects (not only the camera and lights): a frame loop
// then packs the scene again for every frame.
template <class T>
bool moves_objects(const Animation<T>& animation) {
  for (const Path<T>& path : animation.paths)
    for (const Target& t : path.targets)
      if (t.kind == Target::Object) return true;
  return false;
}

// Whether every object the animation moves is an instance (scene/instance.hpp), so that
// a frame needs only its top-level BVH built again (pack/pack.hpp, update_instances).
template <class T>
bool moves_only_instances(const Animation<T>& animation, const Scene<T>& scene) {
  for (const Path<T>& path : animation.paths)
    for (const Target& t : path.targets)
      if (t.kind == Target::Object &&
          (t.index < 0 || static_cast<size_t>(t.index) >= scene.objects.size() ||
           !std::holds_alternative<Instance<T>>(scene.objects[static_cast<size_t>(t.index)])))
        return false;
  return true;
}

// The scene and camera of frame `frame` (any integer; an animation is defined beyond
// its `frames`, the count only says how long a movie of it is).
template <class T>
Frame<T> animate(const Scene<T>& base, const Camera<T>& base_camera, const Animation<T>& animation,
                 long long frame) {
  Frame<T> f{base, base_camera};
  animate_into(base, base_camera, animation, frame, f.scene, f.camera);
  return f;
}

}  // namespace twinray
