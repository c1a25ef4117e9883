// The viewer's state and what its keys do, without a window: `twinray view` (SDL2,
// view_window.cpp) turns each key press into a Key and calls ViewController; the tests
// drive the same controller with synthetic keys (tests/apps/view_keys_test.cpp).
//
//   o          orthographic / perspective
//   1 2 3      ambient / diffuse / specular term on or off
//   s  g       shadows, glaze (reflections) on or off
//   b          CPU / OpenCL backend
//   arrows     orbit the camera around its look-at point (left/right: around the up
//              axis; up/down: elevation, kept short of the poles)
//   + -        samples per pixel doubled / halved (1 to 1024)
//   space      play / pause the animation (if the scene has one)
//   p          save the image as a PNG, at full resolution
//   r          back to the scene's camera
//   q  Esc     quit
//
// Responsiveness: after a change the first image is rendered at a reduced resolution
// chosen from the last full render's time, so that it takes about target_ms; the full
// resolution follows when nothing changed meanwhile.
#pragma once

#include <cmath>
#include <string>

#include <glm/geometric.hpp>
#include <twinray/core/options.hpp>
#include <twinray/io/scene_json.hpp>
#include <twinray/scene/animation.hpp>

namespace twinray_cli {
namespace view {

enum class Key {
  Other,
  Projection,  // o
  Ambient,     // 1
  Diffuse,     // 2
  Specular,    // 3
  Shadows,     // s
  Glaze,       // g
  Backend,     // b
  Left,
  Right,
  Up,
  Down,
  MoreSamples,   // + (also = and keypad +)
  FewerSamples,  // - (also keypad -)
  Play,          // space
  Screenshot,    // p
  Reset,         // r
  Quit,          // q, Esc
};

// The key a character stands for ('o' -> Key::Projection); Key::Other for none.
Key key_from_char(char c);

struct ViewState {
  twinray::Projection projection = twinray::Projection::Perspective;
  unsigned terms = twinray::kAllTerms;
  bool shadows = true;
  bool glaze = true;
  twinray::Backend backend = twinray::Backend::Auto;
  int spp = 1;
  double yaw = 0;    // radians around the up axis, added to the scene's camera
  double pitch = 0;  // radians of elevation, added to the scene's camera
  bool playing = false;
  long long frame = 0;  // animation frame shown
  int frames = 0;       // animation frames; 0: the scene has no animation
  double fps = 30;      // animation frames per second
};

constexpr double kOrbitStep = 0.0872664626;  // 5 degrees per arrow press
constexpr int kMaxViewSpp = 1024;

// One job for the renderer: the state to render, at width / divisor x height / divisor.
struct Job {
  ViewState state;
  long long generation = 0;
  int divisor = 1;
};

// What the renderer made of a job.
struct Result {
  long long generation = 0;
  int divisor = 1;
  double ms = 0;  // render time
  twinray::Backend backend = twinray::Backend::Cpu;
  bool failed = false;
  std::string error;
};

// The viewer's logic: keys, what to render next, playback, the title.
class ViewController {
 public:
  explicit ViewController(ViewState initial, double target_ms = 40.0)
      : state_(initial), initial_(initial), target_ms_(target_ms) {}

  // Applies a key press. Returns true when the image changes.
  bool press(Key key);

  // The next job to start, if any, at time `now_s` (seconds, any monotonic clock);
  // call when the renderer is idle. Advances the animation while playing.
  bool next_job(double now_s, Job& job);

  // A finished render. Returns true when it shows the current state.
  bool finish(const Result& result);

  // Reduced-resolution divisor (1, 2, 4 or 8) for a render that takes full_ms at full
  // size, so that it takes about target_ms.
  static int preview_divisor(double full_ms, double target_ms);

  // The window title: scene, backend, frame time and frames per second, settings.
  std::string title(const std::string& scene) const;

  const ViewState& state() const { return state_; }
  bool quit() const { return quit_; }
  long long generation() const { return generation_; }
  // A PNG was asked for and the full-resolution image of the current state is shown.
  bool screenshot_due() const {
    return screenshot_pending_ && shown_generation_ == generation_ && shown_divisor_ == 1;
  }
  void screenshot_done() { screenshot_pending_ = false; }
  const std::string& note() const { return note_; }

 private:
  void changed() { ++generation_; }

  ViewState state_;
  ViewState initial_;
  double target_ms_;
  long long generation_ = 1;
  long long started_generation_ = 0;
  int started_divisor_ = 0;
  long long shown_generation_ = 0;
  int shown_divisor_ = 0;
  double full_ms_ = 0;  // last full-resolution render time; 0: none yet
  double last_ms_ = 0;
  int last_divisor_ = 1;
  double last_advance_s_ = -1;
  bool quit_ = false;
  bool screenshot_pending_ = false;
  bool backend_known_ = false;
  twinray::Backend shown_backend_ = twinray::Backend::Cpu;
  std::string note_;
};

// `base` (the scene as loaded) as the state shows it: frame `state.frame` of the
// animation, the camera turned by yaw and pitch around its look-at point, and the
// projection, terms, shadows, glaze, spp and backend of the state.
template <class T>
void apply_view(const twinray::io::SceneFile<T>& base, const twinray::Animation<T>* animation,
                const ViewState& s, twinray::io::SceneFile<T>& out) {
  using dvec3 = glm::dvec3;
  if (animation)
    twinray::animate_into(base.scene, base.camera, *animation, s.frame, out.scene, out.camera);
  else
    out.camera = base.camera;
  twinray::Camera<T>& c = out.camera;
  if (s.yaw != 0 || s.pitch != 0) {
    dvec3 up = glm::normalize(dvec3(c.up));
    dvec3 d = dvec3(c.position) - dvec3(c.look_at);
    double dist = glm::length(d);
    double h = glm::dot(d, up);
    dvec3 flat = d - up * h;
    double flat_len = glm::length(flat);
    if (flat_len > 0 && dist > 0) {
      dvec3 e1 = flat / flat_len;
      dvec3 e2 = glm::cross(up, e1);
      dvec3 dir = std::cos(s.yaw) * e1 + std::sin(s.yaw) * e2;
      const double limit = 1.4835298642;  // 85 degrees
      double elevation = std::atan2(h, flat_len) + s.pitch;
      elevation = std::fmax(-limit, std::fmin(limit, elevation));
      dvec3 nd = dist * (std::cos(elevation) * dir + std::sin(elevation) * up);
      c.position = glm::vec<3, T>(dvec3(c.look_at) + nd);
    }
  }
  c.projection = s.projection;
  out.options.terms = s.terms;
  out.options.shadows = s.shadows;
  out.options.glaze = s.glaze;
  out.options.spp = s.spp;
  out.options.backend = s.backend;
}

}  // namespace view
}  // namespace twinray_cli
