// Embree 3's side of the benchmarks that compare it with twinray (embree_bench.cpp,
// ray_query_bench.cpp): the benchmark scenes as an Embree scene (spheres as user
// geometry with an analytic test, or Embree's point spheres; triangles; planes kept
// outside, as twinray keeps them), and closest-hit and occlusion queries through each
// of Embree's calls: one ray at a time, 8- or 16-wide packets, or a stream.
#pragma once

#include <embree3/rtcore.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <cmath>
#include <cstddef>
#include <type_traits>
#include <vector>

#include "bench_runner.hpp"

namespace embree_world {

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
  // Instances (RTC_GEOMETRY_TYPE_INSTANCE): each asset's triangles are one geometry of
  // a scene of its own; a hit with instID set reads its material from its asset's
  // list and its normal, which Embree gives in the asset's space, through the
  // instance's inverse transpose.
  std::vector<RTCScene> asset_scenes;
  std::vector<std::vector<int>> asset_tri_material;
  std::vector<int> instance_of_geom;  // top-level geomID -> instance index, or -1
  std::vector<int> instance_asset;
  std::vector<glm::mat3> instance_normal_map;
  double assets_ms = 0;  // the asset scenes' commits, within build_world
};

enum class Mode { Single, Packet8, Packet16, Stream };

inline const char* mode_name(Mode m) {
  return m == Mode::Single     ? "single"
         : m == Mode::Packet8  ? "packet8"
         : m == Mode::Packet16 ? "packet16"
                               : "stream";
}

// How spheres go to Embree: user geometry with the analytic test below, or Embree's
// own point-cloud primitive.
enum class SphereKind { User, Point };

inline const char* sphere_kind_name(SphereKind k) {
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

inline void sphere_bounds(const RTCBoundsFunctionArguments* args) {
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

inline void sphere_intersect(const RTCIntersectFunctionNArguments* args) {
  by_width(args, [args](auto k) { sphere_intersect_n<decltype(k)::value>(args); });
}

inline void sphere_occluded(const RTCOccludedFunctionNArguments* args) {
  by_width(args, [args](auto k) { sphere_occluded_n<decltype(k)::value>(args); });
}

// One triangle geometry of vertices verts (x y z ...) and index triples tris, attached
// to `scene`; its geometry ID.
inline unsigned attach_triangles(RTCDevice device, RTCScene scene, const std::vector<float>& verts,
                                 const std::vector<unsigned>& tris) {
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  // Embree reads vertex buffers 16 bytes at a time: one float of padding at the end.
  float* vb = static_cast<float*>(rtcSetNewGeometryBuffer(
      g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), verts.size() / 3 + 1));
  std::copy(verts.begin(), verts.end(), vb);
  unsigned* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), tris.size() / 3));
  std::copy(tris.begin(), tris.end(), ib);
  rtcCommitGeometry(g);
  unsigned id = rtcAttachGeometry(scene, g);
  rtcReleaseGeometry(g);
  return id;
}

// Triangles and meshes flattened into one triangle geometry's buffers: vertices
// (x y z ...), index triples and each triangle's material.
struct TriangleSoup {
  std::vector<float> verts;
  std::vector<unsigned> tris;
  std::vector<int> materials;

  // Appends `o` if it is a triangle or a mesh; whether it was one.
  bool add(const twinray::Object<float>& o) {
    const unsigned base = static_cast<unsigned>(verts.size() / 3);
    if (auto* t = std::get_if<twinray::Triangle<float>>(&o)) {
      for (const auto& v : t->vertices) verts.insert(verts.end(), {v.x, v.y, v.z});
      tris.insert(tris.end(), {base, base + 1, base + 2});
      materials.push_back(t->material);
      return true;
    }
    if (auto* m = std::get_if<twinray::Mesh<float>>(&o)) {
      for (const auto& v : m->vertices) verts.insert(verts.end(), {v.x, v.y, v.z});
      for (const auto& f : m->triangles) {
        tris.insert(tris.end(),
                    {base + unsigned(f[0]), base + unsigned(f[1]), base + unsigned(f[2])});
        materials.push_back(m->material);
      }
      return true;
    }
    return false;
  }
};

inline void build_world(World& w, const twinray_bench::BenchScene<float>& b,
                        SphereKind sphere_kind) {
  const auto& scene = b.scene;
  for (const auto& m : scene.materials)
    w.materials.push_back({m.color, m.ka, m.kd, m.ks, m.shininess, m.glaze});
  for (const auto& l : scene.lights) w.lights.push_back({l.position, l.color * l.intensity});
  w.background = scene.background;
  TriangleSoup soup;
  for (const auto& o : scene.objects) {
    if (auto* s = std::get_if<twinray::Sphere<float>>(&o)) {
      w.spheres.push_back({s->center, s->radius});
      w.sphere_material.push_back(s->material);
    } else if (auto* p = std::get_if<twinray::Plane<float>>(&o)) {
      w.planes.push_back({p->point, glm::normalize(p->normal), p->material});
    } else {
      soup.add(o);
    }
  }
  w.tri_material = soup.materials;
  w.primitives =
      static_cast<long long>(w.sphere_material.size() + w.tri_material.size() + w.planes.size());
  w.scene = rtcNewScene(w.device);
  // Each asset as a scene of one triangle geometry, committed here (Embree's instances
  // need their scene committed first); then an instance geometry per placement.
  auto a0 = std::chrono::steady_clock::now();
  for (const auto& asset : scene.assets) {
    TriangleSoup asset_soup;
    for (const auto& o : asset.objects)
      if (!asset_soup.add(o))
        throw std::runtime_error("embree_bench: assets of triangles and meshes only");
    RTCScene child = rtcNewScene(w.device);
    attach_triangles(w.device, child, asset_soup.verts, asset_soup.tris);
    rtcCommitScene(child);
    w.asset_scenes.push_back(child);
    w.asset_tri_material.push_back(std::move(asset_soup.materials));
  }
  w.assets_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - a0).count();
  for (const auto& o : scene.objects) {
    auto* in = std::get_if<twinray::Instance<float>>(&o);
    if (!in) continue;
    RTCGeometry g = rtcNewGeometry(w.device, RTC_GEOMETRY_TYPE_INSTANCE);
    rtcSetGeometryInstancedScene(g, w.asset_scenes[static_cast<size_t>(in->asset)]);
    float xfm[12];  // column-major 3x4: columns x, y, z, translation
    for (int c = 0; c < 4; ++c)
      for (int r = 0; r < 3; ++r) xfm[3 * c + r] = static_cast<float>(in->to_world[c][r]);
    rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm);
    rtcCommitGeometry(g);
    unsigned id = rtcAttachGeometry(w.scene, g);
    rtcReleaseGeometry(g);
    if (w.instance_of_geom.size() <= id) w.instance_of_geom.resize(id + 1, -1);
    w.instance_of_geom[id] = static_cast<int>(w.instance_asset.size());
    w.instance_asset.push_back(in->asset);
    w.instance_normal_map.push_back(
        glm::mat3(glm::transpose(glm::inverse(glm::dmat3(in->to_world)))));
  }
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
  if (!soup.tris.empty()) w.tri_geom = attach_triangles(w.device, w.scene, soup.verts, soup.tris);
}

// The analytic floor: closest plane hit in (tnear, tfar), or -1.
inline int plane_hit(const World& w, vec3 o, vec3 d, float tnear, float tfar, float* t_out) {
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

inline void init_ray(RTCRay& r, vec3 o, vec3 d, float tnear, float tfar) {
  r.org_x = o.x, r.org_y = o.y, r.org_z = o.z, r.tnear = tnear;
  r.dir_x = d.x, r.dir_y = d.y, r.dir_z = d.z, r.time = 0;
  r.tfar = tfar, r.mask = 0xffffffffu, r.id = 0, r.flags = 0;
}

// A closest-hit query from o along d, no hit yet.
inline void init_query(RTCRayHit& q, vec3 o, vec3 d) {
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
inline RTCIntersectContext make_context(bool coherent) {
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  ctx.flags =
      coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  return ctx;
}

// Embree's packet types and calls of width K (8 or 16).
template <int K>
struct Packet;
template <>
struct Packet<8> {
  using RayHit = RTCRayHit8;
  using Ray = RTCRay8;
  static void intersect(const int* valid, RTCScene s, RTCIntersectContext* c, RayHit* p) {
    rtcIntersect8(valid, s, c, p);
  }
  static void occluded(const int* valid, RTCScene s, RTCIntersectContext* c, Ray* p) {
    rtcOccluded8(valid, s, c, p);
  }
};
template <>
struct Packet<16> {
  using RayHit = RTCRayHit16;
  using Ray = RTCRay16;
  static void intersect(const int* valid, RTCScene s, RTCIntersectContext* c, RayHit* p) {
    rtcIntersect16(valid, s, c, p);
  }
  static void occluded(const int* valid, RTCScene s, RTCIntersectContext* c, Ray* p) {
    rtcOccluded16(valid, s, c, p);
  }
};

// Ray i of a packet from r (lanes past the end repeat a valid ray, masked off).
template <class P>
void set_lane(P& p, int k, const RTCRay& r) {
  p.org_x[k] = r.org_x, p.org_y[k] = r.org_y, p.org_z[k] = r.org_z;
  p.dir_x[k] = r.dir_x, p.dir_y[k] = r.dir_y, p.dir_z[k] = r.dir_z;
  p.tnear[k] = r.tnear, p.tfar[k] = r.tfar, p.time[k] = 0;
  p.mask[k] = r.mask, p.id[k] = 0, p.flags[k] = 0;
}

template <int K>
void intersect_packets(RTCScene scene, RTCIntersectContext* ctx, RTCRayHit* rh, size_t n) {
  for (size_t base = 0; base < n; base += K) {
    alignas(64) typename Packet<K>::RayHit p;
    alignas(64) int valid[K];
    for (int k = 0; k < K; ++k) {
      size_t i = base + k;
      valid[k] = i < n ? -1 : 0;
      set_lane(p.ray, k, rh[i < n ? i : base].ray);
      p.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID, p.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
    }
    Packet<K>::intersect(valid, scene, ctx, &p);
    for (int k = 0; k < K && base + k < n; ++k) {
      RTCRayHit& out = rh[base + k];
      out.ray.tfar = p.ray.tfar[k];
      out.hit.geomID = p.hit.geomID[k], out.hit.primID = p.hit.primID[k];
      out.hit.instID[0] = p.hit.instID[0][k];
      out.hit.Ng_x = p.hit.Ng_x[k], out.hit.Ng_y = p.hit.Ng_y[k], out.hit.Ng_z = p.hit.Ng_z[k];
    }
  }
}

template <int K>
void occluded_packets(RTCScene scene, RTCIntersectContext* ctx, RTCRay* rays, size_t n) {
  for (size_t base = 0; base < n; base += K) {
    alignas(64) typename Packet<K>::Ray p;
    alignas(64) int valid[K];
    for (int k = 0; k < K; ++k) {
      size_t i = base + k;
      valid[k] = i < n ? -1 : 0;
      set_lane(p, k, rays[i < n ? i : base]);
    }
    Packet<K>::occluded(valid, scene, ctx, &p);
    for (int k = 0; k < K && base + k < n; ++k) rays[base + k].tfar = p.tfar[k];
  }
}

// Traces n closest-hit queries / occlusion queries in the given mode.
inline void intersect_all(RTCScene scene, Mode mode, bool coherent, RTCRayHit* rh, size_t n) {
  RTCIntersectContext ctx = make_context(coherent);
  if (mode == Mode::Single) {
    for (size_t i = 0; i < n; ++i) rtcIntersect1(scene, &ctx, &rh[i]);
  } else if (mode == Mode::Stream) {
    if (n) rtcIntersect1M(scene, &ctx, rh, static_cast<unsigned>(n), sizeof(RTCRayHit));
  } else if (mode == Mode::Packet16) {
    intersect_packets<16>(scene, &ctx, rh, n);
  } else {
    intersect_packets<8>(scene, &ctx, rh, n);
  }
}

inline void occluded_all(RTCScene scene, Mode mode, bool coherent, RTCRay* rays, size_t n) {
  RTCIntersectContext ctx = make_context(coherent);
  if (mode == Mode::Single) {
    for (size_t i = 0; i < n; ++i) rtcOccluded1(scene, &ctx, &rays[i]);
  } else if (mode == Mode::Stream) {
    if (n) rtcOccluded1M(scene, &ctx, rays, static_cast<unsigned>(n), sizeof(RTCRay));
  } else if (mode == Mode::Packet16) {
    occluded_packets<16>(scene, &ctx, rays, n);
  } else {
    occluded_packets<8>(scene, &ctx, rays, n);
  }
}

inline void intersect_all(RTCScene scene, Mode mode, bool coherent, std::vector<RTCRayHit>& rh) {
  intersect_all(scene, mode, coherent, rh.data(), rh.size());
}
inline void occluded_all(RTCScene scene, Mode mode, bool coherent, std::vector<RTCRay>& rays) {
  occluded_all(scene, mode, coherent, rays.data(), rays.size());
}

}  // namespace embree_world
