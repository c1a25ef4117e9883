// `twinray bench [SCENE] [options]`: the timing table (docs/command-line.md), CSV on stdout, one
// line per scene x backend x precision; the machine, OpenCL program builds and notes on stderr. The
// runner and the built-in scenes are apps/twinray/bench/bench_runner.hpp and
// bench/bench_scenes.hpp, shared with the bench/twinray_bench.cpp program.
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "bench/bench_runner.hpp"
#include "cli_common.hpp"
#include "command.hpp"

namespace twinray_cli {
namespace {

struct BenchArgs {
  std::string scene;  // empty: the built-in set
  std::string backend = "all";
  std::string precision = "float";
  int runs = 5, width = 0, height = 0, spp = 0, threads = 0;
  std::string bvh = "auto";
  std::string obj_dir = ".";
};

bool is_builtin(const std::string& name) {
  for (const char* p : {"spheres_", "mesh_", "obj_"}) {
    std::string prefix = p;
    if (name.compare(0, prefix.size(), prefix) == 0 &&
        twinray_bench::parse_count(name.substr(prefix.size())) > 0)
      return true;
  }
  return name == "demo" || name == "demo_4spp";
}

template <class T>
twinray_bench::BenchScene<T> load(const std::string& name, const BenchArgs& a) {
  int width = a.width > 0 ? a.width : 1920, height = a.height > 0 ? a.height : 1080;
  twinray_bench::BenchScene<T> b;
  if (is_builtin(name)) {
    b = twinray_bench::make_scene<T>(name, width, height, a.obj_dir);
  } else {
    twinray::io::SceneFile<T> f = load_scene_arg<T>(name);
    b.name = name;
    b.scene = f.scene;
    b.camera = f.camera;
    if (a.width > 0) b.camera.width = a.width;
    if (a.height > 0) b.camera.height = a.height;
    b.options = f.options;
    b.spp = f.options.spp;
  }
  if (a.spp > 0) b.spp = a.spp;
  return b;
}

int run_bench(const BenchArgs& a) {
  std::vector<std::string> scenes =
      a.scene.empty() ? twinray_bench::default_scenes() : std::vector<std::string>{a.scene};
  std::vector<twinray::Backend> backends;
  bool have_opencl = twinray::opencl_available(-1);
  if (a.backend == "cpu" || a.backend == "all") backends.push_back(twinray::Backend::Cpu);
  if (a.backend == "opencl" || a.backend == "all" || a.backend == "auto") {
    if (have_opencl)
      backends.push_back(twinray::Backend::OpenCL);
    else if (a.backend == "opencl")
      throw twinray::Error(twinray::ErrorKind::BackendUnavailable, "no OpenCL device");
    else
      std::cerr << "twinray: no OpenCL device, benchmarking the CPU backend only\n";
  }
  if (a.backend == "auto" && !have_opencl) backends.push_back(twinray::Backend::Cpu);
  std::vector<std::string> precisions;
  if (a.precision != "double") precisions.push_back("float");
  if (a.precision != "float") precisions.push_back("double");
  twinray_bench::Config config;
  config.runs = a.runs;
  twinray::set_thread_count(a.threads);
  config.bvh = a.bvh == "on" ? 1 : (a.bvh == "off" ? -1 : 0);
  config.note = [](const std::string& s) { std::cerr << "twinray: " << s << "\n"; };
  std::cerr << "twinray: machine: " << twinray_bench::machine_description() << "\n";
  std::cout << twinray_bench::csv_header() << std::endl;
  for (const std::string& name : scenes)
    for (const std::string& precision : precisions) {
      auto one = [&](auto zero) {
        using T = decltype(zero);
        twinray_bench::BenchScene<T> b = load<T>(name, a);
        for (twinray::Backend backend : backends)
          std::cout << twinray_bench::csv_line(twinray_bench::run(b, backend, config)) << std::endl;
      };
      if (precision == "double")
        one(0.0);
      else
        one(0.0f);
    }
  return kExitOk;
}

const Command kBench(
    "bench", "timing table: ms per frame, rays per second, BVH build, peak memory (CSV)",
    [](CLI::App& app) {
      auto a = std::make_shared<BenchArgs>();
      app.add_option("SCENE", a->scene,
                     "a scene file, or a built-in: demo, demo_4spp, spheres_<N>, mesh_<N>, "
                     "obj_<N> (N like 1e5); default: the built-in set");
      app.add_option("--backend", a->backend, "cpu, opencl, or all (default: both available)")
          ->check(CLI::IsMember({"cpu", "opencl", "auto", "all"}));
      app.add_option("--precision", a->precision, "float (default), double, or both")
          ->check(CLI::IsMember({"float", "double", "both"}));
      app.add_option("--runs", a->runs, "timed runs after one warm-up (default 5)")
          ->check(CLI::Range(1, 1000));
      app.add_option("--width", a->width, "image width (built-in scenes: 1920)")
          ->check(CLI::Range(1, 1 << 15));
      app.add_option("--height", a->height, "image height (built-in scenes: 1080)")
          ->check(CLI::Range(1, 1 << 15));
      app.add_option("--spp", a->spp, "samples per pixel")->check(CLI::Range(1, 1 << 12));
      app.add_option("--threads", a->threads, "CPU backend threads (default: all cores)")
          ->check(CLI::Range(0, 1024));
      app.add_option("--bvh", a->bvh, "auto (the measured threshold), on, off")
          ->check(CLI::IsMember({"auto", "on", "off"}));
      app.add_option("--obj-dir", a->obj_dir, "folder for the obj_<N> scenes' OBJ files");
      return [a] { return run_bench(*a); };
    },
    60);

}  // namespace
}  // namespace twinray_cli
