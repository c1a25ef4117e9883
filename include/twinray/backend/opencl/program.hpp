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
// empty marker file per program, written once the program is in the disk cache, tells
// later processes that it was asked for before (asked_before): the OpenCL backend then
// builds it from the first frame on. A program asked for for the first time can be
// built in the background (BackgroundBuild: on a thread, or by a helper process that
// the application names) while the process renders with another, so that it is in
// the disk cache for later processes.
#pragma once

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

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
// kernel first: 2.6-2.9 s of a 6.2-6.8 s cold first frame of torus.json on a 2-vCPU
// AMD EPYC. Without the copy a warm process builds from PoCL's cache in 50-100 ms
// instead of loading twinray's binary in 20 ms (docs/performance.md).
// pocl_kernel_cache: the value of POCL_KERNEL_CACHE, or null where it is unset.
inline bool keeps_binaries(const DeviceInfo& device, const char* pocl_kernel_cache) {
  if (device.platform_version.find("PoCL") == std::string::npos) return true;
  return pocl_kernel_cache != nullptr && pocl_kernel_cache[0] != '1';
}
inline bool keeps_binaries(const DeviceInfo& device) {
  return keeps_binaries(device, std::getenv("POCL_KERNEL_CACHE"));
}

// Writes a disk-cache file whole or not at all: the bytes go to a temporary file in
// the same folder, named after the process and the caller, which is renamed over
// `path`; a process killed half-way leaves a temporary, never a partial entry. The
// folder is created where missing. Failures only cost the cache: returns false.
inline bool write_cache_file(const std::string& path, const void* data, size_t size) {
  std::error_code ec;
  std::filesystem::create_directories(std::filesystem::path(path).parent_path(), ec);
  const std::string tmp = path + ".tmp-" + std::to_string(::getpid()) + "-" +
                          std::to_string(std::hash<std::thread::id>()(std::this_thread::get_id()));
  {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) return false;
    f.write(static_cast<const char*>(data), static_cast<std::streamsize>(size));
    f.close();
    if (!f) {
      std::remove(tmp.c_str());
      return false;
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) == 0) return true;
  std::remove(tmp.c_str());
  return false;
}

// The binary of a built program (CL_PROGRAM_BINARIES); empty on failure.
inline std::vector<unsigned char> program_binary(cl_program program) {
  size_t size = 0;
  if (clGetProgramInfo(program, CL_PROGRAM_BINARY_SIZES, sizeof size, &size, nullptr) !=
          CL_SUCCESS ||
      size == 0)
    return {};
  std::vector<unsigned char> bytes(size);
  unsigned char* ptr = bytes.data();
  if (clGetProgramInfo(program, CL_PROGRAM_BINARIES, sizeof ptr, &ptr, nullptr) != CL_SUCCESS)
    return {};
  return bytes;
}

// The command that builds a program in a process of its own (BackgroundBuild), where
// the application has one: its argv, to which "--device N --options O --kernel K" are
// appended, and which must do what build_for_later_processes() does (the `twinray`
// command runs itself: apps/twinray/build_helper.cpp). PoCL builds one program at a
// time in a process, so only a process of its own builds beside the frame's build.
// Empty (the default): the program is built on a thread, after the frame.
inline std::vector<std::string>& build_helper_argv() {
  static std::vector<std::string>& argv = *new std::vector<std::string>;
  return argv;
}
inline std::mutex& build_helper_mutex() {
  static std::mutex& mutex = *new std::mutex;
  return mutex;
}
inline void set_build_helper(std::vector<std::string> argv) {
  std::lock_guard<std::mutex> lock(build_helper_mutex());
  build_helper_argv() = std::move(argv);
}
inline std::vector<std::string> build_helper() {
  std::lock_guard<std::mutex> lock(build_helper_mutex());
  return build_helper_argv();
}

// Runs argv (argv[0] a path) with stdin, stdout and stderr on /dev/null and waits for
// it; whether it exited with status 0.
inline bool run_quietly(std::vector<std::string> argv) {
  std::vector<char*> args;
  for (std::string& a : argv) args.push_back(&a[0]);
  args.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  if (posix_spawn_file_actions_init(&actions) != 0) return false;
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return false;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return false;
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

// One program built on a thread of its own, in an OpenCL context of its own, for the
// disk caches of later processes: the driver's (PoCL keeps the program under
// POCL_CACHE_DIR as it builds it) and twinray's (the binary, where twinray keeps
// them), then the marker that tells later processes it was asked for. A context and
// queue of its own: the build needs nothing the calling thread holds (the Context's
// mutex and queue). PoCL builds one program at a time in a process, so the build runs
// after, not beside, other threads' builds. After the build, one launch of `kernel`
// over a single 1x1 work-group, every argument a zero-filled buffer (a zero TrParams:
// an empty rectangle, so the kernel returns at once), makes PoCL generate and cache
// that kernel's code for a 1x1 work-group, which the block kernel's launches use
// (OpenCLBackend::launch_uniform). Nothing of it is used in this process: a later
// request for the same program waits for it (wait) and then builds from the caches.
// Failures cost only the caches: no marker is written, and the next process asks
// again. With a `helper` command (build_helper()), the thread runs it instead, and
// that process builds the program this way. The destructor waits for the thread.
class BackgroundBuild {
 public:
  BackgroundBuild(const DeviceInfo& device, std::string source, std::string options,
                  std::string kernel, std::string binary_file, std::string marker_file,
                  std::vector<std::string> helper = {})
      : device_(device),
        source_(std::move(source)),
        options_(std::move(options)),
        kernel_(std::move(kernel)),
        binary_file_(std::move(binary_file)),
        marker_file_(std::move(marker_file)),
        helper_(std::move(helper)) {
    thread_ = std::thread([this] { helper_.empty() ? run() : run_helper(); });
  }
  BackgroundBuild(const BackgroundBuild&) = delete;
  BackgroundBuild& operator=(const BackgroundBuild&) = delete;
  ~BackgroundBuild() { wait(); }

  // Waits at most `limit` for the build to end; whether it has.
  bool wait_for(std::chrono::milliseconds limit) {
    std::unique_lock<std::mutex> lock(mutex_);
    return done_cv_.wait_for(lock, limit, [this] { return done_; });
  }
  // Waits for the build to end.
  void wait() {
    if (thread_.joinable()) thread_.join();
  }
  // Whether the build reached the disk caches (valid once it has ended).
  bool succeeded() const { return succeeded_; }

 private:
  void run_helper() {
    std::vector<std::string> argv = helper_;
    for (const std::string& a :
         {std::string("--device"), std::to_string(device_.index), std::string("--options"),
          options_, std::string("--kernel"), kernel_})
      argv.push_back(a);
    finish(run_quietly(argv));
  }

  void run() {
    cl_int err = CL_SUCCESS;
    cl_context_properties props[] = {CL_CONTEXT_PLATFORM,
                                     reinterpret_cast<cl_context_properties>(device_.platform), 0};
    cl_context context = clCreateContext(props, 1, &device_.device, nullptr, nullptr, &err);
    cl_command_queue queue = nullptr;
    cl_program program = nullptr;
    cl_kernel kernel = nullptr;
    cl_mem zeros = nullptr;
    bool ok = err == CL_SUCCESS;
    if (ok) queue = clCreateCommandQueue(context, device_.device, 0, &err);
    ok = ok && err == CL_SUCCESS;
    const char* text = source_.c_str();
    if (ok) program = clCreateProgramWithSource(context, 1, &text, nullptr, &err);
    ok = ok && err == CL_SUCCESS;
    ok = ok && clBuildProgram(program, 1, &device_.device, options_.c_str(), nullptr, nullptr) ==
                   CL_SUCCESS;
    if (ok) kernel = clCreateKernel(program, kernel_.c_str(), &err);
    ok = ok && err == CL_SUCCESS;
    cl_uint args = 0;
    ok = ok &&
         clGetKernelInfo(kernel, CL_KERNEL_NUM_ARGS, sizeof args, &args, nullptr) == CL_SUCCESS;
    std::vector<unsigned char> zero_bytes(kZeroBytes, 0);
    if (ok)
      zeros = clCreateBuffer(context, CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, zero_bytes.size(),
                             zero_bytes.data(), &err);
    ok = ok && err == CL_SUCCESS;
    for (cl_uint i = 0; ok && i < args; ++i)
      ok = clSetKernelArg(kernel, i, sizeof zeros, &zeros) == CL_SUCCESS;
    size_t one[2] = {1, 1};
    ok = ok && clEnqueueNDRangeKernel(queue, kernel, 2, nullptr, one, one, 0, nullptr, nullptr) ==
                   CL_SUCCESS;
    ok = ok && clFinish(queue) == CL_SUCCESS;
    if (ok && !binary_file_.empty()) {
      const std::vector<unsigned char> binary = program_binary(program);
      ok = !binary.empty() && write_cache_file(binary_file_, binary.data(), binary.size());
    }
    if (ok && !marker_file_.empty()) ok = write_cache_file(marker_file_, "", 0);
    if (zeros) clReleaseMemObject(zeros);
    if (kernel) clReleaseKernel(kernel);
    if (program) clReleaseProgram(program);
    if (queue) clReleaseCommandQueue(queue);
    if (context) clReleaseContext(context);
    finish(ok);
  }

  void finish(bool ok) {
    std::lock_guard<std::mutex> lock(mutex_);
    succeeded_ = ok;
    done_ = true;
    done_cv_.notify_all();
  }

  // The zero-filled buffer's size: larger than TrParams in double.
  static constexpr size_t kZeroBytes = 4096;

  DeviceInfo device_;
  std::string source_, options_, kernel_, binary_file_, marker_file_;
  std::vector<std::string> helper_;
  std::mutex mutex_;
  std::condition_variable done_cv_;
  bool done_ = false, succeeded_ = false;
  std::thread thread_;
};

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
    background_.clear();  // waits for the background builds
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
    // A background build of the same program: wait for it, then build from the caches
    // it filled rather than compile a second time beside it.
    if (auto job = background_.find(options); job != background_.end()) {
      job->second->wait();
      background_.erase(job);
    }
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
  // earlier process on this device with the same driver and source whose request
  // reached the disk cache (a marker file in cache_dir(), "program-KEY.seen", written
  // by remember() or build_in_background(), or the program's binary where twinray
  // keeps them). Records the request in the process, so the next call answers true.
  // The OpenCL backend renders the first frame of a block program never asked for on
  // this machine with the pixel kernel, which compiles in about half the time on PoCL,
  // and builds the block program in the background (OpenCLBackend::render_into).
  bool asked_before(const std::string& options) {
    if (!asked_.insert(options).second || programs_.count(options) != 0) return true;
    const std::string stem = cache_stem(options, program_source());
    if (stem.empty()) return false;
    std::error_code ec;
    if (std::filesystem::exists(stem + ".seen", ec)) return true;
    return keeps_binaries(info_) && std::filesystem::exists(stem + ".bin", ec);
  }

  // Writes the marker that makes later processes' asked_before(options) answer true.
  // Failures only cost the marker.
  void remember(const std::string& options) {
    const std::string stem = cache_stem(options, program_source());
    if (!stem.empty()) write_cache_file(stem + ".seen", "", 0);
  }

  // Starts building the program for these options on a thread of its own, for later
  // processes (BackgroundBuild: PoCL's cache, twinray's binary where it keeps them, and
  // the marker that asked_before reads), with one launch of `kernel` over a 1x1
  // work-group. Nothing to do without a cache folder, or where this cache holds or
  // builds the program already. get() for the same options waits for it; so do
  // finish_background() and the destructor.
  void build_in_background(const std::string& options, const std::string& kernel) {
    if (programs_.count(options) != 0 || background_.count(options) != 0) return;
    if (auto job = start_build(options, kernel, build_helper()))
      background_.emplace(options, std::move(job));
  }

  // What a build helper process does (build_helper()): builds the program for these
  // options as build_in_background does, on a thread of this process, and waits for
  // it. Whether it reached the disk caches.
  bool build_for_later_processes(const std::string& options, const std::string& kernel) {
    std::unique_ptr<BackgroundBuild> job = start_build(options, kernel, {});
    if (!job) return false;
    job->wait();
    return job->succeeded();
  }

  // Waits, at most `limit` in all, for the background builds to end; whether they all
  // have. One still running past the limit goes on (and is waited for by get() or the
  // destructor).
  bool finish_background(std::chrono::milliseconds limit) {
    const auto deadline = std::chrono::steady_clock::now() + limit;
    for (auto it = background_.begin(); it != background_.end();) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          deadline - std::chrono::steady_clock::now());
      if (!it->second->wait_for(std::max(left, std::chrono::milliseconds(0)))) return false;
      it->second->wait();
      it = background_.erase(it);
    }
    return true;
  }

  // How many background builds this cache has started and not yet waited for.
  size_t background_builds() const { return background_.size(); }

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
    const std::vector<unsigned char> bytes = program_binary(entry.program);
    if (!bytes.empty()) write_cache_file(entry.cache_file, bytes.data(), bytes.size());
  }

 private:
  // A BackgroundBuild of the program for these options; null without a cache folder.
  std::unique_ptr<BackgroundBuild> start_build(const std::string& options,
                                               const std::string& kernel,
                                               std::vector<std::string> helper) const {
    const std::string source = program_source();
    const std::string stem = cache_stem(options, source);
    if (stem.empty()) return nullptr;
    return std::make_unique<BackgroundBuild>(info_, source, options, kernel,
                                             keeps_binaries(info_) ? stem + ".bin" : "",
                                             stem + ".seen", std::move(helper));
  }

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
  std::map<std::string, std::unique_ptr<BackgroundBuild>> background_;
};

}  // namespace opencl
}  // namespace twinray
