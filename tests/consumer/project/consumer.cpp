// A program a twinray user would write: load a scene file (twinray::io), render it on
// the CPU and with OpenCL (twinray::opencl), compare the two framebuffers bit for bit,
// and write a PNG. Built by tests/consumer against an installed twinray (find_package)
// or a source tree (add_subdirectory), with the consumer's own compiler flags.
//
//   consumer SCENE.json OUT.png     exit 0: both backends ran and agree bit for bit
#include <cstring>
#include <iostream>
#include <string>

#include <twinray/io/png.hpp>
#include <twinray/io/scene_json.hpp>
#include <twinray/twinray.hpp>
#include <twinray/version.hpp>

#ifndef TWINRAY_WITH_OPENCL
#error "twinray::opencl must define TWINRAY_WITH_OPENCL"
#endif

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: consumer SCENE.json OUT.png\n";
    return 2;
  }
  static_assert(TWINRAY_VERSION_MAJOR == 0 && TWINRAY_VERSION_MINOR == 2, "version macros");
  std::cout << "twinray " << TWINRAY_VERSION_STRING << "\n";
  // The target's -ffp-contract=off must beat the project's own flags (-march=native
  // -ffp-contract=fast in the test): this runs the library's own self-test.
#ifdef __FMA__
  std::cout << "FMA instructions are enabled: contraction would change the CPU image\n";
#endif
  if (twinray::fp_contraction_detected()) {
    std::cerr << "consumer: compiled with floating-point contraction despite twinray::twinray\n";
    return 1;
  }
  try {
    twinray::io::SceneFile<float> f = twinray::io::load_scene<float>(argv[1]);
    f.camera.width = 64;
    f.camera.height = 48;
    twinray::Image<float> images[2];
    const twinray::Backend backends[2] = {twinray::Backend::Cpu, twinray::Backend::OpenCL};
    for (int i = 0; i < 2; ++i) {
      f.options.backend = backends[i];
      twinray::RenderInfo info;
      images[i] = twinray::render(f.scene, f.camera, f.options, &info);
      std::cout << twinray::to_string(info.backend) << " (" << info.device
                << "): " << info.render_ms << " ms\n";
      if (info.backend != backends[i]) return 1;
    }
    const size_t bytes = images[0].rgb.size() * sizeof(float);
    if (images[0].rgb.size() != images[1].rgb.size() ||
        std::memcmp(images[0].rgb.data(), images[1].rgb.data(), bytes) != 0) {
      size_t differ = 0;
      for (size_t i = 0; i < images[0].rgb.size() && i < images[1].rgb.size(); ++i)
        differ += std::memcmp(&images[0].rgb[i], &images[1].rgb[i], sizeof(float)) != 0;
      std::cerr << "consumer: CPU and OpenCL images differ in " << differ << " of "
                << images[0].rgb.size() << " values\n";
      return 1;
    }
    twinray::io::write_png(argv[2], images[1]);
    std::cout << "consumer: CPU and OpenCL agree bit for bit; wrote " << argv[2] << "\n";
  } catch (const twinray::Error& e) {
    std::cerr << "consumer: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
