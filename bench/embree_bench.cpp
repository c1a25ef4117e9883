// The Embree 3 comparison: renders the benchmark scenes (bench_scenes.hpp)
// with the same camera, Blinn-Phong shading, shadow rays and reflections (up to 4 ray
// segments) as twinray, with Embree finding the hits, and prints the same CSV columns
// as twinray_bench. Float only (Embree is single precision).
//
//   embree_bench [--scenes a,b] [--modes single,packet8,stream] [--runs R]
//                [--width W] [--height H] [--threads N] [--obj-dir DIR]
//
// Each frame is rendered as a wavefront per 16x16 tile: all rays of one bounce are
// traced together, then their shadow rays, then the reflected rays. The mode picks how
// a wavefront goes to Embree: one rtcIntersect1/rtcOccluded1 per ray ("single"),
// 8-wide packets (rtcIntersect8/rtcOccluded8, "packet8") or one stream call
// (rtcIntersect1M/rtcOccluded1M, "stream"); the fastest mode is the figure to quote.
// The infinite floor plane is intersected analytically, outside Embree, exactly as
// twinray keeps planes outside its BVH. Secondary rays leave 1e-4 off the surface.
//
// Debian's libembree3 is built with assertions on: measured on this machine it is 3-8%
// slower than a Release build of the same version. build_ms is
// rtcCommitScene (geometry upload included), the BVH build in Embree's default
// (medium) quality with Embree's own threads.
#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench_runner.hpp"

namespace {

using vec3 = glm::vec3;

struct Plane {
  vec3 p, n;
  int material;
};

struct Material {
  vec3 color;
  float ka, kd, ks, shininess, glaze;
};

struct World {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  unsigned sphere_geom = RTC_INVALID_GEOMETRY_ID, tri_geom = RTC_INVALID_GEOMETRY_ID;
  std::vector<int> sphere_material, tri_material;
  std::vector<Plane> planes;
  std::vector<Material> materials;
  std::vector<twinray::PointLight<float>> lights;
  vec3 background{0};
  long long primitives = 0;
};

enum class Mode { Single, Packet8, Stream };

const char* mode_name(Mode m) {
  return m == Mode::Single ? "single" : (m == Mode::Packet8 ? "packet8" : "stream");
}

void build_world(World& w, const twinray_bench::BenchScene<float>& b) {
  const auto& scene = b.scene;
  for (const auto& m : scene.materials)
    w.materials.push_back({m.color, m.ka, m.kd, m.ks, m.shininess, m.glaze});
  w.lights = scene.lights;
  w.background = scene.background;
  std::vector<float> spheres;  // x y z r
  std::vector<float> verts;    // x y z
  std::vector<unsigned> tris;
  for (const auto& o : scene.objects) {
    if (auto* s = std::get_if<twinray::Sphere<float>>(&o)) {
      spheres.insert(spheres.end(), {s->center.x, s->center.y, s->center.z, s->radius});
      w.sphere_material.push_back(s->material);
    } else if (auto* t = std::get_if<twinray::Triangle<float>>(&o)) {
      unsigned base = static_cast<unsigned>(verts.size() / 3);
      for (const auto& v : t->vertices) verts.insert(verts.end(), {v.x, v.y, v.z});
      tris.insert(tris.end(), {base, base + 1, base + 2});
      w.tri_material.push_back(t->material);
    } else if (auto* p = std::get_if<twinray::Plane<float>>(&o)) {
      w.planes.push_back({p->point, glm::normalize(p->normal), p->material});
    } else if (auto* m = std::get_if<twinray::Mesh<float>>(&o)) {
      unsigned base = static_cast<unsigned>(verts.size() / 3);
      for (const auto& v : m->vertices) verts.insert(verts.end(), {v.x, v.y, v.z});
      for (const auto& f : m->triangles) {
        tris.insert(tris.end(),
                    {base + unsigned(f[0]), base + unsigned(f[1]), base + unsigned(f[2])});
        w.tri_material.push_back(m->material);
      }
    }
  }
  w.primitives =
      static_cast<long long>(w.sphere_material.size() + w.tri_material.size() + w.planes.size());
  w.scene = rtcNewScene(w.device);
  if (!spheres.empty()) {
    RTCGeometry g = rtcNewGeometry(w.device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
    float* buf = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), spheres.size() / 4));
    std::copy(spheres.begin(), spheres.end(), buf);
    rtcCommitGeometry(g);
    w.sphere_geom = rtcAttachGeometry(w.scene, g);
    rtcReleaseGeometry(g);
  }
  if (!tris.empty()) {
    RTCGeometry g = rtcNewGeometry(w.device, RTC_GEOMETRY_TYPE_TRIANGLE);
    // Embree reads vertex buffers 16 bytes at a time: one float of padding at the end.
    float* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), verts.size() / 3 + 1));
    std::copy(verts.begin(), verts.end(), vb);
    unsigned* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), tris.size() / 3));
    std::copy(tris.begin(), tris.end(), ib);
    rtcCommitGeometry(g);
    w.tri_geom = rtcAttachGeometry(w.scene, g);
    rtcReleaseGeometry(g);
  }
}

// The analytic floor: closest plane hit in (tnear, tfar), or -1.
int plane_hit(const World& w, vec3 o, vec3 d, float tnear, float tfar, float* t_out) {
  int best = -1;
  for (size_t i = 0; i < w.planes.size(); ++i) {
    const Plane& p = w.planes[i];
    float denom = glm::dot(d, p.n);
    if (denom == 0) continue;
    float t = glm::dot(p.p - o, p.n) / denom;
    if (t > tnear && t < tfar) {
      tfar = t;
      best = static_cast<int>(i);
    }
  }
  *t_out = tfar;
  return best;
}

void init_ray(RTCRay& r, vec3 o, vec3 d, float tnear, float tfar) {
  r.org_x = o.x, r.org_y = o.y, r.org_z = o.z, r.tnear = tnear;
  r.dir_x = d.x, r.dir_y = d.y, r.dir_z = d.z, r.time = 0;
  r.tfar = tfar, r.mask = 0xffffffffu, r.id = 0, r.flags = 0;
}

// Traces a wavefront of closest-hit queries / occlusion queries in the given mode.
void intersect_all(RTCScene scene, Mode mode, std::vector<RTCRayHit>& rh, size_t n) {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  for (size_t i = 0; i < n; ++i) {
    rh[i].hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh[i].hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  }
  if (mode == Mode::Single) {
    for (size_t i = 0; i < n; ++i) rtcIntersect1(scene, &ctx, &rh[i]);
  } else if (mode == Mode::Stream) {
    if (n) rtcIntersect1M(scene, &ctx, rh.data(), static_cast<unsigned>(n), sizeof(RTCRayHit));
  } else {
    for (size_t base = 0; base < n; base += 8) {
      alignas(32) RTCRayHit8 p;
      alignas(32) int valid[8];
      for (int k = 0; k < 8; ++k) {
        size_t i = base + k;
        valid[k] = i < n ? -1 : 0;
        const RTCRay& r = rh[i < n ? i : base].ray;
        p.ray.org_x[k] = r.org_x, p.ray.org_y[k] = r.org_y, p.ray.org_z[k] = r.org_z;
        p.ray.dir_x[k] = r.dir_x, p.ray.dir_y[k] = r.dir_y, p.ray.dir_z[k] = r.dir_z;
        p.ray.tnear[k] = r.tnear, p.ray.tfar[k] = r.tfar, p.ray.time[k] = 0;
        p.ray.mask[k] = 0xffffffffu, p.ray.id[k] = 0, p.ray.flags[k] = 0;
        p.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID, p.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
      }
      rtcIntersect8(valid, scene, &ctx, &p);
      for (int k = 0; k < 8 && base + k < n; ++k) {
        RTCRayHit& out = rh[base + k];
        out.ray.tfar = p.ray.tfar[k];
        out.hit.geomID = p.hit.geomID[k], out.hit.primID = p.hit.primID[k];
        out.hit.Ng_x = p.hit.Ng_x[k], out.hit.Ng_y = p.hit.Ng_y[k], out.hit.Ng_z = p.hit.Ng_z[k];
      }
    }
  }
}

void occluded_all(RTCScene scene, Mode mode, std::vector<RTCRay>& rays, size_t n) {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  if (mode == Mode::Single) {
    for (size_t i = 0; i < n; ++i) rtcOccluded1(scene, &ctx, &rays[i]);
  } else if (mode == Mode::Stream) {
    if (n) rtcOccluded1M(scene, &ctx, rays.data(), static_cast<unsigned>(n), sizeof(RTCRay));
  } else {
    for (size_t base = 0; base < n; base += 8) {
      alignas(32) RTCRay8 p;
      alignas(32) int valid[8];
      for (int k = 0; k < 8; ++k) {
        size_t i = base + k;
        valid[k] = i < n ? -1 : 0;
        const RTCRay& r = rays[i < n ? i : base];
        p.org_x[k] = r.org_x, p.org_y[k] = r.org_y, p.org_z[k] = r.org_z;
        p.dir_x[k] = r.dir_x, p.dir_y[k] = r.dir_y, p.dir_z[k] = r.dir_z;
        p.tnear[k] = r.tnear, p.tfar[k] = r.tfar, p.time[k] = 0;
        p.mask[k] = 0xffffffffu, p.id[k] = 0, p.flags[k] = 0;
      }
      rtcOccluded8(valid, scene, &ctx, &p);
      for (int k = 0; k < 8 && base + k < n; ++k) rays[base + k].tfar = p.tfar[k];
    }
  }
}

struct Renderer {
  const World& w;
  const twinray::Camera<float>& camera;
  int spp, max_depth = 4;
  Mode mode;

  struct Path {
    vec3 color{0};
    float weight = 1;
    int pixel = 0;
  };

  // Renders the image; returns the rays traced.
  long long render(std::vector<float>& rgb, int threads) const {
    auto cf = camera.frame();
    const int width = camera.width, height = camera.height, tile = 16;
    const int tiles_x = (width + tile - 1) / tile, tiles_y = (height + tile - 1) / tile;
    std::atomic<int> next{0};
    std::atomic<long long> total{0};
    int cols = 1;
    while (cols * cols < spp) ++cols;
    int rows = (spp + cols - 1) / cols;
    auto worker = [&] {
      std::vector<RTCRayHit> rh;
      std::vector<RTCRay> shadow;
      std::vector<Path> paths, next_paths;
      std::vector<vec3> shadow_add;
      std::vector<int> shadow_path;
      std::vector<RTCRayHit> next_rh;
      std::vector<Path> done;
      done.reserve(4096);
      long long rays = 0;
      for (int t; (t = next.fetch_add(1)) < tiles_x * tiles_y;) {
        int x0 = (t % tiles_x) * tile, y0 = (t / tiles_x) * tile;
        int x1 = std::min(x0 + tile, width), y1 = std::min(y0 + tile, height);
        rh.clear();
        paths.clear();
        for (int y = y0; y < y1; ++y)
          for (int x = x0; x < x1; ++x)
            for (int s = 0; s < spp; ++s) {
              float sx = ((s % cols) + 0.5f) / cols, sy = ((s / cols) + 0.5f) / rows;
              vec3 pixel = cf.first_pixel + cf.du * (x + sx - 0.5f) + cf.dv * (y + sy - 0.5f);
              vec3 o = camera.projection == twinray::Projection::Orthographic ? pixel : cf.origin;
              vec3 d = camera.projection == twinray::Projection::Orthographic
                           ? cf.ortho_dir
                           : glm::normalize(pixel - cf.origin);
              RTCRayHit r;
              init_ray(r.ray, o, d, 0.0f, INFINITY);
              rh.push_back(r);
              Path p;
              p.pixel = y * width + x;
              paths.push_back(p);
            }
        done.clear();
        for (int depth = 0; depth < max_depth && !rh.empty(); ++depth) {
          size_t n = rh.size();
          rays += static_cast<long long>(n);
          intersect_all(w.scene, mode, rh, n);
          shadow.clear();
          shadow_add.clear();
          shadow_path.clear();
          next_rh.clear();
          next_paths.clear();
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
              vec3 irradiance = light.color * light.intensity / dist2;
              path.color += m.color * irradiance * m.ka * path.weight;
              vec3 l = to_light / std::sqrt(dist2);
              float ndl = glm::dot(n, l);
              if (!(ndl > 0)) continue;
              vec3 h = glm::normalize(l - d);
              float ndh = std::min(1.0f, std::max(0.0f, glm::dot(n, h)));
              vec3 add = (m.color * irradiance * (m.kd * ndl) +
                          irradiance * (m.ks * std::pow(ndh, m.shininess))) *
                         path.weight;
              vec3 ld = light.position - origin;
              float dist = glm::length(ld);
              RTCRay sr;
              init_ray(sr, origin, ld / dist, 0.0f, dist * 0.9998779296875f);
              shadow.push_back(sr);
              shadow_add.push_back(add);
              shadow_path.push_back(static_cast<int>(i));
            }
            if (m.glaze > 0 && depth + 1 < max_depth) {
              vec3 refl = glm::normalize(d - n * (2 * glm::dot(d, n)));
              RTCRayHit nr;
              init_ray(nr.ray, origin, refl, 0.0f, INFINITY);
              next_rh.push_back(nr);
              Path np = path;
              np.color = vec3(0);
              np.weight = path.weight * m.glaze;
              next_paths.push_back(np);
            }
          }
          // Shadow rays: the floor analytically, the rest through Embree.
          rays += static_cast<long long>(shadow.size());
          occluded_all(w.scene, mode, shadow, shadow.size());
          for (size_t k = 0; k < shadow.size(); ++k) {
            const RTCRay& sr = shadow[k];
            if (sr.tfar < 0) continue;  // Embree marks occluded rays with tfar = -inf
            float tp;
            if (plane_hit(w, vec3(sr.org_x, sr.org_y, sr.org_z), vec3(sr.dir_x, sr.dir_y, sr.dir_z),
                          sr.tnear, sr.tfar, &tp) >= 0)
              continue;
            paths[shadow_path[k]].color += shadow_add[k];
          }
          for (size_t i = 0; i < n; ++i) done.push_back(paths[i]);
          rh.swap(next_rh);
          paths.swap(next_paths);
        }
        for (const Path& p : done) {
          float* c = &rgb[static_cast<size_t>(p.pixel) * 3];
          c[0] += p.color.x / spp, c[1] += p.color.y / spp, c[2] += p.color.z / spp;
        }
      }
      total += rays;
    };
    std::fill(rgb.begin(), rgb.end(), 0.0f);
    std::vector<std::thread> pool;
    for (int i = 1; i < threads; ++i) pool.emplace_back(worker);
    worker();
    for (auto& t : pool) t.join();
    return total.load();
  }
};

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> scenes = twinray_bench::default_scenes();
  std::vector<std::string> modes = {"single", "packet8", "stream"};
  int width = 1920, height = 1080, runs = 5, threads = 0;
  std::string obj_dir = ".";
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (i + 1 >= argc) {
      std::cerr << "embree_bench: " << a << " needs a value\n";
      return 2;
    }
    std::string v = argv[++i];
    if (a == "--scenes")
      scenes = twinray_bench::split(v);
    else if (a == "--modes")
      modes = twinray_bench::split(v);
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
    else {
      std::cerr << "embree_bench: unknown option " << a << "\n";
      return 2;
    }
  }
  if (threads <= 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::cerr << "machine: " << twinray_bench::machine_description() << "\n"
            << "Embree " << RTC_VERSION_STRING
            << " (Debian build, assertions on: 3-8% slower than a Release build)\n";
  std::cout << twinray_bench::csv_header() << std::endl;
  for (const std::string& name : scenes) {
    auto b = twinray_bench::make_scene<float>(name, width, height, obj_dir);
    twinray_bench::reset_peak();
    World w;
    w.device = rtcNewDevice(nullptr);
    auto t0 = std::chrono::steady_clock::now();
    build_world(w, b);
    rtcCommitScene(w.scene);
    double build_ms = twinray_bench::ms_since(t0);
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
      row.backend = std::string("embree-") + mode_name(mode);
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
    }
    rtcReleaseScene(w.scene);
    rtcReleaseDevice(w.device);
  }
  return 0;
}
