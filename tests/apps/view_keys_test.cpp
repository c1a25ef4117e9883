// The viewer's key handling and scheduling (apps/twinray/view_controls.hpp),
// driven by synthetic key presses without a window: the code `twinray view` runs for
// every SDL key event.
#include <cmath>
#include <string>

#include <doctest/doctest.h>
#include <twinray/io/animation_json.hpp>

#include "twinray/view_controls.hpp"

using twinray_cli::view::Job;
using twinray_cli::view::Key;
using twinray_cli::view::key_from_char;
using twinray_cli::view::Result;
using twinray_cli::view::ViewController;
using twinray_cli::view::ViewState;

namespace {

twinray::io::SceneFile<float> movie1() {
  return twinray::io::load_scene<float>(std::string(TWINRAY_SCENES_DIR) + "/movie1.json");
}

// What the window would render for the controller's state.
twinray::io::SceneFile<float> shown(const twinray::io::SceneFile<float>& base,
                                    const twinray::Animation<float>* anim,
                                    const ViewController& c) {
  twinray::io::SceneFile<float> out = base;
  twinray_cli::view::apply_view(base, anim, c.state(), out);
  return out;
}

// Presses the keys a string stands for, as the window does for each SDL key event.
void type(ViewController& c, const std::string& keys) {
  for (char k : keys) c.press(key_from_char(k));
}

}  // namespace

TEST_CASE("keys: characters map to the viewer's keys") {
  CHECK(key_from_char('o') == Key::Projection);
  CHECK(key_from_char('1') == Key::Ambient);
  CHECK(key_from_char('2') == Key::Diffuse);
  CHECK(key_from_char('3') == Key::Specular);
  CHECK(key_from_char('s') == Key::Shadows);
  CHECK(key_from_char('g') == Key::Glaze);
  CHECK(key_from_char('b') == Key::Backend);
  CHECK(key_from_char('+') == Key::MoreSamples);
  CHECK(key_from_char('=') == Key::MoreSamples);
  CHECK(key_from_char('-') == Key::FewerSamples);
  CHECK(key_from_char(' ') == Key::Play);
  CHECK(key_from_char('q') == Key::Quit);
  CHECK(key_from_char(27) == Key::Quit);
  CHECK(key_from_char('x') == Key::Other);
}

TEST_CASE("keys: o toggles orthographic/perspective in the camera that is rendered") {
  twinray::io::SceneFile<float> base = movie1();
  ViewState s;
  s.projection = base.camera.projection;
  ViewController c(s);
  CHECK(shown(base, nullptr, c).camera.projection == twinray::Projection::Perspective);
  long long g = c.generation();
  CHECK(c.press(Key::Projection));
  CHECK(c.generation() == g + 1);
  CHECK(shown(base, nullptr, c).camera.projection == twinray::Projection::Orthographic);
  CHECK(c.title("movie1.json").find("orthographic") != std::string::npos);
  type(c, "o");
  CHECK(shown(base, nullptr, c).camera.projection == twinray::Projection::Perspective);
  CHECK(c.title("movie1.json").find("perspective") != std::string::npos);
}

TEST_CASE("keys: 1 2 3 terms - s shadows - g glaze - + - samples per pixel") {
  twinray::io::SceneFile<float> base = movie1();
  ViewController c(ViewState{});
  type(c, "1");
  CHECK(shown(base, nullptr, c).options.terms == (twinray::kDiffuse | twinray::kSpecular));
  type(c, "23");
  CHECK(shown(base, nullptr, c).options.terms == 0u);
  CHECK(c.title("x").find("terms none") != std::string::npos);
  type(c, "123");
  CHECK(shown(base, nullptr, c).options.terms == twinray::kAllTerms);
  type(c, "s");
  CHECK_FALSE(shown(base, nullptr, c).options.shadows);
  type(c, "g");
  CHECK_FALSE(shown(base, nullptr, c).options.glaze);
  type(c, "sg");
  CHECK(shown(base, nullptr, c).options.shadows);
  CHECK(shown(base, nullptr, c).options.glaze);
  type(c, "++");
  CHECK(shown(base, nullptr, c).options.spp == 4);
  type(c, "-");
  CHECK(shown(base, nullptr, c).options.spp == 2);
  type(c, "---");
  CHECK(c.state().spp == 1);
  CHECK_FALSE(c.press(Key::FewerSamples));  // nothing to change: no new render
  for (int i = 0; i < 20; ++i) c.press(Key::MoreSamples);
  CHECK(c.state().spp == twinray_cli::view::kMaxViewSpp);
  type(c, "q");
  CHECK(c.quit());
}

TEST_CASE("keys: b switches the backend away from the one that rendered") {
  ViewController c(ViewState{});  // backend auto
  Job job;
  REQUIRE(c.next_job(0, job));
  Result r;
  r.generation = job.generation;
  r.divisor = job.divisor;
  r.backend = twinray::Backend::OpenCL;  // auto chose OpenCL
  c.finish(r);
  type(c, "b");
  CHECK(c.state().backend == twinray::Backend::Cpu);
  REQUIRE(c.next_job(0, job));
  CHECK(job.state.backend == twinray::Backend::Cpu);
  r.generation = job.generation;
  r.divisor = job.divisor;
  r.backend = twinray::Backend::Cpu;
  c.finish(r);
  CHECK(c.title("x").find("| cpu |") != std::string::npos);
  type(c, "b");
  CHECK(c.state().backend == twinray::Backend::OpenCL);
  // OpenCL fails (no device): back to the CPU, and the title says why.
  REQUIRE(c.next_job(0, job));
  Result failed;
  failed.generation = job.generation;
  failed.failed = true;
  failed.error = "no OpenCL device found";
  c.finish(failed);
  CHECK(c.state().backend == twinray::Backend::Cpu);
  CHECK(c.title("x").find("no OpenCL device found") != std::string::npos);
}

TEST_CASE("keys: arrows orbit the camera around its look-at point short of the poles") {
  twinray::io::SceneFile<float> base = movie1();
  ViewController c(ViewState{});
  const glm::vec3 look = base.camera.look_at;
  const float dist = glm::length(base.camera.position - look);
  for (Key k : {Key::Right, Key::Left, Key::Up, Key::Down}) {
    ViewController one(ViewState{});
    CHECK(one.press(k));
    twinray::io::SceneFile<float> f = shown(base, nullptr, one);
    CHECK(glm::length(f.camera.position - look) == doctest::Approx(dist).epsilon(1e-5));
    CHECK(glm::length(f.camera.position - base.camera.position) > 0.1f);
    CHECK(f.camera.look_at == look);
  }
  // Right then left is where it started.
  type(c, "");
  c.press(Key::Right);
  c.press(Key::Left);
  twinray::io::SceneFile<float> back = shown(base, nullptr, c);
  CHECK(glm::length(back.camera.position - base.camera.position) < 1e-5f);
  // Up many times: stays 5 degrees short of the up axis, and the camera stays valid.
  for (int i = 0; i < 40; ++i) c.press(Key::Up);
  twinray::io::SceneFile<float> top = shown(base, nullptr, c);
  glm::vec3 d = glm::normalize(top.camera.position - look);
  glm::vec3 up = glm::normalize(base.camera.up);
  CHECK(glm::dot(d, up) == doctest::Approx(std::sin(85.0 * M_PI / 180.0)).epsilon(1e-4));
  // r resets the camera.
  type(c, "r");
  CHECK(glm::length(shown(base, nullptr, c).camera.position - base.camera.position) < 1e-6f);
}

TEST_CASE("responsive: a reduced-resolution image first and then the full one") {
  CHECK(ViewController::preview_divisor(10, 40) == 1);
  CHECK(ViewController::preview_divisor(100, 40) == 2);
  CHECK(ViewController::preview_divisor(500, 40) == 4);
  CHECK(ViewController::preview_divisor(1e6, 40) == 8);
  ViewController c(ViewState{}, 40);
  Job job;
  REQUIRE(c.next_job(0, job));
  CHECK(job.divisor == 4);          // speed unknown: a quarter first
  CHECK_FALSE(c.next_job(0, job));  // (the window asks only when idle; nothing new)
  Result r;
  r.generation = job.generation;
  r.divisor = 4;
  r.ms = 20;  // a full render would take about 320 ms
  CHECK(c.finish(r));
  REQUIRE(c.next_job(0, job));
  CHECK(job.divisor == 1);
  r.divisor = 1;
  r.ms = 320;
  CHECK(c.finish(r));
  CHECK_FALSE(c.next_job(0, job));  // done until something changes
  type(c, "o");
  REQUIRE(c.next_job(0, job));
  CHECK(job.divisor == 4);  // 320 ms / 16 = 20 ms <= 40 ms
  CHECK(job.state.projection == twinray::Projection::Orthographic);
  // A result of an older state is shown but is not the current one.
  type(c, "s");
  r.generation = job.generation;
  r.divisor = 4;
  CHECK_FALSE(c.finish(r));
}

TEST_CASE("screenshot: p waits for the full-resolution image of the current state") {
  ViewController c(ViewState{});
  type(c, "p");
  CHECK_FALSE(c.screenshot_due());
  Job job;
  REQUIRE(c.next_job(0, job));
  Result r;
  r.generation = job.generation;
  r.divisor = job.divisor;
  r.ms = 1;
  c.finish(r);
  CHECK_FALSE(c.screenshot_due());  // a preview only
  REQUIRE(c.next_job(0, job));
  r.divisor = 1;
  c.finish(r);
  CHECK(c.screenshot_due());
  c.screenshot_done();
  CHECK_FALSE(c.screenshot_due());
}

TEST_CASE("space plays the animation: frames advance at the animation's rate") {
  twinray::io::SceneFile<float> base = movie1();
  twinray::Animation<float> anim = twinray::io::parse_animation(base);
  ViewState s;
  s.frames = anim.frames;
  s.fps = 10;
  ViewController c(s, 1000);
  Job job;
  REQUIRE(c.next_job(0, job));
  Result r;
  r.generation = job.generation;
  r.divisor = job.divisor;
  r.ms = 1;
  c.finish(r);
  REQUIRE(c.next_job(0, job));  // full size
  r.divisor = 1;
  c.finish(r);
  type(c, " ");
  CHECK(c.state().playing);
  REQUIRE(c.next_job(1.0, job));
  CHECK(job.state.frame == 1);
  r.generation = job.generation;
  c.finish(r);
  CHECK_FALSE(c.next_job(1.05, job));  // 1/10 s not yet over
  REQUIRE(c.next_job(1.11, job));
  CHECK(job.state.frame == 2);
  // The frame's scene is what the animation gives for it.
  twinray::io::SceneFile<float> f = base;
  twinray_cli::view::apply_view(base, &anim, job.state, f);
  twinray::Frame<float> want = twinray::animate(base.scene, base.camera, anim, 2);
  CHECK(std::get<twinray::Sphere<float>>(f.scene.objects[2]).center ==
        std::get<twinray::Sphere<float>>(want.scene.objects[2]).center);
  CHECK(c.title("x").find("frame 2/120 playing") != std::string::npos);
  type(c, " ");
  CHECK_FALSE(c.state().playing);
  // A scene without an animation: space says so and changes nothing.
  ViewController still(ViewState{});
  CHECK_FALSE(still.press(Key::Play));
  CHECK_FALSE(still.state().playing);
  CHECK(still.title("x").find("no animation") != std::string::npos);
}

TEST_CASE("screenshot while playing: the frame shown is finished at full size first") {
  ViewState s;
  s.frames = 10;
  s.fps = 10;
  ViewController c(s, 40);
  Job job;
  Result r;
  REQUIRE(c.next_job(0, job));
  r.generation = job.generation;
  r.divisor = job.divisor;  // 4
  r.ms = 20;
  c.finish(r);
  REQUIRE(c.next_job(0, job));
  r.divisor = job.divisor;  // 1
  r.ms = 320;
  c.finish(r);
  type(c, " ");
  REQUIRE(c.next_job(1.0, job));
  CHECK(job.state.frame == 1);
  CHECK(job.divisor == 4);  // playing stays at the reduced size
  r.generation = job.generation;
  r.divisor = 4;
  c.finish(r);
  type(c, "p");
  REQUIRE(c.next_job(1.5, job));
  CHECK(job.state.frame == 1);  // not the next frame yet
  CHECK(job.divisor == 1);
  r.divisor = 1;
  c.finish(r);
  CHECK(c.screenshot_due());
  c.screenshot_done();
  REQUIRE(c.next_job(1.6, job));
  CHECK(job.state.frame == 2);
  CHECK(job.divisor == 4);
}
