// The OpenCL program: specialization on the Features mask, the program cache, buffer
// reuse, struct layout as the device compiler sees it.
#include <doctest/doctest.h>

#include <cstdlib>
#include <filesystem>

#include <twinray/twinray.hpp>

#include "backend/parity_util.hpp"
#include "demo_scene.hpp"

using namespace twinray;

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

}  // namespace

TEST_CASE_TEMPLATE("a spheres-only scene gets a kernel without triangle and plane code", T, float,
                   double) {
  Scene<T> scene = spheres_only<T>();
  Camera<T> cam;
  cam.width = 64, cam.height = 48;
  RenderOptions options;
  PackedScene<T> ps = pack(scene, cam, options);
  CHECK((ps.features & TR_F_SPHERES) != 0);
  CHECK((ps.features & (TR_F_TRIANGLES | TR_F_PLANES)) == 0);
  CHECK((ps.features & TR_F_GLAZE) != 0);

  opencl::Context& ctx = opencl::shared_context(-1);
  std::string specialized = opencl::build_options(ctx.info(), ps.features, sizeof(T) == 8);
  char mask[16];
  std::snprintf(mask, sizeof mask, "0x%03xu", ps.features);
  CHECK(specialized.find(std::string("-DTR_FEATURES=") + mask) != std::string::npos);
  // Neither the triangle nor the plane bit is in the mask the program is built with:
  // every TR_HAS(TR_F_TRIANGLES) / TR_HAS(TR_F_PLANES) block is dead code in it.
  CHECK((std::strtoul(mask, nullptr, 16) & (TR_F_TRIANGLES | TR_F_PLANES)) == 0);
  CHECK(specialized.find("fast") == std::string::npos);  // never fast-math

  RenderInfo spec_info, generic_info;
  options.backend = Backend::OpenCL;
  options.specialize = true;
  Image<T> spec = render(scene, cam, options, &spec_info);
  options.specialize = false;
  Image<T> generic = render(scene, cam, options, &generic_info);
  CHECK(spec_info.features == ps.features);
  CHECK(generic_info.features == TR_F_ALL);
  CHECK(test::differing_values(spec, generic) == 0);
  // And the CPU's specialized and generic instantiations give the same bits too.
  options.backend = Backend::Cpu;
  Image<T> cpu_generic = render(scene, cam, options);
  CHECK(test::differing_values(spec, cpu_generic) == 0);
}

TEST_CASE_TEMPLATE("buffer structs have the same size in the kernel as on the host", T, float,
                   double) {
  using Code = device::Code<T>;
  std::vector<int> device = opencl::shared_context(-1).device_struct_sizes(sizeof(T) == 8);
  std::vector<int> host = {int(sizeof(typename Code::Sphere)), int(sizeof(typename Code::Triangle)),
                           int(sizeof(typename Code::Plane)),  int(sizeof(typename Code::Material)),
                           int(sizeof(typename Code::Light)),  int(sizeof(typename Code::BvhNode)),
                           int(sizeof(typename Code::Params))};
  CHECK(device == host);
}

TEST_CASE("programs are cached in the process and on disk; unchanged buffers are not re-sent") {
  auto d = demo::make_demo_scene<float>(48, 32);
  RenderOptions options;
  options.backend = Backend::OpenCL;
  options.spp = 2;  // a mask no other test uses first in this process
  RenderInfo first, second;
  Image<float> a = render(d.scene, d.camera, options, &first);
  opencl::Context& ctx = opencl::shared_context(-1);
  long long uploads = ctx.uploads();
  Image<float> b = render(d.scene, d.camera, options, &second);
  CHECK(second.program_cached);
  CHECK(second.build_ms == 0);
  CHECK(ctx.uploads() == uploads);  // same scene, same frame: nothing re-uploaded
  CHECK(test::differing_values(a, b) == 0);
  // Moving the camera re-sends the per-frame parameters only, and reuses the program.
  d.camera.position.x += 0.5f;
  RenderInfo third;
  render(d.scene, d.camera, options, &third);
  CHECK(third.build_ms == 0);
  CHECK(ctx.uploads() == uploads + 1);
  // The binary was saved after the first launch, keyed on device, driver, source and
  // options, under TWINRAY_CACHE_DIR.
  const char* dir = std::getenv("TWINRAY_CACHE_DIR");
  REQUIRE(dir != nullptr);
  size_t binaries = 0;
  for (const auto& f : std::filesystem::directory_iterator(dir))
    binaries += f.path().extension() == ".bin";
  CHECK(binaries >= 1);
}
