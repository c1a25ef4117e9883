// Animation evaluation (scene/animation.hpp) and the scene file's `animation` section
// (io/animation_json.hpp): positions at given frames, and the loader's errors.
#include <cmath>
#include <string>

#include <doctest/doctest.h>
#include <twinray/io/animation_json.hpp>
#include <twinray/io/scene_json.hpp>
#include <twinray/scene/animation.hpp>

using twinray::Animation;
using twinray::Orbit;
using twinray::Path;
using twinray::Repeat;
using dvec3 = glm::dvec3;

namespace {

void check_near(const glm::vec<3, double>& got, const dvec3& want, double eps = 1e-12) {
  INFO("got (", got.x, ", ", got.y, ", ", got.z, "), want (", want.x, ", ", want.y, ", ", want.z,
       ")");
  CHECK(glm::length(got - want) <= eps);
}

twinray::Scene<double> two_spheres_and_a_light() {
  twinray::Scene<double> s;
  s.add_material({});
  s.add(twinray::Sphere<double>{{1, 0, 0}, 0.5, 0});
  twinray::Triangle<double> t;
  t.vertices = {dvec3(0, 0, 0), dvec3(2, 0, 0), dvec3(0, 4, 0)};
  s.add(t);
  s.add(twinray::Plane<double>{{0, 1, 0}, {0, -1, 0}, 0});
  s.add_light({{-2, -2, 1}, 12, {1, 1, 1}});
  return s;
}

// A scene file around an animation section.
std::string scene_with(const std::string& animation) {
  return R"({ "twinray": 1, "image": { "width": 8, "height": 6 },
    "camera": { "projection": "perspective", "position": [4, -1, 5], "look_at": [0, 0, -1],
                "up": [0, -1, 0] },
    "materials": { "m": {} },
    "lights": [ { "type": "point", "position": [-2, -2, 1], "intensity": 12 } ],
    "objects": [
      { "type": "sphere", "center": [1, 0, -2], "radius": 0.8, "material": "m" },
      { "type": "sphere", "center": [2, 0.2, -0.5], "radius": 0.4, "material": "m" },
      { "type": "triangle", "vertices": [[-1, 0.6, -0.2], [0, 0.6, -0.8], [-2, 0.6, -0.8]],
        "material": "m" },
      { "type": "plane", "point": [0, 1, 0], "normal": [0, -1, 0], "material": "m" } ],
    "animation": )" +
         animation + "}";
}

std::string load_error(const std::string& animation) {
  try {
    twinray::io::parse_scene<double>(scene_with(animation), "t.json");
  } catch (const twinray::Error& e) {
    CHECK(e.kind() == twinray::ErrorKind::InvalidInput);
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST_CASE("orbit: the seed's camera circle with angle += 0.015 per frame") {
  Orbit<double> o;
  o.center = {0, 0, -1};
  o.axis = {0, -1, 0};  // the demo scene's up
  o.radius = 2;
  o.height = 1;
  o.start_angle = 0;
  o.angle_step = 0.015;
  // Angle 0 is +x; with the axis -y, e2 = axis x e1 = +z.
  check_near(o.point(0), {2, -1, -1});
  for (long long k : {1ll, 100ll, 419ll}) {
    double a = 0.015 * double(k);
    check_near(o.point(k), {2 * std::cos(a), -1, -1 + 2 * std::sin(a)});
  }
  // Counter-clockwise seen from the axis tip: with the axis +y, +x turns toward -z.
  o.axis = {0, 1, 0};
  o.height = 0;
  o.start_angle = 0.5 * M_PI;
  check_near(o.point(0), {0, 0, -3});
  // pass_through recovers radius, height and angle of a point.
  Orbit<double> p = o;
  p.pass_through({3, 2, -1}, true, true, true);
  CHECK(p.radius == doctest::Approx(3));
  CHECK(p.height == doctest::Approx(2));
  CHECK(p.start_angle == doctest::Approx(0));
  check_near(p.point(0), {3, 2, -1});
}

TEST_CASE("keyframes: linear in between - hold or loop or bounce outside") {
  twinray::Keyframes<double> k;
  k.keys = {{10, {0, 0, 0}}, {20, {10, 0, 0}}, {30, {10, 20, 0}}};
  check_near(k.point(10), {0, 0, 0});
  check_near(k.point(15), {5, 0, 0});
  check_near(k.point(20), {10, 0, 0});
  check_near(k.point(25), {10, 10, 0});
  check_near(k.point(0), {0, 0, 0});     // hold before
  check_near(k.point(99), {10, 20, 0});  // hold after
  k.repeat = Repeat::Loop;               // period 20
  check_near(k.point(35), {5, 0, 0});
  check_near(k.point(50), {0, 0, 0});
  check_near(k.point(5), {10, 10, 0});
  k.repeat = Repeat::Bounce;  // forwards 10..30, backwards 30..10
  check_near(k.point(35), {10, 10, 0});
  check_near(k.point(45), {5, 0, 0});
  check_near(k.point(50), {0, 0, 0});
  check_near(k.point(55), {5, 0, 0});
  check_near(k.point(5), {5, 0, 0});
}

TEST_CASE("paths move their targets' anchor onto the path - frames do not depend on each other") {
  twinray::Scene<double> scene = two_spheres_and_a_light();
  twinray::Camera<double> camera;
  Animation<double> anim;
  anim.frames = 10;
  Orbit<double> circle;
  circle.center = {0, 0, 0};
  circle.axis = {0, 0, 1};
  circle.radius = 3;
  circle.angle_step = M_PI / 2;  // a quarter turn per frame
  anim.paths.push_back({{twinray::object_target(0)}, circle});
  twinray::Keyframes<double> slide;
  // The triangle and the light move together: the box around the triangle's vertices
  // and the light's position has its center, the anchor, at (0, 1, 0.5).
  slide.keys = {{0, {0, 1, 0.5}}, {4, {4, 1, 0.5}}};
  anim.paths.push_back({{twinray::object_target(1), twinray::light_target(0)}, slide});

  twinray::Frame<double> f = twinray::animate(scene, camera, anim, 1);
  check_near(std::get<twinray::Sphere<double>>(f.scene.objects[0]).center, {0, 3, 0}, 1e-12);
  CHECK(std::get<twinray::Sphere<double>>(f.scene.objects[0]).radius == 0.5);
  const auto& tri = std::get<twinray::Triangle<double>>(f.scene.objects[1]).vertices;
  check_near(tri[0], {1, 0, 0});
  check_near(tri[1], {3, 0, 0});
  check_near(tri[2], {1, 4, 0});
  check_near(f.scene.lights[0].position, {-1, -2, 1});
  // The plane is not animated; the camera neither.
  check_near(std::get<twinray::Plane<double>>(f.scene.objects[2]).point, {0, 1, 0});
  check_near(f.camera.position, camera.position);

  // In place, frame 2 after frame 1 equals frame 2 from the base.
  twinray::animate_into(scene, camera, anim, 2, f.scene, f.camera);
  twinray::Frame<double> g = twinray::animate(scene, camera, anim, 2);
  check_near(std::get<twinray::Sphere<double>>(f.scene.objects[0]).center,
             std::get<twinray::Sphere<double>>(g.scene.objects[0]).center, 0);
  check_near(f.scene.lights[0].position, g.scene.lights[0].position, 0);
  check_near(g.scene.lights[0].position, {0, -2, 1});

  // A target that is not there.
  anim.paths.push_back({{twinray::light_target(3)}, circle});
  CHECK_THROWS_WITH(twinray::animate(scene, camera, anim, 0),
                    "animation: lights[3] does not exist (the scene has 1 lights)");
}

TEST_CASE("scene file: the camera orbit starts at the file's camera and keeps its distance") {
  twinray::io::SceneFile<double> f =
      twinray::io::parse_scene<double>(scene_with(R"({ "frames": 420, "fps": 24,
        "camera": { "type": "orbit", "center": [0, 0, -1], "angle_step": 0.015 } })"),
                                       "t.json");
  Animation<double> anim = twinray::io::parse_animation(f);
  CHECK(anim.frames == 420);
  CHECK(anim.fps == 24);
  REQUIRE(anim.camera);
  CHECK(anim.camera->angle_step == 0.015);
  twinray::Frame<double> f0 = twinray::animate(f.scene, f.camera, anim, 0);
  check_near(f0.camera.position, {4, -1, 5}, 1e-12);
  check_near(f0.camera.look_at, {0, 0, -1}, 0);
  // Radius sqrt(4^2 + 6^2), height 1 along the up axis (0, -1, 0), a = a0 + 0.015 k.
  double r = std::sqrt(52.0), a0 = std::atan2(6.0, 4.0);
  for (long long k : {1ll, 210ll, 419ll}) {
    double a = a0 + 0.015 * double(k);
    twinray::Frame<double> fk = twinray::animate(f.scene, f.camera, anim, k);
    check_near(fk.camera.position, {r * std::cos(a), -1, -1 + r * std::sin(a)}, 1e-12);
    check_near(fk.camera.up, {0, -1, 0}, 0);
  }
}

TEST_CASE("scene file: circle and keyframe paths at given frames - --frame's apply_frame") {
  twinray::io::SceneFile<double> f = twinray::io::parse_scene<double>(scene_with(R"({ "frames": 40,
        "paths": [
          { "target": "objects[1]", "type": "circle", "center": [0, 0.2, 0], "radius": 2,
            "start_angle": 0, "angle_step": 0.25 },
          { "target": ["objects[2]", "lights[0]"], "type": "keyframes", "repeat": "loop",
            "keys": [ { "frame": 0, "position": [-1, -0.7, 0.1] },
                      { "frame": 20, "position": [1, -0.7, 0.1] } ] } ] })"),
                                                                      "t.json");
  twinray::io::SceneFile<double> g = f;
  twinray::io::apply_frame(g, 10);
  // angle 2.5 around -y (the camera's up): (2 cos 2.5, 0.2, 2 sin 2.5)
  check_near(std::get<twinray::Sphere<double>>(g.scene.objects[1]).center,
             {2 * std::cos(2.5), 0.2, 2 * std::sin(2.5)}, 1e-12);
  // The anchor of the triangle and the light (the center of the box around the
  // triangle's vertices and the light, [-1, -0.7, 0.1]) moves by +1 in x at frame 10.
  const auto& tri = std::get<twinray::Triangle<double>>(g.scene.objects[2]).vertices;
  check_near(tri[0], {0, 0.6, -0.2}, 1e-12);
  check_near(tri[2], {-1, 0.6, -0.8}, 1e-12);
  check_near(g.scene.lights[0].position, {-1, -2, 1}, 1e-12);
  // Untouched: objects[0] and the camera.
  check_near(std::get<twinray::Sphere<double>>(g.scene.objects[0]).center, {1, 0, -2}, 0);
  check_near(g.camera.position, {4, -1, 5}, 0);
  // Frames outside the animation are refused.
  twinray::io::SceneFile<double> h = f;
  CHECK_THROWS_WITH(twinray::io::apply_frame(h, 40),
                    "t.json: animation.frames: frame 40 is not in the animation, which has 40 "
                    "frames (0 to 39)");
}

TEST_CASE("scene file: the examples movie1.json and movie2.json load and animate") {
  for (const char* name : {"movie1.json", "movie2.json"}) {
    CAPTURE(name);
    twinray::io::SceneFile<float> f =
        twinray::io::load_scene<float>(std::string(TWINRAY_SCENES_DIR) + "/" + name);
    Animation<float> anim = twinray::io::parse_animation(f);
    CHECK(anim.frames >= 60);
    twinray::Frame<float> a = twinray::animate(f.scene, f.camera, anim, 0);
    twinray::Frame<float> b = twinray::animate(f.scene, f.camera, anim, anim.frames / 4);
    // Something moves.
    CHECK(std::get<twinray::Sphere<float>>(a.scene.objects[2]).center !=
          std::get<twinray::Sphere<float>>(b.scene.objects[2]).center);
  }
  // movie2: three lights, the first moving with intensity 8, two fixed with 4; the
  // camera circles at 0.015 rad per frame.
  twinray::io::SceneFile<float> f =
      twinray::io::load_scene<float>(std::string(TWINRAY_SCENES_DIR) + "/movie2.json");
  Animation<float> anim = twinray::io::parse_animation(f);
  REQUIRE(f.scene.lights.size() == 3);
  CHECK(f.scene.lights[0].intensity == 8);
  CHECK(f.scene.lights[1].intensity == 4);
  CHECK(f.scene.lights[2].intensity == 4);
  REQUIRE(anim.camera);
  CHECK(anim.camera->angle_step == 0.015f);
  twinray::Frame<float> a = twinray::animate(f.scene, f.camera, anim, 0);
  twinray::Frame<float> b = twinray::animate(f.scene, f.camera, anim, 100);
  CHECK(a.scene.lights[0].position != b.scene.lights[0].position);
  CHECK(a.scene.lights[1].position == b.scene.lights[1].position);
  CHECK(a.scene.lights[2].position == b.scene.lights[2].position);
  CHECK(a.camera.position != b.camera.position);
}

TEST_CASE(
    "scene file: a bad animation is refused with the file and the JSON path and the problem") {
  const std::string circle =
      R"({ "target": "objects[0]", "type": "circle", "center": [0, 0, 0], "angle_step": 0.1 })";
  struct Case {
    std::string animation, message;
  } cases[] = {
      {R"({ "fps": 30 })", "t.json: animation.frames: missing (required)"},
      {R"({ "frames": 0 })",
       "t.json: animation.frames: must be an integer in [1, 10000000], got 0"},
      {R"({ "frames": 10, "fps": -1 })", "t.json: animation.fps: must be > 0, got -1"},
      {R"({ "frames": 10, "framez": 3 })",
       "t.json: animation.framez: unknown key (did you mean \"frames\"?); allowed here: frames, "
       "fps, camera, paths"},
      {R"([1, 2])", "t.json: animation: must be an object, got an array of 2"},
      {R"({ "frames": 10, "paths": [)" + circle + R"(,
             { "target": "objects[1]", "type": "circle", "center": [0, 0, 0], "angle_step": 0.1 },
             { "target": "objects[2]", "type": "circle", "center": [0, 0, 0], "radius": -1,
               "angle_step": 0.1 } ] })",
       "t.json: animation.paths[2].radius: must be > 0, got -1"},
      {R"({ "frames": 10, "paths": [ { "target": "objects[9]", "type": "circle",
             "center": [0, 0, 0], "angle_step": 0.1 } ] })",
       "t.json: animation.paths[0].target: objects[9] does not exist: the scene has 4 objects "
       "(objects[0] to objects[3])"},
      {R"({ "frames": 10, "paths": [ { "target": "sphere[0]", "type": "circle",
             "center": [0, 0, 0], "angle_step": 0.1 } ] })",
       "t.json: animation.paths[0].target: must name an object or a light as \"objects[N]\" or "
       "\"lights[N]\", got \"sphere[0]\""},
      {R"({ "frames": 10, "paths": [)" + circle + R"(, { "target": ["lights[0]", "objects[0]"],
             "type": "keyframes", "keys": [ { "frame": 0, "position": [0, 0, 0] } ] } ] })",
       "t.json: animation.paths[1].target[1]: objects[0] is already moved by animation.paths[0] "
       "(one path per object or light)"},
      {R"({ "frames": 10, "paths": [ { "target": "lights[0]", "type": "keyframes",
             "keys": [ { "frame": 5, "position": [0, 0, 0] }, { "frame": 5, "position": [1, 0, 0] } ] } ] })",
       "t.json: animation.paths[0].keys[1].frame: must be greater than the previous key's frame "
       "(5), got 5"},
      {R"({ "frames": 10, "paths": [ { "target": "lights[0]", "type": "keyframes", "keys": [] } ] })",
       "t.json: animation.paths[0].keys: must hold at least one key, got none"},
      {R"({ "frames": 10, "paths": [ { "target": "lights[0]", "type": "keyframes",
             "keys": [ { "frame": 0, "position": [0, 0, 0] } ], "repeat": "pingpong" } ] })",
       "t.json: animation.paths[0].repeat: must be \"hold\", \"loop\", \"bounce\", got "
       "\"pingpong\""},
      {R"({ "frames": 10, "paths": [ { "target": "lights[0]", "type": "spiral" } ] })",
       "t.json: animation.paths[0].type: must be \"circle\", \"keyframes\", got \"spiral\""},
      {R"({ "frames": 10, "paths": [ { "target": "objects[0]", "type": "circle",
             "angle_step": 0.1 } ] })",
       "t.json: animation.paths[0].center: missing (required)"},
      {R"({ "frames": 10, "paths": [ { "target": "objects[0]", "type": "circle",
             "center": [1, 0, -2], "angle_step": 0.1 } ] })",
       "t.json: animation.paths[0].radius: missing, and objects[0] lies on the orbit's axis, so "
       "no radius follows from it; give one"},
      {R"({ "frames": 10, "camera": { "type": "orbit", "axis": [0, 0, 0], "angle_step": 0.1 } })",
       "t.json: animation.camera.axis: must be a non-zero vector of finite length, got [0,0,0]"},
      {R"({ "frames": 10, "camera": { "type": "orbit" } })",
       "t.json: animation.camera.angle_step: missing (required)"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.animation);
    CHECK(load_error(c.animation) == c.message);
  }
}
