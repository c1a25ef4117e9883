// Renders on both backends and compares the linear framebuffers bit for bit.
#pragma once

#include <doctest/doctest.h>

#include <cstring>
#include <string>

#include <twinray/twinray.hpp>

#include "support/scoped_env.hpp"

namespace test {

// Number of framebuffer values whose bits differ (0 = identical images).
template <class T>
size_t differing_values(const twinray::Image<T>& a, const twinray::Image<T>& b) {
  REQUIRE(a.width == b.width);
  REQUIRE(a.height == b.height);
  size_t n = 0;
  for (size_t i = 0; i < a.rgb.size(); ++i)
    if (std::memcmp(&a.rgb[i], &b.rgb[i], sizeof(T)) != 0) ++n;
  return n;
}

template <class T>
twinray::Image<T> render_with(const twinray::Scene<T>& scene, const twinray::Camera<T>& camera,
                              twinray::RenderOptions options, twinray::Backend backend,
                              twinray::RenderInfo* info = nullptr) {
  options.backend = backend;
  options.log = [](const std::string&) {};
  return twinray::render(scene, camera, options, info);
}

// Renders on the CPU and on OpenCL; checks every value has the same bits and that the
// image is not trivially empty. Returns the CPU image.
template <class T>
twinray::Image<T> check_parity(const twinray::Scene<T>& scene, const twinray::Camera<T>& camera,
                               const twinray::RenderOptions& options) {
  twinray::Image<T> cpu = render_with(scene, camera, options, twinray::Backend::Cpu);
  twinray::Image<T> cl = render_with(scene, camera, options, twinray::Backend::OpenCL);
  CHECK(differing_values(cpu, cl) == 0);
  size_t nonzero = 0;
  for (T v : cpu.rgb) nonzero += v != T(0);
  CHECK(nonzero > cpu.rgb.size() / 20);  // a black image would prove nothing
  return cpu;
}

// Renders on OpenCL by one kernel, chosen through the environment: "pixel"
// (TWINRAY_OPENCL_KERNEL=pixel) or "blocks" (TWINRAY_OPENCL_FIRST_FRAME=blocks, so that a
// block program new to the machine is taken at once); checks that it ran and that the
// image is `cpu`'s bit for bit. Returns what the render reported.
template <class T>
twinray::RenderInfo check_kernel_parity(const twinray::Scene<T>& scene,
                                        const twinray::Camera<T>& camera,
                                        const twinray::RenderOptions& options,
                                        const twinray::Image<T>& cpu, const std::string& kernel) {
  const bool pixel = kernel == "pixel";
  test_support::ScopedEnv choice(pixel ? "TWINRAY_OPENCL_KERNEL" : "TWINRAY_OPENCL_FIRST_FRAME",
                                 pixel ? "pixel" : "blocks");
  twinray::RenderInfo info;
  const twinray::Image<T> cl = render_with(scene, camera, options, twinray::Backend::OpenCL, &info);
  CHECK(info.kernel == kernel);
  CHECK(differing_values(cpu, cl) == 0);
  return info;
}

}  // namespace test
