// Texture images (io/texture_image.hpp): size and row order, the exact sRGB-to-linear
// values, grey and alpha, JPEG, and every refusal (missing, folder, empty, garbage,
// truncated, a hostile header over the pixel limit, a file over the byte limit).
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

#include <stb_image_write.h>

#include <twinray/io/texture_image.hpp>

#include "support/refusal.hpp"

using namespace twinray;
using test_support::refusal;
using test_support::TempDir;
namespace fs = std::filesystem;

namespace {

using Bytes = std::vector<unsigned char>;

void sink(void* context, void* data, int size) {
  auto* out = static_cast<Bytes*>(context);
  const unsigned char* p = static_cast<const unsigned char*>(data);
  out->insert(out->end(), p, p + size);
}

// `pixels` holds width x height x comp bytes, first row first.
Bytes png_of(int width, int height, int comp, const Bytes& pixels) {
  REQUIRE(pixels.size() == static_cast<size_t>(width * height * comp));
  Bytes out;
  REQUIRE(stbi_write_png_to_func(sink, &out, width, height, comp, pixels.data(), width * comp));
  return out;
}

Bytes jpg_of(int width, int height, const Bytes& rgb) {
  REQUIRE(rgb.size() == static_cast<size_t>(width * height * 3));
  Bytes out;
  REQUIRE(stbi_write_jpg_to_func(sink, &out, width, height, 3, rgb.data(), 100));
  return out;
}

Bytes flat_rgb(int width, int height, unsigned char r, unsigned char g, unsigned char b) {
  Bytes rgb(static_cast<size_t>(width * height) * 3);
  for (size_t i = 0; i < rgb.size(); i += 3) {
    rgb[i] = r;
    rgb[i + 1] = g;
    rgb[i + 2] = b;
  }
  return rgb;
}

void write_file(const fs::path& path, const Bytes& bytes) {
  std::ofstream f(path, std::ios::binary);
  f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  REQUIRE(f.good());
}

// The IEC 61966-2-1 curve, written out again here, in double, rounded to T once.
template <class T>
T linear(int v) {
  double c = v / 255.0;
  return static_cast<T>(c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4));
}

// PNG chunk CRC (ISO 3309 / zlib's crc32).
uint32_t crc32(const unsigned char* p, size_t n) {
  uint32_t crc = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; ++i) {
    crc ^= p[i];
    for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
  }
  return crc ^ 0xFFFFFFFFu;
}

void put_be32(Bytes& b, size_t at, uint32_t v) {
  b[at] = static_cast<unsigned char>(v >> 24);
  b[at + 1] = static_cast<unsigned char>(v >> 16);
  b[at + 2] = static_cast<unsigned char>(v >> 8);
  b[at + 3] = static_cast<unsigned char>(v);
}

uint32_t get_be32(const Bytes& b, size_t at) {
  return (uint32_t(b[at]) << 24) | (uint32_t(b[at + 1]) << 16) | (uint32_t(b[at + 2]) << 8) |
         uint32_t(b[at + 3]);
}

bool starts_with(const std::string& s, const std::string& prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

bool has(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

// A 32 x 32 RGB PNG of noise (so it compresses poorly and half of it is well past the
// header).
Bytes noisy_png() {
  std::mt19937 rng(7);
  Bytes rgb(32 * 32 * 3);
  for (auto& b : rgb) b = static_cast<unsigned char>(rng() & 0xFF);
  return png_of(32, 32, 3, rgb);
}
}  // namespace

TEST_CASE_TEMPLATE("an RGB PNG keeps its size and row order, and becomes linear", T, float,
                   double) {
  TempDir dir("twinray-texture-test");
  // 2 wide, 3 tall; every byte different, so any reordering shows.
  const Bytes rgb = {0,  255, 10,  128, 1,  2,     //  row 0 (top)
                     30, 40,  50,  60,  70, 80,    //  row 1
                     90, 100, 110, 200, 11, 254};  // row 2 (bottom)
  fs::path file = dir.path / "rows.png";
  write_file(file, png_of(2, 3, 3, rgb));
  Texture<T> tex = io::load_texture<T>(file.string());
  REQUIRE(tex.width == 2);
  REQUIRE(tex.height == 3);
  REQUIRE(tex.texels.size() == 18);
  CHECK(tex.name == file.string());
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 2; ++x)
      for (int c = 0; c < 3; ++c) {
        CAPTURE(x);
        CAPTURE(y);
        CAPTURE(c);
        size_t i = static_cast<size_t>((y * 2 + x) * 3 + c);
        CHECK(tex.texels[tex.texel_index(x, y) + static_cast<size_t>(c)] == linear<T>(rgb[i]));
      }
  // The top-left pixel is (0, 255, 10), the first bytes of the file's first row.
  const T* p = &tex.texels[tex.texel_index(0, 0)];
  CHECK(p[0] == T(0));
  CHECK(p[1] == T(1));                                  // 255 is 1 exactly
  CHECK(p[2] == static_cast<T>(10.0 / 255.0 / 12.92));  // below the knee: linear part
  const T v128 = tex.texels[tex.texel_index(1, 0)];
  CHECK(v128 == static_cast<T>(std::pow((128.0 / 255.0 + 0.055) / 1.055, 2.4)));
  CHECK(std::fabs(static_cast<double>(v128) - 0.21586050011389926) < 1e-7);  // published value
  CHECK(tex.texels[tex.texel_index(1, 2) + 2] == linear<T>(254));            // bottom right
}

TEST_CASE_TEMPLATE("every 8-bit value: a grey PNG becomes R = G = B on the sRGB curve", T, float,
                   double) {
  Bytes grey(256);
  for (int v = 0; v < 256; ++v) grey[static_cast<size_t>(v)] = static_cast<unsigned char>(v);
  Bytes png = png_of(256, 1, 1, grey);
  Texture<T> tex = io::decode_texture<T>(png.data(), png.size(), "ramp.png");
  REQUIRE(tex.width == 256);
  REQUIRE(tex.height == 1);
  CHECK(tex.name == "ramp.png");
  for (int v = 0; v < 256; ++v) {
    CAPTURE(v);
    const T* p = &tex.texels[tex.texel_index(v, 0)];
    CHECK(p[0] == linear<T>(v));
    CHECK(p[1] == p[0]);
    CHECK(p[2] == p[0]);
    if (v > 0) CHECK(p[0] > tex.texels[tex.texel_index(v - 1, 0)]);
  }
  // The same bytes decode to the same values on every call.
  Texture<T> again = io::decode_texture<T>(png.data(), png.size(), "ramp.png");
  CHECK(again.texels == tex.texels);
}

TEST_CASE_TEMPLATE("grey + alpha and RGBA PNGs drop alpha and keep the colour", T, float, double) {
  // Grey + alpha, 2 x 1: (50, alpha 0) and (200, alpha 255).
  Bytes ga = png_of(2, 1, 2, {50, 0, 200, 255});
  Texture<T> g = io::decode_texture<T>(ga.data(), ga.size(), "ga.png");
  REQUIRE(g.texels.size() == 6);
  for (int c = 0; c < 3; ++c) {
    CHECK(g.texels[static_cast<size_t>(c)] == linear<T>(50));
    CHECK(g.texels[static_cast<size_t>(3 + c)] == linear<T>(200));
  }
  // RGBA, 1 x 2: a transparent pixel keeps its colour (nothing is premultiplied).
  Bytes rgba = png_of(1, 2, 4, {20, 120, 220, 0, 240, 5, 77, 128});
  Texture<T> t = io::decode_texture<T>(rgba.data(), rgba.size(), "rgba.png");
  REQUIRE(t.width == 1);
  REQUIRE(t.height == 2);
  REQUIRE(t.texels.size() == 6);
  CHECK(t.texels[0] == linear<T>(20));
  CHECK(t.texels[1] == linear<T>(120));
  CHECK(t.texels[2] == linear<T>(220));
  CHECK(t.texels[3] == linear<T>(240));
  CHECK(t.texels[4] == linear<T>(5));
  CHECK(t.texels[5] == linear<T>(77));
}

TEST_CASE_TEMPLATE("a flat-colour JPEG decodes within one byte of its colour", T, float, double) {
  TempDir dir("twinray-texture-test");
  const int r = 200, g = 100, b = 50;
  fs::path file = dir.path / "flat.jpg";
  write_file(file, jpg_of(16, 8, flat_rgb(16, 8, r, g, b)));
  Texture<T> tex = io::load_texture<T>(file.string());
  REQUIRE(tex.width == 16);
  REQUIRE(tex.height == 8);
  REQUIRE(tex.texels.size() == 16 * 8 * 3);
  const int want[3] = {r, g, b};
  for (size_t i = 0; i < tex.texels.size(); ++i) {
    CAPTURE(i);
    int v = want[i % 3];
    CHECK(tex.texels[i] >= linear<T>(v - 1));
    CHECK(tex.texels[i] <= linear<T>(v + 1));
  }
}

TEST_CASE("texture files that cannot be read are refused, naming the file") {
  TempDir dir("twinray-texture-test");
  SUBCASE("missing") {
    std::string path = (dir.path / "nowhere.png").string();
    std::string m = refusal([&] { io::load_texture<float>(path); });
    CHECK(starts_with(m, path + ": cannot open"));
  }
  SUBCASE("a folder") {
    std::string path = (dir.path / "folder.png").string();
    fs::create_directories(path);
    std::string m = refusal([&] { io::load_texture<float>(path); });
    CHECK(starts_with(m, path + ": is a folder"));
  }
  SUBCASE("empty") {
    fs::path file = dir.path / "empty.png";
    write_file(file, {});
    std::string m = refusal([&] { io::load_texture<float>(file.string()); });
    CHECK(starts_with(m, file.string() + ": the file is empty"));
  }
  SUBCASE("random bytes") {
    std::mt19937 rng(42);
    Bytes junk(1000);
    for (auto& b : junk) b = static_cast<unsigned char>(rng() & 0xFF);
    fs::path file = dir.path / "junk.png";
    write_file(file, junk);
    std::string m = refusal([&] { io::load_texture<double>(file.string()); });
    std::string prefix = file.string() + ": not a PNG or JPEG image stb_image can decode: ";
    CHECK(starts_with(m, prefix));
    CHECK(m.size() > prefix.size());  // stb_image's reason follows
  }
  SUBCASE("a truncated PNG") {
    Bytes png = noisy_png();
    REQUIRE(png.size() > 1000);
    Bytes half(png.begin(), png.begin() + static_cast<std::ptrdiff_t>(png.size() / 2));
    fs::path file = dir.path / "half.png";
    write_file(file, half);
    std::string m = refusal([&] { io::load_texture<float>(file.string()); });
    CHECK(starts_with(m, file.string() + ": the 32 x 32 image is damaged or truncated"));
    // The whole file is fine.
    CHECK(io::decode_texture<float>(png.data(), png.size(), "whole.png").width == 32);
  }
}

TEST_CASE("a PNG header claiming 100000 x 100000 pixels is refused before decoding") {
  Bytes png = png_of(2, 2, 3, flat_rgb(2, 2, 1, 2, 3));
  // IHDR: length at 8, type at 12, width and height at 16 and 20, CRC over type + data
  // (17 bytes) at 29.
  REQUIRE(png.size() > 33);
  REQUIRE(std::string(png.begin() + 12, png.begin() + 16) == "IHDR");
  REQUIRE(crc32(&png[12], 17) == get_be32(png, 29));  // the helper is right
  put_be32(png, 16, 100000);
  put_be32(png, 20, 100000);
  put_be32(png, 29, crc32(&png[12], 17));
  std::string m = refusal([&] { io::decode_texture<float>(png.data(), png.size(), "huge.png"); });
  CHECK(m ==
        "huge.png: the image is 100000 x 100000 pixels (10000000000), more than the limit "
        "of 67108864");

  // The pixel limit is exact: 2 x 2 is 4 pixels.
  Bytes small = png_of(2, 2, 3, flat_rgb(2, 2, 1, 2, 3));
  io::TextureLimits limits;
  limits.max_pixels = 4;
  CHECK(io::decode_texture<double>(small.data(), small.size(), "s.png", limits).width == 2);
  limits.max_pixels = 3;
  m = refusal([&] { io::decode_texture<double>(small.data(), small.size(), "s.png", limits); });
  CHECK(starts_with(m, "s.png: the image is 2 x 2 pixels (4), more than the limit of 3"));
}

TEST_CASE("a JPEG over the pixel limit is refused from its header") {
  Bytes jpg = jpg_of(4, 4, flat_rgb(4, 4, 9, 9, 9));
  io::TextureLimits limits;
  limits.max_pixels = 16;
  CHECK(io::decode_texture<float>(jpg.data(), jpg.size(), "j.jpg", limits).height == 4);
  limits.max_pixels = 15;
  std::string m =
      refusal([&] { io::decode_texture<float>(jpg.data(), jpg.size(), "j.jpg", limits); });
  CHECK(starts_with(m, "j.jpg: the image is 4 x 4 pixels (16), more than the limit of 15"));
}

TEST_CASE("a file over max_file_bytes is refused before it is read") {
  TempDir dir("twinray-texture-test");
  Bytes png = png_of(2, 2, 3, flat_rgb(2, 2, 1, 2, 3));
  fs::path file = dir.path / "big.png";
  write_file(file, png);
  io::TextureLimits limits;
  limits.max_file_bytes = static_cast<long long>(png.size());
  CHECK(io::load_texture<float>(file.string(), limits).width == 2);  // at the limit: fine
  limits.max_file_bytes = 10;
  std::string m = refusal([&] { io::load_texture<float>(file.string(), limits); });
  CHECK(starts_with(m, file.string() + ": "));
  CHECK(has(m, std::to_string(png.size()) + " bytes, more than the limit of 10"));
  // decode_texture holds the same limit for bytes it is given.
  m = refusal([&] { io::decode_texture<float>(png.data(), png.size(), "mem.png", limits); });
  CHECK(starts_with(m, "mem.png: the image is " + std::to_string(png.size()) +
                           " bytes, more than the limit of 10"));
}
