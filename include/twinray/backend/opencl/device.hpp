// OpenCL devices: the error checks every OpenCL call goes through, and the list of
// devices over all platforms (`twinray info` prints it; --device N picks from it).
#pragma once

#ifndef CL_TARGET_OPENCL_VERSION
#define CL_TARGET_OPENCL_VERSION 120
#endif
#include <CL/cl.h>

#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <twinray/core/error.hpp>

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
// A string query of clGetPlatformInfo or clGetDeviceInfo (`get`); "" where it fails.
template <class Get, class Object, class Info>
std::string info_string(Get get, Object object, Info what) {
  size_t size = 0;
  if (get(object, what, 0, nullptr, &size) != CL_SUCCESS || size == 0) return "";
  std::string s(size, '\0');
  get(object, what, size, &s[0], nullptr);
  s.resize(std::strlen(s.c_str()));
  return s;
}
inline std::string platform_string(cl_platform_id p, cl_platform_info what) {
  return info_string(&clGetPlatformInfo, p, what);
}
inline std::string device_string(cl_device_id d, cl_device_info what) {
  return info_string(&clGetDeviceInfo, d, what);
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
      // has fp64 (tests/apps/failure_test.cpp).
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

}  // namespace opencl
}  // namespace twinray
