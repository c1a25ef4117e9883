// ab_frames: two builds of the CPU backend (ab_side.cpp from two source trees, as
// modules) render the same benchmark scene in one process, frame for frame:
// A B, B A, A B, ... after one warm-up frame each, so that both meet the same state of
// the machine. Prints, per scene, B / A over the pairs (the median, the geometric mean
// and the quartiles of the per-pair ratios) and whether every frame of B had A's
// image bits. Which module is loaded first can shift its frames by a few percent;
// scripts/ab_device.sh runs both orders and combines them.
//   ab_frames A.so B.so [--pairs N] [--threads T] [--width W] [--height H] SCENE...
// CSV on stdout: scene,pairs,b_over_a_median,b_over_a_geomean,q1,q3,a_ms,b_ms,same_bits
#include <dlfcn.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "../bench_stats.hpp"

namespace {
using twinray_bench::quantile;
using MakeFn = void* (*)(const char*, int, int, int, const char*, char*, int);
using FrameFn = double (*)(void*, std::uint64_t*);
using FreeFn = void (*)(void*);

struct Module {
  MakeFn make = nullptr;
  FrameFn frame = nullptr;
  FreeFn free = nullptr;
};

bool load(const char* path, Module* m) {
  void* lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
  if (!lib) {
    std::fprintf(stderr, "ab_frames: %s\n", dlerror());
    return false;
  }
  m->make = reinterpret_cast<MakeFn>(dlsym(lib, "twinray_ab_make"));
  m->frame = reinterpret_cast<FrameFn>(dlsym(lib, "twinray_ab_frame"));
  m->free = reinterpret_cast<FreeFn>(dlsym(lib, "twinray_ab_free"));
  if (!m->make || !m->frame || !m->free) {
    std::fprintf(stderr, "ab_frames: %s is not an ab_side module\n", path);
    return false;
  }
  return true;
}

int usage() {
  std::fprintf(stderr,
               "usage: ab_frames A.so B.so [--pairs N] [--threads T] [--width W] [--height H] "
               "SCENE...\n");
  return 2;
}
}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) return usage();
  Module a, b;
  if (!load(argv[1], &a) || !load(argv[2], &b)) return 1;
  int pairs = 8, threads = 0, width = 1920, height = 1080;
  std::vector<std::string> scenes;
  for (int i = 3; i < argc; ++i) {
    std::string arg = argv[i];
    auto value = [&](int* out) {
      if (i + 1 >= argc) return false;
      *out = std::atoi(argv[++i]);
      return true;
    };
    if (arg == "--pairs" || arg == "--threads" || arg == "--width" || arg == "--height") {
      int* out = arg == "--pairs"     ? &pairs
                 : arg == "--threads" ? &threads
                 : arg == "--width"   ? &width
                                      : &height;
      if (!value(out)) return usage();
    } else {
      scenes.push_back(arg);
    }
  }
  if (scenes.empty() || pairs < 1 || threads < 0 || width < 1 || height < 1) return usage();
  std::printf("scene,pairs,b_over_a_median,b_over_a_geomean,q1,q3,a_ms,b_ms,same_bits\n");
  for (const std::string& scene : scenes) {
    char error[512] = "";
    void* ha = a.make(scene.c_str(), width, height, threads, ".", error, sizeof error);
    void* hb =
        ha ? b.make(scene.c_str(), width, height, threads, ".", error, sizeof error) : nullptr;
    if (!ha || !hb) {
      std::fprintf(stderr, "ab_frames: %s: %s\n", scene.c_str(), error);
      return 1;
    }
    std::uint64_t hash_a = 0, hash_b = 0;
    a.frame(ha, &hash_a);
    b.frame(hb, &hash_b);
    bool same = hash_a == hash_b;
    std::vector<double> ratios, ms_a, ms_b;
    for (int p = 0; p < pairs; ++p) {
      double ta, tb;
      if (p % 2 == 0) {
        ta = a.frame(ha, &hash_a);
        tb = b.frame(hb, &hash_b);
      } else {
        tb = b.frame(hb, &hash_b);
        ta = a.frame(ha, &hash_a);
      }
      same = same && hash_a == hash_b;
      ratios.push_back(tb / ta);
      ms_a.push_back(ta);
      ms_b.push_back(tb);
      std::fprintf(stderr, "%s pair %d: A %.1f ms, B %.1f ms, B / A %.3f\n", scene.c_str(), p, ta,
                   tb, tb / ta);
    }
    double log_sum = 0;
    for (double r : ratios) log_sum += std::log(r);
    std::printf("%s,%d,%.4f,%.4f,%.4f,%.4f,%.1f,%.1f,%s\n", scene.c_str(), pairs,
                quantile(ratios, 0.5), std::exp(log_sum / pairs), quantile(ratios, 0.25),
                quantile(ratios, 0.75), quantile(ms_a, 0.5), quantile(ms_b, 0.5),
                same ? "yes" : "no");
    std::fflush(stdout);
    a.free(ha);
    b.free(hb);
  }
  return 0;
}
