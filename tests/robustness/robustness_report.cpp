// Prints the figures of every robustness case (robustness_cases.hpp) as the Markdown
// table of docs/robustness.md: float and double, CPU and OpenCL.
//
//   robustness_report [--png DIR]     DIR: also write the shaded images of some cases
#include <cstdio>
#include <iostream>
#include <string>

#if __has_include(<twinray/io/png.hpp>) && __has_include(<stb_image_write.h>)
#include <twinray/io/png.hpp>
#define RB_HAVE_PNG 1
#endif

#include "robustness_cases.hpp"

namespace {

std::string png_dir;

std::string num(long long v) {
  return v < 0 ? "-" : std::to_string(v);
}
std::string ulp(double v) {
  if (v < 0) return "-";
  char b[32];
  std::snprintf(b, sizeof b, v < 10 ? "%.2f" : "%.3g", v);
  return b;
}

template <class T>
void row(const std::string& name, rb::Backend backend, rb::Figures f) {
  std::cout << "| " << name << " | " << twinray::device::Code<T>::name << " | "
            << twinray::to_string(backend) << " | " << f.samples << " | " << num(f.acne) << " | "
            << num(f.leaks) << " | " << num(f.wrong) << " | " << f.nonfinite << " | "
            << ulp(f.terr_max) << " | " << ulp(f.terr_median) << " | " << num(f.parity) << " |"
            << std::endl;
}

template <class T, class Run>
void run_case(const std::string& name, Run run) {
  std::vector<rb::Backend> backends = {rb::Backend::Cpu};
  if (rb::opencl_ok()) backends.push_back(rb::Backend::OpenCL);
  for (rb::Backend b : backends) {
    rb::Ctx ctx;
    ctx.backend = b;
    ctx.check_parity = b == rb::Backend::Cpu && backends.size() > 1;
#ifdef RB_HAVE_PNG
    if (!png_dir.empty() && b == rb::Backend::Cpu)
      ctx.on_image = [](const std::string& n, const void* img) {
        twinray::io::write_png(png_dir + "/" + n + "_" + twinray::device::Code<T>::name + ".png",
                               *static_cast<const twinray::Image<T>*>(img));
      };
#endif
    rb::Figures f = run(ctx);
    f.parity = ctx.parity;
    row<T>(name, b, f);
  }
}

template <class T>
void all_cases() {
  using rb::Shape;
  for (Shape s : {Shape::Sphere, Shape::Plane, Shape::Mesh, Shape::InsideSphere})
    run_case<T>(std::string("acne, ") + rb::shape_name(s) + ", scale sweep",
                [s](rb::Ctx& c) { return rb::case_acne_sweep<T>(c, s); });
  run_case<T>("watertight grids (vertex/edge rays), scale sweep", [](rb::Ctx& c) {
    rb::Figures f;
    for (double s : {1e-4, 1.0, 1e5})
      for (double off : {0.0, 1e4})
        for (bool tilted : {false, true}) f.add(rb::case_watertight_grid<T>(c, s, off, tilted));
    return f;
  });
  run_case<T>("watertight closed icosphere, from inside", [](rb::Ctx& c) {
    bool single = c.backend == rb::Backend::Cpu;
    rb::Figures f = rb::case_watertight_closed<T>(c, rb::V3<T>(0, 0, 0), T(2), single);
    f.add(
        rb::case_watertight_closed<T>(c, rb::V3<T>(T(148376), T(1234), T(-223423)), T(2), single));
    f.add(rb::case_watertight_closed<T>(c, rb::V3<T>(T(3e-4), T(-1e-4), T(2e-4)), T(1e-4), single));
    return f;
  });
  for (double d : {1e2, 4.1e3, 1e5})
    run_case<T>("tiny far sphere, D = " + ulp(d),
                [d](rb::Ctx& c) { return rb::case_tiny_far_sphere<T>(c, d); });
  run_case<T>("huge ground sphere R = 1e5", [](rb::Ctx& c) { return rb::case_huge_sphere<T>(c); });
  run_case<T>("grazing plane, camera 1e-3 above", [](rb::Ctx& c) {
    rb::Figures f = rb::case_grazing<T>(c, 1e-3, 0.0);
    f.add(rb::case_grazing<T>(c, 1e-3, 1e3));
    return f;
  });
  run_case<T>("degenerate and needle triangles", [](rb::Ctx& c) {
    rb::Figures f = rb::case_degenerate<T>(c, 1.0);
    f.add(rb::case_degenerate<T>(c, 1e-3));
    f.add(rb::case_degenerate<T>(c, 1e4));
    return f;
  });
  run_case<T>("shininess 0..1e4, intensity 0 and 1e30",
              [](rb::Ctx& c) { return rb::case_shininess_intensity<T>(c); });
  for (T k : {T(0.5), T(1)})
    run_case<T>("facing mirrors, depth 64, k = " + ulp(double(k)), [k](rb::Ctx& c) {
      rb::Figures f = rb::case_mirrors<T>(c, k);
      std::cerr << "  mirrors k=" << double(k) << " " << twinray::device::Code<T>::name
                << ": max relative error " << f.rel_err_max << " u\n";
      return f;
    });
  run_case<T>("glass slabs and thin sheets, 0..80 degrees, scale sweep", [](rb::Ctx& c) {
    rb::Figures f;
    for (double s : rb::sweep_scales())
      for (double off : rb::sweep_offsets())
        for (double degrees : {0.0, 40.0, 80.0})
          for (bool thin : {false, true}) f.add(rb::case_glass_slab<T>(c, s, off, degrees, thin));
    std::cerr << "  glass " << twinray::device::Code<T>::name << ": largest relative error "
              << f.rel_err_max << "\n";
    return f;
  });
  for (rb::Prim p : {rb::Prim::Sphere, rb::Prim::Triangle, rb::Prim::Plane}) {
    rb::Figures f = rb::case_t_sweep<T>(p, 2000);
    row<T>(std::string("t sweep, random rays, ") + rb::prim_name(p), rb::Backend::Cpu, f);
  }
}

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--png" && i + 1 < argc) png_dir = argv[++i];
  std::cout
      << "| case | precision | backend | rays | acne px | leaking rays | wrong px | NaN/Inf | "
         "max t err (ulp) | median t err (ulp) | CPU/OpenCL differing px |\n"
      << "|---|---|---|---|---|---|---|---|---|---|---|" << std::endl;
  all_cases<float>();
  all_cases<double>();
  return 0;
}
