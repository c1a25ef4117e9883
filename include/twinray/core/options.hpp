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

// Sub-pixel sample placement (device/sampling.h).
enum class Sampler { Grid = 0 };

// What the framebuffer holds: the shaded image, or an arbitrary output variable of
// the primary ray through each pixel center (device/trace.h tr_render_aov).
enum class Output { Shaded, Depth, Normal, ObjectIndex };

struct RenderOptions {
  Backend backend = Backend::Auto;
  int spp = 1;          // samples per pixel, >= 1
  int max_depth = 4;    // ray segments per camera sample, >= 1 (1 = no reflected rays)
  bool shadows = true;  // trace shadow rays
  bool glaze = true;    // trace reflected rays off glazed surfaces
  unsigned terms = kAllTerms;
  Sampler sampler = Sampler::Grid;
  Output output = Output::Shaded;
  int threads = 0;  // CPU backend threads; 0 = all cores
  int device = -1;  // OpenCL device index over all platforms (twinray info); -1 = first
  // Build the OpenCL program (and pick the CPU instantiation) for exactly the features
  // this scene uses. false: the generic program with everything compiled in, switched
  // at run time; same image, bit for bit.
  bool specialize = true;
  // Where notes go (which backend Auto chose, fallbacks). Empty: standard error.
  std::function<void(const std::string&)> log;
};

// Filled in by render() when asked: what ran and how long it took.
struct RenderInfo {
  Backend backend = Backend::Cpu;  // the backend that rendered
  std::string device;              // CPU model / OpenCL device name
  unsigned features = 0;           // the Features mask compiled in
  double pack_ms = 0;              // packing and acceleration structure
  double build_ms = 0;             // OpenCL program build or cache load (0 on the CPU)
  bool program_cached = false;     // the program came from a cache
  double render_ms = 0;            // rendering, transfers included
  long long rays = 0;              // estimate filled by benchmarks
};

inline void log_note(const RenderOptions& options, const std::string& message) {
  if (options.log)
    options.log(message);
  else
    std::cerr << "twinray: " << message << "\n";
}

}  // namespace twinray
