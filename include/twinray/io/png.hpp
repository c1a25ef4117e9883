// PNG output: 8-bit RGB, each linear value clamped to [0, 1], scaled by 255 and rounded to
// nearest. No gamma curve is applied: the framebuffer is written as computed, like the
// seed's images.
//
// The file follows the PNG specification (W3C PNG, 2nd edition = ISO/IEC 15948): the
// signature, IHDR, the image as one zlib stream split over IDAT chunks, IEND; each chunk
// carries the CRC-32 of its type and data. Every row uses filter type 1 (Sub: each byte
// minus the same channel of the pixel to its left), and zlib (Debian zlib1g-dev)
// compresses with the Z_RLE strategy, which zlib's manual describes as "designed to be
// almost as fast as Z_HUFFMAN_ONLY, but give better compression for PNG image data".
// Against stb_image_write's encoder (its own deflate, a filter chosen per row) that is
// a fifth of the time and a smaller file for 1080p frames of the example scenes
// (bench/png_bench.cpp).
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include <zlib.h>

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

namespace png_detail {

inline void put_u32(std::vector<unsigned char>& out, uint32_t v) {
  const unsigned char be[4] = {static_cast<unsigned char>(v >> 24),
                               static_cast<unsigned char>(v >> 16),
                               static_cast<unsigned char>(v >> 8), static_cast<unsigned char>(v)};
  out.insert(out.end(), be, be + 4);
}

// Appends one chunk: length, type, data, CRC-32 of type and data. `size` < 2^31.
inline void put_chunk(std::vector<unsigned char>& png, const char* type, const unsigned char* data,
                      size_t size) {
  put_u32(png, static_cast<uint32_t>(size));
  const size_t crc_from = png.size();
  png.insert(png.end(), type, type + 4);
  if (size > 0) png.insert(png.end(), data, data + size);
  const uLong crc = crc32(0L, png.data() + crc_from, static_cast<uInt>(size + 4));
  put_u32(png, static_cast<uint32_t>(crc));
}

// Ends the deflate stream on every path out of encode_png.
struct Deflater {
  z_stream z{};
  bool open = false;
  ~Deflater() {
    if (open) deflateEnd(&z);
  }
};

}  // namespace png_detail

// The PNG file's bytes. Throws Error(RuntimeFailure) for an empty image, one wider or
// taller than PNG allows, or a zlib failure.
template <class T>
std::vector<unsigned char> encode_png(const Image<T>& image) {
  using namespace png_detail;
  const uint64_t w = image.width > 0 ? static_cast<uint64_t>(image.width) : 0;
  const uint64_t h = image.height > 0 ? static_cast<uint64_t>(image.height) : 0;
  // A row (filter byte + 3 bytes a pixel) goes to zlib in one call, whose counts are uInt.
  const uint64_t row_bytes = 1 + 3 * w;
  if (w == 0 || h == 0 || w > 0x7fffffffu || h > 0x7fffffffu ||
      row_bytes > std::numeric_limits<uInt>::max())
    throw Error(ErrorKind::RuntimeFailure, "PNG: cannot encode an image of " +
                                               std::to_string(image.width) + "x" +
                                               std::to_string(image.height) + " pixels");
  std::vector<unsigned char> png = {137, 'P', 'N', 'G', 13, 10, 26, 10};
  std::vector<unsigned char> header;
  put_u32(header, static_cast<uint32_t>(w));
  put_u32(header, static_cast<uint32_t>(h));
  // Bit depth 8, colour type 2 (RGB), deflate, adaptive filtering, no interlace.
  header.insert(header.end(), {8, 2, 0, 0, 0});
  put_chunk(png, "IHDR", header.data(), header.size());

  Deflater deflater;
  z_stream& z = deflater.z;
  if (deflateInit2(&z, Z_BEST_SPEED, Z_DEFLATED, 15, 8, Z_RLE) != Z_OK)
    throw Error(ErrorKind::RuntimeFailure, "PNG: zlib could not start a deflate stream");
  deflater.open = true;
  std::vector<unsigned char> idat(size_t(1) << 20);  // one IDAT chunk's data at most
  z.next_out = idat.data();
  z.avail_out = static_cast<uInt>(idat.size());
  auto emit_idat = [&] {
    const size_t filled = idat.size() - z.avail_out;
    if (filled > 0) put_chunk(png, "IDAT", idat.data(), filled);
    z.next_out = idat.data();
    z.avail_out = static_cast<uInt>(idat.size());
  };

  std::vector<unsigned char> row(row_bytes);
  row[0] = 1;  // filter type Sub
  for (uint64_t y = 0; y < h; ++y) {
    const T* src = image.rgb.data() + y * w * 3;
    unsigned char left[3] = {0, 0, 0};  // Sub's byte to the left of the first pixel is 0
    for (uint64_t x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        const unsigned char v = to_8bit(src[3 * x + c]);
        row[1 + 3 * x + c] = static_cast<unsigned char>(v - left[c]);
        left[c] = v;
      }
    z.next_in = row.data();
    z.avail_in = static_cast<uInt>(row_bytes);
    const int flush = y + 1 == h ? Z_FINISH : Z_NO_FLUSH;
    // deflate() stops when the input is used up or the output is full; a full output may
    // hold back more, so it is emitted and deflate() asked again.
    for (;;) {
      if (deflate(&z, flush) == Z_STREAM_ERROR)
        throw Error(ErrorKind::RuntimeFailure, "PNG: zlib failed while compressing");
      if (z.avail_out != 0) break;
      emit_idat();
    }
  }
  emit_idat();
  put_chunk(png, "IEND", nullptr, 0);
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
