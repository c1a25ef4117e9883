// Choosing a backend, and the one-call entry point.
//
//   make_backend<T>(options)   the backend options.backend names:
//     Backend::Cpu     the CPU backend (always there)
//     Backend::OpenCL  the OpenCL backend on options.device; needs twinray::opencl
//     Backend::Auto    OpenCL when a device exists, otherwise the CPU; it says which,
//                      and falls back to the CPU (and says why) when the OpenCL set-up
//                      fails later, for example a program that does not build
//   render(scene, camera, options)   packs the scene, makes the backend, renders once.
//
// Both backends return the same Image<T>, bit for bit on PoCL.
#pragma once

#include <chrono>
#include <memory>
#include <string>

#include <twinray/backend/backend.hpp>
#include <twinray/backend/cpu.hpp>
#include <twinray/core/error.hpp>
#include <twinray/core/fp_contract_check.hpp>
#include <twinray/core/image.hpp>
#include <twinray/core/options.hpp>
#include <twinray/pack/pack.hpp>
#ifdef TWINRAY_WITH_OPENCL
#include <twinray/backend/opencl/backend.hpp>
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

namespace detail {

inline void warn_if_contracted(const RenderOptions& options) {
  static const bool warned = [&] {
    if (fp_contraction_detected())
      log_note(options,
               "warning: this program was compiled with floating-point contraction (FMA); "
               "CPU and OpenCL images will differ. Compile with -ffp-contract=off (the "
               "twinray CMake targets add it).");
    return true;
  }();
  (void)warned;
}

template <class T>
std::unique_ptr<RenderBackend<T>> make_opencl_backend(int device) {
#ifdef TWINRAY_WITH_OPENCL
  return std::make_unique<opencl::OpenCLBackend<T>>(device);
#else
  (void)device;
  throw Error(ErrorKind::BackendUnavailable,
              "twinray was built without OpenCL (link twinray::opencl)");
#endif
}

}  // namespace detail

// Backend::Auto: renders on OpenCL, and from the first OpenCL failure on (a program
// that does not build, a device without fp64 or with too little memory) on the CPU,
// saying why. Bad requests (InvalidInput) are not failures of the device: they throw.
// It keeps a reference to the scene for the CPU it may fall back to.
template <class T>
class AutoBackend final : public RenderBackend<T> {
 public:
  AutoBackend(std::unique_ptr<RenderBackend<T>> primary, RenderOptions options)
      : active_(std::move(primary)), options_(std::move(options)) {}

  Backend kind() const override { return active_->kind(); }
  std::string device_name() const override { return active_->device_name(); }

  void set_scene(std::shared_ptr<const PackedScene<T>> scene) override {
    scene_ = scene;
    active_->set_scene(std::move(scene));
  }

  void render_into(const RenderRequest<T>& request, Image<T>& image,
                   RenderInfo* info = nullptr) override {
    with_fallback([&] { active_->render_into(request, image, info); });
  }

 protected:
  // Queries go where frames go (OpenCL until it fails, then the CPU): both backends give
  // the same bits.
  void intersect_rays(const Ray<T>* rays, size_t n, Hit<T>* hits, unsigned extras,
                      HitExtra<T>* extra_out) override {
    with_fallback(
        [&] { active_->intersect(rays, n, hits, static_cast<HitExtras>(extras), extra_out); });
  }
  void occluded_rays(const Ray<T>* rays, size_t n, uint8_t* blocked) override {
    with_fallback([&] { active_->occluded(rays, n, blocked); });
  }

 private:
  // Runs `run` on the active backend; on an OpenCL failure other than bad input, says
  // why, moves to the CPU for good and runs it again there.
  template <class F>
  void with_fallback(F&& run) {
    if (active_->kind() == Backend::Cpu) return run();
    try {
      return run();
    } catch (const Error& e) {
      if (e.kind() == ErrorKind::InvalidInput) throw;
      log_note(options_,
               std::string("backend auto: OpenCL failed, using the CPU (") + e.what() + ")");
      active_ = std::make_unique<cpu::CpuBackend<T>>();
      active_->set_scene(scene_);
      return run();
    }
  }

  std::unique_ptr<RenderBackend<T>> active_;
  std::shared_ptr<const PackedScene<T>> scene_;
  RenderOptions options_;
};

// The backend options.backend names, on options.device; notes (Auto's choice and
// fallbacks) go to options.log. Throws BackendUnavailable for Backend::OpenCL without
// a device, or for double on a device without fp64.
template <class T>
std::unique_ptr<RenderBackend<T>> make_backend(const RenderOptions& options) {
  detail::warn_if_contracted(options);
  if (options.backend == Backend::Cpu) return std::make_unique<cpu::CpuBackend<T>>();
  if (options.backend == Backend::OpenCL) return detail::make_opencl_backend<T>(options.device);
  std::string why;
  if (opencl_available(options.device, &why)) {
    try {
      auto opencl = detail::make_opencl_backend<T>(options.device);
      log_note(options, "backend auto: using OpenCL");
      return std::make_unique<AutoBackend<T>>(std::move(opencl), options);
    } catch (const Error& e) {
      // A device that cannot take this render (double without fp64).
      log_note(options,
               std::string("backend auto: OpenCL failed, using the CPU (") + e.what() + ")");
      return std::make_unique<cpu::CpuBackend<T>>();
    }
  }
  log_note(options, "backend auto: using the CPU (" + why + ")");
  return std::make_unique<cpu::CpuBackend<T>>();
}

// Renders `scene` through `camera` (T = float or double, end to end) with `options`;
// fills `info` (which backend and device ran, timings) when given. Returns the linear
// HDR framebuffer, camera.width x camera.height, row 0 at the top.
// Throws Error: InvalidInput (bad scene, camera or options; nothing rendered),
// BackendUnavailable (Backend::OpenCL without a device, or double without fp64),
// RuntimeFailure (the OpenCL program does not build, the device runs out of memory).
// Backend::Auto instead falls back to the CPU, and logs why, when there is no device
// or the OpenCL set-up fails.
// Any thread may call it, also several at once; the scene is only read. A frame loop
// makes one backend and calls its render() instead (backend/backend.hpp): this packs
// the scene on every call.
template <class T>
Image<T> render(const Scene<T>& scene, const Camera<T>& camera, const RenderOptions& options,
                RenderInfo* info = nullptr) {
  validate(camera);
  validate(options);
  std::unique_ptr<RenderBackend<T>> backend = make_backend<T>(options);
  const auto t0 = std::chrono::steady_clock::now();
  auto packed = share(pack_scene(scene, backend->pack_options()));
  const double pack_ms = sample_plan::ms_since(t0);
  backend->set_scene(std::move(packed));
  Image<T> image = backend->render({camera, scene.lights, options, {}}, info);
  if (info) info->pack_ms = pack_ms;
  return image;
}

}  // namespace twinray
