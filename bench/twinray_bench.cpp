// twinray's benchmark program: the timing table of `twinray bench`, as CSV
// on stdout (docs/command-line.md columns), the machine and notes on stderr.
//
//   twinray_bench [--scenes demo,spheres_1e6,...] [--backends cpu,opencl]
//                 [--precisions float,double] [--runs R] [--width W] [--height H]
//                 [--threads N] [--bvh auto|on|off] [--bvh-width 2|4|8] [--obj-dir DIR]
//
// Defaults: the built-in set (bench_scenes.hpp) at 1920x1080, both backends (OpenCL
// when a device exists), float, 5 timed runs after one warm-up.
#include <algorithm>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "bench_runner.hpp"

namespace {

int usage(const std::string& what) {
  std::cerr
      << "twinray_bench: " << what
      << "\nusage: twinray_bench [--scenes a,b] [--backends cpu,opencl] [--precisions "
         "float,double] [--runs R] [--width W] [--height H] [--threads N] [--bvh auto|on|off] "
         "[--bvh-width 2|4|8] [--obj-dir DIR]\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> scenes = twinray_bench::default_scenes();
  std::vector<std::string> backends = {"cpu", "opencl"}, precisions = {"float"};
  int width = 1920, height = 1080;
  std::string obj_dir = ".";
  twinray_bench::Config config;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    try {
      if (a == "--scenes")
        scenes = twinray_bench::split(value());
      else if (a == "--backends")
        backends = twinray_bench::split(value());
      else if (a == "--precisions")
        precisions = twinray_bench::split(value());
      else if (a == "--runs")
        config.runs = std::max(1, std::atoi(value().c_str()));
      else if (a == "--width")
        width = std::atoi(value().c_str());
      else if (a == "--height")
        height = std::atoi(value().c_str());
      else if (a == "--threads")
        twinray::set_thread_count(std::max(0, std::atoi(value().c_str())));
      else if (a == "--bvh") {
        std::string v = value();
        config.bvh = v == "on" ? 1 : (v == "off" ? -1 : 0);
      } else if (a == "--bvh-width") {
        config.bvh_width = std::atoi(value().c_str());
        if (!twinray::bvh::valid_width(config.bvh_width)) return usage("--bvh-width: 2, 4 or 8");
      } else if (a == "--obj-dir")
        obj_dir = value();
      else
        return usage("unknown option " + a);
    } catch (const std::exception& e) {
      return usage(e.what());
    }
  }
  if (width < 1 || height < 1) return usage("bad image size");
  std::cerr << "machine: " << twinray_bench::machine_description() << "\n";
  // Only an OpenCL row may load the OpenCL platform: a CPU-only run keeps PoCL (and its
  // LLVM) out of the process, and out of its peak memory.
  const bool want_opencl = std::find(backends.begin(), backends.end(), "opencl") != backends.end();
  const bool have_opencl = want_opencl && twinray::opencl_available();
  std::cout << twinray_bench::csv_header() << std::endl;
  try {
    for (const std::string& name : scenes)
      for (const std::string& precision : precisions) {
        auto one = [&](auto zero) {
          using T = decltype(zero);
          auto b = twinray_bench::make_scene<T>(name, width, height, obj_dir);
          if (b.load_ms > 0) std::cerr << name << ": OBJ read in " << b.load_ms << " ms\n";
          for (const std::string& backend : backends) {
            if (backend == "opencl" && !have_opencl) {
              std::cerr << name << ": no OpenCL device, opencl skipped\n";
              continue;
            }
            auto be = backend == "opencl" ? twinray::Backend::OpenCL : twinray::Backend::Cpu;
            std::cout << twinray_bench::csv_line(twinray_bench::run(b, be, config)) << std::endl;
          }
        };
        if (precision == "double")
          one(0.0);
        else
          one(0.0f);
      }
  } catch (const std::exception& e) {
    std::cerr << "twinray_bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
