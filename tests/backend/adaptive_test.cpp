// Adaptive anti-aliasing (device/adaptive.h, inside each backend): the same bits on
// both backends, in float and double, for every sampler; each pixel is exactly the
// uniform render at spp or at adaptive_spp; the criterion refines edges, not
// everything.
#include <doctest/doctest.h>

#include <cstring>
#include <string>

#include <twinray/twinray.hpp>

#include <twinray/scene/demo_scene.hpp>

using namespace twinray;

namespace {

constexpr int kW = 64, kH = 48;

template <class T>
Image<T> render_on(const twinray::demo::DemoSetup<T>& d, RenderOptions o, Backend b,
                   RenderInfo* info = nullptr) {
  o.backend = b;
  o.log = [](const std::string&) {};
  return render(d.scene, d.camera, o, info);
}

template <class T>
bool same_pixel(const Image<T>& a, const Image<T>& b, int x, int y) {
  return std::memcmp(a.pixel(x, y), b.pixel(x, y), 3 * sizeof(T)) == 0;
}

template <class T>
size_t differing_values(const Image<T>& a, const Image<T>& b) {
  size_t n = 0;
  for (size_t i = 0; i < a.rgb.size(); ++i) n += std::memcmp(&a.rgb[i], &b.rgb[i], sizeof(T)) != 0;
  return n;
}

}  // namespace

TEST_CASE_TEMPLATE("adaptive: every pixel is the uniform render at spp or at adaptive_spp", T,
                   float, double) {
  auto d = twinray::demo::make_demo_scene<T>(kW, kH);
  for (Sampler sampler : {Sampler::Grid, Sampler::Stratified, Sampler::R2}) {
    CAPTURE(to_string(sampler));
    RenderOptions o;
    o.sampler = sampler;
    o.seed = 5;
    o.spp = 4;
    RenderOptions hi = o;
    hi.spp = 16;
    Image<T> low = render_on(d, o, Backend::Cpu);
    Image<T> high = render_on(d, hi, Backend::Cpu);
    o.adaptive_spp = 16;
    RenderInfo info;
    Image<T> a = render_on(d, o, Backend::Cpu, &info);
    long long refined = 0, mismatched = 0;
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        bool is_low = same_pixel(a, low, x, y), is_high = same_pixel(a, high, x, y);
        if (is_high && !is_low) ++refined;
        if (!is_low && !is_high) ++mismatched;
      }
    CHECK(mismatched == 0);
    // The demo has silhouettes, shadow edges and highlights, and large smooth areas.
    CHECK(info.refined_pixels > kW * kH / 50);
    CHECK(info.refined_pixels < kW * kH / 2);
    CHECK(refined <= info.refined_pixels);
    CHECK(refined > info.refined_pixels / 2);  // refining changed those pixels
    CHECK(info.samples == sample_plan::samples_traced(o, kW * kH, info.refined_pixels));
  }
}

TEST_CASE("adaptive: threshold 0 refines every pixel that is not flat, a huge one none") {
  auto d = twinray::demo::make_demo_scene<float>(kW, kH);
  RenderOptions o;
  o.sampler = Sampler::R2;
  o.spp = 2;
  o.adaptive_spp = 8;
  RenderOptions hi = o;
  hi.adaptive_spp = 0;
  hi.spp = 8;
  RenderInfo info;
  o.adaptive_threshold = 1e20;
  RenderOptions lo = o;
  lo.adaptive_spp = 0;
  CHECK(differing_values(render_on(d, o, Backend::Cpu, &info), render_on(d, lo, Backend::Cpu)) ==
        0);
  CHECK(info.refined_pixels == 0);
  o.adaptive_threshold = 0;
  Image<float> all = render_on(d, o, Backend::Cpu, &info);
  CHECK(info.refined_pixels > kW * kH / 2);
  Image<float> uniform = render_on(d, hi, Backend::Cpu);
  long long equal = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) equal += same_pixel(all, uniform, x, y);
  CHECK(equal >= info.refined_pixels);
}

TEST_CASE("adaptive: settings that make no sense are refused") {
  auto d = twinray::demo::make_demo_scene<float>(8, 8);
  RenderOptions o;
  o.spp = 4;
  o.adaptive_spp = 4;  // not more than spp
  CHECK_THROWS_AS(render_on(d, o, Backend::Cpu), Error);
  o.adaptive_spp = 8;
  o.adaptive_threshold = -1;
  CHECK_THROWS_AS(render_on(d, o, Backend::Cpu), Error);
}

#ifdef TWINRAY_WITH_OPENCL
TEST_CASE_TEMPLATE("adaptive: the OpenCL backend gives the CPU's bits", T, float, double) {
  auto d = twinray::demo::make_demo_scene<T>(kW, kH);
  for (Sampler sampler : {Sampler::Grid, Sampler::Stratified, Sampler::R2})
    for (bool glazed_everything : {false, true}) {
      CAPTURE(to_string(sampler));
      CAPTURE(glazed_everything);
      if (glazed_everything)
        for (auto& m : d.scene.materials) m.glaze = T(0.5);
      RenderOptions o;
      o.sampler = sampler;
      o.seed = 9;
      o.spp = 3;
      o.adaptive_spp = 12;
      RenderInfo cpu_info, cl_info;
      Image<T> cpu = render_on(d, o, Backend::Cpu, &cpu_info);
      Image<T> cl = render_on(d, o, Backend::OpenCL, &cl_info);
      CHECK(cl_info.backend == Backend::OpenCL);
      CHECK(differing_values(cpu, cl) == 0);
      CHECK(cpu_info.refined_pixels == cl_info.refined_pixels);
      CHECK(cpu_info.refined_pixels > 0);
    }
}
#endif
