// A spinning 64-beam LiDAR in a street of meshes: one revolution of 2048 steps, each
// step 64 rays from -25 to +15 degrees of elevation, answered by the backend's
// intersect() in one batch. Writes the returns as a PLY point cloud (x y z and the
// object id of each point); the same bytes on every backend.
//   lidar [--backend cpu|opencl] [--output lidar.ply]
#include <cstdio>
#include <vector>

#include "query_scene.hpp"

int main(int argc, char** argv) {
  twinray::Backend kind = twinray::Backend::Cpu;
  std::string output = "lidar.ply";
  if (!example::parse_args(argc, argv, &kind, &output)) return 2;
  try {
    auto backend = example::street_backend(kind);

    const int beams = 64, steps = 2048;
    const glm::vec3 sensor(0.5f, 1.8f, 0.5f);
    const float range = 60.0f;  // metres; farther returns are lost
    std::vector<twinray::Ray<float>> rays;
    rays.reserve(static_cast<size_t>(beams) * steps);
    for (int s = 0; s < steps; ++s) {
      const double azimuth = 6.283185307179586 * s / steps;
      for (int b = 0; b < beams; ++b) {
        const double elevation = (-25.0 + 40.0 * b / (beams - 1)) * 3.141592653589793 / 180.0;
        const glm::vec3 d(float(std::cos(elevation) * std::cos(azimuth)),
                          float(std::sin(elevation)),
                          float(std::cos(elevation) * std::sin(azimuth)));
        rays.push_back(twinray::make_ray(sensor, d, 0.0f, range));
      }
    }
    std::vector<twinray::Hit<float>> hits(rays.size());
    backend->intersect(rays.data(), rays.size(), hits.data());

    size_t points = 0;
    for (const auto& h : hits) points += h.object >= 0;
    std::FILE* f = std::fopen(output.c_str(), "wb");
    if (!f) {
      std::fprintf(stderr, "lidar: cannot write %s\n", output.c_str());
      return 1;
    }
    std::fprintf(f,
                 "ply\nformat ascii 1.0\nelement vertex %zu\nproperty float x\nproperty float "
                 "y\nproperty float z\nproperty int object\nend_header\n",
                 points);
    for (size_t i = 0; i < hits.size(); ++i) {
      if (hits[i].object < 0) continue;
      const auto& r = rays[i];
      const float t = hits[i].t;
      std::fprintf(f, "%.9g %.9g %.9g %d\n", double(r.ox + r.dx * t), double(r.oy + r.dy * t),
                   double(r.oz + r.dz * t), hits[i].object);
    }
    const bool ok = std::fclose(f) == 0;
    std::printf("lidar: %zu of %zu rays returned, %s (%s)\n", points, rays.size(), output.c_str(),
                backend->device_name().c_str());
    return ok ? 0 : 1;
  } catch (const twinray::Error& e) {
    std::fprintf(stderr, "lidar: %s\n", e.what());
    return 1;
  }
}
