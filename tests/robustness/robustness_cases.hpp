// The stiff and extreme scenes, each with what a correct renderer must
// produce, measured in one place: tests/robustness/robustness_test.cpp asserts on the
// figures, robustness_report.cpp prints them as the table of docs/robustness.md.
//
// Every case is a function `Figures case_x<T>(Ctx&)` that renders through
// twinray::render() on ctx.backend (and, when ctx.check_parity, once more on the other
// backend, counting pixels whose bits differ), or calls the device functions directly
// (device/code.hpp) where it needs single rays. References are computed in long
// precision from the very same float/double inputs the renderer saw, so they measure the
// renderer's arithmetic, not the rounding of the scene description. The reference type
// is binary128 (__float128, libquadmath): x87 long double carries only 11 bits more than
// double, which the grazing and huge-sphere cases (condition numbers up to ~1e6) use up.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <quadmath.h>

#include <twinray/twinray.hpp>
#include <twinray/scene/transform.hpp>

#include "support/packing.hpp"

namespace rb {

using twinray::Backend;
template <class T>
using V3 = glm::vec<3, T>;
using LD = __float128;  // the reference precision (113-bit significand)
using VL = glm::vec<3, LD>;
inline LD qabs(LD x) {
  return fabsq(x);
}
inline LD qsqrt(LD x) {
  return sqrtq(x);
}
inline LD qnan() {
  return nanq("");
}
inline bool qisnan(LD x) {
  return isnanq(x) != 0;
}

// ---------------------------------------------------------------- figures, context

struct Figures {
  long long samples = 0;    // pixels or rays examined
  long long acne = -1;      // pixels that differ with vs without secondary rays
  long long leaks = -1;     // rays that slip through a closed surface / wrong hit or miss
  long long wrong = -1;     // pixels off a closed-form answer beyond the stated tolerance
  long long nonfinite = 0;  // NaN or Inf values in the framebuffer (or in t)
  double terr_max = -1;     // |t - t_ref| in ulps of t_ref
  double terr_median = -1;
  double rel_err_max = -1;  // largest relative error against a closed form
  long long parity = -1;    // pixels whose bits differ between CPU and OpenCL (-1 not checked)

  void add(const Figures& o) {
    samples += o.samples;
    auto sum = [](long long& a, long long b) {
      if (b >= 0) a = a < 0 ? b : a + b;
    };
    sum(acne, o.acne);
    sum(leaks, o.leaks);
    sum(wrong, o.wrong);
    sum(parity, o.parity);
    nonfinite += o.nonfinite;
    terr_max = std::max(terr_max, o.terr_max);
    terr_median = std::max(terr_median, o.terr_median);  // the worst median of the parts
    rel_err_max = std::max(rel_err_max, o.rel_err_max);
  }
};

struct Ctx {
  Backend backend = Backend::Cpu;
  bool check_parity = false;  // also render on the other backend, count differing pixels
  long long parity = -1;
  std::function<void(const std::string&, const void*)> on_image;  // optional: dump images
};

inline bool opencl_ok() {
  static const bool ok = twinray::opencl_available();
  return ok;
}

inline Backend other(Backend b) {
  return b == Backend::Cpu ? Backend::OpenCL : Backend::Cpu;
}

template <class T>
bool same_bits(T a, T b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

template <class T>
long long count_differing_pixels(const twinray::Image<T>& a, const twinray::Image<T>& b) {
  long long n = 0;
  for (size_t i = 0; i + 2 < a.rgb.size(); i += 3)
    if (!same_bits(a.rgb[i], b.rgb[i]) || !same_bits(a.rgb[i + 1], b.rgb[i + 1]) ||
        !same_bits(a.rgb[i + 2], b.rgb[i + 2]))
      ++n;
  return n;
}

template <class T>
long long count_nonfinite(const twinray::Image<T>& img, bool inf_is_ok = false) {
  long long n = 0;
  for (T v : img.rgb)
    if (std::isnan(v) || (!inf_is_ok && std::isinf(v))) ++n;
  return n;
}

template <class T>
twinray::Image<T> render(Ctx& ctx, const twinray::Scene<T>& scene, const twinray::Camera<T>& cam,
                         twinray::RenderOptions options) {
  options.log = [](const std::string&) {};
  options.backend = ctx.backend;
  twinray::Image<T> img = twinray::render(scene, cam, options);
  if (ctx.check_parity) {
    options.backend = other(ctx.backend);
    twinray::Image<T> twin = twinray::render(scene, cam, options);
    ctx.parity = std::max(ctx.parity, 0ll) + count_differing_pixels(img, twin);
  }
  return img;
}

// ---------------------------------------------------------------- numbers

template <class T>
constexpr int digits() {
  return std::numeric_limits<T>::digits;
}

// ulp of x in T's format (spacing of T's numbers at |x|), computed in binary128.
template <class T>
LD ulp_of(LD x) {
  x = qabs(x);
  if (!(x > 0)) return LD(std::numeric_limits<T>::denorm_min());
  int e;
  frexpq(x, &e);  // x = m 2^e, m in [0.5, 1)
  LD u = ldexpq(LD(1), e - digits<T>());
  return u > LD(std::numeric_limits<T>::denorm_min()) ? u
                                                      : LD(std::numeric_limits<T>::denorm_min());
}

template <class T>
double ulps_between(T t, LD ref) {
  return double(qabs(LD(t) - ref) / ulp_of<T>(ref));
}

inline double median(std::vector<double> v) {
  if (v.empty()) return -1;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

template <class T>
VL to_ld(const V3<T>& v) {
  return VL(LD(v.x), LD(v.y), LD(v.z));
}
inline LD dot_ld(const VL& a, const VL& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
inline VL cross_ld(const VL& a, const VL& b) {
  return VL(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}

// Reference ray/sphere distance: the nearest root t > 0 of |o + t d - c|^2 = r^2 for
// the exact (rounded) inputs; NaN when the ray misses. Stable form (Haines et al.,
// RTG ch. 7, eqs. 7-10) in binary128: f = o - c is exact there (both are floats or
// doubles), so is f.f - r^2 up to 2^-113.
inline LD ref_sphere_t(VL o, VL d, VL c, LD r) {
  VL f = o - c;
  LD a = dot_ld(d, d), b = -dot_ld(f, d);
  VL perp = f + d * (b / a);
  LD disc = r * r - dot_ld(perp, perp);
  if (disc < 0) return qnan();
  LD cc = dot_ld(f, f) - r * r;
  LD q = b + (b >= 0 ? qsqrt(a * disc) : -qsqrt(a * disc));
  LD t0 = cc / q, t1 = q / a;
  if (t0 > t1) std::swap(t0, t1);
  if (t0 > 0) return t0;
  if (t1 > 0) return t1;
  return qnan();
}

// Reference ray/plane distance: t = n.(p - o) / n.d, NaN for no positive finite root.
inline LD ref_plane_t(VL o, VL d, VL p, VL n) {
  LD den = dot_ld(n, d);
  if (den == 0) return qnan();
  LD t = dot_ld(n, p - o) / den;
  return t > 0 ? t : qnan();
}

// Reference ray/triangle distance (plane of the triangle; inside test by barycentric
// signs in binary128); *min_bary gets the smallest barycentric coordinate.
inline LD ref_triangle_t(VL o, VL d, VL p0, VL p1, VL p2, LD* min_bary = nullptr) {
  VL n = cross_ld(p1 - p0, p2 - p0);
  LD den = dot_ld(n, d);
  if (den == 0) return qnan();
  LD t = dot_ld(n, p0 - o) / den;
  VL x = o + d * t;
  LD nn = dot_ld(n, n);
  LD b0 = dot_ld(cross_ld(p1 - x, p2 - x), n) / nn;
  LD b1 = dot_ld(cross_ld(p2 - x, p0 - x), n) / nn;
  LD b2 = dot_ld(cross_ld(p0 - x, p1 - x), n) / nn;
  if (min_bary) *min_bary = std::min(b0, std::min(b1, b2));
  return t;
}

// ---------------------------------------------------------------- geometry builders

// Icosphere: the icosahedron subdivided `levels` times, vertices on the sphere; shared
// vertices are stored once, so neighbouring triangles see bit-identical edges.
template <class T>
twinray::Mesh<T> icosphere(V3<T> center, T radius, int levels, int material,
                           unsigned jitter_seed = 0, T jitter = T(0)) {
  const LD g = (1 + qsqrt(LD(5))) / 2;
  std::vector<VL> v = {{-1, g, 0},  {1, g, 0},  {-1, -g, 0}, {1, -g, 0}, {0, -1, g},  {0, 1, g},
                       {0, -1, -g}, {0, 1, -g}, {g, 0, -1},  {g, 0, 1},  {-g, 0, -1}, {-g, 0, 1}};
  std::vector<std::array<int, 3>> f = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                       {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                       {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                       {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (VL& p : v) p = p / qsqrt(dot_ld(p, p));
  for (int l = 0; l < levels; ++l) {
    std::vector<std::array<int, 3>> nf;
    std::vector<std::pair<std::pair<int, int>, int>> mid;
    auto midpoint = [&](int a, int b) {
      auto key = std::make_pair(std::min(a, b), std::max(a, b));
      for (auto& m : mid)
        if (m.first == key) return m.second;
      VL p = (v[a] + v[b]) / LD(2);
      v.push_back(p / qsqrt(dot_ld(p, p)));
      mid.push_back({key, int(v.size()) - 1});
      return int(v.size()) - 1;
    };
    for (auto& t : f) {
      int a = midpoint(t[0], t[1]), b = midpoint(t[1], t[2]), c = midpoint(t[2], t[0]);
      nf.push_back({t[0], a, c});
      nf.push_back({t[1], b, a});
      nf.push_back({t[2], c, b});
      nf.push_back({a, b, c});
    }
    f = nf;
  }
  std::mt19937 rng(jitter_seed);
  std::uniform_real_distribution<double> u(-1, 1);
  twinray::Mesh<T> m;
  m.material = material;
  for (VL p : v) {
    LD s = 1 + (jitter_seed ? LD(jitter) * LD(u(rng)) : LD(0));
    m.vertices.push_back(center + V3<T>(T(p.x * s), T(p.y * s), T(p.z * s)) * radius);
  }
  m.triangles = f;
  return m;
}

// n x n unit quads in the plane spanned by ex, ey from origin o, two triangles each,
// alternating diagonals (so vertices have 4, 6 or 8 triangles around them).
template <class T>
twinray::Mesh<T> grid_mesh(V3<T> o, V3<T> ex, V3<T> ey, int n, int material) {
  twinray::Mesh<T> m;
  m.material = material;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) m.vertices.push_back(o + ex * T(i) + ey * T(j));
  auto id = [n](int i, int j) { return j * (n + 1) + i; };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      if ((i + j) % 2 == 0) {
        m.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
        m.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
      } else {
        m.triangles.push_back({id(i, j), id(i + 1, j), id(i, j + 1)});
        m.triangles.push_back({id(i + 1, j), id(i + 1, j + 1), id(i, j + 1)});
      }
    }
  return m;
}

template <class T>
twinray::Material<T> material(T r, T g, T b, T glaze = T(0), T shininess = T(65)) {
  twinray::Material<T> m;
  m.color = V3<T>(r, g, b);
  m.ka = T(0.1), m.kd = T(0.7), m.ks = T(0.5), m.shininess = shininess, m.glaze = glaze;
  return m;
}

template <class T>
twinray::Camera<T> perspective(V3<T> pos, V3<T> look, V3<T> up, T vp_height, int w, int h) {
  twinray::Camera<T> c;
  c.position = pos, c.look_at = look, c.up = up, c.viewplane_height = vp_height;
  c.width = w, c.height = h;
  return c;
}

// The camera ray of pixel (x, y) through its center, exactly as the device makes it.
template <class T>
typename twinray::device::Code<T>::Params params_of(const twinray::Scene<T>& scene,
                                                    const twinray::Camera<T>& cam) {
  twinray::RenderOptions o;
  return test_support::pack(scene, cam, o).params();
}

template <class T>
struct RayT {
  V3<T> o, d;
};

template <class T>
RayT<T> camera_ray(const typename twinray::device::Code<T>::Params& p, int x, int y) {
  using K = typename twinray::device::Code<T>::template Kernel<TR_F_ALL>;
  auto smp = K::tr_sample_position(0, 0, 1, x, y);
  auto r = K::tr_camera_ray(&p, x, y, smp);
  return {r.o, r.d};
}

// Scales of the sweep (1e-4 .. 1e5) and the offsets, in units of the scene's
// size: at the origin and 1e4 sizes away.
inline std::vector<double> sweep_scales() {
  return {1e-4, 1e-2, 1.0, 1e2, 1e5};
}
inline std::vector<double> sweep_offsets() {
  return {0.0, 1e4};
}

// ================================================================ the cases

enum class Shape { Sphere, Plane, Mesh, InsideSphere };
inline const char* shape_name(Shape s) {
  return s == Shape::Sphere  ? "sphere"
         : s == Shape::Plane ? "plane"
         : s == Shape::Mesh  ? "mesh"
                             : "inside";
}

template <class T>
V3<T> far_direction() {
  return glm::normalize(V3<T>(T(0.6), T(-0.3), T(0.7)));
}

// Acne. One convex object (or a sphere seen from inside) and a point light, nothing
// that can occlude: the image with shadow rays must equal, bit for bit, the image
// without them; and with a glazed material, the image with reflected rays (which can
// hit nothing, background black) must equal the one without. acne = differing pixels.
// The map of an instanced case: the unit object scaled unevenly by `scale` x (1, 0.8,
// 1.2), mirrored in x, turned 30 degrees about (1, 1, 0) and moved to `center`.
inline glm::dmat4 instance_map(glm::dvec3 center, double scale) {
  glm::dmat4 m = twinray::Transform::scale_rotate_translate({scale, 0.8 * scale, 1.2 * scale},
                                                            {1, 1, 0}, 30.0, center)
                     .m;
  glm::dmat4 mirror(1.0);
  mirror[0][0] = -1.0;
  return m * mirror;
}

// Adds `object` (built at the origin, unit size) as the one object of an asset, placed
// by instance_map(center, scale).
template <class T>
void add_instanced(twinray::Scene<T>& scene, twinray::Object<T> object, V3<T> center,
                   double scale) {
  twinray::Asset<T> asset;
  asset.name = "unit";
  asset.objects.push_back(std::move(object));
  scene.add_instance(scene.add_asset(asset), instance_map(glm::dvec3(center), scale));
}

// With `instanced`, the sphere or mesh is an asset's unit object, placed by
// instance_map: scaled unevenly (an ellipsoid, still convex), mirrored and turned, so
// every hit is found in the asset's space and mapped back (device/instance.h).
template <class T>
Figures case_acne(Ctx& ctx, Shape shape, double scale, double offset_sizes, int size = 40,
                  bool instanced = false) {
  const T s = T(scale);
  const V3<T> off = far_direction<T>() * T(scale * offset_sizes);
  twinray::Scene<T> scene;
  int mat = scene.add_material(material<T>(T(0.8), T(0.5), T(0.3), T(0.5)));
  twinray::Camera<T> cam;
  V3<T> light;
  switch (shape) {
    case Shape::Sphere:
    case Shape::Mesh:
      if (instanced)
        add_instanced(scene,
                      shape == Shape::Sphere
                          ? twinray::Object<T>(twinray::Sphere<T>{V3<T>(0), T(1), mat})
                          : twinray::Object<T>(icosphere<T>(V3<T>(0), T(1), 1, mat)),
                      off, scale);
      else if (shape == Shape::Sphere)
        scene.add(twinray::Sphere<T>{off, s, mat});
      else
        scene.add(icosphere<T>(off, s, 1, mat));
      cam = perspective<T>(off + V3<T>(T(1.5), T(2), T(4)) * s, off, V3<T>(0, 1, 0), T(3.2) * s,
                           size, size);
      light = off + V3<T>(T(-3), T(4), T(3)) * s;
      break;
    case Shape::Plane:
      scene.add(twinray::Plane<T>{off, V3<T>(T(0.1), T(1), T(0.2)), mat});
      cam = perspective<T>(off + V3<T>(0, 2, 6) * s, off + V3<T>(0, 0, -4) * s, V3<T>(0, 1, 0),
                           T(6) * s, size, size);
      light = off + V3<T>(T(1), T(3), T(-2)) * s;
      break;
    case Shape::InsideSphere:
      if (instanced)
        add_instanced(scene, twinray::Object<T>(twinray::Sphere<T>{V3<T>(0), T(1), mat}), off,
                      scale);
      else
        scene.add(twinray::Sphere<T>{off, s, mat});
      cam = perspective<T>(off + V3<T>(T(0.2), T(0.1), T(0.3)) * s, off + V3<T>(0, 0, -1) * s,
                           V3<T>(0, 1, 0), T(2.4) * s, size, size);
      light = off + V3<T>(T(-0.3), T(0.4), T(0.2)) * s;
      break;
  }
  T intensity = shape == Shape::InsideSphere ? T(0.3) : T(10);  // exposure: E ~ 0.3..1
  scene.add_light(twinray::Light<T>{light, intensity * s * s, V3<T>(1, 1, 1)});
  twinray::RenderOptions o;
  o.max_depth = 1;
  o.glaze = false;
  o.shadows = true;
  twinray::Image<T> with_shadows = render(ctx, scene, cam, o);
  o.shadows = false;
  twinray::Image<T> without = render(ctx, scene, cam, o);
  Figures f;
  f.samples = (long long)size * size;
  f.acne = count_differing_pixels(with_shadows, without);
  f.nonfinite = count_nonfinite(with_shadows) + count_nonfinite(without);
  if (shape != Shape::InsideSphere) {  // from inside, reflected rays do hit the sphere
    o.glaze = true;
    o.max_depth = 4;
    twinray::Image<T> glazed = render(ctx, scene, cam, o);
    f.acne += count_differing_pixels(glazed, without);
    f.nonfinite += count_nonfinite(glazed);
  }
  if (ctx.on_image)
    ctx.on_image(std::string("acne_") + shape_name(shape) + "_" + std::to_string(scale),
                 &with_shadows);
  return f;
}

template <class T>
Figures case_acne_sweep(Ctx& ctx, Shape shape, bool instanced = false) {
  Figures f;
  for (double s : sweep_scales())
    for (double off : sweep_offsets()) f.add(case_acne<T>(ctx, shape, s, off, 40, instanced));
  return f;
}

// Depth AOV of a scene; leaks = pixels in `must_hit` that hit nothing (t = +inf).
template <class T>
twinray::Image<T> depth_image(Ctx& ctx, const twinray::Scene<T>& scene,
                              const twinray::Camera<T>& cam) {
  twinray::RenderOptions o;
  o.output = twinray::Output::Depth;
  return render(ctx, scene, cam, o);
}

// Watertight, tiled: an n x n grid of quads (two triangles each, alternating diagonals)
// seen by an orthographic camera whose pixel centers fall on the grid's vertices, edge
// midpoints and diagonals (every 4th pixel is a vertex), and by an oblique perspective
// camera. Every ray that lands inside the grid must hit it.
template <class T>
Figures case_watertight_grid(Ctx& ctx, double scale, double offset_sizes, bool tilted) {
  const int n = 8;
  const T s = T(scale);
  const V3<T> off = far_direction<T>() * T(scale * offset_sizes * n);
  V3<T> ex = V3<T>(s, 0, 0), ey = V3<T>(0, s, 0);
  if (tilted) ex = V3<T>(s, T(0), T(0.375) * s), ey = V3<T>(T(0.25) * s, s, T(-0.125) * s);
  twinray::Scene<T> scene;
  int mat = scene.add_material(material<T>(T(0.5), T(0.5), T(0.5)));
  scene.add(grid_mesh<T>(off, ex, ey, n, mat));
  Figures f;
  f.leaks = 0;
  // Orthographic, straight down the grid normal: pixel (i, j) is at grid coordinates
  // (i/4, (4n - j)/4), so pixel centers sit on vertices, edges and diagonals.
  {
    const int w = 4 * n + 1;
    V3<T> center = off + (ex + ey) * T(n / 2);
    V3<T> normal = glm::normalize(glm::cross(ex, ey));
    twinray::Camera<T> cam;
    cam.projection = twinray::Projection::Orthographic;
    cam.position = center + normal * (T(4) * s);
    cam.look_at = center;
    cam.up = ey;
    cam.viewplane_height = T(w) * s / T(4);
    cam.width = cam.height = w;
    twinray::Image<T> depth = depth_image(ctx, scene, cam);
    for (int y = 1; y + 1 < w; ++y)
      for (int x = 1; x + 1 < w; ++x)
        if (!tilted && std::isinf(depth.pixel(x, y)[0])) ++f.leaks;
    f.nonfinite += count_nonfinite(depth, true);
    f.samples += tilted ? 0 : (long long)(w - 2) * (w - 2);
  }
  // Oblique perspective views: each ray whose exact hit point (binary128) lies inside
  // the grid by more than a relative 2^-20 of its size must hit.
  for (int view = 0; view < 2; ++view) {
    const int w = 48;
    V3<T> center = off + (ex + ey) * T(n / 2);
    V3<T> normal = glm::normalize(glm::cross(ex, ey));
    V3<T> side = view == 0 ? ex : ey * T(-1);
    twinray::Camera<T> cam =
        perspective<T>(center + normal * (T(3) * s) + side * T(5), center, normal, T(n) * s, w, w);
    if (view == 1) cam.position = center + normal * (T(0.5) * s) + side * T(3) + ex * T(0.5);
    twinray::Image<T> depth = depth_image(ctx, scene, cam);
    auto p = params_of(scene, cam);
    VL o0 = to_ld(off), eX = to_ld(ex), eY = to_ld(ey);
    for (int y = 0; y < w; ++y)
      for (int x = 0; x < w; ++x) {
        RayT<T> r = camera_ray<T>(p, x, y);
        // Intersect the grid's plane in binary128, express in grid coordinates.
        VL nrm = cross_ld(eX, eY);
        LD den = dot_ld(nrm, to_ld(r.d));
        if (den == 0) continue;
        LD t = dot_ld(nrm, o0 - to_ld(r.o)) / den;
        if (!(t > 0)) continue;
        VL q = to_ld(r.o) + to_ld(r.d) * t - o0;
        // Solve q = a ex + b ey (least squares on the 2x2 normal equations).
        LD g11 = dot_ld(eX, eX), g12 = dot_ld(eX, eY), g22 = dot_ld(eY, eY);
        LD r1 = dot_ld(q, eX), r2 = dot_ld(q, eY), det = g11 * g22 - g12 * g12;
        LD a = (r1 * g22 - r2 * g12) / det, b = (r2 * g11 - r1 * g12) / det;
        LD margin = LD(n) * ldexpq(LD(1), -20);
        if (a > margin && b > margin && a < n - margin && b < n - margin) {
          ++f.samples;
          if (std::isinf(depth.pixel(x, y)[0])) ++f.leaks;
        }
      }
    f.nonfinite += count_nonfinite(depth, true);
  }
  return f;
}

// What a closed mesh around `center` (about `radius` across) must show: from a camera
// inside it, in three directions, every pixel hits; and with single_rays, single rays
// from `center` and `second_origin` aimed exactly at every vertex and every edge
// midpoint of `mesh` (placed in the world by `mapped`) all hit (CPU device code).
template <class T, class Map>
void check_closed_mesh(Ctx& ctx, const twinray::Scene<T>& scene, V3<T> center, T radius,
                       const twinray::Mesh<T>& mesh, Map mapped, V3<T> second_origin,
                       bool single_rays, Figures& f) {
  f.leaks = 0;
  const int w = 48;
  for (int view = 0; view < 3; ++view) {
    V3<T> dir = view == 0 ? V3<T>(0, 0, -1) : view == 1 ? V3<T>(1, 0.5, 0.2) : V3<T>(-0.3, -1, 0.4);
    V3<T> pos = center + V3<T>(T(0.1), T(-0.2), T(0.15)) * radius;
    twinray::Camera<T> cam =
        perspective<T>(pos, pos + dir * radius, V3<T>(0.3, 1, -0.2), T(3.5) * radius, w, w);
    twinray::Image<T> depth = depth_image(ctx, scene, cam);
    for (int y = 0; y < w; ++y)
      for (int x = 0; x < w; ++x) {
        ++f.samples;
        if (std::isinf(depth.pixel(x, y)[0])) ++f.leaks;
      }
    f.nonfinite += count_nonfinite(depth, true);
  }
  if (!single_rays) return;
  using K = typename twinray::device::Code<T>::template Kernel<TR_F_ALL>;
  twinray::RenderOptions o;
  twinray::Camera<T> cam;
  cam.position = center + V3<T>(0, 0, 1) * radius;
  cam.look_at = center;
  cam.up = V3<T>(0, 1, 0);
  auto ps = test_support::pack(scene, cam, o);
  auto sref = ps.ref();
  std::vector<V3<T>> targets;
  for (const auto& v : mesh.vertices) targets.push_back(mapped(v));
  for (auto& t : mesh.triangles)
    for (int e = 0; e < 3; ++e)
      targets.push_back(mapped((mesh.vertices[t[e]] + mesh.vertices[t[(e + 1) % 3]]) * T(0.5)));
  V3<T> origins[2] = {center, second_origin};
  for (const V3<T>& from : origins)
    for (const V3<T>& target : targets) {
      decltype(K::tr_camera_ray(&ps.params(), 0, 0, K::tr_sample_position(0, 0, 1, 0, 0))) ray;
      ray.o = from;
      ray.d = K::tr_normalize(target - from);
      auto hit = K::tr_no_hit();
      ++f.samples;
      if (!K::tr_closest_hit(&sref, &ray, T(INFINITY), &hit))
        ++f.leaks;
      else if (!std::isfinite(hit.t))
        ++f.nonfinite;
    }
}

// Watertight, closed: a jittered icosphere (1280 triangles) seen from a camera inside
// it (every pixel must hit), plus single rays from an interior point aimed exactly at
// every vertex and every edge midpoint (CPU device code; every one must hit).
template <class T>
Figures case_watertight_closed(Ctx& ctx, V3<T> center, T radius, bool single_rays) {
  twinray::Scene<T> scene;
  int mat = scene.add_material(material<T>(T(0.5), T(0.5), T(0.5)));
  twinray::Mesh<T> mesh = icosphere<T>(center, radius, 3, mat, 7u, T(0.02));
  scene.add(mesh);
  Figures f;
  check_closed_mesh(
      ctx, scene, center, radius, mesh, [](const V3<T>& v) { return v; },
      center + V3<T>(T(0.31), T(-0.27), T(0.19)) * radius, single_rays, f);
  return f;
}

// Watertight through instances: the jittered icosphere of case_watertight_closed built
// at the origin with radius 1 and placed by instance_map(center, radius), whole or as
// two assets (the triangles on either side of z = 0) placed by the same map, meeting at
// a seam. Seen from a camera inside (every pixel must hit), and single rays from
// interior points aimed exactly at every mapped vertex and edge midpoint (every one
// must hit: at the seam, the two halves' triangles share those edges bit for bit in
// the assets' space, and both see the same mapped ray).
template <class T>
Figures case_watertight_instanced(Ctx& ctx, V3<T> center, double radius, bool halves) {
  twinray::Scene<T> scene;
  int mat = scene.add_material(material<T>(T(0.5), T(0.5), T(0.5)));
  twinray::Mesh<T> mesh = icosphere<T>(V3<T>(0), T(1), 3, mat, 7u, T(0.02));
  const glm::dmat4 map = instance_map(glm::dvec3(center), radius);
  std::vector<twinray::Mesh<T>> parts;
  if (halves) {
    parts.assign(2, mesh);
    parts[0].triangles.clear();
    parts[1].triangles.clear();
    for (const auto& t : mesh.triangles) {
      T z = mesh.vertices[t[0]].z + mesh.vertices[t[1]].z + mesh.vertices[t[2]].z;
      parts[z < T(0) ? 0 : 1].triangles.push_back(t);
    }
  } else {
    parts.push_back(mesh);
  }
  for (const auto& part : parts) {
    twinray::Asset<T> asset;
    asset.objects.push_back(part);
    scene.add_instance(scene.add_asset(asset), map);
  }
  const T r = T(radius);
  Figures f;
  check_closed_mesh(
      ctx, scene, center, r, mesh,
      [&](const V3<T>& v) { return V3<T>(map * glm::dvec4(glm::dvec3(v), 1.0)); },
      center + V3<T>(T(0.31), T(-0.27), T(0.19)) * T(0.5) * r, true, f);
  return f;
}

// A tiny sphere far away (Haines et al. RTG ch. 7, Fig. 7-3): r = 1 at distance D from
// an orthographic camera. The hit mask must equal the analytic disk test
// |center - ray line| < r (binary128, same rays) except within a band of
// 16 u |f| around the rim (the rounding of f - (f.d)d, |f| = D). wrong = other pixels.
template <class T>
Figures case_tiny_far_sphere(Ctx& ctx, double distance) {
  twinray::Scene<T> scene;
  int mat = scene.add_material(material<T>(T(0.8), T(0.8), T(0.8)));
  V3<T> c(T(0.013), T(-0.021), T(-distance));
  scene.add(twinray::Sphere<T>{c, T(1), mat});
  scene.add_light(twinray::Light<T>{V3<T>(T(-distance), T(distance), T(0)), T(distance * distance),
                                    V3<T>(1, 1, 1)});
  twinray::Camera<T> cam;
  cam.projection = twinray::Projection::Orthographic;
  cam.position = V3<T>(0, 0, 0);
  cam.look_at = V3<T>(0, 0, -1);
  cam.up = V3<T>(0, 1, 0);
  cam.viewplane_height = T(2.5);
  cam.width = cam.height = 41;
  twinray::RenderOptions o;
  o.output = twinray::Output::ObjectIndex;
  twinray::Image<T> obj = render(ctx, scene, cam, o);
  o.output = twinray::Output::Shaded;
  twinray::Image<T> shaded = render(ctx, scene, cam, o);
  auto p = params_of(scene, cam);
  Figures f;
  f.wrong = 0;
  const LD band = 16 * ldexpq(LD(1), -digits<T>()) * LD(distance);
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      RayT<T> r = camera_ray<T>(p, x, y);
      VL fo = to_ld(r.o) - to_ld(c), d = to_ld(r.d);
      VL perp = fo - d * (dot_ld(fo, d) / dot_ld(d, d));
      LD l = qsqrt(dot_ld(perp, perp));
      bool want = l < 1, got = obj.pixel(x, y)[0] == T(0);
      ++f.samples;
      if (want != got && qabs(l - 1) > band) ++f.wrong;
    }
  f.nonfinite = count_nonfinite(obj) + count_nonfinite(shaded);
  if (ctx.on_image) ctx.on_image("tiny_far_sphere_" + std::to_string(distance), &shaded);
  return f;
}

// Per-pixel t against a binary128 reference for one sphere/plane scene: ulps error
// of hit pixels, and hit/miss disagreements where the reference is unambiguous.
template <class T>
void depth_against_reference(const twinray::Image<T>& depth, const twinray::Scene<T>& scene,
                             const twinray::Camera<T>& cam,
                             const std::function<LD(const RayT<T>&, LD*)>& reference, Figures& f) {
  auto p = params_of(scene, cam);
  std::vector<double> errs;
  if (f.wrong < 0) f.wrong = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      RayT<T> r = camera_ray<T>(p, x, y);
      LD ambiguity = 0;  // > 0: how close the reference is to a hit/miss boundary
      LD tr = reference(r, &ambiguity);
      T t = depth.pixel(x, y)[0];
      ++f.samples;
      bool want = !qisnan(tr), got = std::isfinite(t);
      if (want != got) {
        if (!(ambiguity > 0)) ++f.wrong;
        continue;
      }
      if (want) errs.push_back(ulps_between<T>(t, tr));
    }
  if (!errs.empty()) {
    f.terr_max = std::max(f.terr_max, *std::max_element(errs.begin(), errs.end()));
    f.terr_median = std::max(f.terr_median, median(errs));
  }
  f.nonfinite += count_nonfinite(depth, true);
}

// A huge sphere close by (RTG ch. 7, Fig. 7-4): a 1e5-radius sphere as the ground,
// camera 1 above it looking toward the horizon. Its hit distances must match the long
// double reference, and it must cover the image like the tangent plane y = 0 does,
// except in the rows where the two part (the horizon dips by sqrt(2h/R)).
template <class T>
Figures case_huge_sphere(Ctx& ctx) {
  const T R = T(1e5);
  twinray::Scene<T> scene;
  int mat = scene.add_material(material<T>(T(0.3), T(0.7), T(0.3)));
  V3<T> c(0, -R, 0);
  scene.add(twinray::Sphere<T>{c, R, mat});
  scene.add_light(twinray::Light<T>{V3<T>(T(3), T(50), T(-20)), T(1200), V3<T>(1, 1, 1)});
  twinray::Camera<T> cam =
      perspective<T>(V3<T>(0, 1, 0), V3<T>(T(0), T(0.8), T(-4)), V3<T>(0, 1, 0), T(3), 64, 48);
  Figures f;
  twinray::Image<T> depth = depth_image(ctx, scene, cam);
  depth_against_reference<T>(
      depth, scene, cam,
      [&](const RayT<T>& r, LD* amb) {
        VL fo = to_ld(r.o) - to_ld(c), d = to_ld(r.d);
        VL perp = fo - d * (dot_ld(fo, d) / dot_ld(d, d));
        LD l = qsqrt(dot_ld(perp, perp));
        *amb = qabs(l - LD(R)) < LD(1e-3) * LD(R) ? 1 : 0;
        return ref_sphere_t(to_ld(r.o), d, to_ld(c), LD(R));
      },
      f);
  // The same view of the plane y = 0: where the plane is hit closer than 100 (the
  // sphere lies below it by at most t^2/2R = 0.05 there), the sphere must be hit too.
  twinray::Scene<T> flat;
  flat.add_material(material<T>(T(0.3), T(0.7), T(0.3)));
  flat.add(twinray::Plane<T>{V3<T>(0, 0, 0), V3<T>(0, 1, 0), 0});
  twinray::Image<T> flat_depth = depth_image(ctx, flat, cam);
  for (size_t i = 0; i < depth.rgb.size(); i += 3)
    if (flat_depth.rgb[i] < T(100) && !std::isfinite(depth.rgb[i])) ++f.wrong;
  twinray::RenderOptions o;
  twinray::Image<T> shaded = render(ctx, scene, cam, o);
  f.nonfinite += count_nonfinite(shaded);
  if (ctx.on_image) ctx.on_image("huge_sphere", &shaded);
  return f;
}

// Grazing: the plane y = 0 seen from h above it, looking at the horizon. Rays going up
// or exactly parallel must miss; rays going down must hit at t = h/|d.y| (reference in
// binary128). Also an orthographic camera whose rays are all exactly parallel to the
// plane (all miss), and a camera exactly in the plane (t = 0 is no hit). With a light,
// shadow rays must not change a pixel (acne).
template <class T>
Figures case_grazing(Ctx& ctx, double height, double offset) {
  twinray::Scene<T> scene;
  int mat = scene.add_material(material<T>(T(0.7), T(0.7), T(0.7)));
  V3<T> base(T(offset), T(0), T(-offset));
  scene.add(twinray::Plane<T>{base, V3<T>(0, 1, 0), mat});
  scene.add_light(twinray::Light<T>{base + V3<T>(T(2), T(3), T(-10)), T(100), V3<T>(1, 1, 1)});
  V3<T> pos = base + V3<T>(0, T(height), 0);
  twinray::Camera<T> cam =
      perspective<T>(pos, pos + V3<T>(0, 0, -1), V3<T>(0, 1, 0), T(0.5), 48, 33);
  Figures f;
  twinray::Image<T> depth = depth_image(ctx, scene, cam);
  depth_against_reference<T>(
      depth, scene, cam,
      [&](const RayT<T>& r, LD* amb) {
        *amb = 0;
        return ref_plane_t(to_ld(r.o), to_ld(r.d), to_ld(base), VL(0, 1, 0));
      },
      f);
  twinray::RenderOptions o;
  twinray::Image<T> lit = render(ctx, scene, cam, o);
  o.shadows = false;
  twinray::Image<T> unshadowed = render(ctx, scene, cam, o);
  f.acne = count_differing_pixels(lit, unshadowed);
  f.nonfinite += count_nonfinite(lit) + count_nonfinite(unshadowed);
  if (ctx.on_image) ctx.on_image("grazing_" + std::to_string(height), &lit);
  // Exactly parallel rays, some of them starting in the plane or below it.
  twinray::Camera<T> ortho;
  ortho.projection = twinray::Projection::Orthographic;
  ortho.position = pos;
  ortho.look_at = pos + V3<T>(0, 0, -1);
  ortho.up = V3<T>(0, 1, 0);
  ortho.viewplane_height = T(4 * height + 1e-3);
  ortho.width = ortho.height = 17;
  twinray::Image<T> par = depth_image(ctx, scene, ortho);
  for (size_t i = 0; i < par.rgb.size(); i += 3) {
    ++f.samples;
    if (!std::isinf(par.rgb[i])) ++f.wrong;
  }
  // Camera exactly in the plane: every t is 0 or negative, so nothing is hit.
  twinray::Camera<T> in_plane = cam;
  in_plane.position = base;
  in_plane.look_at = base + V3<T>(T(0), T(-0.1), T(-1));
  twinray::Image<T> flat = depth_image(ctx, scene, in_plane);
  for (size_t i = 0; i < flat.rgb.size(); i += 3) {
    ++f.samples;
    if (!std::isinf(flat.rgb[i])) ++f.wrong;
  }
  f.nonfinite += count_nonfinite(par, true) + count_nonfinite(flat, true);
  return f;
}

// Degenerate and needle triangles: zero-area triangles (collinear, repeated vertex, a
// single point) are never hit; a unit square cut in two by a needle of aspect 1e7 stays
// watertight, also for rays aimed exactly along the needle's long edges; every value
// is finite.
template <class T>
Figures case_degenerate(Ctx& ctx, double scale) {
  const T s = T(scale);
  twinray::Scene<T> scene;
  int mat = scene.add_material(material<T>(T(0.6), T(0.6), T(0.9)));
  using Tri = twinray::Triangle<T>;
  scene.add(Tri{{V3<T>(0, 0, 0) * s, V3<T>(1, 1, 0) * s, V3<T>(2, 2, 0) * s}, mat});  // collinear
  scene.add(
      Tri{{V3<T>(0, 1, 0) * s, V3<T>(0, 1, 0) * s, V3<T>(1, 0, 0) * s}, mat});  // repeated vertex
  scene.add(Tri{
      {V3<T>(T(0.5), T(0.5), 0) * s, V3<T>(T(0.5), T(0.5), 0) * s, V3<T>(T(0.5), T(0.5), 0) * s},
      mat});
  // Unit square (bottom edge on y = 0) split along y = 0.5 by a needle triangle a b m,
  // m 1e-7 s above the midpoint of a b: aspect 1e7, and all three of its edges shared
  // (a b with the lower half, a m and m b with the fan above), so every ray that lands
  // inside the square away from its open outer boundary must hit one triangle.
  twinray::Mesh<T> sq;
  sq.material = mat;
  sq.vertices = {V3<T>(T(-0.5), 0, 0),         V3<T>(T(0.5), 0, 0),       V3<T>(T(0.5), 1, 0),
                 V3<T>(T(-0.5), 1, 0),         V3<T>(T(-0.5), T(0.5), 0), V3<T>(T(0.5), T(0.5), 0),
                 V3<T>(0, T(0.5) + T(1e-7), 0)};
  for (V3<T>& v : sq.vertices) v = v * s + V3<T>(0, 0, -1) * s;
  const V3<T> a = sq.vertices[4], b = sq.vertices[5], m = sq.vertices[6];
  sq.triangles = {{0, 1, 5}, {0, 5, 4}, {4, 5, 6}, {4, 6, 3}, {6, 5, 2}, {6, 2, 3}};
  int square = scene.add(sq);
  scene.add_light(twinray::Light<T>{V3<T>(1, 2, 3) * s, T(10) * s * s, V3<T>(1, 1, 1)});
  Figures f;
  f.leaks = 0;
  f.wrong = 0;
  twinray::Camera<T> cam = perspective<T>(V3<T>(T(0.2), T(0.3), T(2)) * s, V3<T>(0, 0, -1) * s,
                                          V3<T>(0, 1, 0), T(3) * s, 40, 40);
  twinray::RenderOptions o;
  o.output = twinray::Output::ObjectIndex;
  twinray::Image<T> obj = render(ctx, scene, cam, o);
  for (size_t i = 0; i < obj.rgb.size(); i += 3)
    if (obj.rgb[i] >= T(0) && obj.rgb[i] < T(3)) ++f.wrong;  // a zero-area triangle was hit
  o.output = twinray::Output::Shaded;
  twinray::Image<T> shaded = render(ctx, scene, cam, o);
  o.output = twinray::Output::Depth;
  twinray::Image<T> depth = render(ctx, scene, cam, o);
  f.nonfinite += count_nonfinite(obj) + count_nonfinite(shaded) + count_nonfinite(depth, true);
  f.samples += (long long)obj.width * obj.height;
  // Single rays along the needles' long edges and through m, from a point in front.
  using K = typename twinray::device::Code<T>::template Kernel<TR_F_ALL>;
  auto ps = test_support::pack(scene, cam, twinray::RenderOptions{});
  auto sref = ps.ref();
  V3<T> from = V3<T>(T(0.1), T(0.55), T(1)) * s;
  for (int k = 1; k < 200; ++k) {
    T w = T(0.05) + T(0.9) * T(k) / T(200);  // away from the open boundary at a and b
    V3<T> targets[3] = {a + (m - a) * w, b + (m - b) * w, a + (b - a) * w};
    for (const V3<T>& target : targets) {
      decltype(K::tr_camera_ray(&ps.params(), 0, 0, K::tr_sample_position(0, 0, 1, 0, 0))) ray;
      ray.o = from;
      ray.d = K::tr_normalize(target - from);
      // Where the rounded ray really crosses the square's plane (binary128): only rays
      // landing inside the square (not on or beyond its open boundary) must hit it.
      VL o = to_ld(ray.o), d = to_ld(ray.d);
      LD t = (LD(sq.vertices[0].z) - o.z) / d.z;
      LD x = o.x + t * d.x, y = o.y + t * d.y;
      if (!(y > LD(0.1) * LD(s) && y < LD(0.9) * LD(s) && qabs(x) < LD(0.45) * LD(s))) continue;
      auto hit = K::tr_no_hit();
      ++f.samples;
      if (!K::tr_closest_hit(&sref, &ray, T(INFINITY), &hit) || hit.object != square)
        ++f.leaks;
      else if (!std::isfinite(hit.t) || !std::isfinite(hit.n.x))
        ++f.nonfinite;
    }
  }
  return f;
}

// Shininess 0, 1, 65, 1e4 and light intensity 0, 1, 1e30. Every value finite; the
// specular term is non-increasing in the shininess, pixel by pixel ((n.h)^s with
// n.h in [0, 1]; tolerance 64 u for the rounding of tr_pow_unit); intensity 0 gives
// exactly black; intensity 1e30 gives 1e30 x the intensity-1 image within 16 u
// (shading is linear in the intensity: a few roundings per term differ).
template <class T>
Figures case_shininess_intensity(Ctx& ctx) {
  Figures f;
  f.wrong = 0;
  const T u = std::ldexp(T(1), -digits<T>());
  auto make = [](T shininess, T intensity) {
    twinray::Scene<T> scene;
    int mat = scene.add_material(material<T>(T(0.9), T(0.4), T(0.2), T(0), shininess));
    scene.add(twinray::Sphere<T>{V3<T>(0, 0, 0), T(1), mat});
    scene.add(twinray::Plane<T>{V3<T>(0, -1, 0), V3<T>(0, 1, 0), mat});
    scene.add_light(twinray::Light<T>{V3<T>(2, 3, 3), intensity, V3<T>(1, 1, 1)});
    return scene;
  };
  twinray::Camera<T> cam =
      perspective<T>(V3<T>(0, 1, 4), V3<T>(0, 0, 0), V3<T>(0, 1, 0), T(4), 40, 40);
  twinray::RenderOptions spec;
  spec.terms = twinray::kSpecular;
  twinray::Image<T> prev;
  for (T shininess : {T(0), T(1), T(65), T(1e4)}) {
    twinray::Image<T> img = render(ctx, make(shininess, T(20)), cam, spec);
    f.nonfinite += count_nonfinite(img);
    f.samples += (long long)img.width * img.height;
    if (!prev.rgb.empty())
      for (size_t i = 0; i < img.rgb.size(); ++i)
        if (img.rgb[i] > prev.rgb[i] * (1 + 64 * u)) ++f.wrong;
    prev = img;
  }
  twinray::RenderOptions all;
  twinray::Image<T> one = render(ctx, make(T(65), T(1)), cam, all);
  twinray::Image<T> zero = render(ctx, make(T(65), T(0)), cam, all);
  twinray::Image<T> huge = render(ctx, make(T(65), T(1e30)), cam, all);
  f.nonfinite += count_nonfinite(one) + count_nonfinite(zero) + count_nonfinite(huge);
  f.rel_err_max = 0;
  for (size_t i = 0; i < one.rgb.size(); ++i) {
    if (zero.rgb[i] != T(0)) ++f.wrong;
    LD want = LD(one.rgb[i]) * LD(T(1e30)) / LD(T(1)), got = LD(huge.rgb[i]);
    LD rel = want == 0 ? (got == 0 ? 0 : 1) : qabs(got - want) / want;
    f.rel_err_max = std::max(f.rel_err_max, double(rel / u));  // in units of u
    if (rel > 16 * LD(u)) ++f.wrong;
  }
  return f;
}

// Two facing mirrors (planes z = -1 and z = +1, glaze k), an orthographic camera on
// z = 0 looking down -z and a light at the origin. Every camera ray bounces straight
// between the two planes; each hit at lateral offset (x, y) sees the light at distance
// dl = sqrt(x^2 + y^2 + 1) and shades to L = I/dl^2 (C (ka + kd n.l) + ks (n.h)^s).
// With max_depth = 64 ray segments the pixel is L (1 - k^64)/(1 - k), or 64 L for k = 1
// (closed-form geometric sum). Tolerance 256 u relative: ~40 roundings per shaded hit,
// 64 weighted additions and k^i rounding i times (rel_err_max is in units of u).
template <class T>
Figures case_mirrors(Ctx& ctx, T k) {
  const int depth = 64;
  twinray::Scene<T> scene;
  twinray::Material<T> m = material<T>(T(0.9), T(0.6), T(0.3), k, T(65));
  int mat = scene.add_material(m);
  scene.add(twinray::Plane<T>{V3<T>(0, 0, -1), V3<T>(0, 0, 1), mat});
  scene.add(twinray::Plane<T>{V3<T>(0, 0, 1), V3<T>(0, 0, -1), mat});
  const T intensity = T(2);
  scene.add_light(twinray::Light<T>{V3<T>(0, 0, 0), intensity, V3<T>(1, 1, 1)});
  twinray::Camera<T> cam;
  cam.projection = twinray::Projection::Orthographic;
  cam.position = V3<T>(0, 0, 0);
  cam.look_at = V3<T>(0, 0, -1);
  cam.up = V3<T>(0, 1, 0);
  cam.viewplane_height = T(3);
  cam.width = cam.height = 24;
  twinray::RenderOptions o;
  o.max_depth = depth;
  twinray::Image<T> img = render(ctx, scene, cam, o);
  auto p = params_of(scene, cam);
  Figures f;
  f.wrong = 0;
  f.rel_err_max = 0;
  const LD u = ldexpq(LD(1), -digits<T>());
  const LD kk = LD(k);
  const LD sum = kk == 1 ? LD(depth) : (1 - powq(kk, LD(depth))) / (1 - kk);
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      RayT<T> r = camera_ray<T>(p, x, y);
      LD lx = LD(r.o.x), ly = LD(r.o.y);
      LD dl2 = lx * lx + ly * ly + 1, dl = qsqrt(dl2);
      LD e = LD(intensity) / dl2;
      LD ndotl = 1 / dl;
      VL h = VL(-lx / dl, -ly / dl, 1 / dl + 1);
      LD ndoth = h.z / qsqrt(dot_ld(h, h));
      LD spec = LD(m.ks) * powq(ndoth, LD(m.shininess));
      for (int ch = 0; ch < 3; ++ch) {
        LD albedo = LD(m.color[ch]);
        LD local = e * (albedo * LD(m.ka) + albedo * LD(m.kd) * ndotl + spec);
        LD want = local * sum;
        LD rel = qabs(LD(img.pixel(x, y)[ch]) - want) / want;
        f.rel_err_max = std::max(f.rel_err_max, double(rel / u));
        if (rel > 256 * u) ++f.wrong;
      }
      ++f.samples;
    }
  f.nonfinite = count_nonfinite(img);
  return f;
}

// Glass: a slab of thickness h between two parallel planes, seen by an orthographic
// camera at angle theta to its normal against a white background (no lights, no surface
// terms). Every ray ends in the background, so each pixel is the slab's reflectance
// plus transmittance, the sum of all its internal reflections:
//   R + T = F + (1 - F)^2 (F tau^2 + tau) / (1 - F^2 tau^2),
// F = the Fresnel reflectance at theta, tau = e^(-a h / cos theta_t) over one crossing.
// A ray that hits the face it starts from (acne) adds an interface and a reflection; one
// that slips through a face (a leak) drops one; both move the pixel by about F or more.
// Tolerance 2^-8: what the renderer leaves in rays under its weight cutoff (2^-10) and
// past max_depth, plus float rounding. Scale and offset as the acne sweep; `thin` makes
// the slab 1e-3 of the scene's size (its thickness taken as rounded to T).
template <class T>
Figures case_glass_slab(Ctx& ctx, double scale, double offset_sizes, double degrees, bool thin) {
  const double h = (thin ? 1e-3 : 0.5) * scale;
  const V3<T> off = far_direction<T>() * T(scale * offset_sizes);
  twinray::Scene<T> scene;
  scene.background = V3<T>(1, 1, 1);
  twinray::Material<T> glass;
  glass.ka = glass.kd = glass.ks = T(0);
  glass.transmission = T(1);
  glass.ior = T(1.5);
  glass.absorption = V3<T>(T(0.2 / scale), T(0.8 / scale), T(2 / scale));
  int mat = scene.add_material(glass);
  const V3<T> n(0, 0, 1);
  const V3<T> front = off, back = off - n * T(h);
  scene.add(twinray::Plane<T>{front, n, mat});
  scene.add(twinray::Plane<T>{back, -n, mat});
  // The thickness the renderer sees: the two faces as rounded to T (far from the origin
  // a float sheet 1e-3 of the scene thick is only a few ulps of its position).
  const LD thickness = LD(front.z) - LD(back.z);
  const double a = degrees * M_PI / 180;
  twinray::Camera<T> cam;
  cam.projection = twinray::Projection::Orthographic;
  cam.position = off + V3<T>(T(std::sin(a)), 0, T(std::cos(a))) * T(4 * scale);
  cam.look_at = off;
  cam.up = V3<T>(0, 1, 0);
  cam.viewplane_height = T(scale);
  cam.width = cam.height = 12;
  twinray::RenderOptions o;
  o.max_depth = 32;
  twinray::Image<T> img = render(ctx, scene, cam, o);
  // The closed form from the directions the renderer used (binary128).
  auto p = params_of(scene, cam);
  RayT<T> r = camera_ray<T>(p, 0, 0);
  const LD cos_i = -LD(r.d.z) / qsqrt(dot_ld(VL(r.d), VL(r.d)));
  const LD eta = LD(glass.ior);
  const LD sin2_t = (1 - cos_i * cos_i) / (eta * eta), cos_t = qsqrt(1 - sin2_t);
  const LD rpar = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
  const LD rper = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
  const LD f_ = (rpar * rpar + rper * rper) / 2;
  Figures f;
  f.wrong = 0;
  f.rel_err_max = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      for (int ch = 0; ch < 3; ++ch) {
        const LD tau = expq(-LD(glass.absorption[ch]) * thickness / cos_t);
        const LD want =
            f_ + (1 - f_) * (1 - f_) * (f_ * tau * tau + tau) / (1 - f_ * f_ * tau * tau);
        const LD err = qabs(LD(img.pixel(x, y)[ch]) - want);
        f.rel_err_max = std::max(f.rel_err_max, double(err / want));
        if (err > LD(1) / 256) ++f.wrong;
      }
      ++f.samples;
    }
  f.nonfinite = count_nonfinite(img);
  return f;
}

// Hit-distance error sweep (device code on the host; the depth AOVs above show the
// OpenCL side computes the same bits): random rays against one primitive at each scale
// of the sweep and each offset, |t - t_ref| in ulps of t_ref, t_ref in binary128
// from the same inputs. Rays aim inside the primitive (not grazing its rim or edges),
// so every one must hit: misses count as leaks.
enum class Prim { Sphere, Triangle, Plane };
inline const char* prim_name(Prim p) {
  return p == Prim::Sphere ? "sphere" : p == Prim::Triangle ? "triangle" : "plane";
}

template <class T>
Figures case_t_sweep(Prim prim, int rays_per_config = 400) {
  using K = typename twinray::device::Code<T>::template Kernel<TR_F_ALL>;
  using Code = twinray::device::Code<T>;
  Figures f;
  f.leaks = 0;
  std::vector<double> errs;
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> U(-1, 1);
  auto rand_dir = [&]() {
    for (;;) {
      V3<T> v(T(U(rng)), T(U(rng)), T(U(rng)));
      T l = glm::length(v);
      if (l > T(0.1) && l < T(1)) return v / l;
    }
  };
  for (double s : sweep_scales())
    for (double offs : sweep_offsets())
      for (int i = 0; i < rays_per_config; ++i) {
        const V3<T> off = far_direction<T>() * T(s * offs) + rand_dir() * T(s * 0.5);
        decltype(K::tr_camera_ray(nullptr, 0, 0, K::tr_sample_position(0, 0, 1, 0, 0))) ray;
        auto hit = K::tr_no_hit();
        int found = 0;
        LD tref = 0;
        if (prim == Prim::Sphere) {
          typename Code::Sphere sp{off.x, off.y, off.z, T(s * (0.5 + 0.5 * std::fabs(U(rng)))),
                                   0,     0,     0,     0};
          V3<T> c(sp.cx, sp.cy, sp.cz);
          bool inside = i % 4 == 0;
          V3<T> o = inside ? c + rand_dir() * (sp.radius * T(0.9))
                           : c + rand_dir() * (sp.radius * T(2 + 8 * std::fabs(U(rng))));
          // aim at a point of the sphere's inner 90 % disk, seen from o
          V3<T> target = c + rand_dir() * (sp.radius * T(0.9 * std::fabs(U(rng))));
          ray.o = o;
          ray.d = K::tr_normalize(target - o);
          found = K::tr_intersect_sphere(&sp, ray, T(INFINITY), &hit);
          tref = ref_sphere_t(to_ld(ray.o), to_ld(ray.d), to_ld(c), LD(sp.radius));
        } else if (prim == Prim::Triangle) {
          V3<T> p0 = off, p1 = off + rand_dir() * T(s), p2 = off + rand_dir() * T(s);
          typename Code::Triangle tri{p0.x, p0.y, p0.z, p1.x, p1.y, p1.z, p2.x, p2.y, p2.z, 0, 0};
          double b1 = 0.1 + 0.4 * std::fabs(U(rng)), b2 = 0.1 + 0.4 * std::fabs(U(rng));
          V3<T> target = p0 + (p1 - p0) * T(b1) + (p2 - p0) * T(b2);
          V3<T> o = target + rand_dir() * T(s * (1 + 4 * std::fabs(U(rng))));
          ray.o = o;
          ray.d = K::tr_normalize(target - o);
          LD minb = 0;
          tref = ref_triangle_t(to_ld(ray.o), to_ld(ray.d), to_ld(p0), to_ld(p1), to_ld(p2), &minb);
          VL n = cross_ld(to_ld(p1 - p0), to_ld(p2 - p0));
          LD cosang = qabs(dot_ld(n, to_ld(ray.d))) / qsqrt(dot_ld(n, n));
          if (!(minb > LD(0.01)) || cosang < LD(0.05)) {
            --i;  // sliver or grazing draw: not what this sweep measures
            continue;
          }
          found = K::tr_intersect_triangle(&tri, ray, T(INFINITY), &hit);
        } else {
          V3<T> n = rand_dir();
          typename Code::Plane pl{off.x, off.y, off.z, n.x, n.y, n.z, 0, 0};
          V3<T> d = rand_dir();
          if (std::fabs(glm::dot(d, n)) < T(0.05)) {
            --i;
            continue;
          }
          V3<T> o = off + rand_dir() * T(s * 0.5) + n * T(s * (glm::dot(d, n) > 0 ? -1 : 1));
          ray.o = o;
          ray.d = d;
          found = K::tr_intersect_plane(&pl, ray, T(INFINITY), &hit);
          tref = ref_plane_t(to_ld(ray.o), to_ld(ray.d), to_ld(off), to_ld(n));
        }
        ++f.samples;
        if (!found || qisnan(tref)) {
          ++f.leaks;
          continue;
        }
        if (!std::isfinite(hit.t)) ++f.nonfinite;
        errs.push_back(ulps_between<T>(hit.t, tref));
      }
  f.terr_max = errs.empty() ? -1 : *std::max_element(errs.begin(), errs.end());
  f.terr_median = median(errs);
  return f;
}

}  // namespace rb
