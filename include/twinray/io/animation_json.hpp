// The `animation` key of a scene file (docs/scene-format.md, "The `animation` key";
// docs/movies.md for `twinray movie`), read into Animation<T> (scene/animation.hpp)
// with the loader's strict checks: every key known, every value typed and in range,
// every target existing, or twinray::Error(InvalidInput) with
// `FILE: JSON.PATH: problem`, e.g.
//   movie.json: animation.paths[2].radius: must be > 0, got -1
//
//   "animation": {
//     "frames": 240, "fps": 30,
//     "camera": { "type": "orbit", "center": [0, 0, -1], "angle_step": 0.015 },
//     "paths": [
//       { "target": "objects[0]", "type": "circle", "center": [0, 0, -1],
//         "radius": 1.5, "angle_step": 0.05 },
//       { "target": ["objects[3]", "lights[0]"], "type": "keyframes", "repeat": "bounce",
//         "keys": [ { "frame": 0, "position": [-1, 0, 0] },
//                   { "frame": 60, "position": [1, 0, 0] } ] } ] }
//
// The readers take the JsonReader<T> (io/json_read.hpp) of the file being read.
// load_scene() (io/scene_json.hpp) checks the section as it reads the file; code that
// plays it calls parse_animation(file) there, then animate() (scene/animation.hpp), or
// apply_frame() there for one frame.
#pragma once

#include <cmath>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include <glm/geometric.hpp>

#include <twinray/scene/animation.hpp>
#include <twinray/scene/camera.hpp>
#include <twinray/scene/scene.hpp>
#include <twinray/io/json_read.hpp>

namespace twinray {
namespace io {
namespace detail {

// Largest frame count and |frame| of a key: far beyond any movie, small enough that
// angle_step * frame stays exact enough in double.
constexpr long long kMaxAnimationFrames = 10000000;

// "objects[3]" or "lights[0]".
template <class T>
Target read_target(const JsonReader<T>& r, const Json& v, const std::string& path,
                   const Scene<T>& scene) {
  std::string s = r.string(v, path);
  Target t;
  std::string prefix;
  if (s.rfind("objects[", 0) == 0)
    t.kind = Target::Object, prefix = "objects[";
  else if (s.rfind("lights[", 0) == 0)
    t.kind = Target::Light, prefix = "lights[";
  std::string digits = prefix.empty() || s.back() != ']'
                           ? ""
                           : s.substr(prefix.size(), s.size() - prefix.size() - 1);
  bool ok = !digits.empty() && digits.size() <= 9 &&
            digits.find_first_not_of("0123456789") == std::string::npos;
  if (!ok)
    r.fail(path,
           "must name an object or a light as \"objects[N]\" or \"lights[N]\", got \"" + s + "\"");
  t.index = std::stoi(digits);
  size_t count = t.kind == Target::Object ? scene.objects.size() : scene.lights.size();
  if (static_cast<size_t>(t.index) >= count) {
    std::string what = t.kind == Target::Object ? "objects" : "lights";
    r.fail(path, s + " does not exist: the scene has " + std::to_string(count) + " " + what +
                     (count == 0 ? ""
                                 : " (" + what + "[0] to " + what + "[" +
                                       std::to_string(count - 1) + "])"));
  }
  return t;
}

// An orbit's keys; radius, height and start_angle not given come from where `through`
// is (the camera's position, the targets' anchor).
template <class T>
Orbit<T> read_orbit(const JsonReader<T>& r, const Json& o, const std::string& path,
                    const glm::vec<3, T>& default_center, const glm::vec<3, T>& default_axis,
                    const glm::vec<3, T>& through, const std::string& through_name) {
  using R = JsonReader<T>;
  Orbit<T> orbit;
  const Json* center = r.optional(o, "center");
  orbit.center = center ? r.vector3(*center, R::key_path(path, "center")) : default_center;
  orbit.axis = default_axis;
  if (const Json* a = r.optional(o, "axis")) {
    orbit.axis = r.vector3(*a, R::key_path(path, "axis"));
    T len = glm::length(orbit.axis);
    if (!(len > T(0)) || !std::isfinite(len))
      r.fail(R::key_path(path, "axis"),
             "must be a non-zero vector of finite length, got " + show(*a));
  }
  const Json* radius = r.optional(o, "radius");
  const Json* height = r.optional(o, "height");
  const Json* start = r.optional(o, "start_angle");
  orbit.pass_through(through, !radius, !height, !start);
  if (radius) {
    orbit.radius = r.scalar(*radius, R::key_path(path, "radius"), 0.0, INFINITY, true);
  } else if (!(orbit.radius > T(0))) {
    r.fail(R::key_path(path, "radius"),
           "missing, and " + through_name +
               " lies on the orbit's axis, so no radius follows from it; give one");
  }
  if (height) orbit.height = r.scalar(*height, R::key_path(path, "height"));
  if (start) orbit.start_angle = r.scalar(*start, R::key_path(path, "start_angle"));
  orbit.angle_step = r.scalar(r.require(o, path, "angle_step"), R::key_path(path, "angle_step"));
  return orbit;
}

template <class T>
Keyframes<T> read_keyframes(const JsonReader<T>& r, const Json& o, const std::string& path) {
  using R = JsonReader<T>;
  Keyframes<T> k;
  std::string kpath = R::key_path(path, "keys");
  const Json& keys = r.require(o, path, "keys");
  r.require_array(keys, kpath);
  if (keys.empty()) r.fail(kpath, "must hold at least one key, got none");
  for (size_t i = 0; i < keys.size(); ++i) {
    std::string ipath = R::index_path(kpath, i);
    r.require_object(keys[i], ipath);
    r.check_keys(keys[i], ipath, {"frame", "position"});
    Keyframe<T> key;
    key.frame = r.integer(r.require(keys[i], ipath, "frame"), R::key_path(ipath, "frame"),
                          -kMaxAnimationFrames, kMaxAnimationFrames);
    if (!k.keys.empty() && key.frame <= k.keys.back().frame)
      r.fail(R::key_path(ipath, "frame"), "must be greater than the previous key's frame (" +
                                              std::to_string(k.keys.back().frame) + "), got " +
                                              std::to_string(key.frame));
    key.position = r.vector3(r.require(keys[i], ipath, "position"), R::key_path(ipath, "position"));
    k.keys.push_back(key);
  }
  if (const Json* rep = r.optional(o, "repeat")) {
    std::string s = r.choice(*rep, R::key_path(path, "repeat"), {"hold", "loop", "bounce"});
    k.repeat = s == "hold" ? Repeat::Hold : s == "loop" ? Repeat::Loop : Repeat::Bounce;
  }
  return k;
}

// The section, checked against the scene already read from the same file.
template <class T>
Animation<T> read_animation(const JsonReader<T>& r, const Json& a, const Scene<T>& scene,
                            const Camera<T>& camera) {
  using R = JsonReader<T>;
  const std::string path = "animation";
  r.require_object(a, path);
  r.check_keys(a, path, {"frames", "fps", "camera", "paths"});
  Animation<T> anim;
  anim.frames = static_cast<int>(
      r.integer(r.require(a, path, "frames"), "animation.frames", 1, kMaxAnimationFrames));
  if (const Json* fps = r.optional(a, "fps")) {
    anim.fps = static_cast<double>(r.scalar(*fps, "animation.fps", 0.0, INFINITY, true));
    if (anim.fps > 1000) r.fail("animation.fps", "must be at most 1000, got " + show(*fps));
  }
  if (const Json* c = r.optional(a, "camera")) {
    const std::string cpath = "animation.camera";
    r.require_object(*c, cpath);
    r.check_keys(
        *c, cpath,
        {"type", "center", "axis", "radius", "height", "start_angle", "angle_step", "look_at"});
    r.choice(r.require(*c, cpath, "type"), R::key_path(cpath, "type"), {"orbit"});
    anim.camera = read_orbit(r, *c, cpath, camera.look_at, camera.up, camera.position,
                             "the camera's position");
    if (const Json* l = r.optional(*c, "look_at"))
      anim.camera_look_at = r.vector3(*l, R::key_path(cpath, "look_at"));
  }
  if (const Json* p = r.optional(a, "paths")) {
    const std::string ppath = "animation.paths";
    r.require_array(*p, ppath);
    std::vector<std::string> moved_by;  // per target name, the path that moves it
    std::vector<Target> moved;
    for (size_t i = 0; i < p->size(); ++i) {
      std::string ipath = R::index_path(ppath, i);
      const Json& o = (*p)[i];
      r.require_object(o, ipath);
      std::string type = r.choice(r.require(o, ipath, "type"), R::key_path(ipath, "type"),
                                  {"circle", "keyframes"});
      if (type == "circle")
        r.check_keys(
            o, ipath,
            {"target", "type", "center", "axis", "radius", "height", "start_angle", "angle_step"});
      else
        r.check_keys(o, ipath, {"target", "type", "keys", "repeat"});
      Path<T> path_out;
      std::string tpath = R::key_path(ipath, "target");
      const Json& target = r.require(o, ipath, "target");
      std::vector<std::pair<const Json*, std::string>> names;
      if (target.is_array()) {
        if (target.empty()) r.fail(tpath, "must name at least one object or light, got none");
        for (size_t k = 0; k < target.size(); ++k)
          names.emplace_back(&target[k], R::index_path(tpath, k));
      } else {
        names.emplace_back(&target, tpath);
      }
      for (const auto& n : names) {
        Target t = read_target(r, *n.first, n.second, scene);
        for (size_t m = 0; m < moved.size(); ++m)
          if (moved[m] == t)
            r.fail(n.second, t.name() + " is already moved by " + moved_by[m] +
                                 " (one path per object or light)");
        moved.push_back(t);
        moved_by.push_back(ipath);
        path_out.targets.push_back(t);
      }
      if (type == "circle") {
        r.require(o, ipath, "center");
        glm::vec<3, T> at = anchor(scene, path_out.targets);
        std::string what =
            path_out.targets.size() == 1 ? path_out.targets[0].name() : "the targets' anchor";
        path_out.motion = read_orbit(r, o, ipath, at, camera.up, at, what);
      } else {
        path_out.motion = read_keyframes(r, o, ipath);
      }
      anim.paths.push_back(std::move(path_out));
    }
  }
  return anim;
}

}  // namespace detail

// Reads an `animation` object, checked against the scene and camera read from the
// same file; `file` names it in messages. parse_animation(const SceneFile<T>&)
// (io/scene_json.hpp) calls this.
template <class T>
Animation<T> parse_animation(const nlohmann::ordered_json& animation, const std::string& file,
                             const Scene<T>& scene, const Camera<T>& camera) {
  detail::JsonReader<T> reader(file);
  return detail::read_animation(reader, animation, scene, camera);
}

}  // namespace io
}  // namespace twinray
