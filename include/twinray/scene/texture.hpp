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
  // width x height x 3 linear values in [0, 1] (finite and >= 0 where hdr), row 0 at the
  // top of the image (v = 1), left to right (u = 0 to 1).
  std::vector<T> texels;
  // High dynamic range: from a Radiance HDR file, or any image loaded as an environment.
  // Only an environment may use such a texture; a material's colors stay in [0, 1].
  bool hdr = false;
  std::string name;  // where it came from, for messages

  size_t texel_index(int x, int y) const {
    return (static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x)) * 3;
  }
};

}  // namespace twinray
