// Ray queries on users' rays (docs/ray-queries.md): twinray's CPU code
// (cpu::query_intersect / cpu::query_occluded, what CpuBackend::intersect and occluded
// run) against Embree 3 on the same rays, made before any timing:
//   coherent  a pinhole camera's rays, one per pixel of a W x H image, one intersect batch
//   ao        16 cosine-distributed rays over the hemisphere of each camera hit of an
//             AO image (--ao-width x --ao-height), reaching a tenth of the scene's
//             diameter, through occluded
//   diffuse   one cosine-distributed ray per camera hit of the AO image, intersect
// on spheres_1e6 and mesh_1e6 (apps/twinray/bench/bench_scenes.hpp), whose floor plane
// becomes a quad of two triangles 100 scene diameters wide, so that both engines hold
// the same primitives in their trees (Embree has no plane). Embree takes each batch in chunks on
// the same threads (twinray::parallel_for) through every call it has: rtcIntersect1 / rtcOccluded1
// per ray, 8- and 16-wide packets, and rtcIntersect1M / rtcOccluded1M streams with the coherent and
// the incoherent context flag; the fastest is quoted. Rounds interleave the two engines; the
// figures are medians over rounds.
//
//   ray_query_bench [--scenes spheres_1e6,mesh_1e6] [--rounds R] [--width W]
//                   [--height H] [--ao-width W] [--ao-height H] [--threads N]
#include <pmmintrin.h>
#include <xmmintrin.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include <twinray/backend/cpu.hpp>

#include "bench_stats.hpp"
#include "embree_world.hpp"

namespace {

using vec3 = glm::vec3;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

// A cosine-distributed direction over the hemisphere of unit n (Malley's method).
vec3 cosine_direction(vec3 n, uint32_t id) {
  const float r1 = twinray_bench::hash01(2 * id), r2 = twinray_bench::hash01(2 * id + 1);
  const float radius = std::sqrt(r1), phi = 6.2831853f * r2;
  const vec3 a = std::fabs(n.x) > 0.5f ? vec3(0, 1, 0) : vec3(1, 0, 0);
  const vec3 t = glm::normalize(glm::cross(a, n)), b = glm::cross(n, t);
  return t * (radius * std::cos(phi)) + b * (radius * std::sin(phi)) +
         n * std::sqrt(std::fmax(0.0f, 1.0f - r1));
}

// The camera's ray through the centre of pixel (x, y) (perspective).
twinray::Ray<float> camera_ray(const twinray::CameraFrame<float>& f, int x, int y) {
  const vec3 p = f.first_pixel + f.du * float(x) + f.dv * float(y);
  return twinray::make_ray(f.origin, p - f.origin);
}

RTCRay to_embree(const twinray::Ray<float>& r) {
  RTCRay e;
  embree_world::init_ray(e, vec3(r.ox, r.oy, r.oz), vec3(r.dx, r.dy, r.dz), r.tmin, r.tmax);
  return e;
}

struct Workload {
  std::string name;
  bool closest;   // intersect, else occluded
  bool coherent;  // the rays run together (for Embree's context flag)
  std::vector<twinray::Ray<float>> rays;
};

// Embree's variants: the call, and the context flag for streams.
struct Variant {
  embree_world::Mode mode;
  bool coherent;
  std::string name() const {
    std::string n = embree_world::mode_name(mode);
    if (mode == embree_world::Mode::Stream) n += coherent ? "-coherent" : "-incoherent";
    return n;
  }
};

// Embree answers `w` in chunks of 4096 on parallel_for's threads, from a fresh copy of
// the rays (`rays`/`rayhits`, refilled untimed before); returns seconds.
double time_embree(RTCScene scene, const Variant& v, const Workload& w,
                   std::vector<RTCRayHit>& rayhits, std::vector<RTCRay>& rays, size_t* found) {
  const size_t n = w.rays.size(), chunk = 4096;
  if (w.closest) {
    rayhits.resize(n);
    for (size_t i = 0; i < n; ++i) {
      rayhits[i].ray = to_embree(w.rays[i]);
      rayhits[i].hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rayhits[i].hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    }
  } else {
    rays.resize(n);
    for (size_t i = 0; i < n; ++i) rays[i] = to_embree(w.rays[i]);
  }
  const auto t0 = Clock::now();
  twinray::parallel_for(static_cast<int>((n + chunk - 1) / chunk), 1, [&](int c) {
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
    const size_t begin = static_cast<size_t>(c) * chunk, count = std::min(chunk, n - begin);
    if (w.closest)
      embree_world::intersect_all(scene, v.mode, v.coherent, rayhits.data() + begin, count);
    else
      embree_world::occluded_all(scene, v.mode, v.coherent, rays.data() + begin, count);
  });
  const double s = seconds_since(t0);
  *found = 0;
  for (size_t i = 0; i < n; ++i)
    *found +=
        w.closest ? rayhits[i].hit.geomID != RTC_INVALID_GEOMETRY_ID : rays[i].tfar == -INFINITY;
  return s;
}

double time_twinray(const twinray::PackedScene<float>& ps, const Workload& w,
                    std::vector<twinray::Hit<float>>& hits, std::vector<uint8_t>& blocked,
                    size_t* found, twinray::cpu::QueryWalk walk) {
  const size_t n = w.rays.size();
  hits.resize(n);
  blocked.resize(n);
  const auto t0 = Clock::now();
  if (w.closest)
    twinray::cpu::query_intersect(ps, w.rays.data(), n, hits.data(), 0, nullptr, walk);
  else
    twinray::cpu::query_occluded(ps, w.rays.data(), n, blocked.data(), walk);
  const double s = seconds_since(t0);
  *found = 0;
  for (size_t i = 0; i < n; ++i) *found += w.closest ? hits[i].object >= 0 : blocked[i];
  return s;
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  size_t at = 0;
  while (at <= s.size()) {
    size_t end = s.find(',', at);
    if (end == std::string::npos) end = s.size();
    if (end > at) out.push_back(s.substr(at, end - at));
    at = end + 1;
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> scenes = {"spheres_1e6", "mesh_1e6"};
  int rounds = 3, width = 1920, height = 1080, ao_width = 960, ao_height = 540, threads = 0;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (i + 1 >= argc) {
      std::fprintf(stderr, "%s: a value is missing\n", a.c_str());
      return 2;
    }
    std::string v = argv[++i];
    if (a == "--scenes")
      scenes = split(v);
    else if (a == "--rounds")
      rounds = std::atoi(v.c_str());
    else if (a == "--width")
      width = std::atoi(v.c_str());
    else if (a == "--height")
      height = std::atoi(v.c_str());
    else if (a == "--ao-width")
      ao_width = std::atoi(v.c_str());
    else if (a == "--ao-height")
      ao_height = std::atoi(v.c_str());
    else if (a == "--threads")
      threads = std::atoi(v.c_str());
    else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      return 2;
    }
  }
  if (rounds < 1 || width < 1 || height < 1 || ao_width < 1 || ao_height < 1) {
    std::fprintf(stderr, "rounds and sizes must be >= 1\n");
    return 2;
  }
  twinray::set_thread_count(threads);
  std::printf(
      "ray_query_bench: %s; %d rounds; twinray's CPU code and Embree %d.%d.%d on the "
      "same threads\n",
      twinray_bench::machine_description().c_str(), rounds, RTC_VERSION_MAJOR, RTC_VERSION_MINOR,
      RTC_VERSION_PATCH);
  const std::vector<Variant> variants = {{embree_world::Mode::Single, false},
                                         {embree_world::Mode::Packet8, false},
                                         {embree_world::Mode::Packet16, false},
                                         {embree_world::Mode::Stream, true},
                                         {embree_world::Mode::Stream, false}};
  for (const std::string& name : scenes) {
    twinray_bench::BenchScene<float> b;
    try {
      b = twinray_bench::make_scene<float>(name, width, height);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "%s\n", e.what());
      return 2;
    }
    // Both engines get the same bounded geometry: each plane becomes a quad.
    vec3 lo, hi;
    twinray_bench::bounded_box(b.scene, lo, hi);
    const float diameter = glm::length(hi - lo);
    twinray::Scene<float> bounded = b.scene;
    bounded.objects.clear();
    for (const auto& o : b.scene.objects) {
      auto* plane = std::get_if<twinray::Plane<float>>(&o);
      if (!plane) {
        bounded.objects.push_back(o);
        continue;
      }
      const vec3 n = glm::normalize(plane->normal);
      const vec3 c = (lo + hi) * 0.5f;
      const vec3 at = c - n * glm::dot(c - plane->point, n);  // the centre, on the plane
      const vec3 t =
          glm::normalize(glm::cross(std::fabs(n.x) > 0.5f ? vec3(0, 1, 0) : vec3(1, 0, 0), n));
      const vec3 u = t * (50 * diameter), v = glm::cross(n, t) * (50 * diameter);
      twinray::Mesh<float> quad;
      quad.vertices = {at - u - v, at + u - v, at + u + v, at - u + v};
      quad.triangles = {{0, 1, 2}, {0, 2, 3}};
      quad.material = plane->material;
      bounded.objects.push_back(quad);
    }
    b.scene = bounded;
    auto t_pack = Clock::now();
    const twinray::PackedScene<float> ps = twinray::pack_scene(bounded);
    const double pack_s = seconds_since(t_pack);
    embree_world::World world;
    world.device = rtcNewDevice(nullptr);
    auto t_build = Clock::now();
    embree_world::build_world(world, b, embree_world::SphereKind::User);
    rtcCommitScene(world.scene);
    const double build_s = seconds_since(t_build);

    // The rays, before any timing.
    std::vector<Workload> work(3);
    work[0] = {"coherent", true, true, {}};
    work[1] = {"ao", false, false, {}};
    work[2] = {"diffuse", true, false, {}};
    twinray::Camera<float> camera = b.camera;
    camera.width = width, camera.height = height;
    const auto frame = camera.frame();
    for (int y = 0; y < height; ++y)
      for (int x = 0; x < width; ++x) work[0].rays.push_back(camera_ray(frame, x, y));
    camera.width = ao_width, camera.height = ao_height;
    const auto ao_frame = camera.frame();
    std::vector<twinray::Ray<float>> primary;
    for (int y = 0; y < ao_height; ++y)
      for (int x = 0; x < ao_width; ++x) primary.push_back(camera_ray(ao_frame, x, y));
    std::vector<twinray::Hit<float>> hits(primary.size());
    twinray::cpu::query_intersect(ps, primary.data(), primary.size(), hits.data(), 0, nullptr);
    for (size_t i = 0; i < primary.size(); ++i) {
      const auto& h = hits[i];
      if (h.object < 0) continue;
      const auto& r = primary[i];
      const vec3 n(h.nx, h.ny, h.nz);
      const vec3 p = vec3(r.ox, r.oy, r.oz) + vec3(r.dx, r.dy, r.dz) * h.t;
      const vec3 o = p + n * (1e-4f * (1.0f + std::fabs(p.x) + std::fabs(p.y) + std::fabs(p.z)));
      for (int k = 0; k < 16; ++k)
        work[1].rays.push_back(twinray::make_ray(
            o, cosine_direction(n, static_cast<uint32_t>(i * 16 + k)), 0.0f, diameter / 10));
      work[2].rays.push_back(
          twinray::make_ray(o, cosine_direction(n, static_cast<uint32_t>(i * 16 + 7777))));
    }
    std::printf(
        "\n%s: %lld primitives (the floor a quad); twinray pack %.2f s, Embree build "
        "%.2f s\n",
        name.c_str(), world.primitives, pack_s, build_s);

    std::vector<twinray::Hit<float>> tw_hits;
    std::vector<uint8_t> tw_blocked;
    std::vector<RTCRayHit> em_hits;
    std::vector<RTCRay> em_rays;
    // twinray's walks: what the backend runs first, then packets always of consecutive
    // rays, always of one octant's rays, and every ray alone, which must give the same
    // bits.
    const std::vector<std::pair<twinray::cpu::QueryWalk, const char*>> walks = {
        {twinray::cpu::QueryWalk::Packets, "packets"},
        {twinray::cpu::QueryWalk::PacketsInOrder, "packets in order"},
        {twinray::cpu::QueryWalk::PacketsByOctant, "packets by octant"},
        {twinray::cpu::QueryWalk::RayByRay, "ray by ray"}};
    for (const Workload& w : work) {
      std::vector<std::vector<double>> tws(walks.size());
      std::vector<double>& tw = tws[0];
      std::vector<std::vector<double>> em(variants.size());
      size_t tw_found = 0, walk_found = 0;
      std::vector<bool> same_bits(walks.size(), true);
      std::vector<twinray::Hit<float>> ref_hits;
      std::vector<uint8_t> ref_blocked;
      std::vector<size_t> em_found(variants.size(), 0);
      for (int round = 0; round < rounds + 1; ++round) {  // round 0 warms up
        for (size_t k = 0; k < walks.size(); ++k) {
          double s = time_twinray(ps, w, tw_hits, tw_blocked, k == 0 ? &tw_found : &walk_found,
                                  walks[k].first);
          if (round > 0) tws[k].push_back(s);
          if (k == 0) {
            ref_hits = tw_hits;
            ref_blocked = tw_blocked;
          } else if (w.closest) {
            same_bits[k] = same_bits[k] && std::memcmp(tw_hits.data(), ref_hits.data(),
                                                       tw_hits.size() * sizeof(tw_hits[0])) == 0;
          } else {
            same_bits[k] = same_bits[k] && tw_blocked == ref_blocked;
          }
        }
        for (size_t v = 0; v < variants.size(); ++v) {
          const double s = time_embree(world.scene, variants[v], w, em_hits, em_rays, &em_found[v]);
          if (round > 0) em[v].push_back(s);
        }
      }
      const double n = static_cast<double>(w.rays.size());
      const double tw_rate = n / twinray_bench::quantile(tw, 0.5);
      std::printf("  %-8s %9zu rays (%s, %s): twinray %7.2f Mrays/s (%zu %s)\n", w.name.c_str(),
                  w.rays.size(), w.closest ? "intersect" : "occluded",
                  w.coherent ? "coherent" : "incoherent", tw_rate / 1e6, tw_found,
                  w.closest ? "hits" : "blocked");
      for (size_t k = 1; k < walks.size(); ++k)
        std::printf("           twinray %-19s %7.2f Mrays/s  twinray/this %.2f; same bits: %s\n",
                    walks[k].second, n / twinray_bench::quantile(tws[k], 0.5) / 1e6,
                    tw_rate * twinray_bench::quantile(tws[k], 0.5) / n,
                    same_bits[k] ? "yes" : "NO");
      size_t best = 0;
      for (size_t v = 0; v < variants.size(); ++v) {
        const double rate = n / twinray_bench::quantile(em[v], 0.5);
        if (rate > n / twinray_bench::quantile(em[best], 0.5)) best = v;
        std::printf("           Embree %-20s %7.2f Mrays/s (%zu)  twinray/Embree %.2f\n",
                    variants[v].name().c_str(), rate / 1e6, em_found[v], tw_rate / rate);
      }
      const double best_rate = n / twinray_bench::quantile(em[best], 0.5);
      std::printf("           fastest Embree: %s; twinray/Embree %.2f\n",
                  variants[best].name().c_str(), tw_rate / best_rate);
    }
    rtcReleaseScene(world.scene);
    rtcReleaseDevice(world.device);
  }
  return 0;
}
