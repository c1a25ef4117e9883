// Image<T>: a linear-RGB framebuffer, 3 values per pixel, row 0 at the top. Both
// backends return it; values are HDR (not clamped) until an output format clamps.
#pragma once

#include <cstddef>
#include <vector>

namespace twinray {

// A plain value type: copy and move it freely; like a std::vector, one thread may write
// it or several may read it.
template <class T>
struct Image {
  int width = 0;       // pixels
  int height = 0;      // pixels
  std::vector<T> rgb;  // width * height * 3: r, g, b of (0, 0), then (1, 0), ... row by row

  Image() = default;
  // A black image of w x h pixels (w, h >= 0).
  Image(int w, int h) : width(w), height(h), rgb(static_cast<size_t>(w) * h * 3, T(0)) {}
  // Makes the image w x h pixels, keeping its storage where that is large enough: the
  // values are left as they were (zero where the image grew), for a renderer to
  // overwrite.
  void resize(int w, int h) {
    width = w;
    height = h;
    rgb.resize(static_cast<size_t>(w) * h * 3, T(0));
  }
  // The three values of pixel (x, y), x in [0, width), y in [0, height) from the top.
  // Not range-checked.
  T* pixel(int x, int y) { return &rgb[(static_cast<size_t>(y) * width + x) * 3]; }
  const T* pixel(int x, int y) const { return &rgb[(static_cast<size_t>(y) * width + x) * 3]; }
};

}  // namespace twinray
