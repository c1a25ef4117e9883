// Texture<T>: an RGB image in linear values, read by bilinear filtering with repeat
// wrap (device/texture.h). Files hold sRGB-encoded bytes; io/texture_image.hpp decodes
// them once, on the host, so both backends read the same linear texels.
#pragma once

#include <string>
#include <vector>

namespace twinray {

template <class T>
struct Texture {
  int width = 0, height = 0;  // >= 1 each
  // width x height x 3 linear values in [0, 1], row 0 at the top of the image (v = 1),
  // left to right (u = 0 to 1).
  std::vector<T> texels;
  std::string name;  // where it came from, for messages

  size_t texel_index(int x, int y) const {
    return (static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x)) * 3;
  }
};

}  // namespace twinray
