// A frame loop that reuses one backend: the scene is packed and uploaded once, then
// 60 frames of a camera circling it render into one image with only the camera
// changing. Writes every 15th frame to frame_loop_<n>.png and prints the time per frame.
//
//   frame_loop [--backend cpu|opencl|auto]
#include <chrono>
#include <cmath>
#include <cstring>
#include <iostream>
#include <memory>
#include <string>

#include <twinray/io/png.hpp>
#include <twinray/scene/demo_scene.hpp>
#include <twinray/twinray.hpp>

int main(int argc, char** argv) {
  twinray::RenderOptions options;  // Backend::Auto: OpenCL when there is a device
  if (argc == 3 && std::strcmp(argv[1], "--backend") == 0)
    options.backend = std::strcmp(argv[2], "cpu") == 0      ? twinray::Backend::Cpu
                      : std::strcmp(argv[2], "opencl") == 0 ? twinray::Backend::OpenCL
                                                            : twinray::Backend::Auto;
  auto demo = twinray::demo::make_demo_scene<float>(320, 320);
  twinray::Scene<float>& scene = demo.scene;
  twinray::Camera<float> camera = demo.camera;

  try {
    // Made once per device; packs nothing until it gets a scene.
    std::unique_ptr<twinray::RenderBackend<float>> backend = twinray::make_backend<float>(options);
    // Packed (with its BVH) and handed over once; the backend uploads it at the first
    // frame and keeps it.
    backend->set_scene(twinray::share(twinray::pack_scene(scene, backend->pack_options())));

    const int frames = 60;
    double total_ms = 0;
    twinray::Image<float> image;  // one framebuffer for every frame
    for (int i = 0; i < frames; ++i) {
      const float angle = 6.2831853f * float(i) / float(frames);
      camera.position = {5.f * std::cos(angle), -1.5f, -1.f + 5.f * std::sin(angle)};
      twinray::RenderInfo info;
      auto t0 = std::chrono::steady_clock::now();
      backend->render_into({camera, scene.lights, options}, image, &info);
      double ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      total_ms += ms - info.build_ms;  // OpenCL program builds (the first frames') left out
      if (i % 15 == 0) {
        std::string path = "frame_loop_" + std::to_string(i) + ".png";
        twinray::io::write_png(path, image);
        std::cout << path << ": " << ms << " ms, scene "
                  << (info.scene_uploaded ? "uploaded" : "already on the device") << "\n";
      }
    }
    std::cout << frames << " frames on " << backend->device_name() << ": " << total_ms / frames
              << " ms per frame, program builds left out\n";
  } catch (const twinray::Error& e) {
    std::cerr << "frame_loop: " << e.what() << "\n";
    return e.kind() == twinray::ErrorKind::InvalidInput ? 2 : 1;
  }
}
