// PNG (clamp, then round), PFM (exact floats, bottom-to-top rows), EXR (exact float
// channels, read back through OpenEXR) and atomic writes.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <twinray/io/pfm.hpp>
#include <twinray/io/png.hpp>
#include <stb_image.h>
#include <zlib.h>
#ifdef TWINRAY_WITH_OPENEXR
#include <twinray/io/exr.hpp>
#endif

#include "support/float_bits.hpp"
#include "support/refusal.hpp"

using namespace twinray;
using test_support::TempDir;
namespace fs = std::filesystem;

namespace {

std::string slurp(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}
}  // namespace

TEST_CASE("8-bit conversion clamps, then rounds to nearest") {
  CHECK(io::to_8bit(-0.5f) == 0);
  CHECK(io::to_8bit(NAN) == 0);
  CHECK(io::to_8bit(0.0f) == 0);
  CHECK(io::to_8bit(0.5f / 255.0f) == 1);  // 0.5 rounds up
  CHECK(io::to_8bit(0.49f / 255.0f) == 0);
  CHECK(io::to_8bit(128.4 / 255.0) == 128);
  CHECK(io::to_8bit(1.0f) == 255);
  CHECK(io::to_8bit(7.0f) == 255);
  CHECK(io::to_8bit(INFINITY) == 255);
}

TEST_CASE("PNG is a valid RGB file of the image's size") {
  Image<float> img(5, 3);
  img.pixel(0, 0)[0] = 1.0f;
  std::vector<unsigned char> png = io::encode_png(img);
  REQUIRE(png.size() > 33);
  CHECK(std::string(png.begin() + 1, png.begin() + 4) == "PNG");
  // IHDR: width and height, big-endian, at bytes 16..23; color type 2 (RGB) at 25.
  CHECK(png[19] == 5);
  CHECK(png[23] == 3);
  CHECK(png[24] == 8);
  CHECK(png[25] == 2);
}

namespace {
uint32_t be32(const std::vector<unsigned char>& b, size_t at) {
  return uint32_t(b[at]) << 24 | uint32_t(b[at + 1]) << 16 | uint32_t(b[at + 2]) << 8 | b[at + 3];
}

// The PNG's chunk types in order, after checking each chunk's length and CRC-32.
std::vector<std::string> png_chunks(const std::vector<unsigned char>& png) {
  std::vector<std::string> types;
  size_t at = 8;
  while (at + 12 <= png.size()) {
    const uint32_t length = be32(png, at);
    REQUIRE(at + 12 + length <= png.size());
    const uLong crc = crc32(0L, png.data() + at + 4, length + 4);
    CHECK(be32(png, at + 8 + length) == crc);
    types.emplace_back(png.begin() + at + 4, png.begin() + at + 8);
    at += 12 + length;
  }
  CHECK(at == png.size());
  return types;
}
}  // namespace

TEST_CASE_TEMPLATE("PNG decodes to the image's 8-bit values, every chunk's CRC right", T, float,
                   double) {
  // Values across and beyond [0, 1], NaN, and neighbours that differ by more than 127
  // (the Sub filter's byte wraps around).
  auto check_round_trip = [](int width, int height, uint32_t seed) {
    CAPTURE(width);
    CAPTURE(height);
    Image<T> img(width, height);
    uint32_t state = seed;
    for (size_t i = 0; i < img.rgb.size(); ++i) {
      state = state * 1664525u + 1013904223u;  // Numerical Recipes' LCG
      img.rgb[i] = static_cast<T>((state >> 8) % 1400) / T(1000) - T(0.2);
    }
    img.rgb[0] = std::numeric_limits<T>::quiet_NaN();
    std::vector<unsigned char> png = io::encode_png(img);
    std::vector<std::string> types = png_chunks(png);
    REQUIRE(types.size() >= 3);
    CHECK(types.front() == "IHDR");
    CHECK(types.back() == "IEND");
    for (size_t k = 1; k + 1 < types.size(); ++k) CHECK(types[k] == "IDAT");
    int w = 0, h = 0, channels = 0;
    unsigned char* pixels =
        stbi_load_from_memory(png.data(), static_cast<int>(png.size()), &w, &h, &channels, 3);
    REQUIRE(pixels != nullptr);
    std::vector<unsigned char> decoded(pixels, pixels + size_t(w) * h * 3);
    stbi_image_free(pixels);
    CHECK(w == width);
    CHECK(h == height);
    CHECK(channels == 3);
    CHECK(decoded == io::to_rgb8(img));
    return types.size();
  };
  check_round_trip(1, 1, 1);
  check_round_trip(7, 5, 2);
  check_round_trip(1, 9, 3);
  // Noise does not compress: more than one 1 MiB IDAT chunk.
  CHECK(check_round_trip(1000, 600, 4) > 3);
}

TEST_CASE("PNG refuses an image with no pixels") {
  CHECK_THROWS_AS(io::encode_png(Image<float>(0, 4)), Error);
  CHECK_THROWS_AS(io::encode_png(Image<float>(4, 0)), Error);
}

TEST_CASE_TEMPLATE("PFM round trip keeps every float bit, rows bottom to top", T, float, double) {
  TempDir dir("twinray-io-test");
  Image<T> img(4, 3);
  for (size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = static_cast<T>(0.1 * i - 0.3);
  img.pixel(2, 1)[1] = static_cast<T>(1e30);  // HDR values are kept, not clamped
  fs::path file = dir.path / "x.pfm";
  io::write_pfm(file.string(), img);
  Image<float> back = io::read_pfm(file.string());
  REQUIRE(back.width == 4);
  REQUIRE(back.height == 3);
  for (size_t i = 0; i < img.rgb.size(); ++i) CHECK(back.rgb[i] == static_cast<float>(img.rgb[i]));
  // The first row stored in the file is the bottom row of the image.
  std::string bytes = slurp(file);
  size_t header = std::string("PF\n4 3\n-1.0\n").size();
  float first;
  std::memcpy(&first, bytes.data() + header, 4);
  CHECK(first == static_cast<float>(img.pixel(0, 2)[0]));
}

TEST_CASE("a failed write leaves no partial file and keeps the earlier one") {
  TempDir dir("twinray-io-test");
  fs::path file = dir.path / "out.png";
  Image<float> good(2, 2);
  io::write_png(file.string(), good);
  std::string before = slurp(file);
  REQUIRE(!before.empty());
  // The target is a folder that vanished: the write must fail and touch nothing.
  fs::path missing = dir.path / "gone" / "out.png";
  CHECK_THROWS_AS(io::write_png(missing.string(), good), Error);
  // A read-only folder (as root, permission bits do not stop writes; use a file as the
  // "folder" instead, which fails for everybody).
  fs::path not_a_dir = file / "sub.png";
  CHECK_THROWS_AS(io::write_png(not_a_dir.string(), good), Error);
  CHECK(slurp(file) == before);
  size_t entries = 0;
  for (const auto& e : fs::directory_iterator(dir.path)) {
    (void)e;
    ++entries;
  }
  CHECK(entries == 1);  // no temporary left behind
}

// ---- OpenEXR (io/exr.hpp), in a build with OpenEXR (twinray::exr) ----
#ifdef TWINRAY_WITH_OPENEXR
using test_support::float_bits;

TEST_CASE_TEMPLATE("EXR round trip through OpenEXR keeps every float bit as FLOAT R, G, B", T,
                   float, double) {
  TempDir dir("twinray-io-test");
  Image<T> img(5, 3);
  for (size_t i = 0; i < img.rgb.size(); ++i) img.rgb[i] = static_cast<T>(0.1 * i - 0.3);
  img.pixel(2, 1)[1] = static_cast<T>(1e30);  // HDR values, infinities, NaN, -0 are kept
  img.pixel(4, 2)[0] = static_cast<T>(INFINITY);
  img.pixel(0, 0)[2] = static_cast<T>(-0.0);
  img.pixel(3, 0)[1] = static_cast<T>(1e-40);  // a float denormal
  const std::string file = (dir.path / "x.exr").string();
  io::write_exr(file, img);
  // Read with OpenEXR's own reader (io::read_exr wraps Imf::InputFile); the channels
  // are stored as 32-bit floats, not half.
  Imf::InputFile in(file.c_str());
  std::vector<std::string> names;
  for (auto it = in.header().channels().begin(); it != in.header().channels().end(); ++it) {
    names.push_back(it.name());
    CHECK(it.channel().type == Imf::FLOAT);
  }
  CHECK(names == std::vector<std::string>{"B", "G", "R"});  // OpenEXR sorts by name
  io::ExrImage back = io::read_exr(file);
  REQUIRE(back.width == 5);
  REQUIRE(back.height == 3);
  const char* rgb[3] = {"R", "G", "B"};
  for (int c = 0; c < 3; ++c) {
    const io::ExrChannel* ch = back.find(rgb[c]);
    REQUIRE(ch != nullptr);
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 5; ++x) {
        CAPTURE(x);
        CAPTURE(y);
        CHECK(float_bits(ch->values[static_cast<size_t>(y) * 5 + x]) ==
              float_bits(static_cast<float>(img.pixel(x, y)[c])));
      }
  }
}

TEST_CASE("EXR: named channels in one file, and bad channel lists refused") {
  TempDir dir("twinray-io-test");
  const std::string file = (dir.path / "aov.exr").string();
  std::vector<io::ExrChannel> channels = {
      {"Z", {1.5f, INFINITY, 2.0f, 3.0f, 4.0f, 5.0f}},
      {"N.X", {0, 1, 0, -1, 0.5f, 0.25f}},
      {"object", {-1, 0, 1, 2, 3, 4}},
  };
  io::write_exr(file, 3, 2, channels);
  io::ExrImage back = io::read_exr(file);
  CHECK(back.width == 3);
  CHECK(back.height == 2);
  REQUIRE(back.channels.size() == 3);
  for (const io::ExrChannel& c : channels) {
    const io::ExrChannel* got = back.find(c.name);
    REQUIRE_MESSAGE(got != nullptr, c.name);
    CHECK(got->values == c.values);
  }
  // The wrong number of values, a name given twice, an empty name: refused, nothing written.
  const std::string other = (dir.path / "bad.exr").string();
  CHECK(test_support::refusal([&] {
          io::write_exr(other, 3, 2, {{"Z", {1, 2}}});
        }).find("not of width x height") != std::string::npos);
  CHECK_THROWS_AS(
      io::write_exr(other, 3, 2, {{"Z", std::vector<float>(6)}, {"Z", std::vector<float>(6)}}),
      Error);
  CHECK_THROWS_AS(io::write_exr(other, 3, 2, {{"", std::vector<float>(6)}}), Error);
  CHECK(!fs::exists(other));
}

TEST_CASE("EXR: a failed write keeps the earlier file, and a non-EXR file is refused on reading") {
  TempDir dir("twinray-io-test");
  const std::string file = (dir.path / "out.exr").string();
  Image<float> good(2, 2);
  good.pixel(1, 1)[0] = 0.75f;
  io::write_exr(file, good);
  const std::string before = slurp(file);
  CHECK(before.substr(0, 4) == std::string("\x76\x2f\x31\x01", 4));  // OpenEXR's magic number
  // A "folder" that is a file: the write fails for everybody, root included.
  CHECK_THROWS_AS(io::write_exr((fs::path(file) / "sub.exr").string(), good), Error);
  CHECK(slurp(file) == before);
  CHECK(std::distance(fs::directory_iterator(dir.path), fs::directory_iterator()) == 1);
  std::ofstream(dir.path / "text.exr") << "not an image";
  CHECK(test_support::refusal([&] {
          io::read_exr((dir.path / "text.exr").string());
        }).find("cannot read as EXR") != std::string::npos);
}
#else
TEST_CASE("EXR: this build has no OpenEXR") {
  MESSAGE("OpenEXR (libopenexr-dev) not found at configure time: the EXR writer is not tested");
}
#endif
