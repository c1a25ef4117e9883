// A scene built in code: a glazed sphere on a checkerboard of triangles, a mesh
// (a pyramid), two coloured lights, anti-aliased with 4 stratified samples per pixel,
// rendered in double precision on the CPU and written to custom_scene.png.
#include <iostream>

#include <twinray/io/png.hpp>
#include <twinray/twinray.hpp>

int main() {
  using vec3 = glm::dvec3;
  twinray::Scene<double> scene;
  auto material = [&](vec3 color, double glaze) {
    twinray::Material<double> m;
    m.color = color;
    m.glaze = glaze;
    return scene.add_material(m);
  };
  const int light_tile = material({0.85, 0.85, 0.8}, 0.0);
  const int dark_tile = material({0.15, 0.15, 0.2}, 0.0);
  const int mirror = material({0.9, 0.3, 0.2}, 0.5);
  const int gold = material({0.9, 0.7, 0.2}, 0.0);

  // The floor: 8 x 8 tiles of two triangles each, y = 0.
  for (int i = 0; i < 8; ++i)
    for (int j = 0; j < 8; ++j) {
      vec3 a(i - 4, 0, j - 6), b(i - 3, 0, j - 6), c(i - 3, 0, j - 5), d(i - 4, 0, j - 5);
      int m = (i + j) % 2 ? dark_tile : light_tile;
      scene.add(twinray::Triangle<double>{{a, c, b}, m});
      scene.add(twinray::Triangle<double>{{a, d, c}, m});
    }
  scene.add(twinray::Sphere<double>{{-0.8, 1, -3}, 1.0, mirror});
  twinray::Mesh<double> pyramid;
  pyramid.vertices = {
      {0.8, 0, -1.5}, {2.2, 0, -1.5}, {2.2, 0, -2.9}, {0.8, 0, -2.9}, {1.5, 1.6, -2.2}};
  pyramid.triangles = {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
  pyramid.material = gold;
  scene.add(pyramid);
  scene.add_light({{-3, 5, 1}, 30.0, {1.0, 0.9, 0.8}});
  scene.add_light({{4, 3, 0}, 12.0, {0.5, 0.6, 1.0}});
  scene.background = {0.05, 0.07, 0.12};

  twinray::Camera<double> camera;
  camera.position = {0, 2.5, 4};
  camera.look_at = {0, 0.6, -2.5};
  camera.up = {0, 1, 0};
  camera.width = 640;
  camera.height = 400;

  twinray::RenderOptions options;
  options.backend = twinray::Backend::Cpu;
  options.spp = 4;
  options.sampler = twinray::Sampler::Stratified;
  twinray::RenderInfo info;
  twinray::Image<double> image = twinray::render(scene, camera, options, &info);
  twinray::io::write_png("custom_scene.png", image);
  std::cout << "custom_scene.png: " << camera.width << "x" << camera.height << ", " << info.device
            << ", " << info.render_ms << " ms\n";
}
