// The CPU backend: runs the shared device code (device/code.hpp) over 16x16 tiles of
// the requested rectangle, handed out by parallel_for (core/parallel.hpp). No
// allocation or locking per pixel; the scene's arrays are read in place.
//
// The device code is a template on the Features mask; render() turns the run-time mask
// into a template argument once per render. Each bit in
// TWINRAY_CPU_SPECIALIZED_FEATURES doubles the instantiations (2^n per precision, each
// about 0.7 s of g++ -O3 in every translation unit that renders); the other bits are
// compiled in everywhere and switched by TrParams::features at run time, exactly as in
// the generic OpenCL program. The default takes the four bits that remove the most
// work: a scene without triangles or planes, with shadows off, or with nothing glazed
// runs none of that code. Define the macro (the same in every translation unit) to
// choose others.
#pragma once

#include <algorithm>
#include <atomic>
#include <chrono>
#include <memory>
#include <string>
#include <array>
#include <thread>
#include <type_traits>
#include <vector>

#include <twinray/backend/backend.hpp>
#include <twinray/core/parallel.hpp>
#include <twinray/device/code.hpp>

namespace twinray {
namespace cpu {

#ifndef TWINRAY_CPU_SPECIALIZED_FEATURES
#define TWINRAY_CPU_SPECIALIZED_FEATURES (TR_F_TRIANGLES | TR_F_PLANES | TR_F_SHADOWS | TR_F_GLAZE)
#endif
constexpr unsigned kHostSpecializedFeatures = TWINRAY_CPU_SPECIALIZED_FEATURES;

// This thread's V, made on its first use. Held through a pointer: where the device code
// was handed a thread-local's own address, the compiler cloned the function it was
// passed to with that address as a constant, which in a shared library recomputes it
// (a call to __tls_get_addr) after every call the function makes: a third more time
// per frame of the demo. A pointer loaded at run time cannot be folded in.
template <class V>
V& thread_scratch() {
  thread_local std::unique_ptr<V> held;
  if (!held) held = std::make_unique<V>();
  return *held;
}

// The Features mask the CPU path compiles for a render that needs `needed`.
constexpr unsigned compiled_features(unsigned needed) {
  return (needed & kHostSpecializedFeatures) | (TR_F_ALL & ~kHostSpecializedFeatures);
}

// Calls f(std::integral_constant<unsigned, Features>) with the instantiation for work
// that needs `needed`, the bits of Specialized as template arguments and every other
// bit compiled in: walks the specialized bits from the lowest up, turning each
// run-time bit into a template argument.
template <unsigned Specialized, unsigned Remaining = Specialized, unsigned Fixed = 0u, class F>
void with_features_of(unsigned needed, F&& f) {
  if constexpr (Remaining == 0u) {
    f(std::integral_constant<unsigned, Fixed | (TR_F_ALL & ~Specialized)>());
  } else {
    constexpr unsigned bit = Remaining & (~Remaining + 1u);
    if (needed & bit)
      with_features_of<Specialized, Remaining & ~bit, Fixed | bit>(needed, f);
    else
      with_features_of<Specialized, Remaining & ~bit, Fixed>(needed, f);
  }
}

// The instantiation for a render that needs `needed`.
template <class F>
void with_features(unsigned needed, F&& f) {
  with_features_of<kHostSpecializedFeatures>(needed, f);
}

// Ray queries (device/ray_query.h) specialize the bits that remove the most of their
// work: a scene without triangles, planes or masks runs none of that code. 2^3
// instantiations per precision, apart from the renderer's; the macro chooses others,
// as TWINRAY_CPU_SPECIALIZED_FEATURES does for the renderer.
#ifndef TWINRAY_CPU_QUERY_SPECIALIZED_FEATURES
#define TWINRAY_CPU_QUERY_SPECIALIZED_FEATURES (TR_F_TRIANGLES | TR_F_PLANES | TR_F_MASKS)
#endif
constexpr unsigned kQuerySpecializedFeatures = TWINRAY_CPU_QUERY_SPECIALIZED_FEATURES;

// Calls chunk(begin, end) for consecutive ranges of at most kQueryChunk of the n rays,
// handed out to the threads. Each ray's answer is its own, so the split changes none.
constexpr size_t kQueryChunk = 256;
template <class F>
void for_each_ray_chunk(size_t n, F&& chunk) {
  const size_t chunks = (n + kQueryChunk - 1) / kQueryChunk;
  const size_t per_pass = static_cast<size_t>(1) << 30;  // parallel_for counts in int
  for (size_t first = 0; first < chunks; first += per_pass) {
    const int count = static_cast<int>(std::min(per_pass, chunks - first));
    parallel_for(count, 1, [&](int c) {
      const size_t begin = (first + static_cast<size_t>(c)) * kQueryChunk;
      chunk(begin, std::min(n, begin + kQueryChunk));
    });
  }
}

// How the CPU answers a batch of queries: Packets (what the backend does) walks up to
// TR_PACKET_MAX rays at a time as one packet where their directions share their signs,
// made of consecutive rays, or in runs of rays that mostly share their origins, of the
// rays of one octant (device/ray_query.h, tr_query_intersect_rays), and walks as one only
// a packet whose directions are narrow (tr_query_packet_narrow); PacketsInOrder
// always makes them of consecutive rays, PacketsByOctant always of one octant's rays, and
// both walk every packet of one octant as one;
// RayByRay walks every ray alone. The answers are the same bits either way
// (tests/query).
enum class QueryWalk { Packets, PacketsInOrder, PacketsByOctant, RayByRay };

// The grouping tr_query_intersect_rays and tr_query_occluded_rays take for a walk.
inline int query_grouping(QueryWalk walk) {
  return walk == QueryWalk::PacketsInOrder ? 0 : walk == QueryWalk::PacketsByOctant ? 1 : 2;
}

// Answers the n rays of a query against `scene`, on this thread and parallel_for's, in
// chunks: for each ray, one(kernel, ref, i) where `walk` is RayByRay, else for each
// chunk packets(kernel, ref, scratch, begin, end), which returns how many rays went
// through the packet walk: `kernel` is a null pointer of the CPU kernel type the
// scene's features pick (kQuerySpecializedFeatures), `ref` the device code's view of the
// scene, `scratch` this thread's packet. Returns the sum of packets' results.
template <class T, class One, class Packets>
size_t for_each_query_chunk(const PackedScene<T>& scene, size_t n, QueryWalk walk, One&& one,
                            Packets&& packets) {
  const auto params = query_params(scene.summary());
  const auto ref = scene_ref<T>(scene, &params, nullptr);
  std::atomic<size_t> total{0};
  with_features_of<kQuerySpecializedFeatures>(scene.features, [&](auto features) {
    using K = typename device::Code<T>::template CpuKernel<decltype(features)::value>;
    for_each_ray_chunk(n, [&](size_t begin, size_t end) {
      if (walk == QueryWalk::RayByRay) {
        for (size_t i = begin; i < end; ++i) one(static_cast<K*>(nullptr), ref, i);
        return;
      }
      auto& scratch = thread_scratch<typename device::Code<T>::CpuQueryPacket>();
      const int walked = packets(static_cast<K*>(nullptr), ref, &scratch, begin, end);
      if (walked != 0) total.fetch_add(static_cast<size_t>(walked), std::memory_order_relaxed);
    });
  });
  return total.load();
}

// The closest hit of each of the n rays against `scene` (RenderBackend::intersect): what
// CpuBackend runs, callable without a backend. Returns how many rays went through the
// packet walk.
template <class T>
size_t query_intersect(const PackedScene<T>& scene, const Ray<T>* rays, size_t n, Hit<T>* hits,
                       unsigned extras, HitExtra<T>* extra_out,
                       QueryWalk walk = QueryWalk::Packets) {
  const int flags = static_cast<int>(extras);
  return for_each_query_chunk(
      scene, n, walk,
      [&](auto kernel, const auto& ref, size_t i) {
        std::remove_pointer_t<decltype(kernel)>::tr_query_intersect(
            &ref, &rays[i], &hits[i], extra_out ? &extra_out[i] : nullptr, flags);
      },
      [&](auto kernel, const auto& ref, auto* scratch, size_t begin, size_t end) {
        return std::remove_pointer_t<decltype(kernel)>::tr_query_intersect_rays(
            &ref, scratch, &rays[begin], static_cast<int>(end - begin), &hits[begin],
            extra_out ? &extra_out[begin] : nullptr, flags, query_grouping(walk));
      });
}

// Whether anything blocks each of the n rays (RenderBackend::occluded): 1 or 0. Returns
// how many rays went through the packet walk.
template <class T>
size_t query_occluded(const PackedScene<T>& scene, const Ray<T>* rays, size_t n, uint8_t* blocked,
                      QueryWalk walk = QueryWalk::Packets) {
  return for_each_query_chunk(
      scene, n, walk,
      [&](auto kernel, const auto& ref, size_t i) {
        blocked[i] = static_cast<uint8_t>(
            std::remove_pointer_t<decltype(kernel)>::tr_query_occluded(&ref, &rays[i]) ? 1 : 0);
      },
      [&](auto kernel, const auto& ref, auto* scratch, size_t begin, size_t end) {
        return std::remove_pointer_t<decltype(kernel)>::tr_query_occluded_rays(
            &ref, scratch, &rays[begin], static_cast<int>(end - begin), &blocked[begin],
            query_grouping(walk));
      });
}

// Calls block(x, y, w, h) for every block of at most block_w x block_h pixels of the
// rectangle (frame coordinates), handed out to the threads a few at a time.
template <class F>
void for_each_block(int x0, int y0, int width, int height, int block_w, int block_h, F&& block) {
  const int blocks_x = (width + block_w - 1) / block_w;
  const int blocks_y = (height + block_h - 1) / block_h;
  parallel_for(blocks_x * blocks_y, 1, [&](int b) {
    const int bx = (b % blocks_x) * block_w, by = (b / blocks_x) * block_h;
    block(x0 + bx, y0 + by, std::min(block_w, width - bx), std::min(block_h, height - by));
  });
}

// Calls pixel(x, y) for every pixel of the rectangle (frame coordinates), in 16x16
// tiles handed out to the threads.
template <class F>
void for_each_pixel(int x0, int y0, int width, int height, F&& pixel) {
  for_each_block(x0, y0, width, height, 16, 16, [&](int bx, int by, int bw, int bh) {
    for (int y = by; y < by + bh; ++y)
      for (int x = bx; x < bx + bw; ++x) pixel(x, y);
  });
}

inline std::string cpu_name() {
  return "CPU, " + std::to_string(std::thread::hardware_concurrency()) + " hardware threads";
}

template <class T>
class CpuBackend final : public RenderBackend<T> {
 public:
  Backend kind() const override { return Backend::Cpu; }
  std::string device_name() const override {
    return cpu_name() + ", " + std::to_string(thread_count()) + " used";
  }

  void set_scene(std::shared_ptr<const PackedScene<T>> scene) override {
    scene_ = std::move(scene);
  }

 protected:
  void intersect_rays(const Ray<T>* rays, size_t n, Hit<T>* hits, unsigned extras,
                      HitExtra<T>* extra_out) override {
    require_scene(scene_ != nullptr);
    query_intersect(*scene_, rays, n, hits, extras, extra_out);
  }
  void occluded_rays(const Ray<T>* rays, size_t n, uint8_t* blocked) override {
    require_scene(scene_ != nullptr);
    query_occluded(*scene_, rays, n, blocked);
  }

 public:
  void render_into(const RenderRequest<T>& request, Image<T>& image,
                   RenderInfo* info = nullptr) override {
    require_scene(scene_ != nullptr);
    const PackedFrame<T> frame = pack_frame(scene_->summary(), request);
    const auto t0 = std::chrono::steady_clock::now();
    const unsigned compiled =
        compiled_features(request.options.specialize ? frame.features : TR_F_ALL);
    const auto& p = frame.params;
    image.resize(p.rect_w, p.rect_h);
    long long refined = 0;
    with_features(compiled, [&](auto features) {
      // The device code as the CPU backend compiles it (device/code.hpp, CpuKernel).
      using K = typename device::Code<T>::template CpuKernel<decltype(features)::value>;
      if (p.adaptive_spp > 0)
        refined = render_adaptive<K>(frame, image);
      else
        render_uniform<K>(frame, request.options.output, image);
    });
    if (info) {
      info->backend = Backend::Cpu;
      info->device = device_name();
      info->features = compiled;
      info->kernel.clear();
      info->build_ms = 0;
      info->program_cached = false;
      info->transfer_ms = 0;
      info->scene_uploaded = false;
      info->render_ms = sample_plan::ms_since(t0);
      info->refined_pixels = refined;
      info->samples = sample_plan::samples_traced(
          request.options, static_cast<long long>(p.rect_w) * p.rect_h, refined);
    }
  }

 private:
  template <class K>
  void render_uniform(const PackedFrame<T>& frame, Output output, Image<T>& image) const {
    const auto scene = frame.ref(*scene_);
    const auto& p = frame.params;
    const int aov = device_aov(output);
    if (output == Output::Shaded) {
      // Blocks of pixels traced a segment at a time (device/trace.h tr_render_block);
      // the same values as pixel by pixel.
      using Scratch = typename device::Code<T>::CpuBlockScratch;
      static_assert(TR_BLOCK_SIDE * TR_BLOCK_SIDE <= TR_PACKET_MAX, "a block is one packet");
      // The block kernel's steps (tr_render_block_at), a tile of blocks at a time per
      // thread.
      struct BlockMemory {
        Scratch scratch;
        // The pending rays of each path: read only where glass is in the scene.
        std::array<typename device::Code<T>::CpuRayStack, TR_BLOCK_SIDE * TR_BLOCK_SIDE> stacks;
      };
      parallel_for(K::tr_block_count(&p), TR_TILE_BLOCKS * TR_TILE_BLOCKS, [&](int index) {
        BlockMemory& memory = thread_scratch<BlockMemory>();
        K::tr_render_block_at(&scene, &memory.scratch, memory.stacks.data(), index,
                              image.rgb.data());
      });
      return;
    }
    for_each_pixel(p.rect_x, p.rect_y, p.rect_w, p.rect_h, [&](int x, int y) {
      K::tr_store_rgb(image.rgb.data(), p.rect_w, x - p.rect_x, y - p.rect_y,
                      K::tr_render_aov(&scene, x, y, aov));
    });
  }

  // The adaptive plan (device/adaptive.h): first pass over the statistics window,
  // the criterion over the rectangle, then the refinement of the flagged pixels.
  // Returns how many pixels were refined.
  template <class K>
  long long render_adaptive(const PackedFrame<T>& frame, Image<T>& image) const {
    const auto scene = frame.ref(*scene_);
    const auto& p = frame.params;
    std::vector<T> stats(static_cast<size_t>(p.stats_w) * p.stats_h * TR_ADAPTIVE_STATS);
    for_each_pixel(p.stats_x, p.stats_y, p.stats_w, p.stats_h, [&](int x, int y) {
      typename device::Code<T>::CpuVec3 range;
      auto sum = K::tr_adaptive_first(&scene, x, y, &range);
      K::tr_adaptive_store_stats(&p, stats.data(), x, y, sum, range);
      const int rx = x - p.rect_x, ry = y - p.rect_y;
      if (rx >= 0 && ry >= 0 && rx < p.rect_w && ry < p.rect_h)
        K::tr_store_rgb(image.rgb.data(), p.rect_w, rx, ry, sum * (T(1) / T(p.spp)));
    });
    std::vector<int> flags(static_cast<size_t>(p.rect_w) * p.rect_h);
    parallel_for(p.rect_h, 8, [&](int j) {
      for (int i = 0; i < p.rect_w; ++i)
        flags[static_cast<size_t>(j) * p.rect_w + i] =
            K::tr_adaptive_refine_flag(&p, stats.data(), p.rect_x + i, p.rect_y + j);
    });
    const std::vector<int> list = sample_plan::flagged_pixels(flags);
    parallel_for(static_cast<int>(list.size()), 16, [&](int k) {
      const int i = list[k] % p.rect_w, j = list[k] / p.rect_w;
      K::tr_store_rgb(image.rgb.data(), p.rect_w, i, j,
                      K::tr_adaptive_refine(&scene, stats.data(), p.rect_x + i, p.rect_y + j));
    });
    return static_cast<long long>(list.size());
  }

  std::shared_ptr<const PackedScene<T>> scene_;
};

}  // namespace cpu
}  // namespace twinray

// A translation unit that makes a CPU backend compiles the renderer for every
// specialized Features mask, in float and double: over a minute of g++ -O3. A program
// of several such translation units (or several programs built with the same flags) can
// compile it once: define TWINRAY_CPU_BACKEND_EXTERN in all of them, and compile
//   template class twinray::cpu::CpuBackend<float>;   (and <double>)
// in one translation unit with the same flags (CMake: twinray_cpu_instances(),
// cmake/cpu_instances.cmake; docs/adopting.md).
#ifdef TWINRAY_CPU_BACKEND_EXTERN
extern template class twinray::cpu::CpuBackend<float>;
extern template class twinray::cpu::CpuBackend<double>;
#endif
