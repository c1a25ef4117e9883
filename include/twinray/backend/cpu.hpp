// The CPU backend: runs the shared device code (core/device_code.hpp) over 16x16
// tiles handed out dynamically to a pool of threads, all cores by default. No
// allocation or locking per pixel.
//
// The device code is a template on the Features mask; render_packed() turns the
// run-time mask into a template argument once per render. Each bit in
// TWINRAY_CPU_SPECIALIZED_FEATURES doubles the instantiations (2^n per precision, each
// about 0.7 s of g++ -O3 in every translation unit that calls render()); the other bits
// are compiled in everywhere and switched by TrParams::features at run time, exactly as
// in the generic OpenCL program. The default takes the four bits that remove the most
// work: a scene without triangles or planes, with shadows off, or with nothing glazed
// runs none of that code. Define the macro (the same in every translation unit) to
// choose others.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include <twinray/core/device_code.hpp>
#include <twinray/core/image.hpp>
#include <twinray/core/options.hpp>
#include <twinray/core/pack.hpp>

namespace twinray {
namespace cpu {

#ifndef TWINRAY_CPU_SPECIALIZED_FEATURES
#define TWINRAY_CPU_SPECIALIZED_FEATURES (TR_F_TRIANGLES | TR_F_PLANES | TR_F_SHADOWS | TR_F_GLAZE)
#endif
constexpr unsigned kHostSpecializedFeatures = TWINRAY_CPU_SPECIALIZED_FEATURES;

// The Features mask the CPU path compiles for a render that needs `needed`.
constexpr unsigned compiled_features(unsigned needed) {
  return (needed & kHostSpecializedFeatures) | (TR_F_ALL & ~kHostSpecializedFeatures);
}

inline int thread_count(int requested) {
  if (requested > 0) return requested;
  unsigned n = std::thread::hardware_concurrency();
  return n > 0 ? static_cast<int>(n) : 1;
}

template <class T, unsigned Features>
void render_tiles(const PackedScene<T>& ps, Image<T>& image, int threads, Output output) {
  using Kernel = typename device::Code<T>::template Kernel<Features>;
  constexpr int kTile = 16;
  const int width = ps.params.width, height = ps.params.height;
  const int tiles_x = (width + kTile - 1) / kTile, tiles_y = (height + kTile - 1) / kTile;
  const int n_tiles = tiles_x * tiles_y;
  const typename device::Code<T>::SceneRef scene = ps.ref();
  const int aov = output == Output::Depth    ? TR_AOV_DEPTH
                  : output == Output::Normal ? TR_AOV_NORMAL
                                             : TR_AOV_OBJECT;
  std::atomic<int> next_tile{0};
  auto worker = [&]() {
    for (int tile; (tile = next_tile.fetch_add(1, std::memory_order_relaxed)) < n_tiles;) {
      int x0 = (tile % tiles_x) * kTile, y0 = (tile / tiles_x) * kTile;
      int x1 = std::min(x0 + kTile, width), y1 = std::min(y0 + kTile, height);
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          auto c = output == Output::Shaded ? Kernel::tr_render_pixel(&scene, x, y)
                                            : Kernel::tr_render_aov(&scene, x, y, aov);
          Kernel::tr_store_rgb(image.rgb.data(), width, x, y, c);
        }
    }
  };
  int n = std::min(thread_count(threads), n_tiles);
  std::vector<std::thread> pool;
  for (int i = 1; i < n; ++i) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
}

namespace detail {
// Walks the specialized bits from the lowest up, turning each run-time bit into a
// template argument; 2^popcount(kHostSpecializedFeatures) instantiations in all.
template <class T, unsigned Remaining, unsigned Fixed>
void dispatch(unsigned needed, const PackedScene<T>& ps, Image<T>& image, int threads,
              Output output) {
  if constexpr (Remaining == 0u) {
    render_tiles<T, Fixed | (TR_F_ALL & ~kHostSpecializedFeatures)>(ps, image, threads, output);
  } else {
    constexpr unsigned bit = Remaining & (~Remaining + 1u);
    if (needed & bit)
      dispatch<T, Remaining & ~bit, Fixed | bit>(needed, ps, image, threads, output);
    else
      dispatch<T, Remaining & ~bit, Fixed>(needed, ps, image, threads, output);
  }
}
}  // namespace detail

// Renders a packed scene. `features`: the mask to compile for; TR_F_ALL gives the
// generic instantiation (everything compiled in, switched at run time).
template <class T>
Image<T> render_packed(const PackedScene<T>& ps, unsigned features, int threads, Output output) {
  Image<T> image(ps.params.width, ps.params.height);
  detail::dispatch<T, kHostSpecializedFeatures, 0u>(features, ps, image, threads, output);
  return image;
}

inline std::string cpu_name() {
  return "CPU, " + std::to_string(std::thread::hardware_concurrency()) + " hardware threads";
}

// What a CPU render reports: RenderInfo for `compiled` features on `threads` threads.
inline void fill_info(RenderInfo* info, unsigned compiled, int threads,
                      std::chrono::steady_clock::time_point start) {
  if (!info) return;
  info->backend = Backend::Cpu;
  info->device = cpu_name() + ", " + std::to_string(thread_count(threads)) + " used";
  info->features = compiled;
  info->build_ms = 0;
  info->program_cached = false;
  info->transfer_ms = 0;
  info->render_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace cpu
}  // namespace twinray
