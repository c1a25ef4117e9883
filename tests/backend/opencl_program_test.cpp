// The OpenCL program: specialization on the Features mask, the program cache, buffer
// reuse, struct layout as the device compiler sees it.
#include <doctest/doctest.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <utility>
#include <thread>
#include <vector>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <twinray/twinray.hpp>

#include "backend/parity_util.hpp"
#include "support/packing.hpp"
#include "support/scoped_env.hpp"
#include "support/subprocess.hpp"
#include <twinray/scene/demo_scene.hpp>

using namespace twinray;
using test_support::ScopedEnv;

namespace {

template <class T>
Scene<T> spheres_only() {
  using vec3 = glm::vec<3, T>;
  Scene<T> s;
  Material<T> m;
  m.color = vec3(T(0.2), T(0.7), T(0.3));
  int a = s.add_material(m);
  m.glaze = T(0.5);
  int b = s.add_material(m);
  s.add(Sphere<T>{vec3(0, 0, -1), T(0.8), a});
  s.add(Sphere<T>{vec3(T(1.2), T(0.3), T(-0.4)), T(0.4), b});
  s.add_light({vec3(-2, -2, 1), T(12), vec3(1, 1, 1)});
  return s;
}

// A new, empty folder for this process under the system's temporary folder.
std::string fresh_dir(const std::string& name) {
  return test_support::fresh_folder(std::filesystem::temp_directory_path().string(),
                                    "twinray-test-" + name + "-" + std::to_string(getpid()));
}

}  // namespace

TEST_CASE_TEMPLATE("a spheres-only scene gets a kernel without triangle and plane code", T, float,
                   double) {
  Scene<T> scene = spheres_only<T>();
  Camera<T> cam;
  cam.width = 64, cam.height = 48;
  RenderOptions options;
  const unsigned features = test_support::pack(scene, cam, options).frame.features;
  CHECK((features & TR_F_SPHERES) != 0);
  CHECK((features & (TR_F_TRIANGLES | TR_F_PLANES)) == 0);
  CHECK((features & TR_F_GLAZE) != 0);

  opencl::Context& ctx = opencl::shared_context(-1);
  std::string specialized = opencl::build_options(ctx.info(), features, sizeof(T) == 8);
  char mask[16];
  std::snprintf(mask, sizeof mask, "0x%03xu", features);
  CHECK(specialized.find(std::string("-DTR_FEATURES=") + mask) != std::string::npos);
  // Neither the triangle nor the plane bit is in the mask the program is built with:
  // every TR_HAS(TR_F_TRIANGLES) / TR_HAS(TR_F_PLANES) block is dead code in it.
  CHECK((std::strtoul(mask, nullptr, 16) & (TR_F_TRIANGLES | TR_F_PLANES)) == 0);
  CHECK(specialized.find("fast") == std::string::npos);  // never fast-math
  // A render with specialize on builds its program for exactly its frame's mask, which
  // then reads no feature bits at run time; the generic program (TR_F_ALL) does.
  CHECK(specialized.find("TR_EXACT_FEATURES") == std::string::npos);
  CHECK(opencl::build_options(ctx.info(), features, sizeof(T) == 8, TR_ENTRY_ALL, true)
            .find(" -DTR_EXACT_FEATURES") != std::string::npos);

  RenderInfo spec_info, generic_info;
  options.backend = Backend::OpenCL;
  options.specialize = true;
  Image<T> spec = render(scene, cam, options, &spec_info);
  options.specialize = false;
  Image<T> generic = render(scene, cam, options, &generic_info);
  CHECK(spec_info.features == features);
  CHECK(generic_info.features == TR_F_ALL);
  CHECK(test::differing_values(spec, generic) == 0);
  // The backend built the specialized render's program with the exact-features option,
  // and no generic (TR_F_ALL) program with it.
  {
    char all[16];
    std::snprintf(all, sizeof all, "0x%03xu", static_cast<unsigned>(TR_F_ALL));
    std::lock_guard<std::mutex> lock(ctx.mutex());
    bool exact_specialized = false, exact_generic = false;
    for (std::string built : ctx.programs().built_options()) {
      built += ' ';  // so that a mask at the end is followed by a space too
      const bool exact = built.find(" -DTR_EXACT_FEATURES") != std::string::npos;
      if (built.find(std::string("-DTR_FEATURES=") + mask + " ") != std::string::npos)
        exact_specialized = exact_specialized || exact;
      if (built.find(std::string("-DTR_FEATURES=") + all + " ") != std::string::npos)
        exact_generic = exact_generic || exact;
    }
    CHECK(exact_specialized);
    CHECK_FALSE(exact_generic);
  }
  // And the CPU's specialized and generic instantiations give the same bits too.
  options.backend = Backend::Cpu;
  Image<T> cpu_generic = render(scene, cam, options);
  CHECK(test::differing_values(spec, cpu_generic) == 0);
}

TEST_CASE("the block kernel over half a million spheres gives the CPU backend's bits") {
  // A dense cloud: a block's shadow packets spread over many small leaves, and the
  // packets' masked walk (device/bvh_packet.h) reaches nodes with few of their rays.
  using vec3 = glm::vec3;
  Scene<float> scene;
  Material<float> m;
  m.color = vec3(0.8f, 0.6f, 0.3f);
  int mat = scene.add_material(m);
  unsigned state = 12345u;
  auto next = [&state] {  // a fixed LCG: the same cloud on every run
    state = state * 1664525u + 1013904223u;
    return static_cast<float>(state >> 8) / 16777216.0f;
  };
  const int n = 524289;
  for (int i = 0; i < n; ++i)
    scene.add(Sphere<float>{vec3(2 * next() - 1, 2 * next() - 1, 2 * next() - 2), 0.004f, mat});
  scene.add_light({vec3(-2, -2, 1), 12.0f, vec3(1, 1, 1)});
  Camera<float> cam;
  cam.width = 48, cam.height = 32;
  RenderOptions options;
  options.backend = Backend::OpenCL;
  // The block kernel from the first frame where it is the device's choice (not the
  // pixel kernel of a block program's first frame on the machine).
  ScopedEnv kernel("TWINRAY_OPENCL_KERNEL", nullptr);
  ScopedEnv first_frame("TWINRAY_OPENCL_FIRST_FRAME", "blocks");
  opencl::OpenCLBackend<float> backend;
  backend.set_scene(share(pack_scene(scene, backend.pack_options())));
  RenderInfo info;
  Image<float> gpu = backend.render({cam, scene.lights, options, {}}, &info);
  options.backend = Backend::Cpu;
  Image<float> cpu = render(scene, cam, options);
  CHECK(test::differing_values(gpu, cpu) == 0);
  CHECK(info.kernel == (backend.renders_blocks() ? "blocks" : "pixel"));
}

TEST_CASE("a program is asked for for the first time once per machine") {
  opencl::Context& shared = opencl::shared_context(-1);
  const std::string dir = fresh_dir("asked");
  const std::string a = "-DTR_TEST_OPTIONS_A", b = "-DTR_TEST_OPTIONS_B";
  {
    ScopedEnv cache("TWINRAY_CACHE_DIR", dir.c_str());
    opencl::ProgramCache first(shared.context(), shared.info());
    CHECK_FALSE(first.asked_before(a));
    CHECK(first.asked_before(a));
    CHECK_FALSE(first.asked_before(b));
    // A later process with the same cache folder: only a request whose program reached
    // the disk cache (its marker written) is remembered.
    CHECK_FALSE(opencl::ProgramCache(shared.context(), shared.info()).asked_before(a));
    first.remember(a);
    first.remember(b);
    opencl::ProgramCache later(shared.context(), shared.info());
    CHECK(later.asked_before(a));
    CHECK(later.asked_before(b));
    CHECK_FALSE(later.asked_before("-DTR_TEST_OPTIONS_C"));
    // Written whole or not at all: no temporary is left beside the markers.
    for (const auto& e : std::filesystem::directory_iterator(dir))
      CHECK(e.path().filename().string().find(".tmp") == std::string::npos);
  }
  {
    // No disk cache: only the process remembers.
    ScopedEnv cache("TWINRAY_CACHE_DIR", "");
    opencl::ProgramCache first(shared.context(), shared.info());
    CHECK_FALSE(first.asked_before(a));
    CHECK(first.asked_before(a));
    first.remember(a);
    opencl::ProgramCache later(shared.context(), shared.info());
    CHECK_FALSE(later.asked_before(a));
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("a build lock is taken once, and a stale one is replaced") {
  namespace fs = std::filesystem;
  const std::string dir = fresh_dir("lock");
  const std::string lock = dir + "/program-X.lock";
  const long self = getpid();
  CHECK_FALSE(opencl::build_in_progress(lock));
  REQUIRE(opencl::take_build_lock(lock, self));
  CHECK(opencl::build_lock_pid(lock) == self);
  CHECK(opencl::build_in_progress(lock));
  CHECK_FALSE(opencl::take_build_lock(lock, self));  // a live build holds it
  // An ended process, collected or a zombie, holds no lock.
  const pid_t child = fork();
  if (child == 0) _exit(0);
  REQUIRE(child > 0);
  const auto start = std::chrono::steady_clock::now();
  while (opencl::process_alive(child) &&
         std::chrono::steady_clock::now() - start < std::chrono::seconds(30))
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  CHECK_FALSE(opencl::process_alive(child));  // a zombie: not collected yet
  fs::remove(lock);
  REQUIRE(opencl::take_build_lock(lock, child));
  CHECK_FALSE(opencl::build_in_progress(lock));
  int status = 0;
  waitpid(child, &status, 0);
  CHECK_FALSE(opencl::build_in_progress(lock));
  CHECK(opencl::take_build_lock(lock, self));  // replaces the stale lock
  CHECK(opencl::build_lock_pid(lock) == self);
  // A lock older than kBuildLockMaxAge is stale even where its process runs (the id
  // may have been reused).
  fs::last_write_time(
      lock, fs::file_time_type::clock::now() - opencl::kBuildLockMaxAge - std::chrono::minutes(1));
  CHECK_FALSE(opencl::build_in_progress(lock));
  CHECK(opencl::take_build_lock(lock, self));
  CHECK(opencl::build_in_progress(lock));
  // An unreadable lock (no process id) is stale too.
  fs::remove(lock);
  { std::ofstream(lock) << "x"; }
  CHECK_FALSE(opencl::build_in_progress(lock));
  for (const auto& e : fs::directory_iterator(dir))
    CHECK(e.path().filename().string().find(".tmp") == std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("a build helper is started once per program while it runs, and again once it is killed") {
  // The helper here is a shell that counts its starts; it never builds, so the test
  // needs no compiler.
  namespace fs = std::filesystem;
  const std::string dir = fresh_dir("helper");
  const std::string starts = dir + "/starts";
  ScopedEnv cache("TWINRAY_CACHE_DIR", (dir + "/cache").c_str());
  ScopedEnv on("TWINRAY_OPENCL_BACKGROUND_BUILD", nullptr);
  opencl::Context& shared = opencl::shared_context(-1);
  const std::string options = "-DTR_TEST_OPTIONS_HELPER";
  auto lines = [&] {
    std::ifstream f(starts);
    int n = 0;
    for (std::string line; std::getline(f, line);) ++n;
    return n;
  };
  auto wait_for_lines = [&](int n) {
    const auto start = std::chrono::steady_clock::now();
    while (lines() < n && std::chrono::steady_clock::now() - start < std::chrono::seconds(30))
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    return lines();
  };
  std::string lock;
  {
    opencl::ProgramCache none(shared.context(), shared.info());
    CHECK_FALSE(none.build_in_helper(options, "k"));  // no helper named
  }
  opencl::set_build_helper(
      {"/bin/sh", "-c", "echo started >> " + starts + "; exec sleep 60", "sh"});
  opencl::ProgramCache first(shared.context(), shared.info());
  CHECK(first.build_in_helper(options, "k"));
  CHECK(wait_for_lines(1) == 1);
  for (const auto& e : fs::directory_iterator(dir + "/cache"))
    if (e.path().extension() == ".lock") lock = e.path().string();
  REQUIRE_FALSE(lock.empty());
  const long helper = opencl::build_lock_pid(lock);
  CHECK(opencl::process_alive(helper));
  // Another process while it runs: a build is under way, none is started.
  opencl::ProgramCache second(shared.context(), shared.info());
  CHECK(second.build_in_helper(options, "k"));
  CHECK(opencl::build_lock_pid(lock) == helper);
  {
    ScopedEnv off("TWINRAY_OPENCL_BACKGROUND_BUILD", "0");
    opencl::ProgramCache third(shared.context(), shared.info());
    CHECK_FALSE(third.build_in_helper(options, "k"));
  }
  // Killed: its lock is stale, and the next request starts a new helper.
  kill(static_cast<pid_t>(helper), SIGKILL);
  int status = 0;
  waitpid(static_cast<pid_t>(helper), &status, 0);
  CHECK_FALSE(opencl::build_in_progress(lock));
  opencl::ProgramCache after(shared.context(), shared.info());
  CHECK(after.build_in_helper(options, "k"));
  CHECK(wait_for_lines(2) == 2);
  const long restarted = opencl::build_lock_pid(lock);
  CHECK(restarted != helper);
  CHECK(opencl::process_alive(restarted));
  kill(static_cast<pid_t>(restarted), SIGKILL);
  waitpid(static_cast<pid_t>(restarted), &status, 0);
  CHECK(lines() == 2);
  opencl::set_build_helper({});
  fs::remove_all(dir);
}

TEST_CASE("a block program's first frame on a machine takes the pixel kernel, the same image") {
  // On CPU devices shaded frames take the block kernel; while its program has never
  // been asked for on this machine (PoCL's cache is cold for it), a frame takes the
  // pixel kernel, whose program compiles in about half the time, and the next frame
  // takes the block kernel.
  namespace fs = std::filesystem;
  const std::string dir = fresh_dir("tiered");
  ScopedEnv cache("TWINRAY_CACHE_DIR", dir.c_str());
  ScopedEnv choice("TWINRAY_OPENCL_KERNEL", nullptr);
  ScopedEnv first_frame("TWINRAY_OPENCL_FIRST_FRAME", nullptr);
  Scene<float> scene = spheres_only<float>();
  Camera<float> cam;
  cam.width = 40, cam.height = 24;
  RenderOptions options;
  options.backend = Backend::Cpu;
  const Image<float> cpu = render(scene, cam, options);
  options.backend = Backend::OpenCL;
  const opencl::DeviceInfo device = opencl::shared_context(-1).info();
  const std::string blocks_entry = " -DTR_ENTRY_POINTS=" + std::to_string(TR_ENTRY_BLOCKS);
  // Each Context has a program cache of its own: a fresh one stands for a new process.
  // Per frame: the kernel that rendered, and whether a block program was built by then.
  auto frames = [&](int n) {
    opencl::Context ctx(device);
    opencl::OpenCLBackend<float> backend(ctx);
    backend.set_scene(share(pack_scene(scene, backend.pack_options())));
    std::vector<std::string> kernels;
    for (int i = 0; i < n; ++i) {
      RenderInfo info;
      Image<float> image = backend.render({cam, scene.lights, options, {}}, &info);
      CHECK(test::differing_values(image, cpu) == 0);
      bool block_program = false;
      for (const std::string& built : ctx.programs().built_options())
        block_program = block_program || built.find(blocks_entry) != std::string::npos;
      kernels.push_back(info.kernel + (block_program ? "+" : ""));
    }
    return kernels;
  };
  auto markers = [](const std::string& folder, const char* extension = ".seen") {
    int n = 0;
    for (const auto& e : fs::directory_iterator(folder)) n += e.path().extension() == extension;
    return n;
  };
  if (!device.is_cpu) {
    CHECK(frames(2) == std::vector<std::string>{"pixel", "pixel"});
    return;
  }
  // No build helper is named in this process: nothing is built in the background.
  REQUIRE(opencl::build_helper().empty());
  // "+": a block program was in the process by then; once launched, its marker is
  // written.
  CHECK(frames(2) == std::vector<std::string>{"pixel", "blocks+"});
  CHECK(markers(dir) == 1);
  CHECK(frames(1) == std::vector<std::string>{"blocks+"});  // a later process
  {
    // Processes of one frame: the first notes its request and takes the pixel kernel,
    // the next builds the block program and leaves the marker.
    const std::string one = fresh_dir("tiered-one-frame");
    ScopedEnv one_cache("TWINRAY_CACHE_DIR", one.c_str());
    CHECK(frames(1) == std::vector<std::string>{"pixel"});
    CHECK(markers(one, ".asked") == 1);
    CHECK(markers(one) == 0);
    CHECK(frames(1) == std::vector<std::string>{"blocks+"});
    CHECK(markers(one) == 1);
    CHECK(frames(1) == std::vector<std::string>{"blocks+"});
    fs::remove_all(one);
  }
  for (const char* forced : {"TWINRAY_OPENCL_KERNEL", "TWINRAY_OPENCL_FIRST_FRAME"}) {
    CAPTURE(forced);
    const std::string other = fresh_dir("tiered-forced");
    ScopedEnv set(forced, "blocks");
    ScopedEnv other_cache("TWINRAY_CACHE_DIR", other.c_str());
    CHECK(frames(1) == std::vector<std::string>{"blocks+"});
    CHECK(markers(other, ".asked") == 0);  // nothing asked for: nothing noted
    fs::remove_all(other);
  }
  {
    ScopedEnv none("TWINRAY_CACHE_DIR", "");  // nothing remembered between processes
    CHECK(frames(2) == std::vector<std::string>{"pixel", "blocks+"});
    CHECK(frames(1) == std::vector<std::string>{"pixel"});
  }
  fs::remove_all(dir);
}

TEST_CASE_TEMPLATE("buffer structs have the same size in the kernel as on the host", T, float,
                   double) {
  using Code = device::Code<T>;
  std::vector<int> device = opencl::shared_context(-1).device_struct_sizes(sizeof(T) == 8);
  std::vector<int> host = {
      int(sizeof(typename Code::Sphere)),   int(sizeof(typename Code::Triangle)),
      int(sizeof(typename Code::Plane)),    int(sizeof(typename Code::Material)),
      int(sizeof(typename Code::Light)),    int(sizeof(T)),
      int(sizeof(typename Code::Params)),   int(sizeof(typename Code::TriangleAttr)),
      int(sizeof(typename Code::Texture)),  int(sizeof(typename Code::QueryRay)),
      int(sizeof(typename Code::QueryHit)), int(sizeof(typename Code::QueryExtras)),
      int(sizeof(typename Code::Instance))};
  CHECK(device == host);
}

TEST_CASE("programs are cached in the process and on disk, the scene is sent once") {
  const auto started = std::filesystem::file_time_type::clock::now();
  auto d = twinray::demo::make_demo_scene<float>(48, 32);
  RenderOptions options;
  options.backend = Backend::OpenCL;
  options.spp = 2;  // a mask no other test uses first in this process
  opencl::OpenCLBackend<float> backend;
  backend.set_scene(share(pack_scene(d.scene)));
  RenderInfo first, second;
  Image<float> a = backend.render({d.camera, d.scene.lights, options, {}}, &first);
  CHECK(first.scene_uploaded);
  Image<float> b = backend.render({d.camera, d.scene.lights, options, {}}, &second);
  CHECK(second.program_cached);
  CHECK(second.build_ms == 0);
  CHECK_FALSE(second.scene_uploaded);
  CHECK(test::differing_values(a, b) == 0);
  // Moving the camera and a light sends the frame's parameters and lights only, and
  // reuses the program.
  d.camera.position.x += 0.5f;
  d.scene.lights[0].position.y += 0.25f;
  RenderInfo third;
  Image<float> c = backend.render({d.camera, d.scene.lights, options, {}}, &third);
  CHECK(third.build_ms == 0);
  CHECK_FALSE(third.scene_uploaded);
  CHECK(backend.scene_uploads() == 1);
  // ... and renders what the one-call render() renders from scratch.
  CHECK(test::differing_values(c, render(d.scene, d.camera, options)) == 0);
  // The binary was saved after the first launch, keyed on device, driver, source and
  // options, under TWINRAY_CACHE_DIR (unless it was read from there), where the device
  // keeps binaries; on PoCL with its own kernel cache on, none is written. CTest runs
  // this case a second time with POCL_KERNEL_CACHE=0 (tests/backend/CMakeLists.txt).
  const char* dir = std::getenv("TWINRAY_CACHE_DIR");
  REQUIRE(dir != nullptr);
  size_t binaries = 0, written = 0;
  std::error_code ec;
  for (const auto& f : std::filesystem::directory_iterator(dir, ec)) {
    if (f.path().extension() != ".bin") continue;
    ++binaries;
    written += f.last_write_time() >= started;
  }
  if (opencl::keeps_binaries(opencl::shared_context(-1).info())) {
    CHECK(binaries >= 1);
    if (!first.program_cached) CHECK(written >= 1);
  } else {
    CHECK_FALSE(first.program_cached);
    CHECK(written == 0);
  }
}

TEST_CASE("program binaries are kept everywhere but on PoCL with its kernel cache on") {
  opencl::DeviceInfo pocl, gpu;
  pocl.platform_version = "OpenCL 3.0 PoCL 3.1+debian  Linux, None+Asserts, RELOC, LLVM 15.0.6";
  gpu.platform_version = "OpenCL 3.0 CUDA 12.4.131";
  // PoCL reads POCL_KERNEL_CACHE as on where it is unset or starts with 1.
  CHECK_FALSE(opencl::keeps_binaries(pocl, nullptr));
  CHECK_FALSE(opencl::keeps_binaries(pocl, "1"));
  CHECK(opencl::keeps_binaries(pocl, "0"));
  CHECK(opencl::keeps_binaries(pocl, ""));
  CHECK(opencl::keeps_binaries(gpu, nullptr));
  CHECK(opencl::keeps_binaries(gpu, "1"));
}

TEST_CASE("a render's program holds only the kernels it launches") {
  opencl::Context& ctx = opencl::shared_context(-1);
  std::lock_guard<std::mutex> lock(ctx.mutex());
  const std::pair<int, std::vector<std::string>> cases[] = {
      {TR_ENTRY_RENDER, {"tr_kernel_render"}},
      {TR_ENTRY_BLOCKS, {"tr_kernel_render_blocks"}},
      {TR_ENTRY_AOV, {"tr_kernel_aov"}},
      {TR_ENTRY_ADAPTIVE,
       {"tr_kernel_adaptive_first", "tr_kernel_adaptive_mark", "tr_kernel_adaptive_refine"}},
      {TR_ENTRY_ALL,
       {"tr_kernel_adaptive_first", "tr_kernel_adaptive_mark", "tr_kernel_adaptive_refine",
        "tr_kernel_aov", "tr_kernel_intersect", "tr_kernel_layout_sizes", "tr_kernel_occluded",
        "tr_kernel_render", "tr_kernel_render_blocks", "tr_kernel_sample_positions"}},
      {TR_ENTRY_QUERY, {"tr_kernel_intersect", "tr_kernel_occluded"}}};
  for (const auto& entry_case : cases) {
    // Named copies, not a structured binding: C++17 lets no lambda (CAPTURE's) capture one.
    const int entry_points = entry_case.first;
    const std::vector<std::string>& expected = entry_case.second;
    CAPTURE(entry_points);
    bool built = false;
    double ms = 0;
    const cl_program program =
        ctx.programs()
            .get(opencl::build_options(ctx.info(), TR_F_SPHERES, false, entry_points), &built, &ms)
            .program;
    size_t size = 0;
    REQUIRE(clGetProgramInfo(program, CL_PROGRAM_KERNEL_NAMES, 0, nullptr, &size) == CL_SUCCESS);
    std::string names(size, '\0');
    REQUIRE(clGetProgramInfo(program, CL_PROGRAM_KERNEL_NAMES, size, names.data(), nullptr) ==
            CL_SUCCESS);
    names.resize(std::strlen(names.c_str()));
    std::vector<std::string> held;
    for (size_t at = 0; at <= names.size();) {
      size_t end = names.find(';', at);
      if (end == std::string::npos) end = names.size();
      if (end > at) held.push_back(names.substr(at, end - at));
      at = end + 1;
    }
    std::sort(held.begin(), held.end());
    CHECK(held == expected);
  }
}

// The packet's ray-per-lane loops are marked for vectorization (TR_LANE_LOOP,
// TR_INDEPENDENT_LOOP); a clang-based compiler such as PoCL's says in the build log
// where it could not ("loop not vectorized"), as it did while those loops called OpenCL
// C's fabs (device/math.h, tr_fabs). Built from source here, in float and double, for
// the generic block program (every feature, followed at run time) and for a mesh
// scene's, specialized as its frames are (triangles, a plane, BVH8, shading, shadows,
// glaze, TR_EXACT_FEATURES: what mesh_<N> compiles).
TEST_CASE("the block program's lane loops all vectorize: no missed loop in the build log") {
  opencl::Context& ctx = opencl::shared_context(-1);
  std::lock_guard<std::mutex> lock(ctx.mutex());
  const unsigned mesh_features = TR_F_TRIANGLES | TR_F_PLANES | TR_F_BVH8 | TR_F_SHADOWS |
                                 TR_F_GLAZE | TR_F_AMBIENT | TR_F_DIFFUSE | TR_F_SPECULAR;
  const std::string source = opencl::program_source();
  const char* text = source.c_str();
  for (const bool use_double : {false, true}) {
    if (use_double && !ctx.info().has_fp64) continue;
    for (const unsigned features : {unsigned(TR_F_ALL), mesh_features}) {
      const std::string options = opencl::build_options(ctx.info(), features, use_double,
                                                        TR_ENTRY_BLOCKS, features != TR_F_ALL);
      CAPTURE(options);
      cl_int err = CL_SUCCESS;
      cl_program program = clCreateProgramWithSource(ctx.context(), 1, &text, nullptr, &err);
      REQUIRE(err == CL_SUCCESS);
      const cl_device_id device = ctx.info().device;
      REQUIRE(clBuildProgram(program, 1, &device, options.c_str(), nullptr, nullptr) == CL_SUCCESS);
      const std::string log = opencl::program_build_log(program, device);
      clReleaseProgram(program);
      CAPTURE(log);
      CHECK(log.find("loop not vectorized") == std::string::npos);
    }
  }
}

TEST_CASE("a CPU device reads the packed scene and writes the image in place") {
  auto d = twinray::demo::make_demo_scene<float>(40, 24);
  RenderOptions options;
  options.backend = Backend::OpenCL;
  opencl::OpenCLBackend<float> backend;
  const Image<float> expected = render(d.scene, d.camera, options);
  auto packed = share(pack_scene(d.scene, PackOptions{BvhPolicy::Always, bvh::kOpenClWidth}));
  const PackedScene<float>* arrays = packed.get();
  backend.set_scene(packed);
  packed.reset();  // the backend alone keeps the packed scene alive from here
  CHECK(test::differing_values(backend.render({d.camera, d.scene.lights, options, {}}), expected) ==
        0);
  CHECK(backend.shares_host_memory() == backend.device().is_cpu);
  // Each scene buffer either wraps the packed array itself (a CPU device) or is a copy
  // of its own; an empty array gets a private 16-byte buffer either way.
  const auto args = backend.scene_buffers().args();
  auto host_ptr = [](cl_mem m) {
    void* p = nullptr;
    REQUIRE(clGetMemObjectInfo(m, CL_MEM_HOST_PTR, sizeof p, &p, nullptr) == CL_SUCCESS);
    return static_cast<const void*>(p);
  };
  auto check_array = [&](cl_uint arg, const void* data, size_t count) {
    CAPTURE(arg);
    const bool wrapped = backend.shares_host_memory() && count > 0;
    CHECK(host_ptr(args[arg]) == (wrapped ? data : nullptr));
  };
  REQUIRE(!arrays->spheres.empty());
  REQUIRE(!arrays->bvh_nodes.empty());
  check_array(1, arrays->spheres.data(), arrays->spheres.size());
  check_array(2, arrays->triangles.data(), arrays->triangles.size());
  check_array(3, arrays->planes.data(), arrays->planes.size());
  check_array(4, arrays->materials.data(), arrays->materials.size());
  check_array(6, arrays->bvh_nodes.data(), static_cast<size_t>(arrays->bvh_nodes.size()));
  check_array(7, arrays->bvh_prims.data(), arrays->bvh_prims.size());
  check_array(8, arrays->triangle_attrs.data(), arrays->triangle_attrs.size());
  check_array(9, arrays->textures.data(), arrays->textures.size());
  check_array(10, arrays->texels.data(), arrays->texels.size());
  // Later frames, and a new scene, still render what the CPU renders.
  d.camera.position.x += 0.25f;
  CHECK(test::differing_values(backend.render({d.camera, d.scene.lights, options, {}}),
                               render(d.scene, d.camera, options)) == 0);
  auto other = twinray::demo::make_demo_scene<float>(40, 24);
  other.scene.objects.pop_back();
  backend.set_scene(share(pack_scene(other.scene, PackOptions{BvhPolicy::Never, 8})));
  CHECK(test::differing_values(backend.render({other.camera, other.scene.lights, options, {}}),
                               render(other.scene, other.camera, options)) == 0);
}
