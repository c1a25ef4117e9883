// One OpenCL device in use: its context, command queue and program cache, made once
// per process (shared_context) and shared by every OpenCL backend object on it. The
// mutex serializes what goes through the queue.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <twinray/backend/opencl/device.hpp>
#include <twinray/backend/opencl/program.hpp>

namespace twinray {
namespace opencl {

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
    programs_ = std::make_unique<ProgramCache>(context_, info_);
  }
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  ~Context() {
    programs_.reset();
    clReleaseCommandQueue(queue_);
    clReleaseContext(context_);
  }

  const DeviceInfo& info() const { return info_; }
  cl_context context() const { return context_; }
  cl_command_queue queue() const { return queue_; }
  std::mutex& mutex() { return mutex_; }
  ProgramCache& programs() { return *programs_; }  // under mutex()

  // sizeof of every buffer struct as this device's compiler lays it out (kernel
  // tr_kernel_layout_sizes): TrSphere, TrTriangle, TrPlane, TrMaterial, TrLight,
  // real (bvh_nodes' boxes), TrParams, TrTriangleAttr, TrTexture, TrQueryRay, TrQueryHit,
  // TrQueryExtras, TrInstance. Must equal the host's
  // (device/code.hpp).
  std::vector<int> device_struct_sizes(bool use_double) {
    std::lock_guard<std::mutex> lock(mutex_);
    bool built = false;
    double ms = 0;
    ProgramCache::Entry& entry =
        programs_->get(build_options(info_, TR_F_ALL, use_double), &built, &ms);
    cl_int err = CL_SUCCESS;
    cl_kernel kernel = clCreateKernel(entry.program, "tr_kernel_layout_sizes", &err);
    check(err, "clCreateKernel");
    std::vector<int> sizes(13, 0);
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

 private:
  DeviceInfo info_;
  cl_context context_ = nullptr;
  cl_command_queue queue_ = nullptr;
  std::unique_ptr<ProgramCache> programs_;
  std::mutex mutex_;
};

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

}  // namespace opencl
}  // namespace twinray
