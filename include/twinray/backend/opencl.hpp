// The OpenCL backend: builds kernels/render.cl (embedded at build time, see
// cmake/embed_kernels.cmake) with the scene's Features mask as -D options, uploads the
// packed arrays, runs one work-item per pixel and reads the framebuffer back.
//
// Programs are cached per (device, driver, source, options): in the process, and on
// disk as program binaries saved after their first launch (so PoCL's per-local-size
// code generation is in them). Buffers live as long as the context and are re-uploaded
// only when their bytes changed, so a movie frame sends only what moved.
//
// Thread safety: every function here may be called from any thread; one context
// serializes the renders that share it.
#pragma once

#ifndef CL_TARGET_OPENCL_VERSION
#define CL_TARGET_OPENCL_VERSION 120
#endif
#include <CL/cl.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

#include <twinray/core/error.hpp>
#include <twinray/core/image.hpp>
#include <twinray/core/options.hpp>
#include <twinray/core/pack.hpp>
#include <twinray/generated/opencl_source.hpp>

namespace twinray {
namespace opencl {

inline const char* error_name(cl_int err) {
  switch (err) {
#define TR_CL_CASE(e) \
  case e:             \
    return #e;
    TR_CL_CASE(CL_DEVICE_NOT_FOUND)
    TR_CL_CASE(CL_DEVICE_NOT_AVAILABLE)
    TR_CL_CASE(CL_COMPILER_NOT_AVAILABLE)
    TR_CL_CASE(CL_MEM_OBJECT_ALLOCATION_FAILURE)
    TR_CL_CASE(CL_OUT_OF_RESOURCES)
    TR_CL_CASE(CL_OUT_OF_HOST_MEMORY)
    TR_CL_CASE(CL_BUILD_PROGRAM_FAILURE)
    TR_CL_CASE(CL_INVALID_VALUE)
    TR_CL_CASE(CL_INVALID_PLATFORM)
    TR_CL_CASE(CL_INVALID_DEVICE)
    TR_CL_CASE(CL_INVALID_BINARY)
    TR_CL_CASE(CL_INVALID_BUILD_OPTIONS)
    TR_CL_CASE(CL_INVALID_PROGRAM_EXECUTABLE)
    TR_CL_CASE(CL_INVALID_KERNEL_ARGS)
    TR_CL_CASE(CL_INVALID_WORK_GROUP_SIZE)
    TR_CL_CASE(CL_INVALID_BUFFER_SIZE)
    TR_CL_CASE(CL_INVALID_GLOBAL_WORK_SIZE)
#undef TR_CL_CASE
    case -1001:
      return "CL_PLATFORM_NOT_FOUND_KHR";
    default:
      return "unknown OpenCL error";
  }
}

inline void check(cl_int err, const char* what) {
  if (err == CL_SUCCESS) return;
  std::string message = std::string("OpenCL: ") + what + " failed: " + error_name(err) + " (" +
                        std::to_string(err) + ")";
  if (err == CL_MEM_OBJECT_ALLOCATION_FAILURE || err == CL_OUT_OF_RESOURCES ||
      err == CL_INVALID_BUFFER_SIZE || err == CL_OUT_OF_HOST_MEMORY)
    message += ": the device could not allocate the memory this render needs";
  throw Error(ErrorKind::RuntimeFailure, message);
}

// One OpenCL device, as `twinray info` lists it; `index` counts over all platforms.
struct DeviceInfo {
  int index = 0;
  cl_platform_id platform = nullptr;
  cl_device_id device = nullptr;
  std::string platform_name, platform_version, name, vendor, version, driver_version;
  bool is_cpu = false;
  bool has_fp64 = false;
  bool correctly_rounded_divide_sqrt = false;
  size_t global_mem = 0, max_alloc = 0;
};

namespace detail {
inline std::string platform_string(cl_platform_id p, cl_platform_info what) {
  size_t size = 0;
  if (clGetPlatformInfo(p, what, 0, nullptr, &size) != CL_SUCCESS || size == 0) return "";
  std::string s(size, '\0');
  clGetPlatformInfo(p, what, size, &s[0], nullptr);
  s.resize(std::strlen(s.c_str()));
  return s;
}
inline std::string device_string(cl_device_id d, cl_device_info what) {
  size_t size = 0;
  if (clGetDeviceInfo(d, what, 0, nullptr, &size) != CL_SUCCESS || size == 0) return "";
  std::string s(size, '\0');
  clGetDeviceInfo(d, what, size, &s[0], nullptr);
  s.resize(std::strlen(s.c_str()));
  return s;
}
template <class V>
V device_value(cl_device_id d, cl_device_info what) {
  V v{};
  clGetDeviceInfo(d, what, sizeof(V), &v, nullptr);
  return v;
}
}  // namespace detail

// Every device of every platform, in a stable order. Empty when no platform exists.
inline std::vector<DeviceInfo> list_devices() {
  std::vector<DeviceInfo> out;
  cl_uint n_platforms = 0;
  if (clGetPlatformIDs(0, nullptr, &n_platforms) != CL_SUCCESS || n_platforms == 0) return out;
  std::vector<cl_platform_id> platforms(n_platforms);
  if (clGetPlatformIDs(n_platforms, platforms.data(), nullptr) != CL_SUCCESS) return out;
  for (cl_platform_id p : platforms) {
    cl_uint n_devices = 0;
    if (clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, 0, nullptr, &n_devices) != CL_SUCCESS) continue;
    std::vector<cl_device_id> devices(n_devices);
    if (clGetDeviceIDs(p, CL_DEVICE_TYPE_ALL, n_devices, devices.data(), nullptr) != CL_SUCCESS)
      continue;
    for (cl_device_id d : devices) {
      DeviceInfo info;
      info.index = static_cast<int>(out.size());
      info.platform = p;
      info.device = d;
      info.platform_name = detail::platform_string(p, CL_PLATFORM_NAME);
      info.platform_version = detail::platform_string(p, CL_PLATFORM_VERSION);
      info.name = detail::device_string(d, CL_DEVICE_NAME);
      info.vendor = detail::device_string(d, CL_DEVICE_VENDOR);
      info.version = detail::device_string(d, CL_DEVICE_VERSION);
      info.driver_version = detail::device_string(d, CL_DRIVER_VERSION);
      info.is_cpu =
          (detail::device_value<cl_device_type>(d, CL_DEVICE_TYPE) & CL_DEVICE_TYPE_CPU) != 0;
      info.has_fp64 =
          detail::device_value<cl_device_fp_config>(d, CL_DEVICE_DOUBLE_FP_CONFIG) != 0 ||
          detail::device_string(d, CL_DEVICE_EXTENSIONS).find("cl_khr_fp64") != std::string::npos;
      // Test hook: TWINRAY_TEST_HIDE_FP64=1 makes every device report no double support,
      // so the "double asked of a device without fp64" path can be tested on PoCL, which
      // has fp64 (tests/failure).
      if (const char* hide = std::getenv("TWINRAY_TEST_HIDE_FP64"); hide && *hide == '1')
        info.has_fp64 = false;
      info.correctly_rounded_divide_sqrt =
          (detail::device_value<cl_device_fp_config>(d, CL_DEVICE_SINGLE_FP_CONFIG) &
           CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT) != 0;
      info.global_mem =
          static_cast<size_t>(detail::device_value<cl_ulong>(d, CL_DEVICE_GLOBAL_MEM_SIZE));
      info.max_alloc =
          static_cast<size_t>(detail::device_value<cl_ulong>(d, CL_DEVICE_MAX_MEM_ALLOC_SIZE));
      out.push_back(info);
    }
  }
  return out;
}

// Build options for a Features mask and precision: the mask as -D, and never any
// fast-math option (parity: research/parity-findings.md, Q3).
inline std::string build_options(const DeviceInfo& device, unsigned features, bool use_double) {
  char mask[32];
  std::snprintf(mask, sizeof mask, "0x%03xu", features);
  std::string options = std::string("-cl-std=CL1.2 -DTR_FEATURES=") + mask;
  if (use_double) options += " -DTR_DOUBLE";
  if (device.correctly_rounded_divide_sqrt) options += " -cl-fp32-correctly-rounded-divide-sqrt";
  return options;
}

// FNV-1a, 64 bit: the on-disk cache key.
inline uint64_t fnv1a(const std::string& s, uint64_t h = 1469598103934665603ull) {
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  return h;
}

// Where program binaries are kept: $TWINRAY_CACHE_DIR (empty: no disk cache), else
// $XDG_CACHE_HOME/twinray, else $HOME/.cache/twinray.
inline std::string cache_dir() {
  if (const char* d = std::getenv("TWINRAY_CACHE_DIR")) return d;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return std::string(x) + "/twinray";
  if (const char* h = std::getenv("HOME"); h && *h) return std::string(h) + "/.cache/twinray";
  return "";
}

// An OpenCL context, queue, program cache and buffer set for one device.
class Context {
 public:
  explicit Context(const DeviceInfo& info) : info_(info) {
    cl_int err = CL_SUCCESS;
    cl_context_properties props[] = {CL_CONTEXT_PLATFORM,
                                     reinterpret_cast<cl_context_properties>(info.platform), 0};
    context_ = clCreateContext(props, 1, &info.device, nullptr, nullptr, &err);
    check(err, "clCreateContext");
    queue_ = clCreateCommandQueue(context_, info.device, 0, &err);
    if (err != CL_SUCCESS) clReleaseContext(context_);
    check(err, "clCreateCommandQueue");
  }
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  ~Context() {
    for (auto& b : buffers_)
      if (b.second.mem) clReleaseMemObject(b.second.mem);
    for (auto& p : programs_) clReleaseProgram(p.second.program);
    clReleaseCommandQueue(queue_);
    clReleaseContext(context_);
  }

  const DeviceInfo& info() const { return info_; }
  std::mutex& mutex() { return mutex_; }

  struct ProgramEntry {
    cl_program program = nullptr;
    bool from_cache = false;  // loaded from the disk cache
    bool saved = false;       // binary written to (or read from) the disk cache
    std::string cache_file;
    double build_ms = 0;
  };

  // The program for these build options: from the process, the disk cache, or source.
  ProgramEntry& program(const std::string& options, bool* built_now, double* build_ms) {
    auto it = programs_.find(options);
    *built_now = false;
    *build_ms = 0;
    if (it != programs_.end()) return it->second;
    auto t0 = std::chrono::steady_clock::now();
    ProgramEntry entry;
    const std::string source_text = program_source();
    const char* source = source_text.c_str();
    std::string dir = cache_dir();
    if (!dir.empty()) {
      std::string key = info_.platform_version + "\n" + info_.name + "\n" + info_.driver_version +
                        "\n" + options + "\n" + source;
      char name[64];
      std::snprintf(name, sizeof name, "/program-%016llx.bin",
                    static_cast<unsigned long long>(fnv1a(key)));
      entry.cache_file = dir + name;
      entry.program = load_binary(entry.cache_file, options);
      entry.from_cache = entry.saved = entry.program != nullptr;
    }
    if (!entry.program) entry.program = build_from_source(source, options);
    entry.build_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    *built_now = true;
    *build_ms = entry.build_ms;
    return programs_.emplace(options, entry).first->second;
  }

  // Saves the binary of a program after its first launch (so PoCL's code for the
  // work-group size is in it). Failures only cost the cache.
  void save_binary(ProgramEntry& entry) {
    if (entry.saved || entry.cache_file.empty()) return;
    entry.saved = true;
    size_t size = 0;
    if (clGetProgramInfo(entry.program, CL_PROGRAM_BINARY_SIZES, sizeof size, &size, nullptr) !=
            CL_SUCCESS ||
        size == 0)
      return;
    std::vector<unsigned char> bytes(size);
    unsigned char* ptr = bytes.data();
    if (clGetProgramInfo(entry.program, CL_PROGRAM_BINARIES, sizeof ptr, &ptr, nullptr) !=
        CL_SUCCESS)
      return;
    std::error_code ec;
    std::filesystem::create_directories(std::filesystem::path(entry.cache_file).parent_path(), ec);
    std::string tmp = entry.cache_file + ".tmp" + std::to_string(reinterpret_cast<uintptr_t>(this));
    {
      std::ofstream f(tmp, std::ios::binary);
      if (!f) return;
      f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(size));
      if (!f) {
        std::remove(tmp.c_str());
        return;
      }
    }
    if (std::rename(tmp.c_str(), entry.cache_file.c_str()) != 0) std::remove(tmp.c_str());
  }

  // A device buffer named `slot` holding `bytes`; re-uploaded only if they changed.
  cl_mem upload(const std::string& slot, const void* data, size_t bytes) {
    Buffer& b = buffers_[slot];
    size_t alloc = bytes > 0 ? bytes : 16;  // OpenCL has no empty buffers
    if (!b.mem || b.capacity < alloc) {
      if (b.mem) clReleaseMemObject(b.mem);
      b = Buffer();
      cl_int err = CL_SUCCESS;
      b.mem = clCreateBuffer(context_, CL_MEM_READ_ONLY, alloc, nullptr, &err);
      check(err, "clCreateBuffer (scene data)");
      b.capacity = alloc;
    }
    const unsigned char* p = static_cast<const unsigned char*>(data);
    if (bytes > 0 && (b.shadow.size() != bytes || std::memcmp(b.shadow.data(), p, bytes) != 0)) {
      check(clEnqueueWriteBuffer(queue_, b.mem, CL_TRUE, 0, bytes, p, 0, nullptr, nullptr),
            "clEnqueueWriteBuffer");
      b.shadow.assign(p, p + bytes);
      ++uploads_;
    }
    return b.mem;
  }

  // A write-only output buffer of at least `bytes`.
  cl_mem output(size_t bytes) {
    if (bytes > info_.max_alloc && info_.max_alloc > 0)
      throw Error(ErrorKind::RuntimeFailure,
                  "OpenCL: the framebuffer needs " + std::to_string(bytes >> 20) +
                      " MiB, more than the device's largest allocation (" +
                      std::to_string(info_.max_alloc >> 20) + " MiB) on " + info_.name);
    Buffer& b = buffers_["output"];
    if (!b.mem || b.capacity < bytes) {
      if (b.mem) clReleaseMemObject(b.mem);
      b = Buffer();
      cl_int err = CL_SUCCESS;
      b.mem = clCreateBuffer(context_, CL_MEM_WRITE_ONLY, bytes, nullptr, &err);
      check(err, "clCreateBuffer (framebuffer)");
      b.capacity = bytes;
    }
    return b.mem;
  }

  // A read-write device buffer named `slot` of at least `bytes`, contents undefined
  // (adaptive sampling's per-pixel statistics and flags, backend/adaptive.hpp).
  cl_mem scratch(const std::string& slot, size_t bytes) {
    Buffer& b = buffers_["scratch:" + slot];
    size_t alloc = bytes > 0 ? bytes : 16;
    if (!b.mem || b.capacity < alloc) {
      if (b.mem) clReleaseMemObject(b.mem);
      b = Buffer();
      cl_int err = CL_SUCCESS;
      b.mem = clCreateBuffer(context_, CL_MEM_READ_WRITE, alloc, nullptr, &err);
      check(err, "clCreateBuffer (scratch)");
      b.capacity = alloc;
    }
    return b.mem;
  }

  // sizeof of every buffer struct as this device's compiler lays it out (kernel
  // tr_kernel_layout_sizes): TrSphere, TrTriangle, TrPlane, TrMaterial, TrLight,
  // TrBvhNode, TrParams. Must equal the host's (core/device_code.hpp).
  std::vector<int> device_struct_sizes(bool use_double) {
    std::lock_guard<std::mutex> lock(mutex_);
    bool built = false;
    double ms = 0;
    ProgramEntry& entry = program(build_options(info_, TR_F_ALL, use_double), &built, &ms);
    cl_int err = CL_SUCCESS;
    cl_kernel kernel = clCreateKernel(entry.program, "tr_kernel_layout_sizes", &err);
    check(err, "clCreateKernel");
    std::vector<int> sizes(7, 0);
    cl_mem out =
        clCreateBuffer(context_, CL_MEM_WRITE_ONLY, sizes.size() * sizeof(int), nullptr, &err);
    if (err != CL_SUCCESS) clReleaseKernel(kernel);
    check(err, "clCreateBuffer");
    size_t one = 1;
    err = clSetKernelArg(kernel, 0, sizeof out, &out);
    if (err == CL_SUCCESS)
      err = clEnqueueNDRangeKernel(queue_, kernel, 1, nullptr, &one, &one, 0, nullptr, nullptr);
    if (err == CL_SUCCESS)
      err = clEnqueueReadBuffer(queue_, out, CL_TRUE, 0, sizes.size() * sizeof(int), sizes.data(),
                                0, nullptr, nullptr);
    clReleaseMemObject(out);
    clReleaseKernel(kernel);
    check(err, "layout kernel");
    return sizes;
  }

  // The program text: the embedded kernel, plus $TWINRAY_TEST_KERNEL_APPEND when set.
  // Test hook: appending e.g. a syntax error makes the build fail, so tests can check
  // that the driver's build log reaches the user (tests/failure). The text is part of
  // the cache key, so a broken program is never cached.
  static std::string program_source() {
    std::string source = opencl_source::render_cl();
    if (const char* extra = std::getenv("TWINRAY_TEST_KERNEL_APPEND"))
      source += std::string("\n") + extra + "\n";
    return source;
  }

  cl_command_queue queue() const { return queue_; }
  long long uploads() const { return uploads_; }  // buffer uploads so far (for tests)

 private:
  struct Buffer {
    cl_mem mem = nullptr;
    size_t capacity = 0;
    std::vector<unsigned char> shadow;  // what the device holds, to skip equal uploads
  };

  cl_program build_from_source(const char* source, const std::string& options) {
    cl_int err = CL_SUCCESS;
    cl_program program = clCreateProgramWithSource(context_, 1, &source, nullptr, &err);
    check(err, "clCreateProgramWithSource");
    err = clBuildProgram(program, 1, &info_.device, options.c_str(), nullptr, nullptr);
    if (err != CL_SUCCESS) {
      std::string log = build_log(program);
      clReleaseProgram(program);
      throw Error(ErrorKind::RuntimeFailure, std::string("OpenCL program build failed on ") +
                                                 info_.name + " (" + error_name(err) +
                                                 ") with options '" + options + "':\n" + log);
    }
    return program;
  }

  cl_program load_binary(const std::string& file, const std::string& options) {
    std::ifstream f(file, std::ios::binary);
    if (!f) return nullptr;
    std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(f)),
                                     std::istreambuf_iterator<char>());
    if (bytes.empty()) return nullptr;
    const unsigned char* ptr = bytes.data();
    size_t size = bytes.size();
    cl_int status = CL_SUCCESS, err = CL_SUCCESS;
    cl_program program =
        clCreateProgramWithBinary(context_, 1, &info_.device, &size, &ptr, &status, &err);
    if (err != CL_SUCCESS || status != CL_SUCCESS) {
      if (program) clReleaseProgram(program);
      std::remove(file.c_str());
      return nullptr;
    }
    if (clBuildProgram(program, 1, &info_.device, options.c_str(), nullptr, nullptr) !=
        CL_SUCCESS) {
      clReleaseProgram(program);
      std::remove(file.c_str());
      return nullptr;
    }
    return program;
  }

  std::string build_log(cl_program program) const {
    size_t size = 0;
    clGetProgramBuildInfo(program, info_.device, CL_PROGRAM_BUILD_LOG, 0, nullptr, &size);
    std::string log(size, '\0');
    if (size > 0)
      clGetProgramBuildInfo(program, info_.device, CL_PROGRAM_BUILD_LOG, size, &log[0], nullptr);
    return log;
  }

  DeviceInfo info_;
  cl_context context_ = nullptr;
  cl_command_queue queue_ = nullptr;
  std::map<std::string, ProgramEntry> programs_;
  std::map<std::string, Buffer> buffers_;
  long long uploads_ = 0;
  std::mutex mutex_;
};

// Why list_devices() found nothing: no platform at all, or platforms (named) that list
// no devices.
inline std::string no_device_reason() {
  cl_uint n_platforms = 0;
  if (clGetPlatformIDs(0, nullptr, &n_platforms) != CL_SUCCESS || n_platforms == 0)
    return "no OpenCL platform is installed (the OpenCL ICD loader found none; on Debian: "
           "apt-get install pocl-opencl-icd)";
  std::vector<cl_platform_id> platforms(n_platforms);
  std::string names;
  if (clGetPlatformIDs(n_platforms, platforms.data(), nullptr) == CL_SUCCESS)
    for (cl_platform_id p : platforms)
      names += (names.empty() ? "'" : ", '") + detail::platform_string(p, CL_PLATFORM_NAME) + "'";
  return "the OpenCL platform" + std::string(n_platforms > 1 ? "s " : " ") + names +
         (n_platforms > 1 ? " list" : " lists") +
         " no devices (is the driver configured to expose none, e.g. POCL_DEVICES?)";
}

// The process-wide context of a device (index over all platforms, -1 = the first),
// created on first use. Throws BackendUnavailable when there is no such device.
//
// The contexts live until the process ends and are deliberately never released: at
// exit, an OpenCL implementation may already have destroyed its own state (Oclgrind
// frees its per-thread API-call stack before static destructors run, and releasing then
// corrupts the heap), so the operating system reclaims them instead.
inline Context& shared_context(int device_index) {
  static std::mutex& registry_mutex = *new std::mutex;
  static std::map<int, std::unique_ptr<Context>>& registry =
      *new std::map<int, std::unique_ptr<Context>>;
  std::lock_guard<std::mutex> lock(registry_mutex);
  int index = device_index < 0 ? 0 : device_index;
  auto it = registry.find(index);
  if (it != registry.end()) return *it->second;
  std::vector<DeviceInfo> devices = list_devices();
  if (devices.empty())
    throw Error(ErrorKind::BackendUnavailable, "no OpenCL device found: " + no_device_reason());
  if (index >= static_cast<int>(devices.size()))
    throw Error(ErrorKind::BackendUnavailable,
                "no OpenCL device with index " + std::to_string(index) + " (" +
                    std::to_string(devices.size()) + " found; see `twinray info`)");
  auto context = std::make_unique<Context>(devices[index]);
  return *registry.emplace(index, std::move(context)).first->second;
}

// What an OpenCL render reports: RenderInfo for a program of `features` on `dev`.
inline void fill_info(RenderInfo* info, const DeviceInfo& dev, unsigned features, double build_ms,
                      bool program_cached, std::chrono::steady_clock::time_point start,
                      double transfer_ms) {
  if (!info) return;
  info->backend = Backend::OpenCL;
  info->device = dev.name;
  info->features = features;
  info->build_ms = build_ms;
  info->program_cached = program_cached;
  info->render_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  info->transfer_ms = transfer_ms;
}

// Uploads the eight scene buffers in the order every kernel in kernels/render.cl takes
// them as its first arguments: params, spheres, triangles, planes, materials, lights,
// bvh_nodes, bvh_prims. `params` is passed apart because the adaptive passes upload a
// modified copy of ps.params.
constexpr cl_uint kSceneArgs = 8;
template <class T>
std::array<cl_mem, kSceneArgs> upload_scene(Context& ctx, const PackedScene<T>& ps,
                                            const typename device::Code<T>::Params& params) {
  return {
      ctx.upload("params", &params, sizeof params),
      ctx.upload("spheres", ps.spheres.data(), ps.spheres.size() * sizeof ps.spheres[0]),
      ctx.upload("triangles", ps.triangles.data(), ps.triangles.size() * sizeof ps.triangles[0]),
      ctx.upload("planes", ps.planes.data(), ps.planes.size() * sizeof ps.planes[0]),
      ctx.upload("materials", ps.materials.data(), ps.materials.size() * sizeof ps.materials[0]),
      ctx.upload("lights", ps.lights.data(), ps.lights.size() * sizeof ps.lights[0]),
      ctx.upload("bvh_nodes", ps.bvh_nodes.data(), ps.bvh_nodes.size() * sizeof ps.bvh_nodes[0]),
      ctx.upload("bvh_prims", ps.bvh_prims.data(), ps.bvh_prims.size() * sizeof(int))};
}

// Renders a packed scene on a device; `features` is the mask the program is built for
// (TR_F_ALL: the generic program).
template <class T>
Image<T> render_packed(Context& ctx, const PackedScene<T>& ps, unsigned features, Output output,
                       RenderInfo* info = nullptr) {
  constexpr bool use_double = sizeof(T) == 8;
  std::lock_guard<std::mutex> lock(ctx.mutex());
  const DeviceInfo& dev = ctx.info();
  if (use_double && !dev.has_fp64)
    throw Error(ErrorKind::BackendUnavailable, "OpenCL device " + dev.name +
                                                   " has no double precision (cl_khr_fp64); render "
                                                   "in float or with the CPU backend");
  std::string options = build_options(dev, features, use_double);
  bool built_now = false;
  double build_ms = 0;
  Context::ProgramEntry& entry = ctx.program(options, &built_now, &build_ms);

  auto t0 = std::chrono::steady_clock::now();
  const char* kernel_name = output == Output::Shaded ? "tr_kernel_render" : "tr_kernel_aov";
  cl_int err = CL_SUCCESS;
  cl_kernel kernel = clCreateKernel(entry.program, kernel_name, &err);
  check(err, "clCreateKernel");
  struct KernelGuard {
    cl_kernel k;
    ~KernelGuard() { clReleaseKernel(k); }
  } guard{kernel};

  const int width = ps.params.width, height = ps.params.height;
  size_t out_bytes = static_cast<size_t>(width) * height * 3 * sizeof(T);
  auto t_upload = std::chrono::steady_clock::now();
  std::array<cl_mem, kSceneArgs> scene = upload_scene(ctx, ps, ps.params);
  cl_mem out = ctx.output(out_bytes);
  double transfer_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_upload)
          .count();
  for (cl_uint i = 0; i < kSceneArgs; ++i)
    check(clSetKernelArg(kernel, i, sizeof(cl_mem), &scene[i]), "clSetKernelArg");
  check(clSetKernelArg(kernel, kSceneArgs, sizeof(cl_mem), &out), "clSetKernelArg");
  if (output != Output::Shaded) {
    cl_int aov = output == Output::Depth    ? TR_AOV_DEPTH
                 : output == Output::Normal ? TR_AOV_NORMAL
                                            : TR_AOV_OBJECT;
    check(clSetKernelArg(kernel, kSceneArgs + 1, sizeof aov, &aov), "clSetKernelArg");
  }
  // Rows of 64 on CPU devices (PoCL: best measured, research/parity-findings.md Q5);
  // 8x8 tiles elsewhere. One fixed local size: PoCL generates code once per size.
  size_t local[2] = {dev.is_cpu ? size_t(64) : size_t(8), dev.is_cpu ? size_t(1) : size_t(8)};
  size_t global[2] = {(static_cast<size_t>(width) + local[0] - 1) / local[0] * local[0],
                      (static_cast<size_t>(height) + local[1] - 1) / local[1] * local[1]};
  check(clEnqueueNDRangeKernel(ctx.queue(), kernel, 2, nullptr, global, local, 0, nullptr, nullptr),
        "clEnqueueNDRangeKernel");
  Image<T> image(width, height);
  check(clFinish(ctx.queue()), "clFinish");  // so the read below times the copy alone
  auto t_read = std::chrono::steady_clock::now();
  check(clEnqueueReadBuffer(ctx.queue(), out, CL_TRUE, 0, out_bytes, image.rgb.data(), 0, nullptr,
                            nullptr),
        "clEnqueueReadBuffer");
  transfer_ms +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_read).count();
  ctx.save_binary(entry);
  fill_info(info, dev, features, build_ms, !built_now || entry.from_cache, t0, transfer_ms);
  return image;
}

}  // namespace opencl
}  // namespace twinray
