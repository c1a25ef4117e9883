// One side of ab_frames: the CPU backend (float) and the benchmark scenes of one source
// tree, in a module that ab_frames loads beside the other side's. Built from the tree
// that TWINRAY_AB_SIDE_TREE names (bench/CMakeLists.txt), with the CPU backend's flags.
// Only the functions below are visible, so two sides never share a symbol.
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <memory>
#include <string>

#include "bench_scenes.hpp"
#include "../bench_stats.hpp"

namespace {
struct Side {
  twinray_bench::BenchScene<float> bench;
  twinray::RenderOptions options;
  std::unique_ptr<twinray::RenderBackend<float>> backend;
  twinray::Image<float> image;
};
}  // namespace

#define AB_EXPORT extern "C" __attribute__((visibility("default")))

// The scene packed for a CPU backend on `threads` threads (0: all); null on an error,
// with its message in error[0 .. error_size).
AB_EXPORT void* twinray_ab_make(const char* scene, int width, int height, int threads,
                                const char* obj_dir, char* error, int error_size) {
  try {
    twinray::set_thread_count(threads);
    auto side = std::make_unique<Side>();
    side->bench = twinray_bench::make_scene<float>(scene, width, height, obj_dir);
    side->options = side->bench.options;
    side->options.backend = twinray::Backend::Cpu;
    side->options.spp = side->bench.spp;
    side->backend = twinray::make_backend<float>(side->options);
    side->backend->set_scene(
        twinray::share(twinray::pack_scene(side->bench.scene, side->backend->pack_options())));
    return side.release();
  } catch (const std::exception& e) {
    std::snprintf(error, static_cast<size_t>(error_size), "%s", e.what());
    return nullptr;
  }
}

// Renders one frame; returns its milliseconds, and in *hash the FNV-1a hash of the
// framebuffer's bytes (the same image bits give the same hash on both sides).
AB_EXPORT double twinray_ab_frame(void* handle, std::uint64_t* hash) {
  Side* side = static_cast<Side*>(handle);
  const twinray::RenderRequest<float> request{
      side->bench.camera, side->bench.scene.lights, side->options, {}};
  const auto t0 = std::chrono::steady_clock::now();
  side->backend->render_into(request, side->image, nullptr);
  const double ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  *hash = twinray_bench::image_hash(side->image);
  return ms;
}

AB_EXPORT void twinray_ab_free(void* handle) {
  delete static_cast<Side*>(handle);
}
