// The Embree 3 comparison: renders the benchmark scenes (bench_scenes.hpp)
// with the same camera, Blinn-Phong shading, shadow rays and reflections (up to 4 ray
// segments) as twinray, with Embree finding the hits, and prints the same CSV columns
// as twinray_bench. Float only (Embree is single precision).
//
//   embree_bench [--scenes a,b] [--modes single,packet8,stream] [--spheres user,point]
//                [--runs R] [--width W] [--height H] [--threads N] [--obj-dir DIR]
//                [--image PREFIX] [--device-config CONFIG]
//
// Each frame is rendered as a wavefront per 16x16 tile: all rays of one bounce are
// traced together, then their shadow rays, then the reflected rays. The mode picks how
// a wavefront goes to Embree: one rtcIntersect1/rtcOccluded1 per ray ("single"),
// 8-wide packets (rtcIntersect8/rtcOccluded8, "packet8") or one stream call
// (rtcIntersect1M/rtcOccluded1M, "stream"); the fastest mode is the figure to quote.
// The infinite floor plane is intersected analytically, outside Embree, exactly as
// twinray keeps planes outside its BVH. Secondary rays leave 1e-4 off the surface.
//
// Spheres are Embree user geometry with an analytic intersector ("user", the default:
// Embree's fastest way to trace them) or RTC_GEOMETRY_TYPE_SPHERE_POINT, Embree's
// point-cloud primitive ("point"), which took 1.6-1.9x the frame time on demo and
// spheres_1e3 on this machine (2 threads, every mode). The backend column
// names both choices, e.g. embree-user-packet8. The two give the same image and ray
// count up to rounding at sphere silhouettes (spheres_1e5: 26 rays in 4.6 M).
//
// Debian's libembree3 is built with assertions on: measured on this machine it is 3-8%
// slower than a Release build of the same version. build_ms is
// rtcCommitScene (geometry upload included), the BVH build in Embree's default
// (medium) quality with Embree's own threads.
//
// --device-config (or the environment variable TWINRAY_EMBREE_DEVICE_CONFIG, which
// reaches the program under `twinray bench --against`) is rtcNewDevice's configuration
// string: "isa=avx2" keeps Embree to its AVX2 kernels on an AVX-512 machine, to compare
// it with a twinray built for AVX2 (docs/performance.md, "AVX2 code on an AVX-512
// machine").
#include <embree3/rtcore.h>
#include <pmmintrin.h>
#include <xmmintrin.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <type_traits>
#include <thread>
#include <vector>

#include "bench_runner.hpp"
#include "embree_world.hpp"

namespace {

using vec3 = glm::vec3;
using namespace embree_world;

struct Renderer {
  const World& w;
  const twinray::Camera<float>& camera;
  int spp, max_depth = 4;
  Mode mode;

  // One camera sample's path: the light gathered at its current bounce and the
  // product of the glazes on the way there.
  struct Path {
    vec3 color{0};
    float weight = 1;
    int pixel = 0;
  };
  // A shadow ray's contribution, added to its path if the light is visible.
  struct Pending {
    vec3 add;
    int path;
  };

  // Renders the image; returns the rays traced.
  long long render(std::vector<float>& rgb, int threads) const {
    auto cf = camera.frame();
    const int width = camera.width, height = camera.height, tile = 16;
    const int tiles_x = (width + tile - 1) / tile, tiles_y = (height + tile - 1) / tile;
    const float inv_spp = 1.0f / static_cast<float>(spp);
    std::atomic<int> next{0};
    std::atomic<long long> total{0};
    // Sample s of a pixel sits at the centre of cell (s % cols, s / cols) of a
    // cols x rows grid; the offsets are the same for every pixel, taken once here.
    int cols = 1;
    while (cols * cols < spp) ++cols;
    int rows = (spp + cols - 1) / cols;
    const bool ortho = camera.projection == twinray::Projection::Orthographic;
    std::vector<float> sample_x(spp), sample_y(spp);
    for (int s = 0; s < spp; ++s) {
      sample_x[s] = ((s % cols) + 0.5f) / cols;
      sample_y[s] = ((s / cols) + 0.5f) / rows;
    }
    auto worker = [&] {
      // Embree's documentation strongly recommends flush-to-zero and
      // denormals-are-zero (MXCSR) on each thread that calls rtcIntersect/rtcOccluded:
      // denormal operands take slow paths. Measured here: 6-12% of the frame on demo
      // and mesh_1e4. Values below 1e-38 become 0, nothing an 8-bit image shows. The
      // caller's mode is restored.
      const unsigned mxcsr = _mm_getcsr();
      _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
      _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
      // Per-thread wavefront buffers, reused from tile to tile.
      std::vector<RTCRayHit> rh, next_rh;
      std::vector<RTCRay> shadow;
      std::vector<Path> paths, next_paths;
      std::vector<Pending> pending;
      long long rays = 0;
      for (int t; (t = next.fetch_add(1)) < tiles_x * tiles_y;) {
        int x0 = (t % tiles_x) * tile, y0 = (t / tiles_x) * tile;
        int x1 = std::min(x0 + tile, width), y1 = std::min(y0 + tile, height);
        // Each tile's pixels belong to one thread: clear them here, not in a serial pass.
        for (int y = y0; y < y1; ++y)
          std::fill(rgb.begin() + (static_cast<size_t>(y) * width + x0) * 3,
                    rgb.begin() + (static_cast<size_t>(y) * width + x1) * 3, 0.0f);
        // The wavefront buffers are sized first and written by index: appending
        // with emplace_back took 1.7x the cycles for the camera rays (measured).
        rh.resize(static_cast<size_t>(x1 - x0) * (y1 - y0) * spp);
        paths.resize(rh.size());
        size_t j = 0;
        for (int y = y0; y < y1; ++y)
          for (int x = x0; x < x1; ++x)
            for (int s = 0; s < spp; ++s, ++j) {
              vec3 pixel = cf.first_pixel + cf.du * (x + sample_x[s] - 0.5f) +
                           cf.dv * (y + sample_y[s] - 0.5f);
              init_query(rh[j], ortho ? pixel : cf.origin,
                         ortho ? cf.ortho_dir : glm::normalize(pixel - cf.origin));
              paths[j] = Path();
              paths[j].pixel = y * width + x;
            }
        for (int depth = 0; depth < max_depth && !rh.empty(); ++depth) {
          const size_t n = rh.size();
          rays += static_cast<long long>(n);
          intersect_all(w.scene, mode, true, rh);
          // Room for the most rays this bounce can spawn, trimmed after the loop.
          shadow.resize(n * w.lights.size());
          pending.resize(shadow.size());
          next_rh.resize(n);
          next_paths.resize(n);
          size_t n_shadow = 0, n_next = 0;
          for (size_t i = 0; i < n; ++i) {
            const RTCRay& r = rh[i].ray;
            vec3 o(r.org_x, r.org_y, r.org_z), d(r.dir_x, r.dir_y, r.dir_z);
            float tplane;
            int pl = plane_hit(w, o, d, r.tnear, r.tfar, &tplane);
            Path& path = paths[i];
            vec3 n;
            int material;
            float t;
            if (pl >= 0) {
              n = w.planes[pl].n, material = w.planes[pl].material, t = tplane;
            } else if (rh[i].hit.instID[0] != RTC_INVALID_GEOMETRY_ID) {
              // An instance: the normal comes in the asset's space.
              const int k = w.instance_of_geom[rh[i].hit.instID[0]];
              n = glm::normalize(w.instance_normal_map[static_cast<size_t>(k)] *
                                 vec3(rh[i].hit.Ng_x, rh[i].hit.Ng_y, rh[i].hit.Ng_z));
              material =
                  w.asset_tri_material[static_cast<size_t>(w.instance_asset[k])][rh[i].hit.primID];
              t = r.tfar;
            } else if (rh[i].hit.geomID != RTC_INVALID_GEOMETRY_ID) {
              n = glm::normalize(vec3(rh[i].hit.Ng_x, rh[i].hit.Ng_y, rh[i].hit.Ng_z));
              material = rh[i].hit.geomID == w.sphere_geom ? w.sphere_material[rh[i].hit.primID]
                                                           : w.tri_material[rh[i].hit.primID];
              t = r.tfar;
            } else {
              path.color += w.background * path.weight;
              continue;
            }
            vec3 p = o + d * t;
            if (glm::dot(n, d) > 0) n = -n;
            const Material& m = w.materials[material];
            vec3 origin = p + n * 1e-4f;
            for (const auto& light : w.lights) {
              vec3 to_light = light.position - p;
              float dist2 = glm::dot(to_light, to_light);
              if (!(dist2 > 0)) continue;
              // Reciprocals as twinray's shading takes them (device/shading.h).
              vec3 irradiance = light.rgb * (1.0f / dist2);
              path.color += m.color * irradiance * m.ka * path.weight;
              vec3 l = to_light * (1.0f / std::sqrt(dist2));
              float ndl = glm::dot(n, l);
              if (!(ndl > 0)) continue;
              vec3 h = glm::normalize(l - d);
              float ndh = std::min(1.0f, std::max(0.0f, glm::dot(n, h)));
              vec3 add = (m.color * irradiance * (m.kd * ndl) +
                          irradiance * (m.ks * std::pow(ndh, m.shininess))) *
                         path.weight;
              vec3 ld = light.position - origin;
              float dist = glm::length(ld);
              init_ray(shadow[n_shadow], origin, ld * (1.0f / dist), 0.0f, dist * 0.9998779296875f);
              pending[n_shadow++] = {add, static_cast<int>(i)};
            }
            if (m.glaze > 0 && depth + 1 < max_depth) {
              init_query(next_rh[n_next], origin, glm::normalize(d - n * (2 * glm::dot(d, n))));
              Path& np = next_paths[n_next++];
              np.color = vec3(0);
              np.weight = path.weight * m.glaze;
              np.pixel = path.pixel;
            }
          }
          shadow.resize(n_shadow);
          next_rh.resize(n_next);
          next_paths.resize(n_next);
          // Shadow rays: the floor analytically, the rest through Embree.
          rays += static_cast<long long>(shadow.size());
          occluded_all(w.scene, mode, depth == 0, shadow);
          for (size_t k = 0; k < shadow.size(); ++k) {
            const RTCRay& sr = shadow[k];
            if (sr.tfar < 0) continue;  // Embree marks occluded rays with tfar = -inf
            float tp;
            if (plane_hit(w, vec3(sr.org_x, sr.org_y, sr.org_z), vec3(sr.dir_x, sr.dir_y, sr.dir_z),
                          sr.tnear, sr.tfar, &tp) >= 0)
              continue;
            paths[pending[k].path].color += pending[k].add;
          }
          // This bounce's light goes straight into the tile's pixels.
          for (const Path& p : paths) {
            float* c = &rgb[static_cast<size_t>(p.pixel) * 3];
            c[0] += p.color.x * inv_spp, c[1] += p.color.y * inv_spp, c[2] += p.color.z * inv_spp;
          }
          rh.swap(next_rh);
          paths.swap(next_paths);
        }
      }
      total += rays;
      _mm_setcsr(mxcsr);
    };
    std::vector<std::thread> pool;
    for (int i = 1; i < threads; ++i) pool.emplace_back(worker);
    worker();
    for (auto& t : pool) t.join();
    return total.load();
  }
};

// The frame as a binary PPM, each linear value clamped to [0, 1], scaled by 255 and
// rounded, as twinray writes its PNGs (no gamma curve), for a look or a byte compare.
bool write_ppm(const std::string& path, const std::vector<float>& rgb, int width, int height) {
  std::ofstream f(path, std::ios::binary);
  f << "P6\n" << width << " " << height << "\n255\n";
  std::vector<unsigned char> bytes(rgb.size());
  for (size_t i = 0; i < rgb.size(); ++i) {
    float v = rgb[i];
    bytes[i] = !(v > 0) ? 0 : v >= 1 ? 255 : static_cast<unsigned char>(std::lround(v * 255));
  }
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  return static_cast<bool>(f);
}

const char* usage =
    "usage: embree_bench [options]\n"
    "  --scenes a,b        benchmark scenes (default: twinray bench's set)\n"
    "  --modes a,b         single, packet8, stream (default: all three)\n"
    "  --spheres a,b       user (analytic user geometry, default), point (SPHERE_POINT)\n"
    "  --runs R            timed runs after one warm-up (default 5)\n"
    "  --width W           image width (default 1920)\n"
    "  --height H          image height (default 1080)\n"
    "  --threads N         render threads (default: all hardware threads)\n"
    "  --obj-dir DIR       where obj_* scenes write their OBJ file (default .)\n"
    "  --image PREFIX      write each row's frame to PREFIX<scene>-<backend>.ppm\n"
    "  --device-config S   rtcNewDevice's configuration, e.g. isa=avx2 (default:\n"
    "                      $TWINRAY_EMBREE_DEVICE_CONFIG, else Embree's defaults)\n";

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> scenes = twinray_bench::default_scenes();
  std::vector<std::string> modes = {"single", "packet8", "stream"};
  std::vector<std::string> sphere_kinds = {"user"};
  int width = 1920, height = 1080, runs = 5, threads = 0;
  std::string obj_dir = ".", image_prefix;
  const char* config_env = std::getenv("TWINRAY_EMBREE_DEVICE_CONFIG");
  std::string device_config = config_env ? config_env : "";
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << usage;
      return 0;
    }
    if (i + 1 >= argc) {
      std::cerr << "embree_bench: " << a << " needs a value\n";
      return 2;
    }
    std::string v = argv[++i];
    if (a == "--scenes")
      scenes = twinray_bench::split(v);
    else if (a == "--modes")
      modes = twinray_bench::split(v);
    else if (a == "--spheres")
      sphere_kinds = twinray_bench::split(v);
    else if (a == "--runs")
      runs = std::max(1, std::atoi(v.c_str()));
    else if (a == "--width")
      width = std::atoi(v.c_str());
    else if (a == "--height")
      height = std::atoi(v.c_str());
    else if (a == "--threads")
      threads = std::atoi(v.c_str());
    else if (a == "--obj-dir")
      obj_dir = v;
    else if (a == "--image")
      image_prefix = v;
    else if (a == "--device-config")
      device_config = v;
    else {
      std::cerr << "embree_bench: unknown option " << a << "\n" << usage;
      return 2;
    }
  }
  for (const std::string& m : modes)
    if (m != "single" && m != "packet8" && m != "stream") {
      std::cerr << "embree_bench: unknown mode " << m << " (single, packet8, stream)\n";
      return 2;
    }
  for (const std::string& k : sphere_kinds)
    if (k != "user" && k != "point") {
      std::cerr << "embree_bench: unknown --spheres " << k << " (user, point)\n";
      return 2;
    }
  if (threads <= 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::cerr << "machine: " << twinray_bench::machine_description() << "\n"
            << "Embree " << RTC_VERSION_STRING
            << " (Debian build, assertions on: 3-8% slower than a Release build)\n";
  if (!device_config.empty()) std::cerr << "Embree device configuration: " << device_config << "\n";
  std::cout << twinray_bench::csv_header() << std::endl;
  try {
    for (const std::string& name : scenes) {
      auto b = twinray_bench::make_scene<float>(name, width, height, obj_dir);
      for (const std::string& kind_str : sphere_kinds) {
        const SphereKind kind = kind_str == "user" ? SphereKind::User : SphereKind::Point;
        twinray_bench::reset_peak();
        World w;
        w.device = rtcNewDevice(device_config.empty() ? nullptr : device_config.c_str());
        if (!w.device) {
          std::cerr << "embree_bench: Embree refused the device configuration '" << device_config
                    << "'\n";
          return 2;
        }
        auto t0 = std::chrono::steady_clock::now();
        build_world(w, b, kind);
        auto t1 = std::chrono::steady_clock::now();
        rtcCommitScene(w.scene);
        double build_ms = twinray_bench::ms_since(t0);
        if (!w.instance_asset.empty())
          std::cerr << "embree_bench: " << name << ": " << w.asset_scenes.size()
                    << " asset scene(s) committed in " << w.assets_ms << " ms; the top level of "
                    << w.instance_asset.size() << " instances committed in "
                    << twinray_bench::ms_since(t1) << " ms\n";
        std::vector<float> rgb(static_cast<size_t>(width) * height * 3);
        for (const std::string& mode_str : modes) {
          Mode mode = mode_str == "single" ? Mode::Single
                                           : (mode_str == "packet8" ? Mode::Packet8 : Mode::Stream);
          Renderer r{w, b.camera, b.spp, 4, mode};
          long long rays = r.render(rgb, threads);  // warm-up
          std::vector<double> times;
          for (int k = 0; k < runs; ++k) {
            auto r0 = std::chrono::steady_clock::now();
            rays = r.render(rgb, threads);
            times.push_back(twinray_bench::ms_since(r0));
          }
          std::sort(times.begin(), times.end());
          twinray_bench::Row row;
          row.scene = name;
          row.backend = std::string("embree-") + sphere_kind_name(kind) + "-" + mode_name(mode);
          row.precision = "float";
          row.width = width, row.height = height, row.spp = b.spp;
          row.primitives = w.primitives;
          row.build_ms = build_ms;
          row.min_ms = times.front(), row.median_ms = times[times.size() / 2],
          row.max_ms = times.back();
          row.rays = rays;
          row.mrays_per_s = rays / (row.median_ms * 1e3);
          row.peak_mib = twinray_bench::peak_mib();
          std::cout << twinray_bench::csv_line(row) << std::endl;
          if (!image_prefix.empty()) {
            std::string path = image_prefix + name + "-" + row.backend + ".ppm";
            if (!write_ppm(path, rgb, width, height))
              std::cerr << "embree_bench: cannot write " << path << "\n";
          }
        }
        rtcReleaseScene(w.scene);
        for (RTCScene a : w.asset_scenes) rtcReleaseScene(a);
        rtcReleaseDevice(w.device);
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "embree_bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
