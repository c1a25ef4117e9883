// Renders through the BVH: the same image as the linear loops (scenes without ties),
// and the same image, bit for bit, on the CPU and OpenCL backends in float and double.
#include <doctest/doctest.h>

#include <cstdlib>
#include <cstring>
#include <string>

#include <twinray/twinray.hpp>

#include "bvh_scenes.hpp"
#include "support/packing.hpp"
#include "support/scoped_env.hpp"

namespace {

// A packed scene with what renders it.
template <class T>
struct Case {
  twinray::PackedScene<T> ps;
  twinray::Camera<T> camera;
  std::vector<twinray::Light<T>> lights;
  twinray::RenderOptions options;
};

template <class T>
twinray::Image<T> render(const Case<T>& c, twinray::Backend backend) {
  return test_support::render_packed(c.ps, c.camera, c.lights, c.options, backend);
}

template <class T>
bool same_bits(const twinray::Image<T>& a, const twinray::Image<T>& b) {
  return a.rgb.size() == b.rgb.size() &&
         std::memcmp(a.rgb.data(), b.rgb.data(), a.rgb.size() * sizeof(T)) == 0;
}

template <class T>
Case<T> packed(const twinray::Scene<T>& scene, int max_depth = 4) {
  Case<T> c;
  c.options.max_depth = max_depth;
  c.camera = bvh_test::test_camera<T>(64, 48);
  c.lights = scene.lights;
  c.ps = twinray::pack_scene(scene, twinray::BvhPolicy::Always);
  REQUIRE((c.ps.features & TR_F_BVH) != 0u);
  return c;
}

template <class T>
Case<T> packed(int n_spheres, int n_triangles, uint32_t seed, int max_depth = 4) {
  return packed(bvh_test::random_scene<T>(n_spheres, n_triangles, seed), max_depth);
}

template <class T>
Case<T> without_bvh(Case<T> c) {
  c.ps = test_support::without_bvh(c.ps);
  REQUIRE((c.ps.features & TR_F_BVH) == 0u);
  return c;
}

bool have_opencl() {
#ifdef TWINRAY_WITH_OPENCL
  return twinray::opencl_available();
#else
  return false;
#endif
}

}  // namespace

TEST_CASE_TEMPLATE("bvh: CPU images with and without the BVH are bit-identical", T, float, double) {
  auto with = packed<T>(150, 150, 21u);
  auto without = without_bvh(with);
  CHECK(same_bits(render(with, twinray::Backend::Cpu), render(without, twinray::Backend::Cpu)));
}

TEST_CASE_TEMPLATE("bvh: OpenCL images with and without the BVH are bit-identical", T, float,
                   double) {
  if (!have_opencl()) {
    MESSAGE("no OpenCL device: skipped");
    return;
  }
  auto with = packed<T>(150, 150, 22u);
  auto without = without_bvh(with);
  CHECK(
      same_bits(render(with, twinray::Backend::OpenCL), render(without, twinray::Backend::OpenCL)));
}

TEST_CASE_TEMPLATE("bvh: CPU and OpenCL BVH renders are bit-identical", T, float, double) {
  if (!have_opencl()) {
    MESSAGE("no OpenCL device: skipped");
    return;
  }
  // Meshes with shared edges too: both backends walk the same tree in the same order,
  // so even ties resolve alike.
  auto ps = packed<T>(400, 400, 23u);
  twinray::Scene<T> grid = bvh_test::random_scene<T>(0, 0, 24u);
  grid.add(bvh_test::folded_grid<T>(12, 1));
  auto mesh_ps = packed(grid);
  for (const auto* p : {&ps, &mesh_ps}) {
    auto cpu = render(*p, twinray::Backend::Cpu);
    auto ocl = render(*p, twinray::Backend::OpenCL);
    CHECK(same_bits(cpu, ocl));
  }
}

TEST_CASE_TEMPLATE("bvh: both OpenCL kernels, pixel and blocks, give the CPU backend's bits", T,
                   float, double) {
  if (!have_opencl()) {
    MESSAGE("no OpenCL device: skipped");
    return;
  }
  // tr_kernel_render (a pixel per work-item, for GPUs) and tr_kernel_render_blocks
  // (packets of an 8x8 block, for CPU devices); TWINRAY_OPENCL_KERNEL picks one.
  auto c = packed<T>(300, 300, 25u);
  c.options.spp = 2;
  c.camera = bvh_test::test_camera<T>(61, 43);  // blocks cut at the right and bottom
  const auto cpu = render(c, twinray::Backend::Cpu);
  for (const char* kernel : {"pixel", "blocks"}) {
    CAPTURE(kernel);
    test_support::ScopedEnv choice("TWINRAY_OPENCL_KERNEL", kernel);
    const char* set = std::getenv("TWINRAY_OPENCL_KERNEL");
    REQUIRE((set != nullptr && std::string(set) == kernel));
    CHECK(same_bits(cpu, render(c, twinray::Backend::OpenCL)));
  }
}
