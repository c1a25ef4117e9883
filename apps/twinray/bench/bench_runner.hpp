// The benchmark runner behind `twinray bench` and bench/twinray_bench.cpp: renders a
// scene on a backend in a precision, one warm-up then R timed runs, and prints one CSV
// line per scene x backend x precision (docs/command-line.md):
//   scene,backend,precision,width,height,spp,primitives,build_ms,render_ms_min,
//   render_ms_median,render_ms_max,rays,mrays_per_s,peak_mib
// build_ms: pack_scene() with its BVH build; the OpenCL program build goes to stderr.
// rays: primary + shadow + reflected rays of one frame, counted exactly by a host pass
// through the device code's ray counter (TR_F_COUNT_RAYS, device/features.h).
// peak_mib: the process's peak resident memory from packing to the last run (VmHWM,
// reset before packing where the kernel allows it).
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <twinray/twinray.hpp>

#include "bench_scenes.hpp"

namespace twinray_bench {

// A comma-separated command-line list ("demo,spheres_1e3"), empty items dropped.
inline std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

struct Row {
  std::string scene, backend, precision;
  int width = 0, height = 0, spp = 1;
  long long primitives = 0;
  double build_ms = 0, min_ms = 0, median_ms = 0, max_ms = 0;
  long long rays = 0;
  double mrays_per_s = 0, peak_mib = 0;
  // Interleaved runs only (run_interleaved), not a CSV column: this backend's frame over
  // the CPU backend's, per step, the median.
  double over_cpu_per_step = 0;
};

inline const char* csv_header() {
  return "scene,backend,precision,width,height,spp,primitives,build_ms,render_ms_min,"
         "render_ms_median,render_ms_max,rays,mrays_per_s,peak_mib";
}

inline std::string csv_line(const Row& r) {
  char buf[512];
  std::snprintf(buf, sizeof buf, "%s,%s,%s,%d,%d,%d,%lld,%.1f,%.1f,%.1f,%.1f,%lld,%.2f,%.0f",
                r.scene.c_str(), r.backend.c_str(), r.precision.c_str(), r.width, r.height, r.spp,
                r.primitives, r.build_ms, r.min_ms, r.median_ms, r.max_ms, r.rays, r.mrays_per_s,
                r.peak_mib);
  return buf;
}

// A line as csv_line() writes it, read back (the Embree program prints the same
// columns); false for the header or anything else.
inline bool parse_csv_line(const std::string& line, Row& r) {
  std::vector<std::string> f;
  std::stringstream in(line);
  for (std::string item; std::getline(in, item, ',');) f.push_back(item);
  if (f.size() != 14) return false;
  try {
    size_t used = 0;
    auto number = [&](const std::string& s) {
      double v = std::stod(s, &used);
      if (used != s.size()) throw std::invalid_argument(s);
      return v;
    };
    r.scene = f[0], r.backend = f[1], r.precision = f[2];
    r.width = static_cast<int>(number(f[3])), r.height = static_cast<int>(number(f[4]));
    r.spp = static_cast<int>(number(f[5]));
    r.primitives = static_cast<long long>(number(f[6]));
    r.build_ms = number(f[7]), r.min_ms = number(f[8]), r.median_ms = number(f[9]);
    r.max_ms = number(f[10]);
    r.rays = static_cast<long long>(number(f[11]));
    r.mrays_per_s = number(f[12]), r.peak_mib = number(f[13]);
  } catch (const std::exception&) {
    return false;
  }
  return true;
}

// ---- the machine ----
inline std::string read_first(const std::string& file, const std::string& key) {
  std::ifstream f(file);
  std::string line;
  while (std::getline(f, line))
    if (line.compare(0, key.size(), key) == 0) {
      size_t colon = line.find(':');
      std::string v = colon == std::string::npos ? line : line.substr(colon + 1);
      v.erase(0, v.find_first_not_of(" \t"));
      return v;
    }
  return "";
}

// The CPU as /proc/cpuinfo names it (model name; family and model, which tell the
// generation where a virtual machine reports only a brand name), the widest vector ISA it
// offers, its hardware threads and the memory.
inline std::string machine_description() {
  std::ostringstream s;
  s << read_first("/proc/cpuinfo", "model name");
  const std::string family = read_first("/proc/cpuinfo", "cpu family");
  const std::string model = read_first("/proc/cpuinfo", "model\t");
  if (!family.empty())
    s << " (family " << family << (model.empty() ? "" : ", model " + model) << ")";
  const std::string flags = " " + read_first("/proc/cpuinfo", "flags") + " ";
  const std::pair<const char*, const char*> isas[] = {
      {"avx512f", "AVX-512"}, {"avx2", "AVX2"}, {"avx", "AVX"}, {"sse2", "SSE2"}};
  for (const auto& [flag, isa] : isas)
    if (flags.find(std::string(" ") + flag + " ") != std::string::npos) {
      s << ", " << isa;
      break;
    }
  s << ", " << std::thread::hardware_concurrency() << " hardware threads";
  const double memory_kib = std::atof(read_first("/proc/meminfo", "MemTotal").c_str());
  if (memory_kib > 0) {
    char gib[32];
    std::snprintf(gib, sizeof gib, ", %.0f GiB", memory_kib / (1024.0 * 1024.0));
    s << gib;
  }
  return s.str();
}

// Peak resident memory (VmHWM) in MiB, and its reset (Linux >= 4.0: clear_refs 5).
inline double peak_mib() {
  std::string v = read_first("/proc/self/status", "VmHWM");
  return v.empty() ? 0.0 : std::atof(v.c_str()) / 1024.0;
}
inline void reset_peak() {
  std::ofstream f("/proc/self/clear_refs");
  if (f) f << "5";
}

inline double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Rays of one frame: renders it once on the CPU through the counting instantiation of
// the device code. It has every feature compiled in and honours the run-time mask
// (TrParams::features), so it traces exactly the rays the timed render traces.
template <class T>
long long count_rays(const twinray::PackedScene<T>& ps, const twinray::PackedFrame<T>& frame) {
  using Kernel = typename twinray::device::Code<T>::template Kernel<TR_F_ALL | TR_F_COUNT_RAYS>;
  const auto scene = frame.ref(ps);
  const int width = frame.params.width, height = frame.params.height;
  std::atomic<long long> total{0};
  twinray::parallel_for(height, 1, [&](int y) {
    long long before = twinray::device::ray_counter();  // counts per thread
    for (int x = 0; x < width; ++x) (void)Kernel::tr_render_pixel(&scene, x, y);
    total += twinray::device::ray_counter() - before;
  });
  return total.load();
}

struct Config {
  int runs = 5;
  // BVH: 0 as pack_scene decides (the threshold), 1 always, -1 never (threshold
  // measurements)
  int bvh = 0;
  // BVH width: 0 the backend's (RenderBackend::pack_options), else 2, 4 or 8.
  int bvh_width = 0;
  // Several backends: their timed frames alternate in one loop (run_interleaved).
  bool interleave = false;
  std::function<void(const std::string&)> note = [](const std::string& s) {
    std::cerr << s << "\n";
  };
};

// One backend made ready to time frames of a scene: packed, its scene set, warmed up.
template <class T>
struct Session {
  Row row;
  std::unique_ptr<twinray::RenderBackend<T>> renderer;
  std::shared_ptr<const twinray::PackedScene<T>> scene;
  twinray::PackOptions pack;
  twinray::RenderRequest<T> request;
  // One image for every frame, as a frame loop (and the Embree program) keeps one: the
  // timed frames neither allocate nor zero a framebuffer.
  twinray::Image<T> image;
  std::vector<double> times;  // the timed frames, in ms, in the order they ran
};

// `alike`: a session whose packed scene this one reads if the backend packs the same way
// (BVH policy and width), as a program that holds both backends would. The build is
// timed all the same, the pack then dropped: each row's build_ms is its own backend's
// pack_scene, whether or not it runs alone.
template <class T>
std::unique_ptr<Session<T>> prepare(const BenchScene<T>& b, twinray::Backend backend,
                                    const Config& config, const Session<T>* alike = nullptr) {
  auto session = std::make_unique<Session<T>>();
  Row& row = session->row;
  row.scene = b.name;
  row.backend = backend == twinray::Backend::OpenCL ? "opencl" : "cpu";
  row.precision = twinray::device::Code<T>::name;
  row.width = b.camera.width;
  row.height = b.camera.height;
  row.spp = b.spp;
  twinray::RenderOptions options = b.options;
  options.backend = backend;
  options.spp = b.spp;
  options.log = config.note;

  session->renderer = twinray::make_backend<T>(options);
  twinray::PackOptions pack = session->renderer->pack_options();
  pack.bvh = config.bvh > 0   ? twinray::BvhPolicy::Always
             : config.bvh < 0 ? twinray::BvhPolicy::Never
                              : twinray::BvhPolicy::Auto;
  if (config.bvh_width > 0) pack.bvh_width = config.bvh_width;
  session->pack = pack;
  auto t0 = std::chrono::steady_clock::now();
  auto ps = twinray::share(twinray::pack_scene(b.scene, pack));
  row.build_ms = ms_since(t0);
  const bool shares =
      alike && alike->pack.bvh == pack.bvh && alike->pack.bvh_width == pack.bvh_width;
  if (shares) ps = alike->scene;
  row.primitives =
      static_cast<long long>(ps->spheres.size() + ps->triangles.size() + ps->planes.size());
  if (!ps->bvh_nodes.empty() && !shares) {
    twinray::bvh::Stats st = twinray::bvh::wide_stats(ps->bvh_nodes);
    char buf[200];
    std::snprintf(buf, sizeof buf,
                  ": BVH%d %d nodes, %d leaves (%.2f primitives each, at most %d), depth %d, "
                  "stack %d",
                  ps->bvh_width(), st.nodes, st.leaves, double(ps->bvh_prims.size()) / st.leaves,
                  st.max_leaf, st.max_depth, st.stack_need);
    config.note(b.name + " " + row.precision + buf);
  }

  session->request = twinray::RenderRequest<T>{b.camera, b.scene.lights, options, {}};
  session->scene = ps;
  session->renderer->set_scene(ps);
  twinray::RenderInfo info;
  auto w0 = std::chrono::steady_clock::now();
  // warm-up (program build, scene upload)
  session->renderer->render_into(session->request, session->image, &info);
  double first_ms = ms_since(w0);
  if (backend == twinray::Backend::OpenCL) {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  ": OpenCL program %s in %.1f ms; first frame %.1f ms in all (build, upload, "
                  "first launch; kernel %s) on ",
                  info.program_cached ? "from cache" : "built from source", info.build_ms, first_ms,
                  info.kernel.c_str());
    config.note(b.name + " " + row.precision + buf + info.device);
    // A first frame may take a kernel other than the later frames' (the OpenCL
    // backend's pixel kernel while the block program is new): warm up until a frame
    // builds no program.
    for (int extra = 0; extra < 3 && info.build_ms > 0; ++extra) {
      w0 = std::chrono::steady_clock::now();
      session->renderer->render_into(session->request, session->image, &info);
      if (info.build_ms > 0) {
        std::snprintf(buf, sizeof buf,
                      ": OpenCL program for kernel %s %s in %.1f ms; that frame %.1f ms in all",
                      info.kernel.c_str(), info.program_cached ? "from cache" : "built from source",
                      info.build_ms, ms_since(w0));
        config.note(b.name + " " + row.precision + buf);
      }
    }
  }
  return session;
}

// One timed frame.
template <class T>
double timed_frame(Session<T>& s) {
  auto r0 = std::chrono::steady_clock::now();
  s.renderer->render_into(s.request, s.image);
  s.times.push_back(ms_since(r0));
  return s.times.back();
}

// The row of a session whose frames have run.
template <class T>
Row finish(Session<T>& s) {
  Row row = s.row;
  row.peak_mib = peak_mib();
  std::vector<double> times = s.times;
  std::sort(times.begin(), times.end());
  row.min_ms = times.front();
  row.max_ms = times.back();
  row.median_ms = times[times.size() / 2];
  row.rays = count_rays(*s.scene, twinray::pack_frame(s.scene->summary(), s.request));
  row.mrays_per_s = row.median_ms > 0 ? row.rays / (row.median_ms * 1e3) : 0;
  return row;
}

// One warm-up, then config.runs timed frames.
template <class T>
Row run(const BenchScene<T>& b, twinray::Backend backend, const Config& config) {
  reset_peak();
  std::unique_ptr<Session<T>> s = prepare(b, backend, config);
  for (int i = 0; i < config.runs; ++i) timed_frame(*s);
  return finish(*s);
}

// The backends' timed frames in one loop, frame by frame, so that whatever moves the
// machine's speed meets both alike; the order within each step alternates (A B, B A, ...)
// so that neither always runs right after the other. Backends that pack alike render
// from one packed scene (prepare), so their frames read the same memory and neither
// finds the caches full of another copy; peak_mib is the process's, with every backend held. A
// note gives each step's frames in the order they ran and, with the CPU backend and one
// other, the other over the CPU backend per step (median and range; also the rows'
// over_cpu_per_step).
template <class T>
std::vector<Row> run_interleaved(const BenchScene<T>& b,
                                 const std::vector<twinray::Backend>& backends,
                                 const Config& config) {
  reset_peak();
  std::vector<std::unique_ptr<Session<T>>> sessions;
  for (twinray::Backend backend : backends)
    sessions.push_back(prepare(b, backend, config, sessions.empty() ? nullptr : &*sessions[0]));
  const size_t n = sessions.size();
  // With two backends, one of them the CPU's: the index of each.
  const size_t cpu = sessions[0]->row.backend == "cpu" ? 0 : 1, other = 1 - cpu;
  const bool paired = n == 2 && sessions[cpu]->row.backend == "cpu";
  std::vector<double> ratios;
  for (int i = 0; i < config.runs; ++i) {
    std::string line =
        b.name + " " + sessions[0]->row.precision + ": step " + std::to_string(i + 1) + ":";
    for (size_t j = 0; j < n; ++j) {
      Session<T>& s = *sessions[i % 2 == 0 ? j : n - 1 - j];
      char buf[64];
      std::snprintf(buf, sizeof buf, " %s %.1f ms", s.row.backend.c_str(), timed_frame(s));
      line += buf;
    }
    config.note(line);
    if (paired) ratios.push_back(sessions[other]->times.back() / sessions[cpu]->times.back());
  }
  double median_ratio = 0;
  if (!ratios.empty()) {
    std::sort(ratios.begin(), ratios.end());
    median_ratio = ratios[ratios.size() / 2];
    char buf[200];
    std::snprintf(buf, sizeof buf, ": %s / cpu per step: median %.3f (%.3f-%.3f)",
                  sessions[other]->row.backend.c_str(), median_ratio, ratios.front(),
                  ratios.back());
    config.note(b.name + " " + sessions[0]->row.precision + buf);
  }
  std::vector<Row> rows;
  for (auto& s : sessions) rows.push_back(finish(*s));
  if (paired) rows[other].over_cpu_per_step = median_ratio;
  return rows;
}

// Every backend on a scene: one after the other, or interleaved (config.interleave).
template <class T>
std::vector<Row> run_backends(const BenchScene<T>& b, const std::vector<twinray::Backend>& backends,
                              const Config& config) {
  if (config.interleave && backends.size() > 1) return run_interleaved(b, backends, config);
  std::vector<Row> rows;
  for (twinray::Backend backend : backends) rows.push_back(run(b, backend, config));
  return rows;
}

}  // namespace twinray_bench
