/* twinray device prelude: the one place that knows C++17 and OpenCL C 1.2 differ.
 *
 * Every file under device/ is written in the common subset of both languages and
 * uses only what this prelude defines:
 *   real, vec3          scalar and 3-vector of the render's precision
 *   TR_VEC3(x, y, z)    vector construction ((float3)(a,b,c) is a comma expression in C++)
 *   TR_R(lit)           a literal of type real; device code uses dyadic literals only
 *                       (0.5, 1, 2^-24, ...), which every conversion keeps exact
 *   TR_FN               qualifier of every device function
 *   TR_FN_INLINE        the same, for small functions on the hottest paths (box and
 *                       primitive tests): always inlined on the host, where g++ otherwise
 *                       keeps them as calls and passes vectors through memory; PoCL
 *                       inlines every function into the kernel anyway
 *   TR_FN_NOINLINE      a function kept out of line on both sides, so that the code
 *                       holds one copy of it (the walks a ray packet falls back on)
 *   TR_GLOBAL           address space of pointers into scene buffers
 *   TR_HAS(bit)         compile-time test of the Features mask (TR_FEATURES)
 *   TR_COUNT_RAY()      counts a ray query in benchmark builds (host only; else nothing)
 *   TR_SIMD_LOOP        before a loop over the lanes of a wide node: keeps the host
 *                       compiler from unrolling a short constant-trip loop before its
 *                       loop vectorizer sees it. Unrolled, g++ left the 4-wide box loop
 *                       scalar, and clang 15 made the 8-wide one a 4-wide vector plus four
 *                       scalar lanes put together by inserts; kept, both make one 8-lane
 *                       vector per plane (docs/performance.md). Nothing on OpenCL
 *   TR_LANE_LOOP        before a loop over a packet's rays (one 16-ray group, or all of
 *                       them): TR_SIMD_LOOP under g++ (a group is one AVX-512 vector);
 *                       on an AVX-512 CPU under clang (PoCL, or the host), 16 lanes
 *                       and 512-bit registers, where LLVM 15 would pick 8 lanes for
 *                       `skylake-avx512` (TR_WIDE_VECTORS on every function lets the
 *                       backend use the 512-bit registers)
 *   TR_LOWEST_BIT(m)    index of the lowest set bit of a nonzero unsigned int (an
 *                       integer builtin on both sides: exact, so parity is not at stake)
 *   tr_mask64, TR_LOWEST_BIT64(m)
 *                       a 64-bit unsigned integer (one bit per ray of a packet) and the
 *                       index of its lowest set bit
 *   TR_POPCOUNT(m)      the number of set bits of an unsigned int
 *   TR_PREFETCH(p)      asks for the cache line at p ahead of its use (host only)
 *   TR_LANES_LE(a, b, n), TR_HOST_LANE_MASKS
 *                       the lanes k < n where a[k] <= b[k] as a bit mask, with x86's
 *                       movemask (host only; TR_HOST_LANE_MASKS 0 elsewhere)
 *   TR_ALIGNED(n), TR_LINE_BYTES
 *                       aligns the struct or declaration it comes before to n bytes, and
 *                       a cache line's size: the packet's per-ray arrays start on a line
 *   TR_OPAQUE(x)        hides the value of the scalar lvalue x from the optimizer at this
 *                       point (an empty asm statement under clang on x86; nothing
 *                       elsewhere), so that what is computed from x stays in the branch
 *                       the source puts it in: clang 15 hoisted the triangle test's
 *                       per-ray setup, three divisions, to the start of every walk,
 *                       where three in four of mesh_1e6's ambient occlusion rays reach
 *                       no leaf (8-10% of their time). g++ 12 keeps the branch, and
 *                       there the statement cost 1-2%. Values do not change
 *   TR_INDEPENDENT_LOOP before a loop whose iterations touch disjoint memory that the
 *                       compiler cannot prove apart (fields of one struct read through a
 *                       pointer): clang's assume_safety (PoCL and the host), g++'s ivdep
 *   TR_LANE_GROUP_MIN_RAYS
 *                       the fewest rays of a 16-ray group for which a leaf's primitives
 *                       are tested a ray per SIMD lane (tr_packet_leaf, bvh_packet.h);
 *                       it depends on how many lanes a vector register holds
 *
 * On the device, TR_FEATURES and TR_DOUBLE arrive as -D build options, and
 * TR_EXACT_FEATURES where the program renders only frames of that very mask (tr_use,
 * math.h).
 * On the host, include/twinray/device/code.hpp includes the function headers inside
 * `template <unsigned TR_FEATURES> struct Kernel`, so the same TR_HAS text is a
 * template parameter test there, and includes them once per precision with its
 * own `real`/`vec3` typedefs.
 *
 * Parity rules (docs/architecture.md, "Bitwise parity"): no floating-point contraction on either
 * side, and device code calls no built-in whose result is implementation-defined; it
 * uses + - * /, sqrt, fabs, floor and comparisons only. */
#ifndef TWINRAY_DEVICE_PRELUDE_H
#define TWINRAY_DEVICE_PRELUDE_H

/* Under clang on an AVX-512 CPU (PoCL's kernels, and host code that clang compiles): a
 * packet's 16-ray group loops in 16 lanes, one 512-bit register each, as g++ makes
 * them. LLVM 15 would pick 8 lanes for `skylake-avx512`, which render PoCL's frames
 * slower (bench/twinray_bench.cpp, docs/performance.md). */
#if defined(__clang__) && defined(__AVX512F__)
#define TR_WIDE_VECTORS __attribute__((min_vector_width(512)))
#define TR_LANE_LOOP _Pragma("clang loop vectorize_width(16)")
#else
#define TR_WIDE_VECTORS
#endif

/* TR_INDEPENDENT_LOOP, before a loop whose iterations touch disjoint memory that the
 * compiler cannot prove apart (arrays that are fields of one struct, read through a
 * pointer into it): vectorize it regardless. Under clang (PoCL's kernels, and the
 * host); g++'s form is below. */
#if defined(__clang__) && defined(__AVX512F__)
#define TR_INDEPENDENT_LOOP _Pragma("clang loop vectorize(assume_safety) vectorize_width(16)")
#elif defined(__clang__)
#define TR_INDEPENDENT_LOOP _Pragma("clang loop vectorize(assume_safety)")
#endif

#if defined(__OPENCL_VERSION__) || defined(__OPENCL_C_VERSION__)
/* ---- OpenCL C 1.2 ---- */
#define TR_DEVICE 1
#pragma OPENCL FP_CONTRACT OFF
#ifdef TR_DOUBLE
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double real;
typedef double3 vec3;
#define TR_VEC3(x, y, z) ((double3)((x), (y), (z)))
#else
typedef float real;
typedef float3 vec3;
#define TR_VEC3(x, y, z) ((float3)((x), (y), (z)))
#endif
/* TR_FN_INLINE: always inlined, on both sides: the walk and the primitive tests, whose
 * callers pass constants (BVH width, any hit or closest) that fold away. Left to PoCL,
 * the walk stayed a call with both as run-time values: 6-16% of a frame.
 * TR_FN_OUTLINE: kept out of line on OpenCL: the ray queries, for one ray and for a
 * packet, each with its walk inlined, so the kernel's work-group function stays small.
 * With the one-ray queries inlined into it, a cold first frame took 2.7 s instead of
 * 1.8-2.0; with the packet queries, 12-13% longer (docs/performance.md). */
#ifndef TR_LANE_LOOP
#define TR_LANE_LOOP
#endif
#define TR_FN static inline TR_WIDE_VECTORS
#ifdef TR_NO_ALWAYS_INLINE /* Oclgrind's runs: see tests/sanitizers/run_oclgrind.cmake */
#define TR_FN_INLINE static inline TR_WIDE_VECTORS
#else
#define TR_FN_INLINE static inline __attribute__((always_inline)) TR_WIDE_VECTORS
#endif
#define TR_FN_OUTLINE static __attribute__((noinline)) TR_WIDE_VECTORS
#define TR_FN_NOINLINE static __attribute__((noinline)) TR_WIDE_VECTORS
#define TR_GLOBAL __global
#define TR_COUNT_RAY() \
  do {                 \
  } while (0)
#define TR_LOWEST_BIT(m) (31 - (int)clz((m) & (0u - (m))))
typedef ulong tr_mask64;
#define TR_LOWEST_BIT64(m) (63 - (int)clz((m) & ((tr_mask64)0 - (m))))
#define TR_POPCOUNT(m) ((int)popcount(m))
#define TR_SIMD_LOOP
#define TR_OPAQUE(x) ((void)0)
#ifndef TR_FEATURES
#error "TR_FEATURES (the Features mask) must be passed as a build option"
#endif

#else
/* ---- host C++17 (compile with -ffp-contract=off; the CMake targets carry it) ---- */
#include <cmath>
#include <glm/vec3.hpp>
#define TR_FN static inline TR_WIDE_VECTORS
#define TR_FN_OUTLINE static inline TR_WIDE_VECTORS
#if defined(__GNUC__) || defined(__clang__)
#define TR_FN_INLINE static inline __attribute__((always_inline)) TR_WIDE_VECTORS
#define TR_FN_NOINLINE static __attribute__((noinline)) TR_WIDE_VECTORS
#else
#define TR_FN_INLINE static inline
#define TR_FN_NOINLINE static
#endif
#define TR_GLOBAL
#if defined(__clang__) /* vec3 is an ext_vector_type there (code.hpp): braces */
#define TR_VEC3(x, y, z) (vec3{(x), (y), (z)})
#else
#define TR_VEC3(x, y, z) vec3((x), (y), (z))
#endif
#if defined(__GNUC__) && !defined(__clang__)
#define TR_SIMD_LOOP _Pragma("GCC unroll 1")
#elif defined(__clang__)
#define TR_SIMD_LOOP _Pragma("clang loop unroll(disable)")
#else
#define TR_SIMD_LOOP
#endif
#ifndef TR_LANE_LOOP
#define TR_LANE_LOOP TR_SIMD_LOOP
#endif
#if defined(__clang__) && (defined(__x86_64__) || defined(__i386__))
#define TR_OPAQUE(x) __asm__ volatile("" : "+x"(x))
#else
#define TR_OPAQUE(x) ((void)0)
#endif
#if defined(__GNUC__) && !defined(__clang__)
#define TR_INDEPENDENT_LOOP _Pragma("GCC ivdep") TR_SIMD_LOOP
#endif
namespace twinray {
namespace device {
typedef unsigned long long tr_mask64;
}  // namespace device
}  // namespace twinray
#if defined(__GNUC__) || defined(__clang__)
#define TR_LOWEST_BIT(m) __builtin_ctz(m)
#define TR_LOWEST_BIT64(m) __builtin_ctzll(m)
#define TR_POPCOUNT(m) __builtin_popcount(m)
#else
namespace twinray {
namespace device {
template <class Bits>
inline int lowest_bit(Bits m) {
  int i = 0;
  for (; !(m & 1u); m >>= 1) ++i;
  return i;
}
inline int bit_count(unsigned m) {
  int n = 0;
  for (; m != 0u; m &= m - 1u) ++n;
  return n;
}
}  // namespace device
}  // namespace twinray
#define TR_LOWEST_BIT(m) ::twinray::device::lowest_bit(m)
#define TR_LOWEST_BIT64(m) ::twinray::device::lowest_bit(m)
#define TR_POPCOUNT(m) ::twinray::device::bit_count(m)
#endif
namespace twinray {
namespace device {
/* Ray queries of this thread in instantiations with TR_F_COUNT_RAYS (bench/). */
inline long long& ray_counter() {
  static thread_local long long count = 0;
  return count;
}
}  // namespace device
}  // namespace twinray
#define TR_COUNT_RAY()                                               \
  do {                                                               \
    if (TR_HAS(TR_F_COUNT_RAYS)) ++::twinray::device::ray_counter(); \
  } while (0)
#endif

/* A leaf's primitives go a ray per lane, 16 at a time, for a group of the packet that
 * holds at least this many of the rays that entered the leaf, and one ray at a time
 * otherwise (tr_packet_leaf). Where a register holds 16 floats (AVX-512) the lanes cost
 * one vector per test and win from one ray on. Where it holds 8 (AVX2) they cost two,
 * and win from a quarter of a group. A `znver1` CPU splits each 256-bit operation in
 * two, and there full groups do best. With SSE's 4 lanes they pay for full groups only.
 * The scalar tests leave at their first failed check. Measured with mesh_1e6
 * (bench/twinray_bench.cpp, docs/performance.md, "Other measured changes"). */
#ifndef TR_LANE_GROUP_MIN_RAYS
#if defined(__AVX512F__)
#define TR_LANE_GROUP_MIN_RAYS 1
#elif defined(__AVX2__) && defined(__znver1__)
#define TR_LANE_GROUP_MIN_RAYS 8
#elif defined(__AVX2__)
#define TR_LANE_GROUP_MIN_RAYS 4
#else
#define TR_LANE_GROUP_MIN_RAYS 16
#endif
#endif

/* Written before what it aligns (a struct's name, or a declaration): C++'s alignas on
 * the host, the aligned attribute of OpenCL C (1.2, 6.11.1) on the device. Only the
 * packet's working memory uses it, never a struct that crosses to the device. */
#ifdef TR_DEVICE
#define TR_ALIGNED(n) __attribute__((aligned(n)))
#else
#define TR_ALIGNED(n) alignas(n)
#endif
#define TR_LINE_BYTES 64

/* Asks for the cache line holding address p, without waiting for it: a hint that changes
 * no value. The host's prefetch instruction; nothing on OpenCL, whose devices hide a
 * load's latency with other work-items. */
#ifdef TR_DEVICE
#define TR_PREFETCH(p) ((void)(p))
#else
#define TR_PREFETCH(p) __builtin_prefetch((const void*)(p))
#endif

/* TR_LANES_LE(a, b, n): bit k set where a[k] <= b[k], k < n (2, 4 or 8, a constant once
 * inlined); TR_HOST_LANE_MASKS says whether it exists. A wide node's box test ends in
 * such a mask. Built in its loop, a bit per lane, neither host compiler makes the one
 * compare and movemask that x86 has for it: clang 15 selects a power of two per lane
 * and OR-reduces the vector (9 instructions in a row), g++ does the like. On x86 hosts
 * the mask is the movemask of the compare (the same bits; no value changes): up to
 * 11% faster one-ray walks (docs/performance.md). OpenCL and other hosts keep the loop. */
#if !defined(TR_DEVICE) && (defined(__SSE2__) || defined(_M_X64))
#include <immintrin.h>
namespace twinray {
namespace device {
inline unsigned lanes_le(const float* a, const float* b, int n) {
#if defined(__AVX__)
  if (n == 8)
    return (unsigned)_mm256_movemask_ps(
        _mm256_cmp_ps(_mm256_loadu_ps(a), _mm256_loadu_ps(b), _CMP_LE_OQ));
#endif
  unsigned mask = 0u;
  if (n % 4 == 0) {
    for (int k = 0; k < n; k += 4)
      mask |= (unsigned)_mm_movemask_ps(_mm_cmple_ps(_mm_loadu_ps(a + k), _mm_loadu_ps(b + k)))
              << k;
    return mask;
  }
  for (int k = 0; k < n; ++k) mask |= (unsigned)(a[k] <= b[k]) << k;
  return mask;
}
inline unsigned lanes_le(const double* a, const double* b, int n) {
  unsigned mask = 0u;
#if defined(__AVX__)
  if (n % 4 == 0) {
    for (int k = 0; k < n; k += 4)
      mask |= (unsigned)_mm256_movemask_pd(
                  _mm256_cmp_pd(_mm256_loadu_pd(a + k), _mm256_loadu_pd(b + k), _CMP_LE_OQ))
              << k;
    return mask;
  }
#endif
  for (int k = 0; k + 1 < n; k += 2)
    mask |= (unsigned)_mm_movemask_pd(_mm_cmple_pd(_mm_loadu_pd(a + k), _mm_loadu_pd(b + k))) << k;
  if (n % 2 != 0) mask |= (unsigned)(a[n - 1] <= b[n - 1]) << (n - 1);
  return mask;
}
}  // namespace device
}  // namespace twinray
#define TR_HOST_LANE_MASKS 1
#define TR_LANES_LE(a, b, n) ::twinray::device::lanes_le((a), (b), (n))
#else
#define TR_HOST_LANE_MASKS 0
#define TR_LANES_LE(a, b, n) 0u
#endif

#ifndef TR_INDEPENDENT_LOOP
#define TR_INDEPENDENT_LOOP
#endif

#define TR_R(lit) ((real)(lit))
#define TR_HAS(bit) ((TR_FEATURES & (bit)) != 0u)

#endif /* TWINRAY_DEVICE_PRELUDE_H */
