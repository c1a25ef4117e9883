// OpenCL programs: the build options of a Features variant, and a cache of built
// programs, in the process and on disk.
//
// kernels/render.cl, with the device headers inlined (cmake/embed_kernels.cmake), is
// built once per (Features mask, precision): the mask goes in as -DTR_FEATURES, so the
// code a scene does not need is not compiled. Programs are kept per build options in
// the process, and on disk as program binaries saved after their first launch (PoCL
// generates the code for a work-group size at the first launch, so it is in them).
// The disk key is the device, the driver version, the options and the whole source.
// On PoCL with its own kernel cache on, twinray keeps no binaries (keeps_binaries). An
// empty marker file per program asked for tells later processes that it was asked for
// before (asked_before): the OpenCL backend then builds it from the first frame on.
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <twinray/backend/opencl/device.hpp>
#include <twinray/device/features.h>
#include <twinray/generated/opencl_source.hpp>

namespace twinray {
namespace opencl {

// Build options for a Features mask, precision and set of kernels (TR_ENTRY_*,
// device/features.h): the mask and the set as -D, and never any fast-math option
// (bitwise parity with the CPU backend needs IEEE arithmetic as written:
// docs/architecture.md, "Bitwise parity"). exact: the program only renders frames
// whose mask is `features` itself (-DTR_EXACT_FEATURES: tr_use reads no run-time
// bits, so the code of the frame's clear bits is dead); else, as the generic program
// TR_F_ALL does, it follows each frame's bits at run time.
inline std::string build_options(const DeviceInfo& device, unsigned features, bool use_double,
                                 int entry_points = TR_ENTRY_ALL, bool exact = false) {
  char mask[32];
  std::snprintf(mask, sizeof mask, "0x%03xu", features);
  std::string options = std::string("-cl-std=CL1.2 -DTR_FEATURES=") + mask;
  if (exact) options += " -DTR_EXACT_FEATURES";
  if (entry_points != TR_ENTRY_ALL) options += " -DTR_ENTRY_POINTS=" + std::to_string(entry_points);
  if (use_double) options += " -DTR_DOUBLE";
  if (device.correctly_rounded_divide_sqrt) options += " -cl-fp32-correctly-rounded-divide-sqrt";
  return options;
}

// The compiler's messages for a program built for `device` (CL_PROGRAM_BUILD_LOG);
// "" where there are none.
inline std::string program_build_log(cl_program program, cl_device_id device) {
  size_t size = 0;
  clGetProgramBuildInfo(program, device, CL_PROGRAM_BUILD_LOG, 0, nullptr, &size);
  std::string log(size, '\0');
  if (size > 0)
    clGetProgramBuildInfo(program, device, CL_PROGRAM_BUILD_LOG, size, &log[0], nullptr);
  return log;
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

// The program text: the embedded kernel, plus $TWINRAY_TEST_KERNEL_APPEND when set.
// Test hook: appending e.g. a syntax error makes the build fail, so tests can check
// that the driver's build log reaches the user (tests/apps/failure_test.cpp). The text
// is part of the cache key, so a broken program is never cached.
inline std::string program_source() {
  std::string source = opencl_source::render_cl();
  if (const char* extra = std::getenv("TWINRAY_TEST_KERNEL_APPEND"))
    source += std::string("\n") + extra + "\n";
  return source;
}

// Whether twinray keeps program binaries on disk for this device: everywhere but on
// PoCL with its kernel cache on (POCL_KERNEL_CACHE unset, or set to a value starting
// with 1, as PoCL reads it). PoCL keeps the program and every work-group function it
// generates under POCL_CACHE_DIR already, and handing out a binary
// (CL_PROGRAM_BINARIES) makes it compile a generic work-group function for each
// kernel first, about 40% of a cold first frame of torus.json. Without the copy a
// warm process builds from PoCL's cache in 50-100 ms
// instead of loading twinray's binary in 20 ms (docs/performance.md).
// pocl_kernel_cache: the value of POCL_KERNEL_CACHE, or null where it is unset.
inline bool keeps_binaries(const DeviceInfo& device, const char* pocl_kernel_cache) {
  if (device.platform_version.find("PoCL") == std::string::npos) return true;
  return pocl_kernel_cache != nullptr && pocl_kernel_cache[0] != '1';
}
inline bool keeps_binaries(const DeviceInfo& device) {
  return keeps_binaries(device, std::getenv("POCL_KERNEL_CACHE"));
}

// The built programs of one context. Not thread-safe: the Context's mutex guards it.
class ProgramCache {
 public:
  struct Entry {
    cl_program program = nullptr;
    bool from_cache = false;  // loaded from the disk cache
    bool saved = false;       // binary written to (or read from) the disk cache
    std::string cache_file;
    double build_ms = 0;
  };

  ProgramCache(cl_context context, const DeviceInfo& device) : context_(context), info_(device) {}
  ProgramCache(const ProgramCache&) = delete;
  ProgramCache& operator=(const ProgramCache&) = delete;
  ~ProgramCache() {
    for (auto& p : programs_) clReleaseProgram(p.second.program);
  }

  // The program for these build options: from the process, the disk cache, or source.
  // *built_now: it was not in the process yet; *build_ms: what getting it took.
  Entry& get(const std::string& options, bool* built_now, double* build_ms) {
    auto it = programs_.find(options);
    *built_now = false;
    *build_ms = 0;
    if (it != programs_.end()) return it->second;
    auto t0 = std::chrono::steady_clock::now();
    Entry entry;
    const std::string source_text = program_source();
    const std::string stem = keeps_binaries(info_) ? cache_stem(options, source_text) : "";
    if (!stem.empty()) {
      entry.cache_file = stem + ".bin";
      entry.program = load_binary(entry.cache_file, options);
      entry.from_cache = entry.saved = entry.program != nullptr;
    }
    if (!entry.program) entry.program = build_from_source(source_text.c_str(), options);
    entry.build_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    *built_now = true;
    *build_ms = entry.build_ms;
    return programs_.emplace(options, entry).first->second;
  }

  // Whether a program for these options was asked for before: by this cache, or by an
  // earlier process on this device with the same driver and source (a marker file in
  // cache_dir(), "program-KEY.seen", or the program's binary where twinray keeps
  // them). Records the request either way, so the next call answers true. The OpenCL
  // backend renders the first frame of a block program never asked for on this
  // machine with the pixel kernel, which compiles in about half the time on PoCL
  // (OpenCLBackend::render_into).
  bool asked_before(const std::string& options) {
    if (!asked_.insert(options).second || programs_.count(options) != 0) return true;
    const std::string stem = cache_stem(options, program_source());
    if (stem.empty()) return false;
    const std::string marker = stem + ".seen";
    std::error_code ec;
    if (std::filesystem::exists(marker, ec)) return true;
    if (keeps_binaries(info_) && std::filesystem::exists(stem + ".bin", ec)) return true;
    std::filesystem::create_directories(std::filesystem::path(marker).parent_path(), ec);
    std::ofstream touch(marker, std::ios::binary);  // failure only costs the marker
    return false;
  }

  // The build options of every program this cache holds, one per program.
  std::vector<std::string> built_options() const {
    std::vector<std::string> options;
    for (const auto& p : programs_) options.push_back(p.first);
    return options;
  }

  // Saves the binary of a program after its first launch. Failures only cost the cache.
  void save_binary(Entry& entry) {
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

 private:
  // cache_dir()'s path for a program's files, "program-KEY" (the binary adds ".bin",
  // the marker ".seen"), KEY a hash of the device, the driver version, the options and
  // the whole source. Empty without a cache folder.
  std::string cache_stem(const std::string& options, const std::string& source) const {
    const std::string dir = cache_dir();
    if (dir.empty()) return dir;
    const std::string key = info_.platform_version + "\n" + info_.name + "\n" +
                            info_.driver_version + "\n" + options + "\n" + source;
    char name[64];
    std::snprintf(name, sizeof name, "/program-%016llx",
                  static_cast<unsigned long long>(fnv1a(key)));
    return dir + name;
  }

  cl_program build_from_source(const char* source, const std::string& options) {
    cl_int err = CL_SUCCESS;
    cl_program program = clCreateProgramWithSource(context_, 1, &source, nullptr, &err);
    check(err, "clCreateProgramWithSource");
    err = clBuildProgram(program, 1, &info_.device, options.c_str(), nullptr, nullptr);
    if (err != CL_SUCCESS) {
      std::string log = program_build_log(program, info_.device);
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

  cl_context context_;
  DeviceInfo info_;
  std::map<std::string, Entry> programs_;
  std::set<std::string> asked_;  // asked_before's answers in this process
};

}  // namespace opencl
}  // namespace twinray
