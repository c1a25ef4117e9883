// PFM (Portable Float Map): 32-bit float RGB, little-endian (scale -1), rows from the
// bottom of the image to the top as the format specifies. Writes the framebuffer's
// exact values when T is float (double is rounded to float).
#pragma once

#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <twinray/core/error.hpp>
#include <twinray/core/image.hpp>
#include <twinray/io/atomic_file.hpp>

namespace twinray {
namespace io {

// Any thread may call these; they touch nothing shared.

// The PFM file's bytes.
template <class T>
std::vector<unsigned char> encode_pfm(const Image<T>& image) {
  std::string header =
      "PF\n" + std::to_string(image.width) + " " + std::to_string(image.height) + "\n-1.0\n";
  std::vector<unsigned char> out(header.begin(), header.end());
  out.reserve(out.size() + image.rgb.size() * 4);
  for (int y = image.height - 1; y >= 0; --y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c) {
        float v = static_cast<float>(image.pixel(x, y)[c]);
        unsigned char b[4];
        std::memcpy(b, &v, 4);  // x86 and AArch64 are little-endian, as scale -1 says
        out.insert(out.end(), b, b + 4);
      }
  return out;
}

// Writes `path` atomically (io/atomic_file.hpp): complete, or the earlier file intact.
// Throws Error(RuntimeFailure) naming the path and the system's reason.
template <class T>
void write_pfm(const std::string& path, const Image<T>& image) {
  write_file_atomically(path, encode_pfm(image));
}

// Reads a little-endian color PFM (as written above) into a float image, row 0 at top.
inline Image<float> read_pfm(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(ErrorKind::InvalidInput, path + ": cannot open");
  std::string magic;
  int width = 0, height = 0;
  double scale = 0;
  f >> magic >> width >> height >> scale;
  f.get();
  if (magic != "PF" || width < 1 || height < 1 || scale >= 0)
    throw Error(ErrorKind::InvalidInput, path + ": not a little-endian color PFM");
  Image<float> image(width, height);
  for (int y = height - 1; y >= 0; --y)
    if (!f.read(reinterpret_cast<char*>(image.pixel(0, y)),
                static_cast<std::streamsize>(width) * 12))
      throw Error(ErrorKind::InvalidInput, path + ": truncated PFM");
  return image;
}

}  // namespace io
}  // namespace twinray
