// Ambient occlusion of the street of meshes (query_scene.hpp) from the backend's ray
// queries: a pinhole camera's rays through intersect(), then 16 cosine-distributed
// rays over each hit's hemisphere through occluded(), each reaching a tenth of the
// scene's size; a pixel is the fraction of them that escape. Written as a PNG; the same
// bytes on every backend.
//   ambient_occlusion [--backend cpu|opencl] [--output ao.png]
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <vector>

#include <twinray/io/png.hpp>

#include "query_scene.hpp"

namespace {

// A uniform number in [0, 1) from a counter: the low bits of a 32-bit integer hash
// (Wellons' lowbias32), so every pixel's rays are fixed whatever runs them.
float hash01(uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return float(x >> 8) * (1.0f / 16777216.0f);
}

}  // namespace

int main(int argc, char** argv) {
  twinray::Backend kind = twinray::Backend::Cpu;
  std::string output = "ao.png";
  if (!example::parse_args(argc, argv, &kind, &output)) return 2;
  try {
    auto backend = example::street_backend(kind);

    const int width = 480, height = 270, samples = 16;
    const float reach = 6.0f;  // a tenth of the 60 m street
    const glm::vec3 eye(9.0f, 7.0f, 14.0f), target(0.0f, 1.0f, 0.0f);
    const glm::vec3 w = glm::normalize(eye - target);
    const glm::vec3 u = glm::normalize(glm::cross(glm::vec3(0, 1, 0), w)), v = glm::cross(w, u);
    const float half = 0.45f;  // tan of half the vertical field of view
    std::vector<twinray::Ray<float>> primary;
    primary.reserve(static_cast<size_t>(width) * height);
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) {
        const float sx = (2.0f * (x + 0.5f) / width - 1.0f) * half * width / height;
        const float sy = (1.0f - 2.0f * (y + 0.5f) / height) * half;
        primary.push_back(twinray::make_ray(eye, u * sx + v * sy - w));
      }
    std::vector<twinray::Hit<float>> hits(primary.size());
    backend->intersect(primary.data(), primary.size(), hits.data());

    // 16 rays per hit, over the hemisphere of the normal that faces the camera, with
    // the cosine-weighted density (Malley's method: a uniform point on the disk, lifted).
    std::vector<twinray::Ray<float>> ao;
    ao.reserve(primary.size() * samples);
    for (size_t i = 0; i < primary.size(); ++i) {
      const auto& h = hits[i];
      if (h.object < 0) continue;
      const auto& r = primary[i];
      const glm::vec3 n(h.nx, h.ny, h.nz);
      const glm::vec3 p = glm::vec3(r.ox, r.oy, r.oz) + glm::vec3(r.dx, r.dy, r.dz) * h.t;
      const glm::vec3 a = std::fabs(n.x) > 0.5f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
      const glm::vec3 t = glm::normalize(glm::cross(a, n)), b = glm::cross(n, t);
      for (int k = 0; k < samples; ++k) {
        const uint32_t id = static_cast<uint32_t>(i * samples + k);
        const float r1 = hash01(2 * id), r2 = hash01(2 * id + 1);
        const float radius = std::sqrt(r1), phi = 6.2831853f * r2;
        const float dx = radius * std::cos(phi), dy = radius * std::sin(phi);
        const float dz = std::sqrt(std::fmax(0.0f, 1.0f - r1));
        // Start off the surface by a margin that scales with the point's size.
        const float margin = 1e-4f * (1.0f + std::fabs(p.x) + std::fabs(p.y) + std::fabs(p.z));
        ao.push_back(twinray::make_ray(p + n * margin, t * dx + b * dy + n * dz, 0.0f, reach));
      }
    }
    std::vector<uint8_t> blocked(ao.size());
    backend->occluded(ao.data(), ao.size(), blocked.data());

    twinray::Image<float> image;
    image.resize(width, height);
    size_t next = 0;
    for (size_t i = 0; i < primary.size(); ++i) {
      float value = 1.0f;  // the sky
      if (hits[i].object >= 0) {
        int open = 0;
        for (int k = 0; k < samples; ++k) open += !blocked[next++];
        value = float(open) / samples;
      }
      for (int c = 0; c < 3; ++c) image.rgb[i * 3 + c] = value;
    }
    twinray::io::write_png(output, image);
    std::printf("ambient_occlusion: %zu primary and %zu occlusion rays, %s (%s)\n", primary.size(),
                ao.size(), output.c_str(), backend->device_name().c_str());
    return 0;
  } catch (const twinray::Error& e) {
    std::fprintf(stderr, "ambient_occlusion: %s\n", e.what());
    return 1;
  }
}
