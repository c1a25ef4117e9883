// render(): the one entry point. Packs the scene, picks the backend and runs it.
//   Backend::Cpu     the CPU backend (always there)
//   Backend::OpenCL  the OpenCL backend; needs twinray::opencl (TWINRAY_WITH_OPENCL)
//   Backend::Auto    OpenCL when a device exists, otherwise the CPU; says which
// Both backends return the same Image<T>, bit for bit on PoCL.
#pragma once

#include <chrono>
#include <string>

#include <twinray/backend/adaptive.hpp>
#include <twinray/backend/cpu.hpp>
#include <twinray/core/error.hpp>
#include <twinray/core/fp_contract_check.hpp>
#include <twinray/core/image.hpp>
#include <twinray/core/options.hpp>
#include <twinray/core/pack.hpp>
#ifdef TWINRAY_WITH_OPENCL
#include <twinray/backend/opencl.hpp>
#endif

namespace twinray {

// Is an OpenCL device there? (false when built without twinray::opencl)
inline bool opencl_available(int device = -1, std::string* why = nullptr) {
#ifdef TWINRAY_WITH_OPENCL
  try {
    opencl::shared_context(device);
    return true;
  } catch (const Error& e) {
    if (why) *why = e.what();
    return false;
  }
#else
  (void)device;
  if (why) *why = "twinray was built without OpenCL (link twinray::opencl)";
  return false;
#endif
}

// Renders a packed scene with the chosen backend. `features` is the mask compiled in:
// ps.features for a specialized program, TR_F_ALL for the generic one.
template <class T>
Image<T> render_packed(const PackedScene<T>& ps, unsigned features, const RenderOptions& options,
                       RenderInfo* info = nullptr) {
  static const bool contraction_warned = [&] {
    if (fp_contraction_detected())
      log_note(options,
               "warning: this program was compiled with floating-point contraction (FMA); "
               "CPU and OpenCL images will differ. Compile with -ffp-contract=off (the "
               "twinray CMake targets add it).");
    return true;
  }();
  (void)contraction_warned;
  Backend backend = options.backend;
  const bool automatic = backend == Backend::Auto;
  if (automatic) {
    std::string why;
    backend = opencl_available(options.device, &why) ? Backend::OpenCL : Backend::Cpu;
    log_note(options, backend == Backend::OpenCL ? "backend auto: using OpenCL"
                                                 : "backend auto: using the CPU (" + why + ")");
  }
  const bool adaptive = options.adaptive_spp > 0 && options.output == Output::Shaded;
  if (backend == Backend::OpenCL) {
#ifdef TWINRAY_WITH_OPENCL
    try {
      if (adaptive) return adaptive::render_packed(ps, features, Backend::OpenCL, options, info);
      return opencl::render_packed(opencl::shared_context(options.device), ps, features,
                                   options.output, info);
    } catch (const Error& e) {
      // Auto: an OpenCL set-up that fails (the program does not build, the device has
      // no double support or too little memory) falls back to the CPU and says why.
      if (!automatic || e.kind() == ErrorKind::InvalidInput) throw;
      log_note(options,
               std::string("backend auto: OpenCL failed, using the CPU (") + e.what() + ")");
    }
#else
    throw Error(ErrorKind::BackendUnavailable,
                "twinray was built without OpenCL (link twinray::opencl)");
#endif
  }
  if (adaptive) return adaptive::render_packed(ps, features, Backend::Cpu, options, info);
  auto t0 = std::chrono::steady_clock::now();
  unsigned compiled = cpu::compiled_features(features);
  Image<T> image = cpu::render_packed(ps, compiled, options.threads, options.output);
  cpu::fill_info(info, compiled, options.threads, t0);
  return image;
}

// Renders `scene` through `camera` (T = float or double, end to end) with `options`;
// fills `info` (which backend and device ran, timings) when given. Returns the linear
// HDR framebuffer, camera.width x camera.height, row 0 at the top.
// Throws Error: InvalidInput (bad scene, camera or options; nothing rendered),
// BackendUnavailable (Backend::OpenCL without a device, or double without fp64),
// RuntimeFailure (the OpenCL program does not build, the device runs out of memory).
// Backend::Auto instead falls back to the CPU, and logs why, when there is no device
// or the OpenCL set-up fails.
// Any thread may call it, also several at once; the scene is only read.
template <class T>
Image<T> render(const Scene<T>& scene, const Camera<T>& camera, const RenderOptions& options,
                RenderInfo* info = nullptr) {
  auto t0 = std::chrono::steady_clock::now();
  PackedScene<T> ps = pack(scene, camera, options);
  double pack_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  Image<T> image = render_packed(ps, options.specialize ? ps.features : TR_F_ALL, options, info);
  if (info) info->pack_ms = pack_ms;
  return image;
}

}  // namespace twinray
