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

namespace {

using vec3 = glm::vec3;

struct Plane {
  vec3 p, n;
  int material;
};

// One sphere as both sphere kinds read it: the user geometry's callbacks through their
// user pointer, and SPHERE_POINT as an RTC_FORMAT_FLOAT4 vertex (x, y, z, radius).
struct Sphere {
  vec3 center;
  float radius;
};
static_assert(sizeof(Sphere) == 4 * sizeof(float), "Sphere is an RTC_FORMAT_FLOAT4 vertex");

struct Material {
  vec3 color;
  float ka, kd, ks, shininess, glaze;
};

// A point light as twinray packs it: colour times intensity, the irradiance at unit
// distance.
struct Light {
  vec3 position, rgb;
};

struct World {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  unsigned sphere_geom = RTC_INVALID_GEOMETRY_ID, tri_geom = RTC_INVALID_GEOMETRY_ID;
  // The spheres by primID. The user geometry's callbacks read them through their user
  // pointer, so they live as long as the scene.
  std::vector<Sphere> spheres;
  std::vector<int> sphere_material, tri_material;
  std::vector<Plane> planes;
  std::vector<Material> materials;
  std::vector<Light> lights;
  vec3 background{0};
  long long primitives = 0;
};

enum class Mode { Single, Packet8, Stream };

const char* mode_name(Mode m) {
  return m == Mode::Single ? "single" : (m == Mode::Packet8 ? "packet8" : "stream");
}

// How spheres go to Embree: user geometry with the analytic test below, or Embree's
// own point-cloud primitive.
enum class SphereKind { User, Point };

const char* sphere_kind_name(SphereKind k) {
  return k == SphereKind::User ? "user" : "point";
}

// ---- spheres as Embree user geometry ----

// The nearer root of |o + t d - c|^2 = r^2 inside (tnear, tfar), in the numerically
// stable form of Haines, Guenther and Akenine-Moeller, "Precision Improvements for
// Ray/Sphere Intersection" (Ray Tracing Gems, ch. 7), the form twinray's
// device/intersect_sphere.h starts from. With f = o - c, a = d.d, b = -f.d and
// c = f.f - r^2:
//  - the discriminant is a D = a (r^2 - |f + (b/a) d|^2), where f + (b/a) d runs from
//    the centre to the ray's closest point and is formed before it is squared; the
//    textbook b^2 - a c equals it but cancels for a sphere small against its
//    distance, where b^2 and a c are both about a |f|^2;
//  - the roots are c/q and q/a with q = b + sign(b) sqrt(a D), so the near root of a
//    big sphere close by does not cancel either (Numerical Recipes 5.6).
// Returns false where the ray misses or both roots fall outside the interval.
inline bool sphere_root(const Sphere& sphere, vec3 o, vec3 d, float tnear, float tfar,
                        float* t_out) {
  const vec3 f = o - sphere.center;
  const float r2 = sphere.radius * sphere.radius;
  const float a = glm::dot(d, d), b = -glm::dot(f, d);
  const vec3 perp = f + d * (b / a);
  const float disc = a * (r2 - glm::dot(perp, perp));
  if (disc < 0) return false;
  const float c = glm::dot(f, f) - r2;
  const float q = b >= 0 ? b + std::sqrt(disc) : b - std::sqrt(disc);
  if (q == 0) return false;  // origin on the sphere and a tangent ray: no finite root
  float t0 = c / q, t1 = q / a;
  if (t0 > t1) std::swap(t0, t1);
  if (t0 > tnear && t0 < tfar) {
    *t_out = t0;
    return true;
  }
  if (t1 > tnear && t1 < tfar) {
    *t_out = t1;
    return true;
  }
  return false;
}

// Embree calls the callbacks below with N = 1 (rtcIntersect1, incoherent streams) or
// the packet width, 4, 8 or 16 (rtcIntersect8 and coherent streams give N = 8 with
// AVX2); valid[i] is -1 for the lanes to test and 0 for the rest. RTCRayN/RTCHitN
// store each field as N consecutive floats, so a compile-time N turns every access
// into a fixed offset: the dispatch instantiates the widths Embree uses, K = 0 reads
// N at run time for any other.

void sphere_bounds(const RTCBoundsFunctionArguments* args) {
  const Sphere& s = static_cast<const Sphere*>(args->geometryUserPtr)[args->primID];
  RTCBounds* b = args->bounds_o;
  const vec3 lo = s.center - s.radius, hi = s.center + s.radius;
  b->lower_x = lo.x, b->lower_y = lo.y, b->lower_z = lo.z;
  b->upper_x = hi.x, b->upper_y = hi.y, b->upper_z = hi.z;
}

template <unsigned K>
void sphere_intersect_n(const RTCIntersectFunctionNArguments* args) {
  const unsigned N = K ? K : args->N;
  const Sphere& s = static_cast<const Sphere*>(args->geometryUserPtr)[args->primID];
  RTCRayN* ray = RTCRayHitN_RayN(args->rayhit, N);
  RTCHitN* hit = RTCRayHitN_HitN(args->rayhit, N);
  for (unsigned i = 0; i < N; ++i) {
    if (!args->valid[i]) continue;
    const vec3 o(RTCRayN_org_x(ray, N, i), RTCRayN_org_y(ray, N, i), RTCRayN_org_z(ray, N, i));
    const vec3 d(RTCRayN_dir_x(ray, N, i), RTCRayN_dir_y(ray, N, i), RTCRayN_dir_z(ray, N, i));
    float t;
    if (!sphere_root(s, o, d, RTCRayN_tnear(ray, N, i), RTCRayN_tfar(ray, N, i), &t)) continue;
    // Closest so far: shorten the ray and record the hit. Ng is the hit point
    // relative to the centre, f + t d; it need not be unit length (the renderer
    // normalizes it).
    const vec3 ng = (o - s.center) + d * t;
    RTCRayN_tfar(ray, N, i) = t;
    RTCHitN_Ng_x(hit, N, i) = ng.x;
    RTCHitN_Ng_y(hit, N, i) = ng.y;
    RTCHitN_Ng_z(hit, N, i) = ng.z;
    RTCHitN_u(hit, N, i) = 0;
    RTCHitN_v(hit, N, i) = 0;
    RTCHitN_primID(hit, N, i) = args->primID;
    RTCHitN_geomID(hit, N, i) = args->geomID;
    RTCHitN_instID(hit, N, i, 0) = args->context->instID[0];
  }
}

template <unsigned K>
void sphere_occluded_n(const RTCOccludedFunctionNArguments* args) {
  const unsigned N = K ? K : args->N;
  const Sphere& s = static_cast<const Sphere*>(args->geometryUserPtr)[args->primID];
  RTCRayN* ray = args->ray;
  for (unsigned i = 0; i < N; ++i) {
    if (!args->valid[i]) continue;
    const vec3 o(RTCRayN_org_x(ray, N, i), RTCRayN_org_y(ray, N, i), RTCRayN_org_z(ray, N, i));
    const vec3 d(RTCRayN_dir_x(ray, N, i), RTCRayN_dir_y(ray, N, i), RTCRayN_dir_z(ray, N, i));
    float t;
    // Any hit in the interval occludes; Embree's convention for it is tfar = -inf.
    if (sphere_root(s, o, d, RTCRayN_tnear(ray, N, i), RTCRayN_tfar(ray, N, i), &t))
      RTCRayN_tfar(ray, N, i) = -INFINITY;
  }
}

// Calls f(std::integral_constant<unsigned, K>) with K = args->N for the widths Embree
// uses, K = 0 (N read at run time) for any other.
template <class Args, class F>
void by_width(const Args* args, F f) {
  switch (args->N) {
    case 1:
      return f(std::integral_constant<unsigned, 1>{});
    case 4:
      return f(std::integral_constant<unsigned, 4>{});
    case 8:
      return f(std::integral_constant<unsigned, 8>{});
    case 16:
      return f(std::integral_constant<unsigned, 16>{});
    default:
      return f(std::integral_constant<unsigned, 0>{});
  }
}

void sphere_intersect(const RTCIntersectFunctionNArguments* args) {
  by_width(args, [args](auto k) { sphere_intersect_n<decltype(k)::value>(args); });
}

void sphere_occluded(const RTCOccludedFunctionNArguments* args) {
  by_width(args, [args](auto k) { sphere_occluded_n<decltype(k)::value>(args); });
}

void build_world(World& w, const twinray_bench::BenchScene<float>& b, SphereKind sphere_kind) {
  const auto& scene = b.scene;
  for (const auto& m : scene.materials)
    w.materials.push_back({m.color, m.ka, m.kd, m.ks, m.shininess, m.glaze});
  for (const auto& l : scene.lights) w.lights.push_back({l.position, l.color * l.intensity});
  w.background = scene.background;
  std::vector<float> verts;  // x y z
  std::vector<unsigned> tris;
  for (const auto& o : scene.objects) {
    if (auto* s = std::get_if<twinray::Sphere<float>>(&o)) {
      w.spheres.push_back({s->center, s->radius});
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
  if (!w.spheres.empty() && sphere_kind == SphereKind::User) {
    // Embree builds its BVH over the boxes sphere_bounds gives and calls
    // sphere_intersect / sphere_occluded for the spheres a ray reaches.
    RTCGeometry g = rtcNewGeometry(w.device, RTC_GEOMETRY_TYPE_USER);
    rtcSetGeometryUserPrimitiveCount(g, static_cast<unsigned>(w.spheres.size()));
    rtcSetGeometryUserData(g, w.spheres.data());
    rtcSetGeometryBoundsFunction(g, sphere_bounds, nullptr);
    rtcSetGeometryIntersectFunction(g, sphere_intersect);
    rtcSetGeometryOccludedFunction(g, sphere_occluded);
    rtcCommitGeometry(g);
    w.sphere_geom = rtcAttachGeometry(w.scene, g);
    rtcReleaseGeometry(g);
  } else if (!w.spheres.empty()) {
    RTCGeometry g = rtcNewGeometry(w.device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
    Sphere* buf = static_cast<Sphere*>(rtcSetNewGeometryBuffer(
        g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, sizeof(Sphere), w.spheres.size()));
    std::copy(w.spheres.begin(), w.spheres.end(), buf);
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

// A closest-hit query from o along d, no hit yet.
void init_query(RTCRayHit& q, vec3 o, vec3 d) {
  init_ray(q.ray, o, d, 0.0f, INFINITY);
  q.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  q.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

// The query context. With RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT, Embree's default,
// rtcIntersect1M/rtcOccluded1M trace a stream one ray at a time; with
// RTC_INTERSECT_CONTEXT_FLAG_COHERENT they regroup it into packets, which pays where
// the rays run together. A wavefront holds the rays of one 16x16 tile: its camera
// rays, the shadow rays of their hits (neighbouring points, one light) and its
// mirror rays (a bundle off the glazed floor) are coherent; the shadow rays of
// mirror hits start all over the scene. Measured in stream mode: all incoherent
// is ~18% slower on demo and ~25% on mesh_1e4; coherent deep shadow rays ~8%
// slower on spheres_1e5. Single rays and packet8 do not read the flag.
RTCIntersectContext make_context(bool coherent) {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags =
      coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  return ctx;
}

// Traces a wavefront of closest-hit queries / occlusion queries in the given mode.
void intersect_all(RTCScene scene, Mode mode, bool coherent, std::vector<RTCRayHit>& rh) {
  RTCIntersectContext ctx = make_context(coherent);
  const size_t n = rh.size();
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

void occluded_all(RTCScene scene, Mode mode, bool coherent, std::vector<RTCRay>& rays) {
  RTCIntersectContext ctx = make_context(coherent);
  const size_t n = rays.size();
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
        rtcReleaseDevice(w.device);
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "embree_bench: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
