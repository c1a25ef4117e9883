// The backend interface (backend/backend.hpp): rectangles give the same bits as the
// whole frame on every backend, uniform and adaptive, shaded and AOVs; a backend
// keeps its scene across frames that change only the camera, the lights or the
// options; render_into overwrites whatever image it is given; bad requests are refused.
#include <doctest/doctest.h>

#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include <twinray/scene/demo_scene.hpp>
#include <twinray/twinray.hpp>

#include "backend/parity_util.hpp"

using namespace twinray;

namespace {

std::vector<Backend> backends() {
  std::vector<Backend> b{Backend::Cpu};
  if (opencl_available()) b.push_back(Backend::OpenCL);
  return b;
}

template <class T>
std::unique_ptr<RenderBackend<T>> quiet_backend(Backend which) {
  RenderOptions o;
  o.backend = which;
  o.log = [](const std::string&) {};
  return make_backend<T>(o);
}

// `rect` cut out of a whole frame.
template <class T>
Image<T> crop(const Image<T>& full, const PixelRect& r) {
  Image<T> out(r.width, r.height);
  for (int y = 0; y < r.height; ++y)
    for (int x = 0; x < r.width; ++x)
      for (int c = 0; c < 3; ++c)
        out.rgb[(static_cast<size_t>(y) * r.width + x) * 3 + c] =
            full.rgb[(static_cast<size_t>(r.y + y) * full.width + r.x + x) * 3 + c];
  return out;
}

// Rectangles at the frame's corners and edges (where the adaptive border is clipped),
// inside it, one pixel, one row, and the whole frame given explicitly.
std::vector<PixelRect> rects(int w, int h) {
  return {{0, 0, 16, 16},       {w - 16, h - 16, 16, 16}, {0, h - 5, w, 5}, {17, 9, 23, 31},
          {w / 2, h / 2, 1, 1}, {w - 1, 0, 1, h},         {5, 0, 40, 1},    {0, 0, w, h}};
}

template <class T>
void check_rects(const RenderOptions& options) {
  auto d = demo::make_demo_scene<T>(72, 56);
  for (Backend b : backends()) {
    INFO("backend " << to_string(b));
    auto renderer = quiet_backend<T>(b);
    renderer->set_scene(share(pack_scene(d.scene)));
    Image<T> full = renderer->render({d.camera, d.scene.lights, options});
    for (const PixelRect& r : rects(d.camera.width, d.camera.height)) {
      INFO("rect " << r.x << "," << r.y << " " << r.width << "x" << r.height);
      Image<T> part = renderer->render({d.camera, d.scene.lights, options, r});
      CHECK(part.width == r.width);
      CHECK(part.height == r.height);
      CHECK(test::differing_values(part, crop(full, r)) == 0);
    }
  }
}

}  // namespace

TEST_CASE_TEMPLATE("backend: a rectangle has the whole frame's bits (uniform, 2 spp)", T, float,
                   double) {
  RenderOptions o;
  o.spp = 2;
  o.sampler = Sampler::Stratified;
  check_rects<T>(o);
}

TEST_CASE_TEMPLATE("backend: a rectangle has the whole frame's bits (adaptive grid 1 to 4)", T,
                   float, double) {
  RenderOptions o;
  o.spp = 1;
  o.adaptive_spp = 4;
  o.adaptive_threshold = 1.0 / 64;
  check_rects<T>(o);
}

TEST_CASE_TEMPLATE("backend: a rectangle has the whole frame's bits (adaptive R2 2 to 8)", T, float,
                   double) {
  RenderOptions o;
  o.spp = 2;
  o.adaptive_spp = 8;
  o.sampler = Sampler::R2;
  check_rects<T>(o);
}

TEST_CASE("backend: a rectangle has the whole frame's bits (depth, normal and object AOVs)") {
  for (Output out : {Output::Depth, Output::Normal, Output::ObjectIndex}) {
    RenderOptions o;
    o.output = out;
    check_rects<float>(o);
  }
}

TEST_CASE("backend: adaptive rectangles refine exactly the whole frame's pixels there") {
  auto d = demo::make_demo_scene<float>(64, 48);
  RenderOptions o;
  o.spp = 1;
  o.adaptive_spp = 4;
  for (Backend b : backends()) {
    auto renderer = quiet_backend<float>(b);
    renderer->set_scene(share(pack_scene(d.scene)));
    RenderInfo whole, left, right;
    renderer->render({d.camera, d.scene.lights, o}, &whole);
    renderer->render({d.camera, d.scene.lights, o, PixelRect{0, 0, 30, 48}}, &left);
    renderer->render({d.camera, d.scene.lights, o, PixelRect{30, 0, 34, 48}}, &right);
    CHECK(whole.refined_pixels > 0);
    CHECK(left.refined_pixels + right.refined_pixels == whole.refined_pixels);
    CHECK(left.samples + right.samples == whole.samples);
  }
}

TEST_CASE_TEMPLATE("backend: frames that move the camera and lights reuse the scene", T, float,
                   double) {
  auto d = demo::make_demo_scene<T>(48, 40);
  for (Backend b : backends()) {
    INFO("backend " << to_string(b));
    auto renderer = quiet_backend<T>(b);
    renderer->set_scene(share(pack_scene(d.scene)));
    RenderOptions o;
    o.backend = b;
    o.log = [](const std::string&) {};
    for (int frame = 0; frame < 3; ++frame) {
      d.camera.position.x += T(0.3);
      d.scene.lights[0].position.y -= T(0.2);
      o.shadows = frame != 1;
      o.spp = 1 + frame;
      RenderInfo info;
      Image<T> image = renderer->render({d.camera, d.scene.lights, o}, &info);
      CHECK(info.scene_uploaded == (b == Backend::OpenCL && frame == 0));
      // The same frame rendered from scratch (packed and uploaded anew).
      CHECK(test::differing_values(image, render(d.scene, d.camera, o)) == 0);
    }
  }
}

TEST_CASE("backend: a new scene replaces the old one") {
  auto d = demo::make_demo_scene<float>(40, 30);
  for (Backend b : backends()) {
    auto renderer = quiet_backend<float>(b);
    renderer->set_scene(share(pack_scene(d.scene)));
    Image<float> before = renderer->render({d.camera, d.scene.lights, RenderOptions{}});
    Scene<float> moved = d.scene;
    std::get<Sphere<float>>(moved.objects[0]).center.x += 0.5f;
    renderer->set_scene(share(pack_scene(moved)));
    RenderInfo info;
    Image<float> after = renderer->render({d.camera, moved.lights, RenderOptions{}}, &info);
    CHECK(info.scene_uploaded == (b == Backend::OpenCL));
    CHECK(test::differing_values(before, after) > 0);
    CHECK(test::differing_values(after, render(moved, d.camera, RenderOptions{})) == 0);
  }
}

TEST_CASE("backend: bad requests are refused before anything renders") {
  auto d = demo::make_demo_scene<float>(32, 32);
  for (Backend b : backends()) {
    auto renderer = quiet_backend<float>(b);
    CHECK_THROWS_WITH_AS(renderer->render({d.camera, d.scene.lights, RenderOptions{}}),
                         doctest::Contains("no scene"), Error);
    renderer->set_scene(share(pack_scene(d.scene)));
    for (PixelRect r : {PixelRect{-1, 0, 4, 4}, PixelRect{30, 0, 4, 4}, PixelRect{0, 29, 4, 4}}) {
      CHECK_THROWS_WITH_AS(renderer->render({d.camera, d.scene.lights, RenderOptions{}, r}),
                           doctest::Contains("is not inside the 32 x 32 frame"), Error);
    }
    RenderOptions bad;
    bad.adaptive_spp = 1;  // not more than spp
    CHECK_THROWS_WITH_AS(renderer->render({d.camera, d.scene.lights, bad}),
                         doctest::Contains("render.adaptive.spp"), Error);
    std::vector<Light<float>> dark = d.scene.lights;
    dark[0].intensity = -1;
    CHECK_THROWS_WITH_AS(renderer->render({d.camera, dark, RenderOptions{}}),
                         doctest::Contains("lights[0].intensity"), Error);
  }
}

// render_into reuses the caller's image: whatever it held before (other values, another
// size, a larger or smaller buffer), the result is the bits of a fresh render().
template <class T>
void check_render_into(const RenderOptions& options) {
  auto d = demo::make_demo_scene<T>(64, 48);
  for (Backend b : backends()) {
    INFO("backend " << to_string(b));
    auto renderer = quiet_backend<T>(b);
    renderer->set_scene(share(pack_scene(d.scene)));
    const RenderRequest<T> whole{d.camera, d.scene.lights, options, {}};
    const PixelRect r{7, 5, 20, 13};
    const RenderRequest<T> part{d.camera, d.scene.lights, options, r};
    const Image<T> expected = renderer->render(whole);
    const Image<T> expected_part = renderer->render(part);

    Image<T> image(64, 48);
    std::fill(image.rgb.begin(), image.rgb.end(), T(-7.5));  // stale values everywhere
    renderer->render_into(whole, image);
    CHECK(test::differing_values(image, expected) == 0);
    renderer->render_into(part, image);  // shrinks
    CHECK(image.width == r.width);
    CHECK(image.height == r.height);
    CHECK(test::differing_values(image, expected_part) == 0);
    renderer->render_into(whole, image);  // grows again
    CHECK(test::differing_values(image, expected) == 0);

    Image<T> larger(200, 100);
    std::fill(larger.rgb.begin(), larger.rgb.end(), T(3));
    renderer->render_into(whole, larger);
    CHECK(test::differing_values(larger, expected) == 0);

    // A refused request leaves the image as it was.
    const Image<T> kept = image;
    CHECK_THROWS_AS(
        renderer->render_into({d.camera, d.scene.lights, options, PixelRect{60, 0, 8, 8}}, image),
        Error);
    CHECK(test::differing_values(image, kept) == 0);
  }
}

TEST_CASE_TEMPLATE("backend: render_into a reused image gives a fresh render's bits", T, float,
                   double) {
  RenderOptions uniform;
  uniform.spp = 2;
  check_render_into<T>(uniform);
  RenderOptions adaptive;
  adaptive.spp = 1;
  adaptive.adaptive_spp = 4;
  check_render_into<T>(adaptive);
  RenderOptions depth;
  depth.output = Output::Depth;
  check_render_into<T>(depth);
}
