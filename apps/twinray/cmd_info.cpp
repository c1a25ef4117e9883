// `twinray info`: the OpenCL platforms and devices (with the indices --device takes)
// and how this twinray was built.
#include <cstdio>
#include <iostream>
#include <thread>

#include <twinray/backend/cpu.hpp>
#include <twinray/version.hpp>
#ifdef TWINRAY_WITH_OPENCL
#include <twinray/backend/opencl/program.hpp>
#endif

#include "cli_common.hpp"
#include "command.hpp"

namespace twinray_cli {
namespace {

std::string yes_no(bool b) {
  return b ? "yes" : "no";
}

int run_info() {
  std::cout << "twinray " << TWINRAY_VERSION_STRING << "\n";
  std::cout << "build:\n";
#if defined(__clang__)
  std::cout << "  compiler:        clang " << __clang_version__ << "\n";
#elif defined(__GNUC__)
  std::cout << "  compiler:        g++ " << __VERSION__ << "\n";
#endif
  char mask[16];
  std::snprintf(mask, sizeof mask, "0x%03x", twinray::cpu::kHostSpecializedFeatures);
  std::cout << "  precisions:      float, double (--precision)\n";
  std::cout << "  CPU backend:     yes, " << std::thread::hardware_concurrency()
            << " hardware threads, features specialized at compile time: " << mask << "\n";
#ifdef TWINRAY_WITH_OPENCL
  std::cout << "  OpenCL backend:  yes (OpenCL " << CL_TARGET_OPENCL_VERSION / 100 << "."
            << CL_TARGET_OPENCL_VERSION / 10 % 10 << " API)\n";
  std::string cache = twinray::opencl::cache_dir();
  std::cout << "  program cache:   " << (cache.empty() ? "off (TWINRAY_CACHE_DIR is empty)" : cache)
            << "\n";
#else
  std::cout << "  OpenCL backend:  no (built without OpenCL)\n";
#endif
  std::cout << "  OBJ meshes:      yes (with MTL materials and textures)\n";
  std::cout << "  scene format:    version " << twinray::io::kSceneFormatVersion << "\n";

#ifdef TWINRAY_WITH_OPENCL
  std::vector<twinray::opencl::DeviceInfo> devices = twinray::opencl::list_devices();
  if (devices.empty()) {
    std::cout << "OpenCL devices: none (no OpenCL platform is installed, or it has no devices; "
                 "--backend auto uses the CPU)\n";
    return kExitOk;
  }
  std::cout << "OpenCL devices (--device N):\n";
  for (const twinray::opencl::DeviceInfo& d : devices) {
    std::cout << "  [" << d.index << "] " << d.name << "\n"
              << "      platform:   " << d.platform_name << " (" << d.platform_version << ")\n"
              << "      type:       " << (d.is_cpu ? "CPU" : "GPU or accelerator") << ", vendor "
              << d.vendor << "\n"
              << "      version:    " << d.version << ", driver " << d.driver_version << "\n"
              << "      double:     " << yes_no(d.has_fp64) << "\n"
              << "      memory:     " << (d.global_mem >> 20) << " MiB, largest allocation "
              << (d.max_alloc >> 20) << " MiB\n"
              << "      binaries:   "
              << (twinray::opencl::keeps_binaries(d)
                      ? "kept in the program cache"
                      : "not kept (PoCL's own kernel cache holds the programs)")
              << "\n";
  }
#endif
  return kExitOk;
}

const Command kInfo(
    "info", "list OpenCL platforms and devices, and how twinray was built",
    [](CLI::App&) { return [] { return run_info(); }; }, 90);

}  // namespace
}  // namespace twinray_cli
