// The boxes the BVH builder works with: BasicBox, the records of the primitives
// (PrimRef) and their boxes. A primitive's box is computed in double and rounded
// outward to the scene's precision, so that it contains the primitive as the
// intersection tests see it, and a hit never lies outside the boxes above it.
#pragma once

#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

#include <twinray/core/large_array.hpp>
#include <twinray/core/parallel.hpp>
#include <twinray/device/code.hpp>

namespace twinray {
namespace bvh {

// Half the surface area of the box [lo, hi] (3 values each), 0 for an empty one (lo[0] >
// hi[0]): the SAH's measure, in double whatever R is. Boxes and the builder's bins
// (Builder::sah_split) both take it from here, so their areas are the same bits.
template <class R>
double half_area_of(const R* lo, const R* hi) {
  if (lo[0] > hi[0]) return 0;
  double dx = double(hi[0]) - lo[0], dy = double(hi[1]) - lo[1], dz = double(hi[2]) - lo[2];
  return dx * dy + dy * dz + dz * dx;
}

// An axis-aligned box. The builder keeps primitives' boxes in the scene's precision
// (R = T), rounded outward, so a million float primitives stream through each level of
// the build as 28-byte records; bins, centroid bounds and SAH costs are in double.
template <class R>
struct BasicBox {
  R lo[3] = {std::numeric_limits<R>::infinity(), std::numeric_limits<R>::infinity(),
             std::numeric_limits<R>::infinity()};
  R hi[3] = {-std::numeric_limits<R>::infinity(), -std::numeric_limits<R>::infinity(),
             -std::numeric_limits<R>::infinity()};
  template <class S>
  void grow(const BasicBox<S>& b) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = b.lo[a] < lo[a] ? R(b.lo[a]) : lo[a];
      hi[a] = b.hi[a] > hi[a] ? R(b.hi[a]) : hi[a];
    }
  }
  template <class S>
  void grow(const S p[3]) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = p[a] < lo[a] ? R(p[a]) : lo[a];
      hi[a] = p[a] > hi[a] ? R(p[a]) : hi[a];
    }
  }
  bool empty() const { return lo[0] > hi[0]; }
  double half_area() const { return half_area_of(lo, hi); }
  // The box converted to another precision, lane by lane (exact from float to double).
  template <class S>
  BasicBox<S> as() const {
    BasicBox<S> b;
    for (int a = 0; a < 3; ++a) b.lo[a] = S(lo[a]), b.hi[a] = S(hi[a]);
    return b;
  }
};
using Box = BasicBox<double>;

// One primitive as the builder sees it: its bounds, outward-rounded to R, and its id.
// The centroid is recomputed from the bounds where needed, in R, halved before the sum
// (no overflow). It need not be the exact midpoint: binning, partitioning and the
// centroid bounds all compute it with this one function.
template <class R>
struct PrimRef {
  BasicBox<R> box;
  int id;
  void centroid(R c[3]) const {
    for (int a = 0; a < 3; ++a) c[a] = midpoint(box.lo[a], box.hi[a]);
  }
  R centroid(int a) const { return midpoint(box.lo[a], box.hi[a]); }
  // The one centroid formula: binning, partitioning and the centroid bounds must agree
  // on it to the bit.
  static R midpoint(R lo, R hi) { return R(0.5) * lo + R(0.5) * hi; }
};

// The neighbour of r toward -inf (toward = -1) or +inf (+1), as std::nextafter gives it,
// for an r that is not NaN and not already the infinity it steps toward: one integer
// step of its bits. Inline, where glibc's nextafter is a call: the builder rounds six
// values per primitive and per node, and the calls were most of its first pass.
template <class R>
R step_toward(R r, int toward) {
  using Bits = typename std::conditional<sizeof(R) == 4, std::uint32_t, std::uint64_t>::type;
  if (r == R(0)) return R(toward) * std::numeric_limits<R>::denorm_min();
  Bits bits;
  std::memcpy(&bits, &r, sizeof bits);
  // Away from zero is one more in magnitude.
  const bool away = (r > R(0)) == (toward > 0);
  bits = away ? bits + 1 : bits - 1;
  std::memcpy(&r, &bits, sizeof bits);
  return r;
}

// v rounded to R toward -inf (down) or +inf (up): a box stays around what it bounds.
template <class R>
R round_down(double v) {
  R r = static_cast<R>(v);
  return static_cast<double>(r) > v ? step_toward(r, -1) : r;
}
template <class R>
R round_up(double v) {
  R r = static_cast<R>(v);
  return static_cast<double>(r) < v ? step_toward(r, +1) : r;
}

// A primitive's box, computed in double and rounded outward to T, so it contains the
// primitive as the tests see it.
template <class T>
BasicBox<T> rounded_box(const Box& box) {
  BasicBox<T> rounded;
  for (int a = 0; a < 3; ++a) {
    rounded.lo[a] = round_down<T>(box.lo[a]);
    rounded.hi[a] = round_up<T>(box.hi[a]);
  }
  return rounded;
}
template <class T>
BasicBox<T> primitive_box(const typename device::Code<T>::Sphere& s) {
  double c[3] = {s.cx, s.cy, s.cz}, rad = s.radius;
  Box box;
  for (int a = 0; a < 3; ++a) {
    box.lo[a] = c[a] - rad;
    box.hi[a] = c[a] + rad;
  }
  return rounded_box<T>(box);
}
template <class T>
BasicBox<T> primitive_box(const typename device::Code<T>::Triangle& t) {
  double p[3][3] = {{t.p0x, t.p0y, t.p0z}, {t.p1x, t.p1y, t.p1z}, {t.p2x, t.p2y, t.p2z}};
  Box box;
  for (auto& v : p) box.grow(v);
  return rounded_box<T>(box);
}
// The box of primitive i (spheres first, then triangles).
template <class T>
BasicBox<T> primitive_box(const LargeVector<typename device::Code<T>::Sphere>& spheres,
                          const LargeVector<typename device::Code<T>::Triangle>& triangles, int i) {
  const int n_spheres = static_cast<int>(spheres.size());
  return i < n_spheres ? primitive_box<T>(spheres[static_cast<size_t>(i)])
                       : primitive_box<T>(triangles[static_cast<size_t>(i - n_spheres)]);
}

// The builder's record of every primitive (spheres first, then triangles): its id and
// its box (primitive_box), filled on every thread.
template <class T>
LargeVector<PrimRef<T>> primitive_refs(
    const LargeVector<typename device::Code<T>::Sphere>& spheres,
    const LargeVector<typename device::Code<T>::Triangle>& triangles) {
  const int n = static_cast<int>(spheres.size() + triangles.size());
  LargeVector<PrimRef<T>> refs(static_cast<size_t>(n));
  parallel_for(n, 4096, [&](int i) {
    PrimRef<T>& r = refs[static_cast<size_t>(i)];
    r.id = i;
    r.box = primitive_box<T>(spheres, triangles, i);
  });
  return refs;
}

}  // namespace bvh
}  // namespace twinray
