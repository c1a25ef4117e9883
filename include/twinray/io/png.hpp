// PNG output (8-bit RGB through stb_image_write, Debian libstb): each linear value is
// clamped to [0, 1], scaled by 255 and rounded to nearest. No gamma curve is applied:
// the framebuffer is written as computed, like the seed's images.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include <stb_image_write.h>

#include <twinray/core/error.hpp>
#include <twinray/core/image.hpp>
#include <twinray/io/atomic_file.hpp>

namespace twinray {
namespace io {

// Any thread may call these; they touch nothing shared.

// One linear value as 8 bits: clamp to [0, 1] (NaN is 0), scale by 255, round to nearest.
template <class T>
unsigned char to_8bit(T v) {
  if (!(v > T(0))) return 0;  // also NaN
  if (v >= T(1)) return 255;
  return static_cast<unsigned char>(std::lround(v * T(255)));
}

// The whole image as 8-bit RGB, row 0 first.
template <class T>
std::vector<unsigned char> to_rgb8(const Image<T>& image) {
  std::vector<unsigned char> rgb(image.rgb.size());
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = to_8bit(image.rgb[i]);
  return rgb;
}

// The PNG file's bytes. Throws Error(RuntimeFailure) if stb cannot encode.
template <class T>
std::vector<unsigned char> encode_png(const Image<T>& image) {
  std::vector<unsigned char> rgb = to_rgb8(image);
  std::vector<unsigned char> png;
  auto sink = [](void* context, void* data, int size) {
    auto* out = static_cast<std::vector<unsigned char>*>(context);
    const unsigned char* p = static_cast<const unsigned char*>(data);
    out->insert(out->end(), p, p + size);
  };
  if (!stbi_write_png_to_func(sink, &png, image.width, image.height, 3, rgb.data(),
                              image.width * 3))
    throw Error(ErrorKind::RuntimeFailure, "PNG encoding failed");
  return png;
}

// Writes `path` atomically (io/atomic_file.hpp): complete, or the earlier file intact.
// Throws Error(RuntimeFailure) naming the path and the system's reason.
template <class T>
void write_png(const std::string& path, const Image<T>& image) {
  write_file_atomically(path, encode_png(image));
}

}  // namespace io
}  // namespace twinray
