// Image<T>: a linear-RGB framebuffer, 3 values per pixel, row 0 at the top. Both
// backends return it; values are HDR (not clamped) until an output format clamps.
#pragma once

#include <cstddef>
#include <vector>

namespace twinray {

template <class T>
struct Image {
  int width = 0;
  int height = 0;
  std::vector<T> rgb;  // width * height * 3

  Image() = default;
  Image(int w, int h) : width(w), height(h), rgb(static_cast<size_t>(w) * h * 3, T(0)) {}
  T* pixel(int x, int y) { return &rgb[(static_cast<size_t>(y) * width + x) * 3]; }
  const T* pixel(int x, int y) const { return &rgb[(static_cast<size_t>(y) * width + x) * 3]; }
};

}  // namespace twinray
