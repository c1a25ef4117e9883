// RenderOptions: everything about a render that is not the scene or the camera.
#pragma once

#include <functional>
#include <iostream>
#include <string>

namespace twinray {

enum class Backend { Cpu, OpenCL, Auto };

inline const char* to_string(Backend b) {
  return b == Backend::Cpu ? "cpu" : (b == Backend::OpenCL ? "opencl" : "auto");
}

// Shading terms, combinable as a bit mask.
enum Terms : unsigned {
  kAmbient = 1u,
  kDiffuse = 2u,
  kSpecular = 4u,
  kAllTerms = 7u,
};

// Sub-pixel sample placement (device/sampling.h): regular grid, stratified (jittered
// grid cells), or the R2 low-discrepancy sequence shifted per pixel.
enum class Sampler { Grid = 0, Stratified = 1, R2 = 2 };

inline const char* to_string(Sampler s) {
  return s == Sampler::Grid ? "grid" : (s == Sampler::Stratified ? "stratified" : "r2");
}

// "grid", "stratified", "r2" -> the sampler; false when the name is none of them.
inline bool parse_sampler(const std::string& name, Sampler* out) {
  for (Sampler s : {Sampler::Grid, Sampler::Stratified, Sampler::R2})
    if (name == to_string(s)) {
      *out = s;
      return true;
    }
  return false;
}

// What the framebuffer holds: the shaded image, or an arbitrary output variable of
// the primary ray through each pixel center (device/trace.h tr_render_aov).
enum class Output { Shaded, Depth, Normal, ObjectIndex, ShadingNormal, Uv };

struct RenderOptions {
  Backend backend = Backend::Auto;
  int spp = 1;          // samples per pixel, >= 1
  int max_depth = 4;    // ray segments per camera sample, >= 1 (1 = no reflected rays)
  bool shadows = true;  // trace shadow rays
  bool glaze = true;    // trace reflected rays off glazed surfaces
  unsigned terms = kAllTerms;
  Sampler sampler = Sampler::Grid;
  int seed = 0;  // sampler seed: stratified jitter and R2's per-pixel shift
  // Adaptive anti-aliasing (device/adaptive.h): 0 = off; otherwise a first pass of
  // `spp` samples in every pixel, then `adaptive_spp` (> spp) in every pixel whose
  // contrast (largest per-channel range of its samples and difference to the means of
  // its 8 neighbours, linear units) is above `adaptive_threshold`.
  int adaptive_spp = 0;
  double adaptive_threshold = 1.0 / 32;
  Output output = Output::Shaded;
  int device = -1;  // OpenCL device index over all platforms (twinray info); -1 = first
  // Build the OpenCL program (and pick the CPU instantiation) for exactly the features
  // this scene uses. false: the generic program with everything compiled in, switched
  // at run time; same image, bit for bit.
  bool specialize = true;
  // Where notes go (which backend Auto chose, fallbacks). Empty: standard error.
  std::function<void(const std::string&)> log;
};

// Filled in by a render when asked: what ran and how long it took.
struct RenderInfo {
  Backend backend = Backend::Cpu;  // the backend that rendered
  std::string device;              // CPU model / OpenCL device name
  unsigned features = 0;           // the Features mask compiled in
  std::string kernel;              // OpenCL kernel: blocks, pixel, aov or adaptive
  double pack_ms = 0;              // packing and acceleration structure
  double build_ms = 0;             // OpenCL program build or cache load (0 on the CPU)
  bool program_cached = false;     // the program came from a cache
  double render_ms = 0;            // rendering, transfers included
  long long rays = 0;              // estimate filled by benchmarks
  double transfer_ms = 0;          // host<->device copies inside render_ms (0 on the CPU)
  bool scene_uploaded = false;     // this render sent the scene's arrays to the device
  long long refined_pixels = 0;    // adaptive sampling: pixels that got adaptive_spp
  long long samples = 0;           // adaptive sampling: camera samples traced in all
};

inline void log_note(const RenderOptions& options, const std::string& message) {
  if (options.log)
    options.log(message);
  else
    std::cerr << "twinray: " << message << "\n";
}

}  // namespace twinray
