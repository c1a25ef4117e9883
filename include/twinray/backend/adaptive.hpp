// Adaptive anti-aliasing on both backends (criterion and bit rules: device/adaptive.h).
//
//   1. first pass, every pixel: RenderOptions::spp samples; mean to the framebuffer,
//      sum and per-channel range to a statistics buffer;
//   2. mark, every pixel: the contrast test against adaptive_threshold;
//   3. the host lists the marked pixels in row-major order (the flags come back from
//      the device: 4 bytes a pixel);
//   4. refine, one work-item per listed pixel: adaptive_spp samples.
// The CPU runs the same device functions over the same steps with its thread pool,
// so both return the same bits; render() calls this when options.adaptive_spp > 0.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>

#include <twinray/backend/cpu.hpp>
#include <twinray/core/error.hpp>
#include <twinray/core/image.hpp>
#include <twinray/core/options.hpp>
#include <twinray/core/pack.hpp>
#include <twinray/core/validate.hpp>
#ifdef TWINRAY_WITH_OPENCL
#include <twinray/backend/opencl.hpp>
#endif

namespace twinray {
namespace adaptive {

// Refuses adaptive settings that make no sense, naming the scene file's keys.
inline void validate_options(const RenderOptions& o) {
  if (o.adaptive_spp <= o.spp || o.adaptive_spp > Limits::max_spp)
    throw invalid_input("render.adaptive.spp: must be more than render.spp (" +
                        std::to_string(o.spp) + ") and at most " + std::to_string(Limits::max_spp) +
                        ", got " + std::to_string(o.adaptive_spp));
  if (!(o.adaptive_threshold >= 0.0) || !(o.adaptive_threshold < 1e30))
    throw invalid_input("render.adaptive.threshold: must be a finite number >= 0");
}

// Camera samples an adaptive render traces: spp everywhere, plus the refinement's.
inline long long samples_traced(const RenderOptions& o, long long pixels, long long refined) {
  long long extra = o.sampler == Sampler::R2 ? o.adaptive_spp - o.spp : o.adaptive_spp;
  return pixels * o.spp + refined * extra;
}

namespace detail {

// Runs f(k) for k in [0, n), in chunks of `chunk` handed out to `threads` threads.
template <class F>
void parallel_chunks(int n, int chunk, int threads, F&& f) {
  std::atomic<int> next{0};
  auto worker = [&]() {
    for (int begin; (begin = next.fetch_add(chunk, std::memory_order_relaxed)) < n;)
      for (int k = begin, end = std::min(begin + chunk, n); k < end; ++k) f(k);
  };
  int pool_size = std::min(cpu::thread_count(threads), (n + chunk - 1) / chunk);
  std::vector<std::thread> pool;
  for (int i = 1; i < pool_size; ++i) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
}

// Calls f(std::integral_constant<unsigned, Features>) with the CPU instantiation for a
// render that needs `needed` (the same choice as cpu::render_packed).
template <unsigned Remaining, unsigned Fixed, class F>
void with_features(unsigned needed, F& f) {
  if constexpr (Remaining == 0u) {
    f(std::integral_constant<unsigned, Fixed | (TR_F_ALL & ~cpu::kHostSpecializedFeatures)>());
  } else {
    constexpr unsigned bit = Remaining & (~Remaining + 1u);
    if (needed & bit)
      with_features<Remaining & ~bit, Fixed | bit>(needed, f);
    else
      with_features<Remaining & ~bit, Fixed>(needed, f);
  }
}

// Row-major indices of the flagged pixels.
inline std::vector<int> flagged_pixels(const std::vector<int>& flags) {
  std::vector<int> list;
  for (size_t i = 0; i < flags.size(); ++i)
    if (flags[i]) list.push_back(static_cast<int>(i));
  return list;
}

}  // namespace detail

// The CPU backend. `params`: ps.params with adaptive_spp set.
template <class T>
Image<T> render_cpu(const PackedScene<T>& ps, const typename device::Code<T>::Params& params,
                    unsigned features, int threads, long long* refined) {
  const int width = params.width, height = params.height;
  Image<T> image(width, height);
  std::vector<T> stats(static_cast<size_t>(width) * height * TR_ADAPTIVE_STATS);
  std::vector<int> flags(static_cast<size_t>(width) * height);
  typename device::Code<T>::SceneRef scene = ps.ref();
  scene.params = &params;
  auto run = [&](auto compiled) {
    using K = typename device::Code<T>::template Kernel<decltype(compiled)::value>;
    constexpr int kTile = 16;
    const int tiles_x = (width + kTile - 1) / kTile, tiles_y = (height + kTile - 1) / kTile;
    detail::parallel_chunks(tiles_x * tiles_y, 1, threads, [&](int tile) {
      int x0 = (tile % tiles_x) * kTile, y0 = (tile / tiles_x) * kTile;
      for (int y = y0; y < std::min(y0 + kTile, height); ++y)
        for (int x = x0; x < std::min(x0 + kTile, width); ++x) {
          glm::vec<3, T> range;
          auto sum = K::tr_adaptive_first(&scene, x, y, &range);
          K::tr_adaptive_store_stats(stats.data(), width, x, y, sum, range);
          K::tr_store_rgb(image.rgb.data(), width, x, y, sum * (T(1) / T(params.spp)));
        }
    });
    detail::parallel_chunks(height, 8, threads, [&](int y) {
      for (int x = 0; x < width; ++x)
        flags[static_cast<size_t>(y) * width + x] =
            K::tr_adaptive_refine_flag(&params, stats.data(), x, y);
    });
    std::vector<int> list = detail::flagged_pixels(flags);
    *refined = static_cast<long long>(list.size());
    detail::parallel_chunks(static_cast<int>(list.size()), 16, threads, [&](int k) {
      int x = list[k] % width, y = list[k] / width;
      K::tr_store_rgb(image.rgb.data(), width, x, y,
                      K::tr_adaptive_refine(&scene, stats.data(), x, y));
    });
  };
  detail::with_features<cpu::kHostSpecializedFeatures, 0u>(features, run);
  return image;
}

#ifdef TWINRAY_WITH_OPENCL
// The OpenCL backend; `features` is the program's mask, as in opencl::render_packed.
template <class T>
Image<T> render_opencl(opencl::Context& ctx, const PackedScene<T>& ps,
                       const typename device::Code<T>::Params& params, unsigned features,
                       RenderInfo* info, long long* refined) {
  using opencl::check;
  using clock = std::chrono::steady_clock;
  auto ms_since = [](clock::time_point t) {
    return std::chrono::duration<double, std::milli>(clock::now() - t).count();
  };
  constexpr bool use_double = sizeof(T) == 8;
  std::lock_guard<std::mutex> lock(ctx.mutex());
  const opencl::DeviceInfo& dev = ctx.info();
  if (use_double && !dev.has_fp64)
    throw Error(ErrorKind::BackendUnavailable, "OpenCL device " + dev.name +
                                                   " has no double precision (cl_khr_fp64); render "
                                                   "in float or with the CPU backend");
  bool built_now = false;
  double build_ms = 0;
  opencl::Context::ProgramEntry& entry =
      ctx.program(opencl::build_options(dev, features, use_double), &built_now, &build_ms);

  auto t0 = clock::now();
  struct Kernels {
    cl_kernel k[3] = {nullptr, nullptr, nullptr};
    ~Kernels() {
      for (cl_kernel x : k)
        if (x) clReleaseKernel(x);
    }
  } kernels;
  const char* names[3] = {"tr_kernel_adaptive_first", "tr_kernel_adaptive_mark",
                          "tr_kernel_adaptive_refine"};
  for (int i = 0; i < 3; ++i) {
    cl_int err = CL_SUCCESS;
    kernels.k[i] = clCreateKernel(entry.program, names[i], &err);
    check(err, "clCreateKernel");
  }
  cl_kernel first = kernels.k[0], mark = kernels.k[1], refine = kernels.k[2];

  const int width = params.width, height = params.height;
  const size_t pixels = static_cast<size_t>(width) * height;
  auto t_upload = clock::now();
  std::array<cl_mem, opencl::kSceneArgs> scene = opencl::upload_scene(ctx, ps, params);
  double transfer_ms = ms_since(t_upload);
  cl_mem out = ctx.output(pixels * 3 * sizeof(T));
  cl_mem stats = ctx.scratch("adaptive_stats", pixels * TR_ADAPTIVE_STATS * sizeof(T));
  cl_mem flags = ctx.scratch("adaptive_flags", pixels * sizeof(cl_int));

  auto arg = [](cl_kernel k, cl_uint i, size_t size, const void* value) {
    check(clSetKernelArg(k, i, size, value), "clSetKernelArg");
  };
  for (cl_uint i = 0; i < opencl::kSceneArgs; ++i) {
    arg(first, i, sizeof(cl_mem), &scene[i]);
    arg(refine, i, sizeof(cl_mem), &scene[i]);
  }
  arg(first, opencl::kSceneArgs, sizeof(cl_mem), &out);
  arg(first, opencl::kSceneArgs + 1, sizeof(cl_mem), &stats);
  arg(mark, 0, sizeof(cl_mem), &scene[0]);
  arg(mark, 1, sizeof(cl_mem), &stats);
  arg(mark, 2, sizeof(cl_mem), &flags);

  // Rows of 64 on CPU devices, 8x8 elsewhere (as opencl::render_packed).
  size_t local[2] = {dev.is_cpu ? size_t(64) : size_t(8), dev.is_cpu ? size_t(1) : size_t(8)};
  size_t global[2] = {(static_cast<size_t>(width) + local[0] - 1) / local[0] * local[0],
                      (static_cast<size_t>(height) + local[1] - 1) / local[1] * local[1]};
  check(clEnqueueNDRangeKernel(ctx.queue(), first, 2, nullptr, global, local, 0, nullptr, nullptr),
        "clEnqueueNDRangeKernel (adaptive first pass)");
  check(clEnqueueNDRangeKernel(ctx.queue(), mark, 2, nullptr, global, local, 0, nullptr, nullptr),
        "clEnqueueNDRangeKernel (adaptive mark)");
  check(clFinish(ctx.queue()), "clFinish");

  auto t_flags = clock::now();
  std::vector<int> flag_values(pixels);
  check(clEnqueueReadBuffer(ctx.queue(), flags, CL_TRUE, 0, pixels * sizeof(cl_int),
                            flag_values.data(), 0, nullptr, nullptr),
        "clEnqueueReadBuffer (adaptive flags)");
  std::vector<int> list = detail::flagged_pixels(flag_values);
  *refined = static_cast<long long>(list.size());
  cl_int count = static_cast<cl_int>(list.size());
  if (count > 0) {
    cl_mem list_mem = ctx.upload("adaptive_pixels", list.data(), list.size() * sizeof(int));
    transfer_ms += ms_since(t_flags);
    arg(refine, opencl::kSceneArgs, sizeof(cl_mem), &out);
    arg(refine, opencl::kSceneArgs + 1, sizeof(cl_mem), &stats);
    arg(refine, opencl::kSceneArgs + 2, sizeof(cl_mem), &list_mem);
    arg(refine, opencl::kSceneArgs + 3, sizeof count, &count);
    size_t local1 = 64, global1 = (static_cast<size_t>(count) + 63) / 64 * 64;
    check(clEnqueueNDRangeKernel(ctx.queue(), refine, 1, nullptr, &global1, &local1, 0, nullptr,
                                 nullptr),
          "clEnqueueNDRangeKernel (adaptive refine)");
    check(clFinish(ctx.queue()), "clFinish");
  } else {
    transfer_ms += ms_since(t_flags);
  }

  Image<T> image(width, height);
  auto t_read = clock::now();
  check(clEnqueueReadBuffer(ctx.queue(), out, CL_TRUE, 0, pixels * 3 * sizeof(T), image.rgb.data(),
                            0, nullptr, nullptr),
        "clEnqueueReadBuffer");
  transfer_ms += ms_since(t_read);
  ctx.save_binary(entry);
  opencl::fill_info(info, dev, features, build_ms, !built_now || entry.from_cache, t0, transfer_ms);
  return image;
}
#endif

// Adaptive render of a packed scene on `backend` (Cpu or OpenCL, already resolved);
// `features` as in render_packed.
template <class T>
Image<T> render_packed(const PackedScene<T>& ps, unsigned features, Backend backend,
                       const RenderOptions& options, RenderInfo* info) {
  validate_options(options);
  typename device::Code<T>::Params params = ps.params;
  params.adaptive_spp = options.adaptive_spp;
  params.adaptive_threshold = static_cast<T>(options.adaptive_threshold);
  long long refined = 0;
  Image<T> image;
  if (backend == Backend::OpenCL) {
#ifdef TWINRAY_WITH_OPENCL
    image =
        render_opencl(opencl::shared_context(options.device), ps, params, features, info, &refined);
#else
    throw Error(ErrorKind::BackendUnavailable,
                "twinray was built without OpenCL (link twinray::opencl)");
#endif
  } else {
    auto t0 = std::chrono::steady_clock::now();
    unsigned compiled = cpu::compiled_features(features);
    image = render_cpu(ps, params, compiled, options.threads, &refined);
    cpu::fill_info(info, compiled, options.threads, t0);
  }
  if (info) {
    info->refined_pixels = refined;
    info->samples =
        samples_traced(options, static_cast<long long>(params.width) * params.height, refined);
  }
  return image;
}

}  // namespace adaptive
}  // namespace twinray
