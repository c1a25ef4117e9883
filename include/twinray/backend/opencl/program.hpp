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
// later processes that it is there (asked_before): the OpenCL backend then builds it
// from the first frame on. A block program new to the machine is built into the disk
// caches by a detached helper process that the application names (build_in_helper;
// the `twinray` command runs itself), while the process renders with the pixel
// kernel; a lock file tells later processes that the build is under way.
#pragma once

#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <unistd.h>

#include <twinray/backend/opencl/device.hpp>
#include <twinray/core/atomic_file.hpp>
#include <twinray/core/process.hpp>
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

// Writes a disk-cache file whole or not at all (core/atomic_file.hpp): a process killed
// half-way leaves a temporary, never a partial entry. The temporary is named after the
// host, the process and the thread, since two contexts of one process may save the same
// program at once; no fsync, since a lost entry only costs a rebuild. The folder is
// created where missing. Failures only cost the cache: returns false.
inline bool write_cache_file(const std::string& path, const void* data, size_t size) {
  std::error_code ec;
  std::filesystem::create_directories(std::filesystem::path(path).parent_path(), ec);
  const std::string suffix =
      temporary_suffix() + "-" +
      std::to_string(std::hash<std::thread::id>()(std::this_thread::get_id()));
  return try_write_file_atomically(path, data, size, suffix, false);
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

// The command that builds a program in a detached process of its own
// (ProgramCache::build_in_helper), where the application names one: its argv, to which
// "--device N --options O --kernel K" are appended, and which must do what
// ProgramCache::build_for_later_processes() does (the `twinray` command runs itself:
// apps/twinray/build_helper.cpp). A process of its own may outlive the application,
// which then neither waits for the build at exit nor shares PoCL's one build at a time
// in a process with it. Empty (the default): nothing is built in the background.
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

// Whether a program new to the machine may be built in the background by the build
// helper: unless TWINRAY_OPENCL_BACKGROUND_BUILD is 0.
inline bool background_build_enabled() {
  const char* v = std::getenv("TWINRAY_OPENCL_BACKGROUND_BUILD");
  return !(v && std::string(v) == "0");
}

// The build lock of a program ("program-KEY.lock" beside its marker): it exists while
// a build helper process builds the program, and holds that process's id in decimal.
// A lock whose process has ended (killed, say), or older than kBuildLockMaxAge (the
// id may have been reused), is stale: it is ignored and replaced.
constexpr std::chrono::minutes kBuildLockMaxAge{10};

// Whether a lock's process runs (core/process.hpp): a zombie counts as ended, since a
// helper killed after its parent ended may wait as one for a parent that never
// collects it.
using twinray::process_alive;

// The process id a lock file holds; 0 where it holds none or cannot be read.
inline long build_lock_pid(const std::string& lock) {
  std::ifstream f(lock);
  long pid = 0;
  return f >> pid ? pid : 0;
}

// Whether a live build holds this lock (above).
inline bool build_in_progress(const std::string& lock) {
  std::error_code ec;
  const auto written = std::filesystem::last_write_time(lock, ec);
  if (ec || std::filesystem::file_time_type::clock::now() - written > kBuildLockMaxAge)
    return false;
  return process_alive(build_lock_pid(lock));
}

// Takes the build lock for process `pid`: creates it, whole, where there is none, or
// replaces a stale one. False where a live build holds it or it cannot be written. The
// file is written beside it and linked to its name, which fails where the name exists:
// two processes never both take it, and no reader sees it half-written. (Two processes
// that find the same stale lock at once can both replace it: that costs a second
// build, never a broken cache entry.)
inline bool take_build_lock(const std::string& lock, long pid) {
  std::error_code ec;
  std::filesystem::create_directories(std::filesystem::path(lock).parent_path(), ec);
  const std::string tmp = lock + ".tmp-" + std::to_string(::getpid());
  const std::string text = std::to_string(pid) + "\n";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!(f << text) || (f.close(), !f)) {
      std::remove(tmp.c_str());
      return false;
    }
  }
  bool taken = ::link(tmp.c_str(), lock.c_str()) == 0;
  if (!taken && errno == EEXIST && !build_in_progress(lock)) {
    std::remove(lock.c_str());
    taken = ::link(tmp.c_str(), lock.c_str()) == 0;
  }
  std::remove(tmp.c_str());
  return taken;
}

// Starts argv (argv[0] a path) detached: a process group of its own, stdin, stdout
// and stderr on /dev/null, no other descriptor of this process, nobody waiting for it.
// A group of its own: Ctrl-C at a terminal, sent to the foreground group, does not
// reach it. The same session: where the scheduler groups processes by session
// (autogroups), a helper at low priority yields to the session's other processes, where
// in a session of its own it would get a share as large as theirs.
// Its process id; 0 where it could not start. A parent that outlives it leaves it a
// zombie until the parent ends (process_alive counts a zombie as ended).
inline long spawn_detached(std::vector<std::string> argv) {
  std::vector<char*> args;
  for (std::string& a : argv) args.push_back(&a[0]);
  args.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawnattr_t attr;
  if (posix_spawn_file_actions_init(&actions) != 0) return 0;
  if (posix_spawnattr_init(&attr) != 0) {
    posix_spawn_file_actions_destroy(&actions);
    return 0;
  }
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addclosefrom_np(&actions, 3);
  sigset_t none;
  sigemptyset(&none);
  posix_spawnattr_setsigmask(&attr, &none);
  posix_spawnattr_setpgroup(&attr, 0);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGMASK);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, args[0], &actions, &attr, args.data(), environ);
  posix_spawnattr_destroy(&attr);
  posix_spawn_file_actions_destroy(&actions);
  return spawned == 0 ? pid : 0;
}

// Builds one program into the disk caches for later processes, in an OpenCL context
// of its own: the driver's (PoCL keeps the program under POCL_CACHE_DIR as it builds
// it) and twinray's (the binary, where twinray keeps them: `binary_file` not empty),
// then writes `marker_file`, the marker that tells later processes the program is
// there. After the build, one launch of `kernel` over a single 1x1 work-group, every
// argument a zero-filled buffer (a zero TrParams: an empty rectangle, so the kernel
// returns at once), makes PoCL generate and cache that kernel's code for a 1x1
// work-group, which the block kernel's launches use (OpenCLBackend::launch_uniform).
// Failures cost only the caches: no marker is written. Whether the marker was.
inline bool build_into_caches(const DeviceInfo& device, const std::string& source,
                              const std::string& options, const std::string& kernel_name,
                              const std::string& binary_file, const std::string& marker_file) {
  cl_int err = CL_SUCCESS;
  cl_context_properties props[] = {CL_CONTEXT_PLATFORM,
                                   reinterpret_cast<cl_context_properties>(device.platform), 0};
  cl_context context = clCreateContext(props, 1, &device.device, nullptr, nullptr, &err);
  cl_command_queue queue = nullptr;
  cl_program program = nullptr;
  cl_kernel kernel = nullptr;
  cl_mem zeros = nullptr;
  bool ok = err == CL_SUCCESS;
  if (ok) queue = clCreateCommandQueue(context, device.device, 0, &err);
  ok = ok && err == CL_SUCCESS;
  const char* text = source.c_str();
  if (ok) program = clCreateProgramWithSource(context, 1, &text, nullptr, &err);
  ok = ok && err == CL_SUCCESS;
  ok = ok &&
       clBuildProgram(program, 1, &device.device, options.c_str(), nullptr, nullptr) == CL_SUCCESS;
  if (ok) kernel = clCreateKernel(program, kernel_name.c_str(), &err);
  ok = ok && err == CL_SUCCESS;
  cl_uint args = 0;
  ok = ok && clGetKernelInfo(kernel, CL_KERNEL_NUM_ARGS, sizeof args, &args, nullptr) == CL_SUCCESS;
  std::vector<unsigned char> zero_bytes(4096, 0);  // more than TrParams in double
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
  // Test hook: a pause between the build and the marker, so that tests can find the
  // build under way, or kill it before its marker (tests/apps/cli_test.cpp).
  if (const char* pause = std::getenv("TWINRAY_TEST_BUILD_PAUSE_MS"))
    std::this_thread::sleep_for(std::chrono::milliseconds(std::atoi(pause)));
  if (ok && !binary_file.empty()) {
    const std::vector<unsigned char> binary = program_binary(program);
    ok = !binary.empty() && write_cache_file(binary_file, binary.data(), binary.size());
  }
  if (ok) ok = write_cache_file(marker_file, "", 0);
  if (zeros) clReleaseMemObject(zeros);
  if (kernel) clReleaseKernel(kernel);
  if (program) clReleaseProgram(program);
  if (queue) clReleaseCommandQueue(queue);
  if (context) clReleaseContext(context);
  return ok;
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

  // Whether a program for these options is known to be built: asked for by this cache
  // before, or in the disk cache for this device, driver and source (its marker,
  // "program-KEY.seen" in cache_dir(), written once the program was in the caches by
  // remember() or build_into_caches(), or its binary where twinray keeps them).
  // Records the request in the process, so the next call answers true. The OpenCL
  // backend renders the first frame of a block program not known on this machine with
  // the pixel kernel, which compiles in about half the time on PoCL, while a build
  // helper process builds the block program (OpenCLBackend::render_into).
  bool asked_before(const std::string& options) {
    if (!asked_.insert(options).second || programs_.count(options) != 0) return true;
    const std::string stem = cache_stem(options, program_source());
    if (stem.empty()) return false;
    std::error_code ec;
    if (std::filesystem::exists(stem + ".seen", ec)) {
      remembered_.insert(options);
      return true;
    }
    return keeps_binaries(info_) && std::filesystem::exists(stem + ".bin", ec);
  }

  // Notes in the disk cache that a process asked for the program for these options
  // ("program-KEY.asked"); whether none had before (always true without a cache
  // folder). Without a build helper, the first process that asks renders with the pixel
  // kernel and the next builds the block program itself.
  bool note_request(const std::string& options) {
    const std::string stem = cache_stem(options, program_source());
    if (stem.empty()) return true;
    std::error_code ec;
    if (std::filesystem::exists(stem + ".asked", ec)) return false;
    write_cache_file(stem + ".asked", "", 0);
    return true;
  }

  // Writes the marker that makes later processes' asked_before(options) answer true,
  // once per process: call it once the program was built and launched, so that it is
  // in the caches. Failures only cost the marker.
  void remember(const std::string& options) {
    if (!remembered_.insert(options).second) return;
    const std::string stem = cache_stem(options, program_source());
    if (!stem.empty()) write_cache_file(stem + ".seen", "", 0);
  }

  // Whether build_in_helper() would build the program for these options: a build
  // helper is named, TWINRAY_OPENCL_BACKGROUND_BUILD is not 0, and there is a cache
  // folder.
  bool helper_builds(const std::string& options) const {
    return !build_helper().empty() && background_build_enabled() &&
           !cache_stem(options, program_source()).empty();
  }

  // Has the application's build helper (build_helper()) build the program for these
  // options into the disk caches, in a detached process of its own (spawn_detached)
  // that outlives this one, at idle priority: this process neither waits for it nor shares
  // PoCL's one-build-at-a-time with it. The build lock ("program-KEY.lock") holds this
  // process's id while it starts the helper, then the helper's; the helper removes it
  // when done. Whether a build is under way: started now, or by an earlier process
  // whose lock is live (then no second one starts). False without a helper, a cache
  // folder, or where TWINRAY_OPENCL_BACKGROUND_BUILD=0.
  bool build_in_helper(const std::string& options, const std::string& kernel) {
    if (!helper_builds(options)) return false;
    const std::vector<std::string> helper = build_helper();
    const std::string stem = cache_stem(options, program_source());
    const std::string lock = stem + ".lock";
    if (build_in_progress(lock)) return true;
    if (!take_build_lock(lock, ::getpid())) return build_in_progress(lock);
    std::vector<std::string> argv = helper;
    for (const std::string& a :
         {std::string("--device"), std::to_string(info_.index), std::string("--options"), options,
          std::string("--kernel"), kernel})
      argv.push_back(a);
    const long pid = spawn_detached(argv);
    const std::string text = std::to_string(pid) + "\n";
    if (pid <= 0 || !write_cache_file(lock, text.data(), text.size())) {
      std::remove(lock.c_str());
      return false;
    }
    return true;
  }

  // What the build helper process does (build_in_helper): builds the program for these
  // options into the disk caches (build_into_caches), unless its marker is there
  // already, and removes the build lock. Whether the program is in the caches.
  bool build_for_later_processes(const std::string& options, const std::string& kernel) {
    const std::string source = program_source();
    const std::string stem = cache_stem(options, source);
    if (stem.empty()) return false;
    std::error_code ec;
    const bool ok = std::filesystem::exists(stem + ".seen", ec) ||
                    build_into_caches(info_, source, options, kernel,
                                      keeps_binaries(info_) ? stem + ".bin" : "", stem + ".seen");
    std::remove((stem + ".lock").c_str());
    return ok;
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
    const std::vector<unsigned char> bytes = program_binary(entry.program);
    if (!bytes.empty()) write_cache_file(entry.cache_file, bytes.data(), bytes.size());
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
  std::set<std::string> asked_;       // asked_before's answers in this process
  std::set<std::string> remembered_;  // markers written or found by this process
};

}  // namespace opencl
}  // namespace twinray
