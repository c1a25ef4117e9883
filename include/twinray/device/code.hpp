// The host side of the shared device code: the same files kernels/render.cl compiles
// as OpenCL C, compiled here as C++, once per precision (namespaces f32 and f64) and
// once per Features mask (Kernel<TR_FEATURES>), so TR_HAS(bit) is a compile-time
// constant on both sides and the CPU path leaves out what the OpenCL program leaves out.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <glm/vec3.hpp>
#include <glm/geometric.hpp>

#include <twinray/device/prelude.h>
#include <twinray/device/features.h>

namespace twinray {
namespace device {

// The scalar math the device files call unqualified; std's float overloads are picked.
using std::fabs;
using std::floor;
using std::sqrt;

namespace f32 {
typedef float real;
typedef glm::vec<3, float> vec3;
#include <twinray/device/types.h>
template <unsigned TR_FEATURES>
struct Kernel {
#include <twinray/device/functions.h>
};
}  // namespace f32

// The buffer structs (types.h, the part outside TR_WORKING_TYPES_ONLY) of namespace ns,
// for an instantiation that compiles only the working structs and the functions again.
#define TWINRAY_DEVICE_SHARE_BUFFER_STRUCTS(ns) \
  using ns::TrBoxPlanes;                        \
  using ns::TrInstance;                         \
  using ns::TrLight;                            \
  using ns::TrMaterial;                         \
  using ns::TrParams;                           \
  using ns::TrPlane;                            \
  using ns::TrQueryExtras;                      \
  using ns::TrQueryHit;                         \
  using ns::TrQueryRay;                         \
  using ns::TrSceneRef;                         \
  using ns::TrSlabRows;                         \
  using ns::TrSphere;                           \
  using ns::TrTexture;                          \
  using ns::TrTriangle;                         \
  using ns::TrTriangleAttr;

#if defined(__clang__)
// The CPU backend's float code under clang: vec3 a native 3-lane vector
// (ext_vector_type, 16 bytes), as float3 is in the OpenCL C that PoCL compiles with the
// same LLVM. The same operations lane by lane, so the same values; the CPU backend's
// frames take 0.90-1.00 of g++ 12's time with clang++ 15, where over glm's struct
// clang's took 1.08-1.16 times g++'s (docs/performance.md, "The compiler"). The buffer
// structs are f32's own (no vec3 in them), so a packed scene serves both; only the
// working structs and the functions are compiled again. f32 keeps glm's vec3 for host
// code that mixes the device math with glm (the tests). double gets the same where AVX
// is on (f64_vec, below).
namespace f32_vec {
typedef float real;
typedef float vec3 __attribute__((ext_vector_type(3)));
TWINRAY_DEVICE_SHARE_BUFFER_STRUCTS(f32)
#define TR_WORKING_TYPES_ONLY
#include <twinray/device/types.h>
#undef TR_WORKING_TYPES_ONLY
template <unsigned TR_FEATURES>
struct Kernel {
#include <twinray/device/functions.h>
};
}  // namespace f32_vec
#endif

namespace f64 {
typedef double real;
typedef glm::vec<3, double> vec3;
#include <twinray/device/types.h>
template <unsigned TR_FEATURES>
struct Kernel {
#include <twinray/device/functions.h>
};
}  // namespace f64

#if defined(__clang__) && defined(__AVX__)
// double likewise, where AVX is on: a 3-lane double vector is 32 bytes, passed in a
// ymm register with AVX and in memory without, so code compiled without AVX keeps
// glm's vec3 (f64) and never meets this namespace's functions.
namespace f64_vec {
typedef double real;
typedef double vec3 __attribute__((ext_vector_type(3)));
TWINRAY_DEVICE_SHARE_BUFFER_STRUCTS(f64)
#define TR_WORKING_TYPES_ONLY
#include <twinray/device/types.h>
#undef TR_WORKING_TYPES_ONLY
template <unsigned TR_FEATURES>
struct Kernel {
#include <twinray/device/functions.h>
};
}  // namespace f64_vec
#endif

// The code the CPU backend renders with, per precision (Code<T>::CpuKernel).
#if defined(__clang__)
namespace f32_cpu = f32_vec;
#else
namespace f32_cpu = f32;
#endif
#if defined(__clang__) && defined(__AVX__)
namespace f64_cpu = f64_vec;
#else
namespace f64_cpu = f64;
#endif

// Layout checks: the OpenCL compiler must lay these out the same way; the kernel
// tr_kernel_layout_sizes reports its sizes and tests/backend/opencl_program_test.cpp
// compares them.
static_assert(sizeof(f32::TrSphere) == 32 && sizeof(f64::TrSphere) == 48, "TrSphere layout");
static_assert(sizeof(f32::TrTriangle) == 44 && sizeof(f64::TrTriangle) == 80, "TrTriangle layout");
static_assert(sizeof(f32::TrPlane) == 32 && sizeof(f64::TrPlane) == 56, "TrPlane layout");
static_assert(sizeof(f32::TrMaterial) == 60 && sizeof(f64::TrMaterial) == 112, "TrMaterial layout");
static_assert(sizeof(f32::TrTriangleAttr) == 68 && sizeof(f64::TrTriangleAttr) == 128,
              "TrTriangleAttr layout");
static_assert(sizeof(f32::TrTexture) == 16 && sizeof(f64::TrTexture) == 16, "TrTexture layout");
static_assert(sizeof(f32::TrLight) == 64 && sizeof(f64::TrLight) == 120, "TrLight layout");
static_assert(sizeof(f32::TrParams) == 120 + 104 && sizeof(f64::TrParams) == 240 + 104,
              "TrParams layout");
static_assert(sizeof(f32::TrInstance) == 112 && sizeof(f64::TrInstance) == 208,
              "TrInstance layout");
static_assert(sizeof(f32::TrQueryRay) == 40 && sizeof(f64::TrQueryRay) == 72, "TrQueryRay layout");
static_assert(sizeof(f32::TrQueryHit) == 40 && sizeof(f64::TrQueryHit) == 64, "TrQueryHit layout");
static_assert(sizeof(f32::TrQueryExtras) == 24 && sizeof(f64::TrQueryExtras) == 48,
              "TrQueryExtras layout");

// The packet's per-ray arrays start on cache lines (types.h, TrRayPacket), so that a
// lane loop's 16-ray group never straddles two.
template <class Packet, class Scratch>
constexpr bool lane_arrays_on_lines() {
  return alignof(Packet) == TR_LINE_BYTES && offsetof(Packet, tri_sx) % TR_LINE_BYTES == 0 &&
         offsetof(Packet, tri_kx) % TR_LINE_BYTES == 0 &&
         offsetof(Packet, ox) % TR_LINE_BYTES == 0 && offsetof(Packet, ix) % TR_LINE_BYTES == 0 &&
         offsetof(Packet, fx) % TR_LINE_BYTES == 0 && offsetof(Packet, t) % TR_LINE_BYTES == 0 &&
         offsetof(Packet, prim) % TR_LINE_BYTES == 0 &&
         offsetof(Scratch, specular) % TR_LINE_BYTES == 0 &&
         offsetof(Scratch, n_dot_h) % TR_LINE_BYTES == 0 &&
         offsetof(Scratch, hit_p) % TR_LINE_BYTES == 0;
}
static_assert(lane_arrays_on_lines<f32::TrRayPacket, f32::TrBlockScratch>() &&
                  lane_arrays_on_lines<f64::TrRayPacket, f64::TrBlockScratch>() &&
                  lane_arrays_on_lines<f32_cpu::TrRayPacket, f32_cpu::TrBlockScratch>() &&
                  lane_arrays_on_lines<f64_cpu::TrRayPacket, f64_cpu::TrBlockScratch>(),
              "TrRayPacket lane arrays");

// Maps the scalar type T to its instantiation of the device code.
template <class T>
struct Code;

template <>
struct Code<float> {
  using Sphere = f32::TrSphere;
  using Triangle = f32::TrTriangle;
  using Plane = f32::TrPlane;
  using Material = f32::TrMaterial;
  using TriangleAttr = f32::TrTriangleAttr;
  using Texture = f32::TrTexture;
  using Light = f32::TrLight;
  using Instance = f32::TrInstance;
  using Params = f32::TrParams;
  using SceneRef = f32::TrSceneRef;
  using Ray = f32::TrRay;
  using Hit = f32::TrHit;
  using Path = f32::TrPath;
  using RayStack = f32::TrRayStack;
  using Sample2 = f32::TrSample2;
  using BlockScratch = f32::TrBlockScratch;
  using Nearest = f32::TrNearest;
  using QueryRay = f32::TrQueryRay;
  using QueryHit = f32::TrQueryHit;
  using QueryExtras = f32::TrQueryExtras;
  template <unsigned Features>
  using Kernel = f32::Kernel<Features>;
  template <unsigned Features>
  using CpuKernel = f32_cpu::Kernel<Features>;
  using CpuBlockScratch = f32_cpu::TrBlockScratch;
  using CpuRayStack = f32_cpu::TrRayStack;
  using CpuQueryPacket = f32_cpu::TrQueryPacket;
  using CpuVec3 = f32_cpu::vec3;
  static constexpr const char* name = "float";
};

template <>
struct Code<double> {
  using Sphere = f64::TrSphere;
  using Triangle = f64::TrTriangle;
  using Plane = f64::TrPlane;
  using Material = f64::TrMaterial;
  using TriangleAttr = f64::TrTriangleAttr;
  using Texture = f64::TrTexture;
  using Light = f64::TrLight;
  using Instance = f64::TrInstance;
  using Params = f64::TrParams;
  using SceneRef = f64::TrSceneRef;
  using Ray = f64::TrRay;
  using Hit = f64::TrHit;
  using Path = f64::TrPath;
  using RayStack = f64::TrRayStack;
  using Sample2 = f64::TrSample2;
  using BlockScratch = f64::TrBlockScratch;
  using Nearest = f64::TrNearest;
  using QueryRay = f64::TrQueryRay;
  using QueryHit = f64::TrQueryHit;
  using QueryExtras = f64::TrQueryExtras;
  template <unsigned Features>
  using Kernel = f64::Kernel<Features>;
  template <unsigned Features>
  using CpuKernel = f64_cpu::Kernel<Features>;
  using CpuBlockScratch = f64_cpu::TrBlockScratch;
  using CpuRayStack = f64_cpu::TrRayStack;
  using CpuQueryPacket = f64_cpu::TrQueryPacket;
  using CpuVec3 = f64_cpu::vec3;
  static constexpr const char* name = "double";
};

}  // namespace device
}  // namespace twinray
