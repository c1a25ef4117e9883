// Demo-scene throughput on the CPU backend: renders the seed's demo
// scene several times and prints the median render time and rays per second.
//
//   robustness_demo_bench [--width W] [--height H] [--runs N] [--double] [--threads T]
//                         [--no-count]
//
// Rays are counted exactly, once, by a host pass that follows tr_trace/tr_shade's
// decisions with the same device functions: every camera ray, every shadow ray actually
// cast (light in front of the surface, shadows on) and every reflected ray.
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>
#include <vector>

#include <twinray/twinray.hpp>

#include <twinray/scene/demo_scene.hpp>

#include "support/packing.hpp"

namespace {

template <class T>
long long count_rays(const test_support::Packed<T>& ps) {
  using K = typename twinray::device::Code<T>::template Kernel<TR_F_ALL>;
  auto s = ps.ref();
  const auto& p = ps.params();
  long long rays = 0;
  for (int y = 0; y < p.height; ++y)
    for (int x = 0; x < p.width; ++x)
      for (int i = 0; i < p.spp; ++i) {
        auto smp = K::tr_sample_position(p.sampler, i, p.spp, x, y);
        auto ray = K::tr_camera_ray(&p, x, y, smp);
        int segments = (ps.frame.features & TR_F_GLAZE) ? p.max_depth : 1;
        for (int depth = 0; depth < segments; ++depth) {
          ++rays;
          auto hit = K::tr_no_hit();
          if (!K::tr_closest_hit(&s, &ray, T(INFINITY), &hit)) break;
          glm::vec<3, T> n = glm::dot(hit.n, ray.d) > T(0) ? -hit.n : hit.n;
          if (ps.frame.features & TR_F_SHADOWS)
            for (const auto& l : ps.frame.lights) {
              glm::vec<3, T> to_light = glm::vec<3, T>(l.px, l.py, l.pz) - hit.p;
              T d2 = K::tr_dot(to_light, to_light);
              if (!(d2 > T(0))) continue;
              if (K::tr_dot(n, to_light * (T(1) / std::sqrt(d2))) > T(0)) ++rays;
            }
          if (!(ps.frame.features & TR_F_GLAZE) || !(ps.scene.materials[hit.material].glaze > T(0)))
            break;
          glm::vec<3, T> m = K::tr_normalize(ray.d - hit.n * (T(2) * K::tr_dot(ray.d, hit.n)));
          ray.o = K::tr_offset_ray_origin(hit.p, hit.perr, hit.n, m);
          ray.d = m;
        }
      }
  return rays;
}

template <class T>
int run(int width, int height, int runs, int threads, bool count) {
  twinray::demo::DemoSetup<T> d = twinray::demo::make_demo_scene<T>(width, height);
  twinray::RenderOptions options;
  options.backend = twinray::Backend::Cpu;
  twinray::set_thread_count(threads);
  test_support::Packed<T> ps = test_support::pack(d.scene, d.camera, options);
  long long rays = count ? count_rays(ps) : 0;
  std::vector<double> ms;
  twinray::render(d.scene, d.camera, options);  // warm-up
  for (int r = 0; r < runs; ++r) {
    twinray::RenderInfo info;
    twinray::render(d.scene, d.camera, options, &info);
    ms.push_back(info.render_ms);
  }
  std::sort(ms.begin(), ms.end());
  double median = ms[ms.size() / 2];
  std::cout << "demo " << width << "x" << height << " " << twinray::device::Code<T>::name
            << ", CPU backend, " << twinray::thread_count() << " threads, " << runs << " runs\n"
            << "  render ms: median " << median << ", min " << ms.front() << ", max " << ms.back()
            << "\n"
            << "  rays per frame: " << rays << " (" << width * height << " camera rays)\n"
            << "  rays/s (median): " << rays / (median * 1e-3) / 1e6 << " M\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  int width = 1920, height = 1080, runs = 7, threads = 0;
  bool use_double = false, count = true;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--width" && i + 1 < argc)
      width = std::atoi(argv[++i]);
    else if (a == "--height" && i + 1 < argc)
      height = std::atoi(argv[++i]);
    else if (a == "--runs" && i + 1 < argc)
      runs = std::max(1, std::atoi(argv[++i]));
    else if (a == "--threads" && i + 1 < argc)
      threads = std::atoi(argv[++i]);
    else if (a == "--double")
      use_double = true;
  }
  return use_double ? run<double>(width, height, runs, threads, count)
                    : run<float>(width, height, runs, threads, count);
}
