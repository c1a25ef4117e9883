// Every failure path, on the real `twinray` program: the exit status of
// docs/command-line.md (1 run-time failure, 3 backend unavailable), a message that names the cause,
// no partial output file, and `--backend auto` falling back to the CPU with the reason.
//
// Broken OpenCL set-ups are made with the real ICD loader and PoCL where they can be:
// no platform (OCL_ICD_VENDORS = an empty folder), a platform without devices
// (POCL_DEVICES naming none), a device with too little memory (POCL_MEMORY_LIMIT).
// Two need twinray's documented test hooks (backend/opencl/program.hpp, backend/opencl/device.hpp):
// a kernel that does not build (TWINRAY_TEST_KERNEL_APPEND) and a device without fp64
// (TWINRAY_TEST_HIDE_FP64; PoCL has fp64). Unwritable folders and full disks are real
// read-only and 64 KiB tmpfs mounts when the test may mount them (as root: root ignores
// file permissions), otherwise a read-only folder (or, for root, /proc/self) and
// RLIMIT_FSIZE.
#include <doctest/doctest.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <sys/mount.h>
#include <sys/stat.h>
#include <unistd.h>

#include "support/subprocess.hpp"

namespace fs = std::filesystem;
using Child = test_support::Result;
using ChildOptions = test_support::RunOptions;
using test_support::contains;

namespace {

// A fresh folder for one test case.
std::string work_dir(const std::string& name) {
  std::string dir = std::string(TWINRAY_FAILURE_WORK_DIR) + "/" + name;
  std::error_code ec;
  fs::remove_all(dir, ec);
  fs::create_directories(dir);
  return dir;
}

// `twinray render demo -o OUT --quiet EXTRA...`, 32 x 32 unless EXTRA gives a size.
Child render(const std::string& dir, const std::string& output,
             const std::vector<std::string>& extra, ChildOptions options = {}) {
  options.timeout_s = 120;
  std::vector<std::string> argv = {TWINRAY_EXE, "render", "demo", "-o", output, "--quiet"};
  bool sized = false;
  for (const std::string& a : extra) sized = sized || a == "--width";
  if (!sized) argv.insert(argv.end(), {"--width", "32", "--height", "32"});
  argv.insert(argv.end(), extra.begin(), extra.end());
  // Program caches inside this test's folder: a cached program would hide build failures.
  options.env.push_back("TWINRAY_CACHE_DIR=" + dir + "/cache");
  options.env.push_back("POCL_CACHE_DIR=" + dir + "/pocl-cache");
  return test_support::run(argv, options);
}

// For INFO(): what a run said, shown when a check on it fails.
std::string describe(const Child& c) {
  return "exit status " + std::to_string(c.status) + "\nstdout:\n" + c.out + "\nstderr:\n" + c.err;
}

// Files left in `dir` whose name starts with `prefix` (temporaries of atomic writes).
std::vector<std::string> leftovers(const std::string& dir, const std::string& prefix) {
  std::vector<std::string> found;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().rfind(prefix, 0) == 0)
      found.push_back(e.path().filename().string());
  return found;
}

// A tmpfs mounted for the duration of a test (root only); unmounted on destruction.
struct TmpfsMount {
  std::string dir;
  bool mounted = false;
  TmpfsMount(const std::string& where, const char* options, unsigned long flags) : dir(where) {
    fs::create_directories(dir);
    mounted = ::geteuid() == 0 && ::mount("tmpfs", dir.c_str(), "tmpfs", flags, options) == 0;
    if (!mounted && ::geteuid() == 0)
      MESSAGE("mount tmpfs on " << dir << " failed: " << std::strerror(errno));
  }
  ~TmpfsMount() {
    if (mounted) ::umount2(dir.c_str(), MNT_DETACH);
  }
};

const std::string kAutoFallback = "backend auto: ";

}  // namespace

TEST_CASE("no OpenCL platform: --backend opencl exits 3 and says there is no platform") {
  std::string dir = work_dir("no_platform");
  fs::create_directories(dir + "/no-vendors");
  ChildOptions o;
  o.env = {"OCL_ICD_VENDORS=" + dir + "/no-vendors", "OCL_ICD_FILENAMES"};
  Child c = render(dir, dir + "/out.png", {"--backend", "opencl"}, o);
  INFO(describe(c));
  CHECK(c.status == 3);
  CHECK(contains(c.err, "the requested backend is not available"));
  CHECK(contains(c.err, "no OpenCL platform is installed"));
  CHECK_FALSE(fs::exists(dir + "/out.png"));
}

TEST_CASE("no OpenCL platform: --backend auto renders on the CPU and says why") {
  std::string dir = work_dir("no_platform_auto");
  fs::create_directories(dir + "/no-vendors");
  ChildOptions o;
  o.env = {"OCL_ICD_VENDORS=" + dir + "/no-vendors", "OCL_ICD_FILENAMES"};
  Child c = render(dir, dir + "/out.png", {"--backend", "auto"}, o);
  INFO(describe(c));
  CHECK(c.status == 0);
  CHECK(contains(c.err, "backend auto: using the CPU"));
  CHECK(contains(c.err, "no OpenCL platform is installed"));
  CHECK(contains(c.out, "backend cpu"));
  CHECK(fs::exists(dir + "/out.png"));
}

TEST_CASE("a platform without devices: exit 3 naming the platform, auto falls back") {
  std::string dir = work_dir("no_devices");
  ChildOptions o;
  o.env = {"POCL_DEVICES=none-such-device"};
  Child c = render(dir, dir + "/out.png", {"--backend", "opencl"}, o);
  INFO(describe(c));
  CHECK(c.status == 3);
  CHECK(contains(c.err, "no OpenCL device found"));
  CHECK(contains(c.err, "'Portable Computing Language' lists no devices"));
  CHECK_FALSE(fs::exists(dir + "/out.png"));

  Child a = render(dir, dir + "/out.png", {"--backend", "auto"}, o);

  INFO(describe(a));
  CHECK(a.status == 0);
  CHECK(contains(a.err, "backend auto: using the CPU"));
  CHECK(contains(a.err, "lists no devices"));
  CHECK(fs::exists(dir + "/out.png"));
}

TEST_CASE("a kernel that fails to build: exit 1 with the driver's build log") {
  std::string dir = work_dir("kernel_build");
  ChildOptions o;
  o.env = {"TWINRAY_TEST_KERNEL_APPEND=twinray_test_syntax_error here;"};
  Child c = render(dir, dir + "/out.png", {"--backend", "opencl"}, o);
  INFO(describe(c));
  CHECK(c.status == 1);
  CHECK(contains(c.err, "OpenCL program build failed"));
  CHECK(contains(c.err, "with options '-cl-std=CL1.2"));
  // The log itself: the compiler's diagnostic quoting the broken line.
  CHECK(contains(c.err, "error:"));
  CHECK(contains(c.err, "twinray_test_syntax_error"));
  CHECK_FALSE(fs::exists(dir + "/out.png"));
  // Nothing broken was cached: the same run without the hook succeeds.
  Child ok = render(dir, dir + "/out.png", {"--backend", "opencl"});
  INFO(describe(ok));
  CHECK(ok.status == 0);
  CHECK(contains(ok.out, "backend opencl"));
}

TEST_CASE("a kernel that fails to build: --backend auto falls back to the CPU with the log") {
  std::string dir = work_dir("kernel_build_auto");
  ChildOptions o;
  o.env = {"TWINRAY_TEST_KERNEL_APPEND=twinray_test_syntax_error here;"};
  Child c = render(dir, dir + "/out.png", {"--backend", "auto"}, o);
  INFO(describe(c));
  CHECK(c.status == 0);
  CHECK(contains(c.err, "backend auto: OpenCL failed, using the CPU"));
  CHECK(contains(c.err, "OpenCL program build failed"));
  CHECK(contains(c.out, "backend cpu"));
  CHECK(fs::exists(dir + "/out.png"));
}

TEST_CASE("a kernel that fails to build: adaptive sampling with --backend auto falls back too") {
  // The adaptive passes take their own path through render(); the fallback must cover it.
  std::string dir = work_dir("kernel_build_auto_adaptive");
  ChildOptions o;
  o.env = {"TWINRAY_TEST_KERNEL_APPEND=twinray_test_syntax_error here;"};
  Child c =
      render(dir, dir + "/out.png", {"--backend", "auto", "--spp", "2", "--adaptive", "8"}, o);
  INFO(describe(c));
  CHECK(c.status == 0);
  CHECK(contains(c.err, "backend auto: OpenCL failed, using the CPU"));
  CHECK(contains(c.out, "backend cpu"));
  CHECK(fs::exists(dir + "/out.png"));
}

TEST_CASE("an image too large for the device: exit 1 naming the sizes, no file") {
  std::string dir = work_dir("too_large");
  ChildOptions o;
  // PoCL's devices with 1 GiB of memory: the largest allocation is 256 MiB, and an
  // 8192 x 8192 float framebuffer is 768 MiB.
  o.env = {"POCL_MEMORY_LIMIT=1"};
  Child c = render(dir, dir + "/out.pfm",
                   {"--backend", "opencl", "--width", "8192", "--height", "8192"}, o);
  INFO(describe(c));
  CHECK(c.status == 1);
  CHECK(contains(c.err, "the framebuffer needs 768 MiB"));
  CHECK(contains(c.err, "more than the device's largest allocation (256 MiB)"));
  CHECK_FALSE(fs::exists(dir + "/out.pfm"));
}

TEST_CASE("double on a device without fp64: exit 3, auto falls back to the CPU") {
  std::string dir = work_dir("no_fp64");
  ChildOptions o;
  o.env = {"TWINRAY_TEST_HIDE_FP64=1"};
  Child c = render(dir, dir + "/out.png", {"--backend", "opencl", "--precision", "double"}, o);
  INFO(describe(c));
  CHECK(c.status == 3);
  CHECK(contains(c.err, "has no double precision (cl_khr_fp64)"));
  CHECK_FALSE(fs::exists(dir + "/out.png"));

  Child a = render(dir, dir + "/out.png", {"--backend", "auto", "--precision", "double"}, o);

  INFO(describe(a));
  CHECK(a.status == 0);
  CHECK(contains(a.err, "backend auto: OpenCL failed, using the CPU"));
  CHECK(contains(a.err, "no double precision"));
  CHECK(contains(a.out, "backend cpu"));
  CHECK(fs::exists(dir + "/out.png"));

  // Float on the same device still uses OpenCL.
  Child f = render(dir, dir + "/float.png", {"--backend", "opencl"}, o);
  INFO(describe(f));
  CHECK(f.status == 0);
}

TEST_CASE("an unwritable output folder: exit 1, the message names the file, nothing left") {
  std::string dir = work_dir("unwritable");
  std::string folder = dir + "/locked";
  TmpfsMount ro(folder, "size=64k", MS_RDONLY);
  // Root ignores permissions: without a read-only mount, a folder of /proc stands in
  // (it exists, and no file can be created in it).
  bool chmodded = !ro.mounted && ::geteuid() != 0;
  if (chmodded) ::chmod(folder.c_str(), 0555);
  if (!ro.mounted && !chmodded) folder = "/proc/self";
  Child c = render(dir, folder + "/out.png", {"--backend", "cpu"});
  INFO(describe(c));
  CHECK(c.status == 1);
  CHECK(contains(c.err, folder + "/out.png: cannot write"));
  CHECK((contains(c.err, "Read-only file system") || contains(c.err, "Permission denied") ||
         contains(c.err, "No such file or directory")));
  CHECK(leftovers(folder, "out.png").empty());
  if (chmodded) ::chmod(folder.c_str(), 0755);
}

TEST_CASE("a full disk while writing: exit 1, the earlier file is intact, no temporary") {
  std::string dir = work_dir("disk_full");
  std::string folder = dir + "/small";
  TmpfsMount disk(folder, "size=64k", 0);
  const std::string earlier = "an earlier, good image\n";
  {
    std::ofstream f(folder + "/out.pfm", std::ios::binary);
    f << earlier;
  }
  ChildOptions o;
  // Without a mount (not root): a 64 KiB file size limit stands in for the full disk.
  if (!disk.mounted) o.max_file_bytes = 64 * 1024;
  // 128 x 128 x 3 floats = 192 KiB: does not fit.
  Child c = render(dir, folder + "/out.pfm",
                   {"--backend", "cpu", "--width", "128", "--height", "128"}, o);
  INFO(describe(c));
  CHECK(c.status == 1);
  CHECK(contains(c.err, folder + "/out.pfm: write failed"));
  CHECK((contains(c.err, "No space left on device") || contains(c.err, "File too large")));
  CHECK(test_support::read_file(folder + "/out.pfm") == earlier);
  std::vector<std::string> left = leftovers(folder, "out.pfm");
  CHECK(left.size() == 1);  // out.pfm itself, no out.pfm.tmp-*
}
