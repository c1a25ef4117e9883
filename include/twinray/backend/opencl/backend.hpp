// The OpenCL backend: the launches. It builds (or takes from the cache) the program
// for the render's Features mask (program.hpp), sends the scene's arrays once per scene
// and the frame's parameters and lights every render (buffers.hpp), runs one
// work-item per pixel of the rectangle and reads the framebuffer back. On a CPU device
// the scene's arrays and the framebuffer are the host's own memory, not copies. Each
// triangle's index in its mesh, which only ray queries read, goes to the device at the
// first query on a scene: renders never hold it there.
#pragma once

#include <array>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <twinray/backend/backend.hpp>
#include <twinray/backend/opencl/buffers.hpp>
#include <twinray/backend/opencl/context.hpp>
#include <twinray/backend/opencl/program.hpp>

namespace twinray {
namespace opencl {

// Kernels of one program, released together.
class Kernels {
 public:
  Kernels(cl_program program, std::initializer_list<const char*> names) {
    for (const char* name : names) {
      cl_int err = CL_SUCCESS;
      kernels_.push_back(clCreateKernel(program, name, &err));
      if (err != CL_SUCCESS) {
        kernels_.pop_back();
        release();
        check(err, "clCreateKernel");
      }
    }
  }
  Kernels(const Kernels&) = delete;
  Kernels& operator=(const Kernels&) = delete;
  ~Kernels() { release(); }
  cl_kernel operator[](size_t i) const { return kernels_[i]; }

 private:
  void release() {
    for (cl_kernel k : kernels_) clReleaseKernel(k);
    kernels_.clear();
  }
  std::vector<cl_kernel> kernels_;
};

inline void set_arg(cl_kernel k, cl_uint i, size_t size, const void* value) {
  check(clSetKernelArg(k, i, size, value), "clSetKernelArg");
}

template <class T>
class OpenCLBackend final : public RenderBackend<T> {
 public:
  // The backend on device `device_index` (over all platforms; -1: the first). Throws
  // BackendUnavailable when there is no such device, or for double on a device
  // without fp64.
  explicit OpenCLBackend(int device_index = -1) : OpenCLBackend(shared_context(device_index)) {}
  // The backend on a context the caller made, and keeps alive longer than the backend:
  // its own program cache, outside the process-wide one.
  explicit OpenCLBackend(Context& context) : ctx_(context), in_place_(in_place_on(ctx_.info())) {
    if (sizeof(T) == 8 && !ctx_.info().has_fp64)
      throw Error(ErrorKind::BackendUnavailable,
                  "OpenCL device " + ctx_.info().name +
                      " has no double precision (cl_khr_fp64); render in float or with the CPU "
                      "backend");
  }

  // The block kernel (kernels/render.cl).
  static constexpr const char* kBlockKernel = "tr_kernel_render_blocks";

  Backend kind() const override { return Backend::OpenCL; }
  PackOptions pack_options() const override {
    PackOptions options;
    options.bvh_width = bvh::kOpenClWidth;
    return options;
  }
  std::string device_name() const override { return ctx_.info().name; }
  const DeviceInfo& device() const { return ctx_.info(); }

  void set_scene(std::shared_ptr<const PackedScene<T>> scene) override {
    pending_ = std::move(scene);
    pending_top_level_.reset();
    has_scene_ = pending_ != nullptr;
    if (has_scene_) scene_ = pending_->summary();
  }

  // Only the top level and the instances go at the next render, where `scene` is the
  // one the device holds; else (another scene, or one not sent yet) set_scene().
  void set_moved_instances(std::shared_ptr<const PackedScene<T>> scene) override {
    if (!scene || pending_ || scene != uploaded_.lock()) return set_scene(std::move(scene));
    scene_ = scene->summary();
    pending_top_level_ = std::move(scene);
  }

  // Times the scene's arrays went to the device (once per set_scene that was rendered),
  // times only its top level did (set_moved_instances), and the bytes copied in all
  // (nothing where the device reads them in place).
  long long scene_uploads() const { return scene_uploads_; }
  long long top_level_uploads() const { return top_level_uploads_; }
  size_t scene_bytes_sent() const { return buffers_.bytes_sent(); }

  // Whether the device works in the host's memory (a CPU device): then the scene's
  // arrays and the framebuffer are wrapped, not copied (buffers.hpp). Oclgrind is left
  // out: its uninitialized-memory checker marks global memory as defined only when the
  // host writes it through the API, so a CL_MEM_USE_HOST_PTR buffer would read as
  // uninitialized everywhere and hide the kernel's real reads of undefined data.
  // TWINRAY_OPENCL_IN_PLACE=0, read when the backend is made, copies on every device
  // (the tests cover the copying path on a CPU device so).
  bool shares_host_memory() const { return in_place_; }
  static bool in_place_on(const DeviceInfo& dev) {
    const char* in_place = std::getenv("TWINRAY_OPENCL_IN_PLACE");
    return dev.is_cpu && dev.platform_name.find("Oclgrind") == std::string::npos &&
           !(in_place && std::string(in_place) == "0");
  }
  const SceneBuffers& scene_buffers() const { return buffers_; }

  // Whether shaded frames run tr_kernel_render_blocks (an 8x8 block per work-item,
  // traced in packets as on the CPU backend) rather than tr_kernel_render (a pixel per
  // work-item): on CPU devices, where a work-item is an iteration of a thread's loop
  // and the packets pay as they do in C++, except the first frame of a block program
  // new to the machine (render_into). GPUs keep a pixel per work-item: a packet's
  // loops would diverge across a warp. TWINRAY_OPENCL_KERNEL=pixel or =blocks chooses
  // (both give the same bits: tests/pack/bvh_render_test.cpp).
  bool renders_blocks() const {
    const std::string kernel = kernel_choice();
    if (kernel == "pixel") return false;
    if (kernel == "blocks") return true;
    return ctx_.info().is_cpu;
  }
  // TWINRAY_OPENCL_KERNEL's value ("" where unset).
  static std::string kernel_choice() {
    const char* kernel = std::getenv("TWINRAY_OPENCL_KERNEL");
    return kernel ? kernel : "";
  }
  // Whether the first frame of a block program never asked for on this machine takes
  // the pixel kernel: unless TWINRAY_OPENCL_KERNEL=blocks, or
  // TWINRAY_OPENCL_FIRST_FRAME=blocks (the block kernel from the first frame, where
  // the block kernel is the device's choice; the test suite sets it).
  static bool new_block_program_takes_pixel() {
    const char* first = std::getenv("TWINRAY_OPENCL_FIRST_FRAME");
    return kernel_choice() != "blocks" && !(first && std::string(first) == "blocks");
  }

  void render_into(const RenderRequest<T>& request, Image<T>& image,
                   RenderInfo* info = nullptr) override {
    using clock = std::chrono::steady_clock;
    require_scene(has_scene_);
    const PackedFrame<T> frame = pack_frame(scene_, request);
    const auto& p = frame.params;
    const unsigned features = request.options.specialize ? frame.features : TR_F_ALL;
    std::lock_guard<std::mutex> lock(ctx_.mutex());
    const DeviceInfo& dev = ctx_.info();
    bool built_now = false;
    double build_ms = 0;
    // The program holds only the kernels this render launches (TR_ENTRY_*); the launch
    // below follows the same choice.
    int entry_points = p.adaptive_spp > 0                         ? TR_ENTRY_ADAPTIVE
                       : request.options.output != Output::Shaded ? TR_ENTRY_AOV
                       : renders_blocks()                         ? TR_ENTRY_BLOCKS
                                                                  : TR_ENTRY_RENDER;
    auto options_for = [&](int entry) {
      return build_options(dev, features, sizeof(T) == 8, entry, request.options.specialize);
    };
    // The first frame that needs a block program not yet in the disk caches (no marker:
    // PoCL's cache is cold for it too) renders with the pixel kernel, the same image,
    // whose program PoCL compiles in about half the time; later frames, and later
    // processes, take the block kernel (docs/performance.md, "PoCL program build").
    // Where the application names a build helper (the `twinray` command does), a
    // detached process started once the frame is rendered builds the block program into
    // the disk caches, and later processes render with the pixel kernel until it is
    // there (ProgramCache::build_in_helper); no process waits for it. Started after the
    // frame, not beside it, it takes no core from the frame. Else the first process to
    // ask takes the pixel kernel and the next builds the block program.
    std::string options = options_for(entry_points);
    std::string build_after;  // the block program's options, for the helper after the frame
    if (entry_points == TR_ENTRY_BLOCKS && new_block_program_takes_pixel() &&
        !ctx_.programs().asked_before(options)) {
      const bool helper = ctx_.programs().helper_builds(options);
      if (ctx_.programs().note_request(options) || helper) {
        if (helper) build_after = options;
        entry_points = TR_ENTRY_RENDER;
        options = options_for(entry_points);
      }
    }
    ProgramCache::Entry& program = ctx_.programs().get(options, &built_now, &build_ms);

    const auto t0 = clock::now();
    const bool uploading = upload_pending_scene();
    const bool in_place = shares_host_memory();
    buffers_.upload_frame(ctx_, frame);
    double transfer_ms = sample_plan::ms_since(t0);

    const size_t out_bytes = static_cast<size_t>(p.rect_w) * p.rect_h * 3 * sizeof(T);
    if (out_bytes > dev.max_alloc && dev.max_alloc > 0)
      throw Error(ErrorKind::RuntimeFailure,
                  "OpenCL: the framebuffer needs " + std::to_string(out_bytes >> 20) +
                      " MiB, more than the device's largest allocation (" +
                      std::to_string(dev.max_alloc >> 20) + " MiB) on " + dev.name);
    image.resize(p.rect_w, p.rect_h);
    if (in_place)
      output_.wrap(ctx_.context(), CL_MEM_READ_WRITE, image.rgb.data(), out_bytes,
                   "clCreateBuffer (framebuffer, host memory)");
    else
      output_.reserve(ctx_.context(), CL_MEM_READ_WRITE, out_bytes, "clCreateBuffer (framebuffer)");
    long long refined = 0;
    if (entry_points == TR_ENTRY_ADAPTIVE)
      refined = launch_adaptive(program.program, frame, &transfer_ms);
    else
      launch_uniform(program.program, request.options.output, entry_points, p);

    const auto t_read = clock::now();
    if (in_place) {
      // Mapping makes the device's writes visible in the image (the OpenCL 1.2 rule for
      // CL_MEM_USE_HOST_PTR); on a CPU device it copies nothing.
      cl_int err = CL_SUCCESS;
      void* mapped = clEnqueueMapBuffer(ctx_.queue(), output_.mem(), CL_TRUE, CL_MAP_READ, 0,
                                        out_bytes, 0, nullptr, nullptr, &err);
      check(err, "clEnqueueMapBuffer (framebuffer)");
      if (mapped != image.rgb.data())  // a device may map a copy of its own
        std::memcpy(image.rgb.data(), mapped, out_bytes);
      check(clEnqueueUnmapMemObject(ctx_.queue(), output_.mem(), mapped, 0, nullptr, nullptr),
            "clEnqueueUnmapMemObject (framebuffer)");
      check(clFinish(ctx_.queue()), "clFinish");
      output_.release();  // the image is the caller's: wrap it afresh each render
    } else {
      check(clEnqueueReadBuffer(ctx_.queue(), output_.mem(), CL_TRUE, 0, out_bytes,
                                image.rgb.data(), 0, nullptr, nullptr),
            "clEnqueueReadBuffer");
    }
    transfer_ms += sample_plan::ms_since(t_read);
    ctx_.programs().save_binary(program);
    // Built and launched: in PoCL's cache, with its code for the launch's work-group.
    if (entry_points == TR_ENTRY_BLOCKS) ctx_.programs().remember(options);
    if (!build_after.empty()) ctx_.programs().build_in_helper(build_after, kBlockKernel);
    if (info) {
      info->backend = Backend::OpenCL;
      info->device = dev.name;
      info->features = features;
      info->kernel = entry_points == TR_ENTRY_BLOCKS   ? "blocks"
                     : entry_points == TR_ENTRY_RENDER ? "pixel"
                     : entry_points == TR_ENTRY_AOV    ? "aov"
                                                       : "adaptive";
      info->build_ms = build_ms;
      info->program_cached = !built_now || program.from_cache;
      info->render_ms = sample_plan::ms_since(t0);
      info->transfer_ms = transfer_ms;
      info->scene_uploaded = uploading;
      info->refined_pixels = refined;
      info->samples = sample_plan::samples_traced(
          request.options, static_cast<long long>(p.rect_w) * p.rect_h, refined);
    }
  }

  // Ray queries on rays that are already on the device: `rays` holds n Ray<T> (40 bytes
  // each in float, 72 in double), and the answers go to `hits` (n Hit<T>) and, where
  // `extras` asks, `extra_out` (n HitExtra<T>), or to `blocked` (n bytes, 1 or 0), as
  // intersect() and occluded() give them. The buffers must belong to this backend's
  // context (context().context()) and be large enough; nothing is copied to or from the
  // host, and the call returns when the answers are in the buffers.
  void intersect_buffers(cl_mem rays, size_t n, cl_mem hits, HitExtras extras = HitExtras::None,
                         cl_mem extra_out = nullptr) {
    const unsigned flags = static_cast<unsigned>(extras);
    if (n > 0 && (!rays || !hits))
      throw invalid_input("intersect_buffers: null rays or hits for " + std::to_string(n) +
                          " rays");
    if (n > 0 && flags != 0 && !extra_out)
      throw invalid_input("intersect_buffers: extras asked for, but extra_out is null");
    std::lock_guard<std::mutex> lock(ctx_.mutex());
    with_query_kernel(true, n, [&](cl_kernel k) {
      launch_query(k, true, rays, hits, extra_out ? extra_out : hits, flags, n);
    });
  }
  void occluded_buffers(cl_mem rays, size_t n, cl_mem blocked) {
    if (n > 0 && (!rays || !blocked))
      throw invalid_input("occluded_buffers: null rays or blocked for " + std::to_string(n) +
                          " rays");
    std::lock_guard<std::mutex> lock(ctx_.mutex());
    with_query_kernel(false, n,
                      [&](cl_kernel k) { launch_query(k, false, rays, blocked, nullptr, 0, n); });
  }
  // The context the query buffers must belong to.
  Context& context() { return ctx_; }

  // Rays a host-side query sends to the device at a time, through buffers of that size.
  static constexpr size_t kQueryChunk = size_t(1) << 18;

 protected:
  void intersect_rays(const Ray<T>* rays, size_t n, Hit<T>* hits, unsigned extras,
                      HitExtra<T>* extra_out) override {
    host_query(true, rays, n, hits, sizeof(Hit<T>), extras, extra_out);
  }
  void occluded_rays(const Ray<T>* rays, size_t n, uint8_t* blocked) override {
    host_query(false, rays, n, blocked, 1, 0, nullptr);
  }

 private:
  using Params = typename device::Code<T>::Params;

  // Sends the scene set last to the device if it has not gone yet; whether it went now.
  // Its triangle_faces stay on the host until a query (upload_faces).
  bool upload_pending_scene() {
    const bool in_place = shares_host_memory();
    if (pending_top_level_) {
      buffers_.upload_top_level(ctx_, *pending_top_level_, in_place);
      pending_top_level_.reset();
      ++top_level_uploads_;
      return true;
    }
    if (!pending_) return false;
    buffers_.upload_scene(ctx_, *pending_, in_place);
    uploaded_ = pending_;
    // In place, the device reads the packed arrays themselves: keep them. Otherwise
    // the device holds a copy, and the host's is the caller's business: all but
    // triangle_faces, kept here (4 bytes a triangle) for a query to send.
    LargeVector<int>().swap(host_faces_);
    if (!in_place) host_faces_ = pending_->triangle_faces;
    host_scene_ = in_place ? std::move(pending_) : nullptr;
    pending_.reset();
    ++scene_uploads_;
    return true;
  }

  // Sends the scene's triangle_faces to the device (wraps them in place) if they have
  // not gone yet: queries order ties and report hits by them, renders never read them.
  void upload_faces() {
    if (buffers_.has_faces()) return;
    const bool in_place = shares_host_memory();
    const LargeVector<int>& faces = in_place ? host_scene_->triangle_faces : host_faces_;
    buffers_.upload_faces(ctx_, faces.data(), faces.size(), in_place);
    if (!in_place) LargeVector<int>().swap(host_faces_);  // the device's copy serves now
  }

  // Runs `launches(kernel)` with the intersect (closest) or occluded kernel, its scene's
  // arguments set, for a batch of n rays: the scene, its triangle_faces and the query
  // parameters on the device first. One kernel object serves the batch's launches,
  // whatever their number. The caller holds the context's lock.
  template <class Launches>
  void with_query_kernel(bool closest, size_t n, const Launches& launches) {
    require_scene(has_scene_);
    if (n == 0) return;
    upload_pending_scene();
    upload_faces();
    buffers_.upload_params(ctx_, query_params(scene_));
    bool built = false;
    double ms = 0;
    ProgramCache::Entry& program = ctx_.programs().get(
        build_options(ctx_.info(), scene_.features, sizeof(T) == 8, TR_ENTRY_QUERY, true), &built,
        &ms);
    Kernels kernels(program.program, {closest ? "tr_kernel_intersect" : "tr_kernel_occluded"});
    set_scene_args(kernels[0]);
    launches(kernels[0]);
    ctx_.programs().save_binary(program);
  }

  // A host-side query: the rays go to the device kQueryChunk at a time through fixed
  // buffers, and each chunk's answers (out_size bytes a ray, and the extras) come back
  // before the next goes.
  void host_query(bool closest, const Ray<T>* rays, size_t n, void* out, size_t out_size,
                  unsigned extras, HitExtra<T>* extra_out) {
    require_scene(has_scene_);
    std::lock_guard<std::mutex> lock(ctx_.mutex());
    if (n == 0) return;
    with_query_kernel(closest, n, [&](cl_kernel k) {
      host_query_chunks(k, closest, rays, n, out, out_size, extras, extra_out);
    });
  }

  // host_query's chunks, through kernel k (with_query_kernel).
  void host_query_chunks(cl_kernel k, bool closest, const Ray<T>* rays, size_t n, void* out,
                         size_t out_size, unsigned extras, HitExtra<T>* extra_out) {
    const size_t chunk = std::min(n, kQueryChunk);
    query_rays_.reserve(ctx_.context(), CL_MEM_READ_ONLY, chunk * sizeof(Ray<T>),
                        "clCreateBuffer (query rays)");
    query_out_.reserve(ctx_.context(), CL_MEM_WRITE_ONLY, chunk * out_size,
                       "clCreateBuffer (query answers)");
    if (extras != 0)
      query_extras_.reserve(ctx_.context(), CL_MEM_WRITE_ONLY, chunk * sizeof(HitExtra<T>),
                            "clCreateBuffer (query extras)");
    for (size_t first = 0; first < n; first += chunk) {
      const size_t count = std::min(chunk, n - first);
      check(clEnqueueWriteBuffer(ctx_.queue(), query_rays_.mem(), CL_FALSE, 0,
                                 count * sizeof(Ray<T>), rays + first, 0, nullptr, nullptr),
            "clEnqueueWriteBuffer (query rays)");
      launch_query(k, closest, query_rays_.mem(), query_out_.mem(),
                   extras != 0 ? query_extras_.mem() : query_out_.mem(), extras, count);
      check(clEnqueueReadBuffer(ctx_.queue(), query_out_.mem(), CL_TRUE, 0, count * out_size,
                                static_cast<char*>(out) + first * out_size, 0, nullptr, nullptr),
            "clEnqueueReadBuffer (query answers)");
      if (extras != 0)
        check(clEnqueueReadBuffer(ctx_.queue(), query_extras_.mem(), CL_TRUE, 0,
                                  count * sizeof(HitExtra<T>), extra_out + first, 0, nullptr,
                                  nullptr),
              "clEnqueueReadBuffer (query extras)");
    }
  }

  // Runs query kernel k (with_query_kernel: tr_kernel_intersect where `closest`, else
  // tr_kernel_occluded) over the first n rays of the device buffers, in launches of at
  // most 2^24 work-items (the global offset says where each starts), and waits for it.
  void launch_query(cl_kernel k, bool closest, cl_mem rays, cl_mem out, cl_mem extras,
                    unsigned extra_flags, size_t n) {
    cl_uint arg = kSceneArgs;
    set_arg(k, arg++, sizeof(cl_mem), &rays);
    set_arg(k, arg++, sizeof(cl_mem), &out);
    if (closest) {
      cl_int flags = static_cast<cl_int>(extra_flags);
      set_arg(k, arg++, sizeof(cl_mem), &extras);
      set_arg(k, arg++, sizeof flags, &flags);
    }
    cl_ulong last = n;
    set_arg(k, arg, sizeof last, &last);
    const size_t local = 64, piece = size_t(1) << 24;
    for (size_t at = 0; at < n; at += piece) {
      size_t count = std::min(piece, n - at);
      size_t global = (count + local - 1) / local * local;
      check(clEnqueueNDRangeKernel(ctx_.queue(), k, 1, &at, &global, &local, 0, nullptr, nullptr),
            "clEnqueueNDRangeKernel (ray query)");
    }
    check(clFinish(ctx_.queue()), "clFinish");
  }

  // Work-items in side x side work-groups. Pixel kernels use 8x8 on every device:
  // neighbouring rays meet the same nodes and primitives, and on PoCL square tiles beat
  // rows of 64 work-items by up to 11% on the large scenes (docs/performance.md). The
  // block kernel, whose work-item is already an 8x8 block, runs one per work-group:
  // 1.5-4% faster frames on PoCL than 8x8 groups of blocks. One fixed local size per
  // kernel: PoCL generates code once per size.
  void launch_2d(cl_kernel kernel, int width, int height, const char* what, size_t side = 8) {
    size_t local[2] = {side, side};
    size_t global[2] = {(static_cast<size_t>(width) + local[0] - 1) / local[0] * local[0],
                        (static_cast<size_t>(height) + local[1] - 1) / local[1] * local[1]};
    check(clEnqueueNDRangeKernel(ctx_.queue(), kernel, 2, nullptr, global, local, 0, nullptr,
                                 nullptr),
          what);
  }

  void set_scene_args(cl_kernel kernel) {
    std::array<cl_mem, kSceneArgs> args = buffers_.args();
    for (cl_uint i = 0; i < kSceneArgs; ++i) set_arg(kernel, i, sizeof(cl_mem), &args[i]);
  }

  void launch_uniform(cl_program program, Output output, int entry_points, const Params& p) {
    const bool shaded = output == Output::Shaded;
    const bool blocks = entry_points == TR_ENTRY_BLOCKS;
    Kernels kernels(program, {blocks   ? "tr_kernel_render_blocks"
                              : shaded ? "tr_kernel_render"
                                       : "tr_kernel_aov"});
    cl_kernel k = kernels[0];
    set_scene_args(k);
    cl_mem out = output_.mem();
    set_arg(k, kSceneArgs, sizeof(cl_mem), &out);
    if (!shaded) {
      cl_int aov = device_aov(output);
      set_arg(k, kSceneArgs + 1, sizeof aov, &aov);
    }
    if (blocks)  // a row of work-items, each a block (tr_render_block_at)
      launch_2d(k, device::Code<T>::template Kernel<TR_F_ALL>::tr_block_count(&p), 1,
                "clEnqueueNDRangeKernel (blocks)", 1);
    else
      launch_2d(k, p.rect_w, p.rect_h, "clEnqueueNDRangeKernel");
    check(clFinish(ctx_.queue()), "clFinish");  // so the read times the copy alone
  }

  // The adaptive plan (device/adaptive.h): first pass over the statistics window and
  // the criterion over the rectangle on the device; the host lists the flagged pixels
  // (4 bytes a pixel come back) and the device refines them. Returns their count.
  long long launch_adaptive(cl_program program, const PackedFrame<T>& frame, double* transfer_ms) {
    const Params& p = frame.params;
    Kernels kernels(program, {"tr_kernel_adaptive_first", "tr_kernel_adaptive_mark",
                              "tr_kernel_adaptive_refine"});
    cl_kernel first = kernels[0], mark = kernels[1], refine = kernels[2];
    const size_t rect_pixels = static_cast<size_t>(p.rect_w) * p.rect_h;
    stats_.reserve(ctx_.context(), CL_MEM_READ_WRITE,
                   static_cast<size_t>(p.stats_w) * p.stats_h * TR_ADAPTIVE_STATS * sizeof(T),
                   "clCreateBuffer (adaptive statistics)");
    flags_.reserve(ctx_.context(), CL_MEM_READ_WRITE, rect_pixels * sizeof(cl_int),
                   "clCreateBuffer (adaptive flags)");
    cl_mem out = output_.mem(), stats = stats_.mem(), flags = flags_.mem();
    cl_mem params = buffers_.params();
    set_scene_args(first);
    set_arg(first, kSceneArgs, sizeof(cl_mem), &out);
    set_arg(first, kSceneArgs + 1, sizeof(cl_mem), &stats);
    set_arg(mark, 0, sizeof(cl_mem), &params);
    set_arg(mark, 1, sizeof(cl_mem), &stats);
    set_arg(mark, 2, sizeof(cl_mem), &flags);
    launch_2d(first, p.stats_w, p.stats_h, "clEnqueueNDRangeKernel (adaptive first pass)");
    launch_2d(mark, p.rect_w, p.rect_h, "clEnqueueNDRangeKernel (adaptive mark)");
    check(clFinish(ctx_.queue()), "clFinish");

    const auto t_flags = std::chrono::steady_clock::now();
    std::vector<int> flag_values(rect_pixels);
    check(clEnqueueReadBuffer(ctx_.queue(), flags, CL_TRUE, 0, rect_pixels * sizeof(cl_int),
                              flag_values.data(), 0, nullptr, nullptr),
          "clEnqueueReadBuffer (adaptive flags)");
    const std::vector<int> list = sample_plan::flagged_pixels(flag_values);
    const cl_int count = static_cast<cl_int>(list.size());
    if (count > 0) {
      pixels_.write(ctx_, CL_MEM_READ_ONLY, list.data(), list.size() * sizeof(int),
                    "clCreateBuffer (adaptive pixels)");
      *transfer_ms += sample_plan::ms_since(t_flags);
      cl_mem pixels = pixels_.mem();
      set_scene_args(refine);
      set_arg(refine, kSceneArgs, sizeof(cl_mem), &out);
      set_arg(refine, kSceneArgs + 1, sizeof(cl_mem), &stats);
      set_arg(refine, kSceneArgs + 2, sizeof(cl_mem), &pixels);
      set_arg(refine, kSceneArgs + 3, sizeof count, &count);
      size_t local = 64, global = (static_cast<size_t>(count) + 63) / 64 * 64;
      check(clEnqueueNDRangeKernel(ctx_.queue(), refine, 1, nullptr, &global, &local, 0, nullptr,
                                   nullptr),
            "clEnqueueNDRangeKernel (adaptive refine)");
      check(clFinish(ctx_.queue()), "clFinish");
    } else {
      *transfer_ms += sample_plan::ms_since(t_flags);
    }
    return count;
  }

  Context& ctx_;
  SceneSummary<T> scene_;  // what pack_frame reads; the arrays are in buffers_
  std::shared_ptr<const PackedScene<T>> pending_;  // set, not yet uploaded
  // Set by set_moved_instances: the scene the device holds, its top level not yet sent.
  std::shared_ptr<const PackedScene<T>> pending_top_level_;
  std::weak_ptr<const PackedScene<T>> uploaded_;  // the scene whose arrays the device holds
  // The arrays the device reads in place (shares_host_memory()); declared before the
  // buffers that wrap them, so that it outlives them.
  std::shared_ptr<const PackedScene<T>> host_scene_;
  // The scene's triangle_faces while a device that copies has not got them (upload_faces).
  LargeVector<int> host_faces_;
  bool in_place_;  // shares_host_memory()
  bool has_scene_ = false;
  long long scene_uploads_ = 0, top_level_uploads_ = 0;
  SceneBuffers buffers_;
  Buffer output_, stats_, flags_, pixels_;
  Buffer query_rays_, query_out_, query_extras_;
};

}  // namespace opencl
}  // namespace twinray
