// Renders the seed's demo scene and its comparison images (ambient only, diffuse only,
// specular only, no shadows, no glaze, all glazed, orthographic) to PNG files.
//
//   demo [--backend cpu|opencl|auto] [--double] [--width W --height H] [OUT_DIR]
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>

#include <twinray/io/png.hpp>
#include <twinray/twinray.hpp>

#include <twinray/scene/demo_scene.hpp>

template <class T>
int run(twinray::Backend backend, int width, int height, const std::string& out_dir) {
  for (const twinray::demo::Variant& v : twinray::demo::seed_variants()) {
    twinray::demo::DemoSetup<T> d = twinray::demo::make_demo_scene<T>(width, height);
    twinray::RenderOptions options;
    options.backend = backend;
    twinray::demo::apply(v, d, options);
    twinray::RenderInfo info;
    twinray::Image<T> image = twinray::render(d.scene, d.camera, options, &info);
    std::string path = out_dir + "/" + v.name + ".png";
    twinray::io::write_png(path, image);
    std::cout << path << ": " << twinray::to_string(info.backend) << " (" << info.device << "), "
              << width << "x" << height << ", " << info.render_ms << " ms render, " << info.build_ms
              << " ms program build\n";
  }
  return 0;
}

int main(int argc, char** argv) {
  twinray::Backend backend = twinray::Backend::Auto;
  bool use_double = false;
  int width = 400, height = 400;
  std::string out_dir = ".";
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--backend" && i + 1 < argc) {
      std::string b = argv[++i];
      backend = b == "cpu"      ? twinray::Backend::Cpu
                : b == "opencl" ? twinray::Backend::OpenCL
                                : twinray::Backend::Auto;
    } else if (a == "--double") {
      use_double = true;
    } else if (a == "--width" && i + 1 < argc) {
      width = std::atoi(argv[++i]);
    } else if (a == "--height" && i + 1 < argc) {
      height = std::atoi(argv[++i]);
    } else if (a == "--help" || a == "-h") {
      std::cout << "usage: demo [--backend cpu|opencl|auto] [--double] [--width W --height H] "
                   "[OUT_DIR]\n";
      return 0;
    } else {
      out_dir = a;
    }
  }
  try {
    return use_double ? run<double>(backend, width, height, out_dir)
                      : run<float>(backend, width, height, out_dir);
  } catch (const twinray::Error& e) {
    std::cerr << "demo: " << e.what() << "\n";
    return e.kind() == twinray::ErrorKind::InvalidInput         ? 2
           : e.kind() == twinray::ErrorKind::BackendUnavailable ? 3
                                                                : 1;
  }
}
