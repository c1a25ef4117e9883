// Small helpers the benchmark programs share (embree_tree_bench.cpp, ab/ab_frames.cpp,
// ab/ab_side.cpp, ray_query_bench.cpp, query_batch_bench.cpp). No twinray header: an
// ab_side module built from an older tree includes this one.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace twinray_bench {

// A uniform number in [0, 1) from a counter (Wellons' lowbias32 hash): random numbers
// that any thread makes for any index, the same on every run.
inline float hash01(std::uint32_t x) {
  x ^= x >> 16;
  x *= 0x7feb352du;
  x ^= x >> 15;
  x *= 0x846ca68bu;
  x ^= x >> 16;
  return float(x >> 8) * (1.0f / 16777216.0f);
}

// FNV-1a over the bytes of an image's framebuffer (any type with a `rgb` vector): the
// same image bits, the same hash.
template <class Image>
std::uint64_t image_hash(const Image& image) {
  std::uint64_t h = 14695981039346656037ull;
  const auto* bytes = reinterpret_cast<const unsigned char*>(image.rgb.data());
  for (std::size_t i = 0; i < image.rgb.size() * sizeof(image.rgb[0]); ++i)
    h = (h ^ bytes[i]) * 1099511628211ull;
  return h;
}

// The q-quantile of v (nearest rank): 0.5 the median, 0.25 and 0.75 the quartiles.
inline double quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5)];
}
inline double median(std::vector<double> v) {
  return quantile(std::move(v), 0.5);
}

}  // namespace twinray_bench
