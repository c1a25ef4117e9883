// PNG encoding of rendered frames, two ways, alternated so that a drift of the
// machine's speed hits both:
//   twinray   io::encode_png: Sub-filtered rows, zlib's deflate with Z_RLE (io/png.hpp)
//   stb       stb_image_write's stbi_write_png_to_func at its defaults (a filter chosen
//             per row, its own deflate at level 8), from the same 8-bit pixels
// Prints, per image, the median ms and the file size of each, and their ratios.
//
//   twinray render demo --width 1920 --height 1080 -o demo.pfm
//   png_bench [--rounds 7] demo.pfm [more.pfm ...]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include <stb_image_write.h>

#include <twinray/io/pfm.hpp>
#include <twinray/io/png.hpp>

#include "bench_stats.hpp"

namespace {

double ms_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

size_t stb_png_bytes(const twinray::Image<float>& image) {
  std::vector<unsigned char> rgb = twinray::io::to_rgb8(image);
  size_t bytes = 0;
  auto sink = [](void* context, void*, int size) { *static_cast<size_t*>(context) += size; };
  if (!stbi_write_png_to_func(sink, &bytes, image.width, image.height, 3, rgb.data(),
                              image.width * 3))
    throw std::runtime_error("stb could not encode the image");
  return bytes;
}

}  // namespace

int main(int argc, char** argv) {
  int rounds = 7;
  std::vector<std::string> files;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--rounds" && i + 1 < argc)
      rounds = std::max(1, std::atoi(argv[++i]));
    else if (!a.empty() && a[0] != '-')
      files.push_back(a);
    else {
      std::fprintf(stderr, "usage: png_bench [--rounds N] IMAGE.pfm [IMAGE.pfm ...]\n");
      return 2;
    }
  }
  if (files.empty()) {
    std::fprintf(stderr, "usage: png_bench [--rounds N] IMAGE.pfm [IMAGE.pfm ...]\n");
    return 2;
  }
  std::printf("image,width,height,twinray_ms,stb_ms,stb_over_twinray,twinray_bytes,stb_bytes\n");
  try {
    for (const std::string& file : files) {
      const twinray::Image<float> image = twinray::io::read_pfm(file);
      std::vector<double> ours, theirs;
      size_t our_bytes = 0, their_bytes = 0;
      for (int r = 0; r < rounds; ++r) {
        auto t = std::chrono::steady_clock::now();
        our_bytes = twinray::io::encode_png(image).size();
        ours.push_back(ms_since(t));
        t = std::chrono::steady_clock::now();
        their_bytes = stb_png_bytes(image);
        theirs.push_back(ms_since(t));
      }
      const double a = twinray_bench::median(ours), b = twinray_bench::median(theirs);
      std::printf("%s,%d,%d,%.1f,%.1f,%.2f,%zu,%zu\n", file.c_str(), image.width, image.height, a,
                  b, b / a, our_bytes, their_bytes);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "png_bench: %s\n", e.what());
    return 1;
  }
}
