// One large batch of ray queries through each backend's intersect(): N random rays
// (origins anywhere in the scene's box, directions uniform over the sphere; made before
// any timing) in one call per backend, as a user with a large batch makes it. Prints,
// per backend, the time, the rays per second, the hits, and how much the call added to
// the process's peak memory beyond the rays and hits arrays the caller holds (the
// backends answer in chunks and keep no second copy of the batch); then whether the
// backends' hits are the same bits.
//
//   query_batch_bench [--rays 1e8] [--scene mesh_1e6] [--backends cpu,opencl]
//
// Memory: 40 bytes a ray and 40 a hit in float, for each backend's hits: 12 GB at 1e8.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <twinray/twinray.hpp>

#include "bench_runner.hpp"
#include "bench_stats.hpp"

namespace {

using vec3 = glm::vec3;

double resident_mib() {
  const std::string v = twinray_bench::read_first("/proc/self/status", "VmRSS");
  return v.empty() ? 0.0 : std::atof(v.c_str()) / 1024.0;
}

}  // namespace

int main(int argc, char** argv) {
  long long n = 100000000;
  std::string scene_name = "mesh_1e6", backends_arg = "cpu,opencl";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) {
      std::fprintf(stderr, "%s: a value is missing\n", a.c_str());
      return 2;
    }
    const std::string v = argv[++i];
    if (a == "--rays")
      n = twinray_bench::parse_count(v);
    else if (a == "--scene")
      scene_name = v;
    else if (a == "--backends")
      backends_arg = v;
    else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      return 2;
    }
  }
  if (n < 1 || n > (1ll << 32) / 5) {
    std::fprintf(stderr, "--rays: from 1 to %lld\n", (1ll << 32) / 5);
    return 2;
  }
  twinray_bench::BenchScene<float> b;
  try {
    b = twinray_bench::make_scene<float>(scene_name, 64, 64);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  // The box the rays start in: the spheres and meshes (planes have none).
  vec3 lo, hi;
  twinray_bench::bounded_box(b.scene, lo, hi);
  const size_t count = static_cast<size_t>(n);
  std::vector<twinray::Ray<float>> rays(count);
  twinray::parallel_for(static_cast<int>((count + 65535) / 65536), 1, [&](int c) {
    const size_t end = std::min(count, static_cast<size_t>(c + 1) * 65536);
    for (size_t i = static_cast<size_t>(c) * 65536; i < end; ++i) {
      const uint32_t id = static_cast<uint32_t>(5 * i);
      const vec3 o = lo + (hi - lo) * vec3(twinray_bench::hash01(id), twinray_bench::hash01(id + 1),
                                           twinray_bench::hash01(id + 2));
      const float z = 2.0f * twinray_bench::hash01(id + 3) - 1.0f;
      const float phi = 6.2831853f * twinray_bench::hash01(id + 4);
      const float r = std::sqrt(std::fmax(0.0f, 1.0f - z * z));
      rays[i] = twinray::make_ray(o, vec3(r * std::cos(phi), r * std::sin(phi), z));
    }
  });
  const double rays_mib = count * sizeof(rays[0]) / double(1 << 20);
  std::printf(
      "query_batch_bench: %s, %d threads; %s; %lld random rays (%.0f MiB), one "
      "intersect call per backend\n",
      twinray_bench::machine_description().c_str(), twinray::thread_count(), scene_name.c_str(), n,
      rays_mib);

  std::vector<std::vector<twinray::Hit<float>>> answers;
  std::vector<std::string> names;
  for (const std::string& name : twinray_bench::split(backends_arg)) {
    twinray::RenderOptions options;
    options.log = [](const std::string&) {};
    if (name == "cpu")
      options.backend = twinray::Backend::Cpu;
    else if (name == "opencl")
      options.backend = twinray::Backend::OpenCL;
    else {
      std::fprintf(stderr, "--backends: cpu or opencl, not %s\n", name.c_str());
      return 2;
    }
    try {
      auto backend = twinray::make_backend<float>(options);
      backend->set_scene(twinray::share(twinray::pack_scene(b.scene, backend->pack_options())));
      // One ray first: the scene's upload and the OpenCL program are not the batch's.
      twinray::Hit<float> first;
      backend->intersect(rays.data(), 1, &first);
      std::vector<twinray::Hit<float>> hits(count);  // zeroed: every page resident
      const double before = resident_mib();
      twinray_bench::reset_peak();
      const auto t0 = std::chrono::steady_clock::now();
      backend->intersect(rays.data(), count, hits.data());
      const double s = twinray_bench::ms_since(t0) / 1000.0;
      const double added = twinray_bench::peak_mib() - before;
      size_t found = 0;
      for (const auto& h : hits) found += h.object >= 0;
      std::printf(
          "  %-6s %8.2f s  %7.2f Mrays/s  %zu hits  peak +%.1f MiB over the arrays "
          "(rays %.0f + hits %.0f MiB) (%s)\n",
          name.c_str(), s, n / s / 1e6, found, added, rays_mib,
          count * sizeof(hits[0]) / double(1 << 20), backend->device_name().c_str());
      answers.push_back(std::move(hits));
      names.push_back(name);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s: %s\n", name.c_str(), e.what());
      return 1;
    }
  }
  for (size_t k = 1; k < answers.size(); ++k) {
    size_t differ = 0;
    for (size_t i = 0; i < count; ++i)
      differ += std::memcmp(&answers[0][i], &answers[k][i], sizeof(answers[0][i])) != 0;
    std::printf("  %s against %s: %zu of %lld hits differ%s\n", names[k].c_str(), names[0].c_str(),
                differ, n, differ == 0 ? " (the same bits)" : "");
  }
  return 0;
}
