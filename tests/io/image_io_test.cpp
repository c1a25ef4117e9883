// PNG (clamp, then round), PFM (exact floats, bottom-to-top rows) and atomic writes.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <twinray/io/pfm.hpp>
#include <twinray/io/png.hpp>

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
