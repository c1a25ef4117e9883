// `twinray bench [SCENE] [options]`: the timing table (docs/command-line.md), CSV on stdout, one
// line per scene x backend x precision; the machine, OpenCL program builds and notes on stderr. The
// runner and the built-in scenes are apps/twinray/bench/bench_runner.hpp and
// bench/bench_scenes.hpp, shared with the bench/twinray_bench.cpp program.
//
// With `--against PROGRAM` (build/bench/embree_bench, or any program that takes its options and
// prints the same CSV), rounds of both are interleaved scene by scene, and stdout has the
// ratios instead: per scene the medians over the rounds, CPU / comparator taken within
// each round (median, least, largest) and OpenCL / CPU taken within each round (median;
// with --interleave, the round's median per step). `--plot FILE.png` draws the cost per ray against
// the primitive count of the spheres_<N> and mesh_<N> scenes (gnuplot).
#include <algorithm>
#include <cstdio>
#include <ctime>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "bench/bench_runner.hpp"
#include "cli_common.hpp"
#include "command.hpp"
#include "report_metrics.hpp"

namespace twinray_cli {
namespace {

struct BenchArgs {
  std::string scene;  // empty: the built-in set
  std::string backend = "all";
  std::string precision = "float";
  int runs = 5, width = 0, height = 0, spp = 0, threads = 0;
  std::string bvh = "auto";
  int bvh_width = 0;  // 0: each backend's own
  std::string obj_dir = ".";
  std::string against;  // a comparison program: interleaved rounds and ratios
  int rounds = 3;
  bool interleave = false;  // the backends' timed frames alternate in one loop
  std::string plot;         // a PNG of the cost per ray against the primitive count
  bool markdown = false;    // with --against: a Markdown table and its caption, not CSV
};

bool is_builtin(const std::string& name) {
  for (const char* p : {"spheres_", "mesh_", "obj_"}) {
    std::string prefix = p;
    if (name.compare(0, prefix.size(), prefix) == 0 &&
        twinray_bench::parse_count(name.substr(prefix.size())) > 0)
      return true;
  }
  const size_t x = name.find('x');
  if (name.compare(0, 7, "forest_") == 0 && x != std::string::npos &&
      twinray_bench::parse_count(name.substr(7, x - 7)) > 0 &&
      twinray_bench::parse_count(name.substr(x + 1)) > 0)
    return true;
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

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// One scene through the comparison program: its fastest row.
twinray_bench::Row run_against(const BenchArgs& a, const std::string& scene) {
  std::ostringstream cmd;
  cmd << shell_quote(a.against) << " --scenes " << shell_quote(scene) << " --runs " << a.runs
      << " --obj-dir " << shell_quote(a.obj_dir);
  if (a.width > 0) cmd << " --width " << a.width;
  if (a.height > 0) cmd << " --height " << a.height;
  if (a.threads > 0) cmd << " --threads " << a.threads;
  FILE* pipe = ::popen(cmd.str().c_str(), "r");
  if (!pipe) throw twinray::Error(twinray::ErrorKind::RuntimeFailure, "cannot run " + a.against);
  std::string out;
  char buffer[4096];
  for (size_t n; (n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;) out.append(buffer, n);
  const int status = ::pclose(pipe);
  twinray_bench::Row best;
  bool found = false;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    twinray_bench::Row row;
    if (!twinray_bench::parse_csv_line(line, row) || row.scene != scene) continue;
    std::cerr << "twinray: " << line << "\n";
    if (!found || row.median_ms < best.median_ms) best = row;
    found = true;
  }
  if (status != 0 || !found)
    throw twinray::Error(twinray::ErrorKind::RuntimeFailure,
                         a.against + " (for " + scene + ") " +
                             (status != 0 ? "failed (status " + std::to_string(status) + ")"
                                          : "printed no CSV row for the scene"));
  return best;
}

// The cost per ray against N: one curve per family (spheres_<N>, mesh_<N>) and system.
void write_plot(const std::string& png, const std::map<std::string, std::vector<double>>& ns,
                const std::map<std::string, long long>& primitives,
                const std::vector<std::string>& systems, const std::string& comparator) {
  std::ostringstream data, plot;
  int index = 0;
  for (const char* family : {"spheres_", "mesh_"})
    for (const std::string& system : systems) {
      std::vector<std::pair<long long, double>> points;  // (N, ns per ray), by N
      for (const auto& [key, values] : ns) {
        // key: "<system>|<scene>"
        size_t bar = key.find('|');
        std::string sys = key.substr(0, bar), scene = key.substr(bar + 1);
        if (sys == system && scene.rfind(family, 0) == 0)
          points.push_back({primitives.at(scene), report::median(values)});
      }
      std::sort(points.begin(), points.end());
      std::ostringstream block;
      for (const auto& [n, value] : points) block << n << " " << value << "\n";
      if (points.empty()) continue;
      data << "$d" << index << " << EOD\n" << block.str() << "EOD\n";
      plot << (index ? ", \\\n     " : "plot ") << "$d" << index
           << " using 1:2 with linespoints title '"
           << std::string(family).substr(0, std::string(family).size() - 1) << ", "
           << (system == "comparator" ? comparator : system) << "'";
      ++index;
    }
  if (index == 0) {
    std::cerr << "twinray: --plot: no spheres_<N> or mesh_<N> scene was run, so no plot\n";
    return;
  }
  std::string script =
      data.str() +
      "set terminal pngcairo size 900,600 noenhanced font ',10'\n"
      "set output '" +
      png +
      ".tmp'\n"
      "set logscale x\nset grid\nset key top left\n"
      "set xlabel 'primitives (N)'\nset ylabel 'ns per ray (median frame / rays)'\n"
      "set title 'cost per ray against N'\n" +
      plot.str() + "\n";
  FILE* gp = ::popen("gnuplot", "w");
  if (!gp) throw twinray::Error(twinray::ErrorKind::RuntimeFailure, "--plot: cannot run gnuplot");
  std::fwrite(script.data(), 1, script.size(), gp);
  // Written beside, then renamed: a failed plot leaves an earlier one as it was.
  if (::pclose(gp) != 0 || std::rename((png + ".tmp").c_str(), png.c_str()) != 0) {
    std::remove((png + ".tmp").c_str());
    throw twinray::Error(
        twinray::ErrorKind::RuntimeFailure,
        "--plot: gnuplot failed to write " + png + " (Debian: apt-get install gnuplot-nox)");
  }
  std::cerr << "twinray: wrote " << png << "\n";
}

// One scene's figures from the interleaved rounds: medians over the rounds, the ratios
// taken within each round. A figure of a backend that was not run is 0.
struct SceneSummary {
  std::string scene, other_backend;
  std::string size;  // "1920x1080, 1 spp"
  long long rays = 0;
  double cpu_ms = 0, opencl_ms = 0, other_ms = 0;
  double cpu_over_other = 0, cpu_over_other_min = 0, cpu_over_other_max = 0;
  double opencl_over_cpu = 0;
  double cpu_build_ms = 0, other_build_ms = 0, cpu_build_over_other = 0;
};

// A figure, or "" where it was not measured.
std::string figure(double v, const char* format) {
  char text[64] = "";
  if (v > 0) std::snprintf(text, sizeof text, format, v);
  return text;
}

void print_csv(const std::vector<SceneSummary>& rows) {
  std::cout << "scene,rays,twinray_cpu_ms,twinray_opencl_ms,comparator_ms,comparator_backend,"
               "cpu_over_comparator,cpu_over_comparator_min,cpu_over_comparator_max,"
               "opencl_over_cpu,twinray_cpu_build_ms,comparator_build_ms,"
               "cpu_build_over_comparator"
            << std::endl;
  for (const SceneSummary& r : rows)
    std::cout << r.scene << ',' << r.rays << ',' << figure(r.cpu_ms, "%.1f") << ','
              << figure(r.opencl_ms, "%.1f") << ',' << figure(r.other_ms, "%.1f") << ','
              << r.other_backend << ',' << figure(r.cpu_over_other, "%.3f") << ','
              << figure(r.cpu_over_other_min, "%.3f") << ',' << figure(r.cpu_over_other_max, "%.3f")
              << ',' << figure(r.opencl_over_cpu, "%.3f") << ',' << figure(r.cpu_build_ms, "%.1f")
              << ',' << figure(r.other_build_ms, "%.1f") << ','
              << figure(r.cpu_build_over_other, "%.3f") << std::endl;
}

// The compiler that built this program, as its predefined macros name it.
std::string compiler_description() {
#if defined(__clang__)
  std::string version = __clang_version__;
  version.erase(version.find_last_not_of(' ') + 1);
  return "clang++ " + version;
#elif defined(__GNUC__)
  return std::string("g++ ") + __VERSION__;
#else
  return "an unknown compiler";
#endif
}

// The widest vector ISA this program was compiled for: what its CPU backend runs.
const char* compiled_isa() {
#if defined(__AVX512F__)
  return "AVX-512";
#elif defined(__AVX2__)
  return "AVX2";
#elif defined(__AVX__)
  return "AVX";
#elif defined(__SSE2__) || defined(__x86_64__)
  return "SSE2";
#else
  return "no x86 SIMD";
#endif
}

// The options of this run as a command line that repeats it.
std::string command_line(const BenchArgs& a) {
  std::ostringstream c;
  c << "twinray bench";
  if (!a.scene.empty()) c << ' ' << a.scene;
  c << " --against " << a.against << " --rounds " << a.rounds << " --runs " << a.runs
    << " --backend " << a.backend;
  if (a.interleave) c << " --interleave";
  if (a.width > 0) c << " --width " << a.width;
  if (a.height > 0) c << " --height " << a.height;
  if (a.spp > 0) c << " --spp " << a.spp;
  if (a.threads > 0) c << " --threads " << a.threads;
  if (a.bvh != "auto") c << " --bvh " << a.bvh;
  if (a.bvh_width > 0) c << " --bvh-width " << a.bvh_width;
  if (a.obj_dir != ".") c << " --obj-dir " << a.obj_dir;
  c << " --markdown";
  return c.str();
}

// The table of docs/performance.md's "At a glance": a caption that names the machine,
// the compilers and the command, then one row per scene.
void print_markdown(const BenchArgs& a, const std::vector<SceneSummary>& rows,
                    const twinray_bench::Config& config) {
  const std::string program = a.against.substr(a.against.find_last_of('/') + 1);
  char date[32] = "";
  const std::time_t now = std::time(nullptr);
  std::strftime(date, sizeof date, "%Y-%m-%d", std::gmtime(&now));
  const SceneSummary* first = rows.empty() ? nullptr : &rows.front();
  std::cout << "Measured " << date << " on " << twinray_bench::machine_description()
            << "; twinray built by " << compiler_description() << " for " << compiled_isa() << ", "
            << twinray::thread_count() << " threads, float"
            << (first ? ", " + first->size : std::string()) << "; against `" << program << "` in "
            << a.rounds << (a.rounds == 1 ? " round" : " interleaved rounds") << " of " << a.runs
            << (a.runs == 1 ? " frame" : " frames")
            << " per scene and system (medians; ratios taken within each round"
            << (config.interleave ? ", OpenCL / CPU per step of frames interleaved" : "")
            << "; build: `pack_scene` against the comparator's geometry set-up and commit). "
               "Command: `"
            << command_line(a) << "`.\n\n";
  std::cout << "| scene | rays per frame | twinray CPU ms | twinray OpenCL ms | " << program
            << " ms (mode) | CPU / " << program << " (rounds) | OpenCL / CPU | build, CPU / "
            << program << " |\n";
  std::cout << "|---|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const SceneSummary& r : rows) {
    std::string range = r.cpu_over_other_min > 0
                            ? " (" + figure(r.cpu_over_other_min, "%.3f") + "-" +
                                  figure(r.cpu_over_other_max, "%.3f") + ")"
                            : "";
    std::string build = r.cpu_build_over_other > 0 ? figure(r.cpu_build_over_other, "%.2f") + " (" +
                                                         figure(r.cpu_build_ms, "%.1f") + " / " +
                                                         figure(r.other_build_ms, "%.1f") + " ms)"
                                                   : "";
    std::cout << "| " << r.scene << " | " << r.rays << " | " << figure(r.cpu_ms, "%.1f") << " | "
              << figure(r.opencl_ms, "%.1f") << " | " << figure(r.other_ms, "%.1f")
              << (r.other_backend.empty() ? "" : " (" + r.other_backend + ")") << " | "
              << figure(r.cpu_over_other, "%.3f") << range << " | "
              << figure(r.opencl_over_cpu, "%.3f") << " | " << build << " |" << std::endl;
  }
}

// Interleaved rounds of twinray and the comparison program; the ratios on stdout. The
// order alternates from round to round (twinray's backends, then the comparator; then
// the comparator, then the backends in reverse), so that no side always runs right
// after another: what ran just before moves a figure on a shared machine, a build's
// most of all (a process that has just exited leaves memory the next one must have
// backed afresh, docs/performance.md).
int run_compare(const BenchArgs& a, const std::vector<std::string>& scenes,
                const std::vector<twinray::Backend>& backends,
                const twinray_bench::Config& config) {
  struct Sample {
    std::map<std::string, std::vector<double>> ms;  // system -> median ms, per round
    std::vector<double> cpu_over_other;
    std::vector<double> opencl_over_cpu;  // per round: the round's ratio
    std::vector<double> cpu_build, other_build, cpu_build_over_other;  // per round
    long long rays = 0, primitives = 0;
    std::string other_backend;
    std::string size;  // the frame's size and samples per pixel
  };
  std::map<std::string, Sample> samples;
  std::vector<std::string> systems;
  for (int round = 1; round <= a.rounds; ++round)
    for (const std::string& name : scenes) {
      std::cerr << "twinray: round " << round << " of " << a.rounds << ": " << name << "\n";
      Sample& s = samples[name];
      twinray_bench::BenchScene<float> b = load<float>(name, a);
      const bool comparator_first = round % 2 == 0;
      twinray_bench::Row other;
      if (comparator_first) other = run_against(a, name);
      std::vector<twinray::Backend> order = backends;
      if (comparator_first) std::reverse(order.begin(), order.end());
      double cpu = 0, cpu_build = 0, opencl = 0, opencl_per_step = 0;
      for (const twinray_bench::Row& row : twinray_bench::run_backends(b, order, config)) {
        std::cerr << "twinray: " << twinray_bench::csv_line(row) << "\n";
        std::string system = "twinray-" + row.backend;
        s.ms[system].push_back(row.median_ms);
        if (std::find(systems.begin(), systems.end(), system) == systems.end())
          systems.push_back(system);
        if (row.backend == "cpu") cpu = row.median_ms, cpu_build = row.build_ms;
        if (row.backend == "opencl")
          opencl = row.median_ms, opencl_per_step = row.over_cpu_per_step;
        s.rays = row.rays;
        s.primitives = row.primitives;
        s.size = std::to_string(row.width) + "x" + std::to_string(row.height) + ", " +
                 std::to_string(row.spp) + " spp";
      }
      if (!comparator_first) other = run_against(a, name);
      s.ms["comparator"].push_back(other.median_ms);
      s.other_backend = other.backend;
      if (cpu > 0 && opencl > 0)
        s.opencl_over_cpu.push_back(opencl_per_step > 0 ? opencl_per_step : opencl / cpu);
      if (cpu > 0) {
        s.cpu_over_other.push_back(cpu / other.median_ms);
        s.cpu_build.push_back(cpu_build);
        s.other_build.push_back(other.build_ms);
        if (cpu_build > 0 && other.build_ms > 0)
          s.cpu_build_over_other.push_back(cpu_build / other.build_ms);
      }
    }
  systems.push_back("comparator");
  std::vector<SceneSummary> summaries;
  std::map<std::string, std::vector<double>> ns_per_ray;
  std::map<std::string, long long> primitives;
  for (const std::string& name : scenes) {
    Sample& s = samples[name];
    auto ms = [&](const std::string& system) {
      auto it = s.ms.find(system);
      return it == s.ms.end() ? 0.0 : report::median(it->second);
    };
    SceneSummary r;
    r.scene = name;
    r.size = s.size;
    r.rays = s.rays;
    r.cpu_ms = ms("twinray-cpu");
    r.opencl_ms = ms("twinray-opencl");
    r.other_ms = ms("comparator");
    r.other_backend = s.other_backend;
    r.cpu_over_other = report::median(s.cpu_over_other);
    if (!s.cpu_over_other.empty()) {
      r.cpu_over_other_min = *std::min_element(s.cpu_over_other.begin(), s.cpu_over_other.end());
      r.cpu_over_other_max = *std::max_element(s.cpu_over_other.begin(), s.cpu_over_other.end());
    }
    r.opencl_over_cpu = report::median(s.opencl_over_cpu);
    r.cpu_build_ms = report::median(s.cpu_build);
    r.other_build_ms = report::median(s.other_build);
    r.cpu_build_over_other = report::median(s.cpu_build_over_other);
    summaries.push_back(r);
    primitives[name] = s.primitives;
    for (const auto& [system, values] : s.ms)
      for (double v : values)
        if (s.rays > 0) ns_per_ray[system + "|" + name].push_back(v * 1e6 / double(s.rays));
  }
  if (a.markdown)
    print_markdown(a, summaries, config);
  else
    print_csv(summaries);
  if (!a.plot.empty()) {
    std::string program = a.against.substr(a.against.find_last_of('/') + 1);
    write_plot(a.plot, ns_per_ray, primitives, systems, program);
  }
  return kExitOk;
}

int run_bench(const BenchArgs& a) {
  std::vector<std::string> scenes =
      a.scene.empty() ? twinray_bench::default_scenes() : std::vector<std::string>{a.scene};
  std::vector<twinray::Backend> backends;
  // A CPU-only run never asks for the OpenCL platform, so PoCL is never loaded.
  const bool have_opencl = a.backend != "cpu" && twinray::opencl_available(-1);
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
  config.interleave = a.interleave;
  twinray::set_thread_count(a.threads);
  config.bvh = a.bvh == "on" ? 1 : (a.bvh == "off" ? -1 : 0);
  config.bvh_width = a.bvh_width;
  config.note = [](const std::string& s) { std::cerr << "twinray: " << s << "\n"; };
  std::cerr << "twinray: machine: " << twinray_bench::machine_description() << "\n";
  if (!a.against.empty()) {
    if (a.plot.find('\'') != std::string::npos) usage_error("--plot: the file name has a quote");
    if (a.precision != "float")
      usage_error("--against: the comparison renders in float only (Embree is single precision)");
    return run_compare(a, scenes, backends, config);
  }
  if (!a.plot.empty()) usage_error("--plot: give --against too (it plots both systems)");
  if (a.markdown) usage_error("--markdown: give --against too (it prints the comparison's table)");
  std::cout << twinray_bench::csv_header() << std::endl;
  for (const std::string& name : scenes)
    for (const std::string& precision : precisions) {
      auto one = [&](auto zero) {
        using T = decltype(zero);
        twinray_bench::BenchScene<T> b = load<T>(name, a);
        for (const twinray_bench::Row& row : twinray_bench::run_backends(b, backends, config))
          std::cout << twinray_bench::csv_line(row) << std::endl;
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
                     "obj_<N> (N like 1e5), forest_<K>x<N> (K instances of mesh_<N>'s blob); "
                     "default: the built-in set");
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
      app.add_option("--bvh-width", a->bvh_width,
                     "children per BVH node: 2, 4 or 8 (default: the fastest on each backend)")
          ->check(CLI::IsMember({2, 4, 8}));
      app.add_flag("--interleave", a->interleave,
                   "with two backends: their timed frames alternate, frame by frame, in one "
                   "loop (peak_mib is then the process's, with both held)");
      app.add_option("--obj-dir", a->obj_dir, "folder for the obj_<N> scenes' OBJ files");
      app.add_option("--against", a->against,
                     "a comparison program (build/bench/embree_bench): interleaved rounds, and the "
                     "ratios as CSV");
      app.add_option("--rounds", a->rounds, "rounds with --against (default 3)")
          ->check(CLI::Range(1, 100));
      app.add_flag("--markdown", a->markdown,
                   "with --against: a Markdown table with a caption naming the machine, the "
                   "compiler and this command, instead of CSV");
      app.add_option("--plot", a->plot,
                     "with --against: a PNG of the cost per ray against N (gnuplot)");
      return [a] { return run_bench(*a); };
    },
    60);

}  // namespace
}  // namespace twinray_cli
