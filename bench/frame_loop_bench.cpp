// The cost of a frame loop that moves only the camera, two ways, on each backend:
//   render()   twinray::render(scene, camera, options) every frame: packs the scene,
//              builds its BVH and uploads it every time;
//   backend    one backend from make_backend, the scene packed and set once, then
//              backend->render_into({camera, lights, options}, image) every frame,
//              into one image.
// Rounds alternate between the two so that a drift of the machine's speed hits both.
// Prints the median ms per frame of each, and their ratio.
//
//   frame_loop_bench [--scene spheres_1e5] [--width 640 --height 360] [--frames 12]
//                    [--rounds 3] [--backends cpu,opencl]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include <twinray/twinray.hpp>

#include "bench_runner.hpp"
#include "bench_stats.hpp"

namespace {

// The camera of frame i: a step along a circle around the look-at point.
twinray::Camera<float> camera_at(const twinray::Camera<float>& base, int i) {
  twinray::Camera<float> c = base;
  glm::vec3 d = base.position - base.look_at;
  float a = 0.02f * static_cast<float>(i);
  c.position = base.look_at + glm::vec3(d.x * std::cos(a) - d.z * std::sin(a), d.y,
                                        d.x * std::sin(a) + d.z * std::cos(a));
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  std::string scene_name = "spheres_1e5", backends_arg = "cpu,opencl";
  int width = 640, height = 360, frames = 12, rounds = 3;
  for (int i = 1; i + 1 < argc; i += 2) {
    std::string a = argv[i], v = argv[i + 1];
    if (a == "--scene")
      scene_name = v;
    else if (a == "--width")
      width = std::atoi(v.c_str());
    else if (a == "--height")
      height = std::atoi(v.c_str());
    else if (a == "--frames")
      frames = std::max(1, std::atoi(v.c_str()));
    else if (a == "--rounds")
      rounds = std::max(1, std::atoi(v.c_str()));
    else if (a == "--backends")
      backends_arg = v;
    else {
      std::cerr << "frame_loop_bench: unknown option " << a << "\n";
      return 2;
    }
  }
  std::cerr << "machine: " << twinray_bench::machine_description() << "\n";
  twinray_bench::BenchScene<float> b = twinray_bench::make_scene<float>(scene_name, width, height);
  std::cout << "scene,backend,frames,render_call_ms_per_frame,backend_ms_per_frame,ratio\n";
  for (const std::string& name : twinray_bench::split(backends_arg)) {
    twinray::RenderOptions options = b.options;
    options.spp = b.spp;
    options.backend = name == "opencl" ? twinray::Backend::OpenCL : twinray::Backend::Cpu;
    options.log = [](const std::string&) {};
    if (options.backend == twinray::Backend::OpenCL && !twinray::opencl_available()) {
      std::cerr << "frame_loop_bench: no OpenCL device, skipping opencl\n";
      continue;
    }
    // Program builds, caches warm: on OpenCL the first frame of a new block program
    // takes the pixel kernel, the second builds the block kernel.
    for (int warm = 0; warm < 2; ++warm) (void)twinray::render(b.scene, b.camera, options);
    std::vector<double> one_call, reused;
    for (int r = 0; r < rounds; ++r) {
      auto t0 = std::chrono::steady_clock::now();
      for (int i = 0; i < frames; ++i)
        (void)twinray::render(b.scene, camera_at(b.camera, i), options);
      one_call.push_back(twinray_bench::ms_since(t0) / frames);

      t0 = std::chrono::steady_clock::now();
      auto backend = twinray::make_backend<float>(options);
      backend->set_scene(twinray::share(twinray::pack_scene(b.scene, backend->pack_options())));
      twinray::Image<float> image;
      for (int i = 0; i < frames; ++i)
        backend->render_into({camera_at(b.camera, i), b.scene.lights, options}, image);
      reused.push_back(twinray_bench::ms_since(t0) / frames);
    }
    double a = twinray_bench::median(one_call), c = twinray_bench::median(reused);
    std::cout << scene_name << "," << name << "," << frames << "," << a << "," << c << "," << c / a
              << std::endl;
  }
}
