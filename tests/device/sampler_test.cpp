// Sub-pixel samplers (device/sampling.h): every position lies inside its pixel, in its
// stratum where the sampler has strata, is the same real in float and double, and is
// the same bits on the OpenCL device as on the host.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <set>
#include <utility>
#include <vector>

#include <twinray/device/code.hpp>
#include <twinray/core/options.hpp>
#ifdef TWINRAY_WITH_OPENCL
#include <twinray/backend/opencl/buffers.hpp>
#endif

using namespace twinray;

namespace {

using K32 = device::Code<float>::Kernel<TR_F_ALL>;
using K64 = device::Code<double>::Kernel<TR_F_ALL>;

const int kSamplers[] = {TR_SAMPLER_GRID, TR_SAMPLER_STRATIFIED, TR_SAMPLER_R2};

int columns(int spp) {
  int c = 1;
  while (c * c < spp) ++c;
  return c;
}

}  // namespace

TEST_CASE("samplers: the options' names and the device's numbers agree") {
  CHECK(static_cast<int>(Sampler::Grid) == TR_SAMPLER_GRID);
  CHECK(static_cast<int>(Sampler::Stratified) == TR_SAMPLER_STRATIFIED);
  CHECK(static_cast<int>(Sampler::R2) == TR_SAMPLER_R2);
  for (Sampler s : {Sampler::Grid, Sampler::Stratified, Sampler::R2}) {
    Sampler back = Sampler::Grid;
    CHECK(parse_sampler(to_string(s), &back));
    CHECK(back == s);
  }
  Sampler unused;
  CHECK_FALSE(parse_sampler("halton", &unused));
}

TEST_CASE("samplers: every position lies inside the pixel and is the same in float and double") {
  for (int sampler : kSamplers)
    for (int spp : {1, 2, 3, 4, 5, 8, 9, 16, 17, 63, 64, 256, 1000})
      for (int seed : {0, 7})
        for (int py = 0; py < 3; ++py)
          for (int px = 0; px < 3; ++px)
            for (int i = 0; i < spp; ++i) {
              auto a = K32::tr_sample_position_seeded(sampler, seed, i, spp, px, py);
              auto b = K64::tr_sample_position_seeded(sampler, seed, i, spp, px, py);
              INFO("sampler " << sampler << " spp " << spp << " sample " << i);
              REQUIRE(a.x >= 0.0f);
              REQUIRE(a.x < 1.0f);
              REQUIRE(a.y >= 0.0f);
              REQUIRE(a.y < 1.0f);
              REQUIRE(static_cast<double>(a.x) == b.x);
              REQUIRE(static_cast<double>(a.y) == b.y);
            }
}

TEST_CASE("samplers: the largest sample count still places every sample in its cell") {
  const int spp = Limits::max_spp;  // 256 x 256 cells: the limit of the 32-bit arithmetic
  for (int sampler : {TR_SAMPLER_GRID, TR_SAMPLER_STRATIFIED})
    for (int i : {0, 1, 255, 256, 32767, 65279, 65534, 65535}) {
      auto s = K64::tr_sample_position_seeded(sampler, 3, i, spp, 5, 9);
      CAPTURE(i);
      CHECK(static_cast<int>(std::floor(s.x * 256)) == i % 256);
      CHECK(static_cast<int>(std::floor(s.y * 256)) == i / 256);
    }
}

TEST_CASE("samplers: grid gives cell centers, stratified one jittered sample per cell") {
  for (int spp : {1, 4, 9, 16, 12, 100}) {
    int cols = columns(spp), rows = (spp + cols - 1) / cols;
    std::set<std::pair<int, int>> cells;
    for (int i = 0; i < spp; ++i) {
      CAPTURE(spp);
      CAPTURE(i);
      auto g = K64::tr_sample_position_seeded(TR_SAMPLER_GRID, 0, i, spp, 2, 3);
      CHECK(g.x == doctest::Approx((i % cols + 0.5) / cols).epsilon(1e-6));
      CHECK(g.y == doctest::Approx((i / cols + 0.5) / rows).epsilon(1e-6));
      auto s = K64::tr_sample_position_seeded(TR_SAMPLER_STRATIFIED, 0, i, spp, 2, 3);
      int cx = static_cast<int>(std::floor(s.x * cols)),
          cy = static_cast<int>(std::floor(s.y * rows));
      CHECK(cx == i % cols);
      CHECK(cy == i / cols);
      cells.insert({cx, cy});
    }
    CHECK(static_cast<int>(cells.size()) == spp);
  }
  // spp = 1: the grid's one sample is the pixel center, exactly.
  auto c = K32::tr_sample_position_seeded(TR_SAMPLER_GRID, 0, 0, 1, 17, 4);
  CHECK(c.x == 0.5f);
  CHECK(c.y == 0.5f);
}

TEST_CASE("samplers: jitter and shifts depend on pixel and seed, R2 is progressive") {
  auto same = [](int sampler, int seed_a, int px_a, int seed_b, int px_b) {
    int equal = 0;
    for (int i = 0; i < 16; ++i) {
      auto a = K64::tr_sample_position_seeded(sampler, seed_a, i, 16, px_a, 0);
      auto b = K64::tr_sample_position_seeded(sampler, seed_b, i, 16, px_b, 0);
      equal += a.x == b.x && a.y == b.y;
    }
    return equal;
  };
  for (int sampler : {TR_SAMPLER_STRATIFIED, TR_SAMPLER_R2}) {
    CAPTURE(sampler);
    CHECK(same(sampler, 0, 0, 0, 0) == 16);  // deterministic
    CHECK(same(sampler, 0, 0, 0, 1) == 0);   // neighbouring pixels differ
    CHECK(same(sampler, 0, 0, 1, 0) == 0);   // seeds differ
  }
  CHECK(same(TR_SAMPLER_GRID, 0, 0, 5, 1) == 16);  // the grid is the same everywhere
  // R2: sample i does not depend on the count, so N samples are a prefix of M > N.
  for (int i = 0; i < 64; ++i) {
    auto a = K64::tr_sample_position_seeded(TR_SAMPLER_R2, 3, i, 64, 4, 5);
    auto b = K64::tr_sample_position_seeded(TR_SAMPLER_R2, 3, i, 256, 4, 5);
    CHECK(a.x == b.x);
    CHECK(a.y == b.y);
  }
  // Low discrepancy: 64 R2 samples hit at least 50 of the 64 cells of an 8 x 8 grid
  // (52 to 55 in the pixels tried); independent uniform points hit about 41.
  std::set<int> hit;
  for (int i = 0; i < 64; ++i) {
    auto a = K64::tr_sample_position_seeded(TR_SAMPLER_R2, 0, i, 64, 1, 1);
    hit.insert(static_cast<int>(a.x * 8) * 8 + static_cast<int>(a.y * 8));
  }
  CHECK(hit.size() >= 50);
}

#ifdef TWINRAY_WITH_OPENCL
namespace {
// Every position of a width x height block of pixels, computed on the device.
template <class T>
std::vector<T> device_positions(int sampler, int seed, int spp, int width, int height) {
  opencl::Context& ctx = opencl::shared_context(-1);
  std::lock_guard<std::mutex> lock(ctx.mutex());
  bool built = false;
  double ms = 0;
  auto& entry =
      ctx.programs().get(opencl::build_options(ctx.info(), TR_F_ALL, sizeof(T) == 8), &built, &ms);
  cl_int err = CL_SUCCESS;
  cl_kernel kernel = clCreateKernel(entry.program, "tr_kernel_sample_positions", &err);
  REQUIRE(err == CL_SUCCESS);
  std::vector<T> out(static_cast<size_t>(width) * height * spp * 2);
  opencl::Buffer positions;
  positions.reserve(ctx.context(), CL_MEM_READ_WRITE, out.size() * sizeof(T), "clCreateBuffer");
  cl_mem buffer = positions.mem();
  clSetKernelArg(kernel, 0, sizeof buffer, &buffer);
  clSetKernelArg(kernel, 1, sizeof(int), &sampler);
  clSetKernelArg(kernel, 2, sizeof(int), &seed);
  clSetKernelArg(kernel, 3, sizeof(int), &spp);
  clSetKernelArg(kernel, 4, sizeof(int), &width);
  clSetKernelArg(kernel, 5, sizeof(int), &height);
  size_t global[2] = {static_cast<size_t>(width), static_cast<size_t>(height)};
  err =
      clEnqueueNDRangeKernel(ctx.queue(), kernel, 2, nullptr, global, nullptr, 0, nullptr, nullptr);
  if (err == CL_SUCCESS)
    err = clEnqueueReadBuffer(ctx.queue(), buffer, CL_TRUE, 0, out.size() * sizeof(T), out.data(),
                              0, nullptr, nullptr);
  clReleaseKernel(kernel);
  REQUIRE(err == CL_SUCCESS);
  return out;
}
}  // namespace

TEST_CASE_TEMPLATE("samplers: the OpenCL device places every sample at the host's bits", T, float,
                   double) {
  using K = typename device::Code<T>::template Kernel<TR_F_ALL>;
  const int width = 9, height = 7;
  for (int sampler : kSamplers)
    for (int spp : {1, 5, 16}) {
      CAPTURE(sampler);
      CAPTURE(spp);
      std::vector<T> cl = device_positions<T>(sampler, 11, spp, width, height);
      size_t differ = 0;
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
          for (int i = 0; i < spp; ++i) {
            auto s = K::tr_sample_position_seeded(sampler, 11, i, spp, x, y);
            size_t k = ((static_cast<size_t>(y) * width + x) * spp + i) * 2;
            differ += std::memcmp(&s.x, &cl[k], sizeof(T)) != 0;
            differ += std::memcmp(&s.y, &cl[k + 1], sizeof(T)) != 0;
          }
      CHECK(differ == 0);
    }
}
#endif
