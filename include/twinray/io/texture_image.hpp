// load_texture() / decode_texture(): a PNG or JPEG file as a Texture<T> of linear RGB
// texels, through stb_image (Debian libstb: libstb.so holds the implementation, so this
// header only declares it and never defines STB_IMAGE_IMPLEMENTATION).
//
// Why here: image files hold sRGB-encoded 8-bit values, and the renderer shades in linear
// light. The conversion is done once, on the host, through one table, so the CPU and the
// OpenCL backend read exactly the same linear texels and no kernel applies a curve.
//
// What is read: every image stb_image can decode (PNG and JPEG are the formats scenes
// use; stb_image's other formats, such as BMP, TGA or a GIF's first frame, come through
// the same way). Radiance HDR files are refused as textures (stb_image would clamp them to
// 8 bits) and read as they are for an environment (load_environment). The
// image is decoded to 8-bit RGB: grey becomes R = G = B, any alpha channel is dropped (a
// texture is a colour, not a mask), and 16-bit PNGs are reduced to their high 8 bits.
// Each 8-bit value v becomes linear by the sRGB curve of IEC 61966-2-1:
//   c = v / 255;  linear = c <= 0.04045 ? c / 12.92 : ((c + 0.055) / 1.055)^2.4
// computed in double and rounded to T once (0 -> 0 and 255 -> 1 exactly). Row 0 of the
// texture is the first row of the file (the top of the image).
//
// Limits (TextureLimits): the file size is checked before the file is read, and the
// width x height the header claims is checked before anything is decoded, so a hostile
// header cannot make stb_image allocate gigabytes. Errors are twinray::Error(InvalidInput)
// whose message starts with the file name and says what is wrong:
// `spot.png: not a PNG or JPEG image stb_image can decode: bad png sig`.
//
// Threads: any thread may call these. stb_image keeps its failure reason in a
// thread-local variable from version 2.26 on (when the compiler supports it); in older
// builds it is one process-wide variable, so when several threads fail at once the reason
// quoted in a message may be another thread's. The refusal itself is still right, and no
// locking is done for this. stb_image's vertical-flip switch is process-wide state this
// header never sets; a program that sets it (stbi_set_flip_vertically_on_load) would turn
// every texture upside down.
#pragma once

#include <array>
#include <climits>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>

#include <stb_image.h>

#include <twinray/core/error.hpp>
#include <twinray/io/small_file.hpp>
#include <twinray/scene/texture.hpp>

namespace twinray {
namespace io {

struct TextureLimits {
  long long max_file_bytes = 256ll << 20;  // 256 MiB of compressed image
  long long max_pixels = 1ll << 26;        // 64 Mi pixels (768 MiB of float texels)
};

namespace detail {

// The linear value of one 8-bit sRGB value, in double (IEC 61966-2-1).
inline double srgb_to_linear(int v) {
  double c = v / 255.0;
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

// The 256 linear values, rounded to T once; built on first use, the same on every call.
template <class T>
const std::array<T, 256>& srgb_table() {
  static const std::array<T, 256> table = [] {
    std::array<T, 256> t{};
    for (int v = 0; v < 256; ++v) t[static_cast<size_t>(v)] = static_cast<T>(srgb_to_linear(v));
    return t;
  }();
  return table;
}

struct StbiFree {
  void operator()(void* p) const { stbi_image_free(p); }
};

inline std::string stbi_reason() {
  const char* reason = stbi_failure_reason();
  return reason ? reason : "no reason given";
}

inline std::string pixels_text(long long width, long long height) {
  return std::to_string(width) + " x " + std::to_string(height);
}

// The width and height a PNG's IHDR chunk claims, read directly: stb_image's own sanity
// checks refuse some huge headers without saying the size, and the limit is ours to name.
inline bool png_header_size(const unsigned char* bytes, size_t size, unsigned long long& width,
                            unsigned long long& height) {
  static const unsigned char kSignature[8] = {137, 80, 78, 71, 13, 10, 26, 10};
  if (size < 24) return false;
  for (int i = 0; i < 8; ++i)
    if (bytes[i] != kSignature[i]) return false;
  if (bytes[12] != 'I' || bytes[13] != 'H' || bytes[14] != 'D' || bytes[15] != 'R') return false;
  auto be32 = [&](size_t at) {
    return (static_cast<unsigned long long>(bytes[at]) << 24) |
           (static_cast<unsigned long long>(bytes[at + 1]) << 16) |
           (static_cast<unsigned long long>(bytes[at + 2]) << 8) |
           static_cast<unsigned long long>(bytes[at + 3]);
  };
  width = be32(16);
  height = be32(20);
  return true;
}

inline void check_pixels(unsigned long long width, unsigned long long height,
                         const std::string& name, const TextureLimits& limits) {
  // Each is below 2^32, so the product fits.
  unsigned long long pixels = width * height;
  if (limits.max_pixels < 0 || pixels > static_cast<unsigned long long>(limits.max_pixels))
    throw invalid_input(name + ": the image is " +
                        pixels_text(static_cast<long long>(width), static_cast<long long>(height)) +
                        " pixels (" + std::to_string(pixels) + "), more than the limit of " +
                        std::to_string(limits.max_pixels));
}

}  // namespace detail

namespace detail {

// decode_texture, or, with `hdr`, decode_environment: `kinds` names the formats accepted.
template <class T>
Texture<T> decode_image(const unsigned char* bytes, size_t size, const std::string& name,
                        const TextureLimits& limits, bool hdr) {
  const std::string kinds = hdr ? "PNG, JPEG or Radiance HDR" : "PNG or JPEG";
  if (size == 0) throw invalid_input(name + ": the file is empty, not a " + kinds + " image");
  if (limits.max_file_bytes < 0 || size > static_cast<unsigned long long>(limits.max_file_bytes))
    throw invalid_input(name + ": the image is " + std::to_string(size) +
                        " bytes, more than the limit of " + std::to_string(limits.max_file_bytes));
  if (size > static_cast<size_t>(INT_MAX))
    throw invalid_input(name + ": the image is " + std::to_string(size) +
                        " bytes, more than stb_image can read");
  const int len = static_cast<int>(size);

  // The size the header claims, checked before anything is allocated for the pixels.
  unsigned long long png_width = 0, png_height = 0;
  if (detail::png_header_size(bytes, size, png_width, png_height))
    detail::check_pixels(png_width, png_height, name, limits);
  int width = 0, height = 0, channels = 0;
  if (!stbi_info_from_memory(bytes, len, &width, &height, &channels))
    throw invalid_input(name + ": not a " + kinds +
                        " image stb_image can decode: " + detail::stbi_reason());
  if (width <= 0 || height <= 0)
    throw invalid_input(name + ": the image is " + detail::pixels_text(width, height) +
                        " pixels; a texture needs at least one");
  detail::check_pixels(static_cast<unsigned long long>(width),
                       static_cast<unsigned long long>(height), name, limits);
  const bool hdr_file = stbi_is_hdr_from_memory(bytes, len) != 0;
  if (hdr_file && !hdr)
    throw invalid_input(name +
                        ": is a Radiance HDR image; textures are 8-bit sRGB images (PNG or JPEG)");
  Texture<T> texture;
  texture.width = width;
  texture.height = height;
  texture.name = name;
  texture.hdr = hdr;
  const size_t count = static_cast<size_t>(width) * static_cast<size_t>(height) * 3;
  if (hdr_file) {
    // Radiance HDR holds linear values (RGBE: Ward, Graphics Gems II, 1991): no curve.
    int got_width = 0, got_height = 0, file_channels = 0;
    std::unique_ptr<float, detail::StbiFree> values(
        stbi_loadf_from_memory(bytes, len, &got_width, &got_height, &file_channels, 3));
    if (!values || got_width != width || got_height != height)
      throw invalid_input(name + ": the " + detail::pixels_text(width, height) +
                          " Radiance HDR image is damaged or truncated; stb_image cannot decode "
                          "it: " +
                          detail::stbi_reason());
    texture.texels.resize(count);
    for (size_t i = 0; i < count; ++i) {
      const T v = static_cast<T>(values.get()[i]);
      if (!(v >= T(0)) || !std::isfinite(v))
        throw invalid_input(name + ": texel value " + std::to_string(i / 3) + " is " +
                            std::to_string(values.get()[i]) + ", not a finite value >= 0");
      texture.texels[i] = v;
    }
    return texture;
  }

  int got_width = 0, got_height = 0, file_channels = 0;
  std::unique_ptr<stbi_uc, detail::StbiFree> pixels(
      stbi_load_from_memory(bytes, len, &got_width, &got_height, &file_channels, 3));
  if (!pixels)
    throw invalid_input(
        name + ": the " + detail::pixels_text(width, height) +
        " image is damaged or truncated; stb_image cannot decode it: " + detail::stbi_reason());
  if (got_width != width || got_height != height)
    throw invalid_input(name + ": the header says " + detail::pixels_text(width, height) +
                        " pixels but " + detail::pixels_text(got_width, got_height) +
                        " were decoded");

  const std::array<T, 256>& table = detail::srgb_table<T>();
  texture.texels.resize(count);
  const stbi_uc* p = pixels.get();
  for (size_t i = 0; i < count; ++i) texture.texels[i] = table[p[i]];
  return texture;
}

}  // namespace detail

// Decodes an image file's bytes; `name` (the file it came from) starts every message and
// becomes the texture's name. Throws Error(InvalidInput).
template <class T>
Texture<T> decode_texture(const unsigned char* bytes, size_t size, const std::string& name,
                          const TextureLimits& limits = {}) {
  return detail::decode_image<T>(bytes, size, name, limits, false);
}

// The same for an environment (Environment<T>): a Radiance HDR file's linear values as
// they are, or a PNG or JPEG decoded as above; the texture is marked hdr.
template <class T>
Texture<T> decode_environment(const unsigned char* bytes, size_t size, const std::string& name,
                              const TextureLimits& limits = {}) {
  return detail::decode_image<T>(bytes, size, name, limits, true);
}

// Reads and decodes an image file (size-checked before it is read); the texture's name is
// `path`. Throws Error(InvalidInput) naming the path.
template <class T>
Texture<T> load_texture(const std::string& path, const TextureLimits& limits = {}) {
  std::string bytes = detail::read_small_file(path, limits.max_file_bytes, "an image file");
  return decode_texture<T>(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(), path,
                           limits);
}

// Reads and decodes an environment image (decode_environment).
template <class T>
Texture<T> load_environment(const std::string& path, const TextureLimits& limits = {}) {
  std::string bytes = detail::read_small_file(path, limits.max_file_bytes, "an image file");
  return decode_environment<T>(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size(),
                               path, limits);
}

}  // namespace io
}  // namespace twinray
