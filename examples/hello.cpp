// The README's API example: a sphere on a floor, rendered with OpenCL when a device
// exists (else the CPU), written to hello.png.
#include <twinray/io/png.hpp>
#include <twinray/twinray.hpp>

int main() {
  twinray::Scene<float> scene;
  twinray::Material<float> red;
  red.color = {0.8f, 0.15f, 0.1f};
  int m = scene.add_material(red);
  scene.add(twinray::Sphere<float>{{0, 0, -3}, 1.0f, m});
  scene.add(twinray::Plane<float>{{0, -1, 0}, {0, 1, 0}, m});
  scene.add_light({{-2, 3, 0}, 20.0f, {1, 1, 1}});
  twinray::Camera<float> camera;
  camera.position = {0, 0.5f, 2}, camera.look_at = {0, 0, -3}, camera.up = {0, 1, 0};
  twinray::RenderOptions options;  // Backend::Auto; Backend::Cpu or Backend::OpenCL to choose
  twinray::io::write_png("hello.png", twinray::render(scene, camera, options));
}
