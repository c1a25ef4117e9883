// The order in which both backends hand a frame's blocks to their threads
// (device/trace.h tr_tiled_block): every block exactly once, a tile's blocks one after
// the other, for rectangles whose sides are and are not whole tiles.
#include <doctest/doctest.h>

#include <vector>

#include <twinray/device/code.hpp>

using namespace twinray;

namespace {

using K = device::Code<float>::Kernel<TR_F_ALL>;

}  // namespace

TEST_CASE("block order: every block of the rectangle exactly once") {
  const int sides[][2] = {{1, 1},  {1, 9}, {9, 1},  {3, 3},  {4, 4},     {5, 3},
                          {7, 13}, {8, 8}, {13, 7}, {17, 4}, {240, 135}, {50, 50}};
  for (const auto& side : sides) {
    const int bx_n = side[0], by_n = side[1];
    CAPTURE(bx_n);
    CAPTURE(by_n);
    std::vector<int> seen(static_cast<size_t>(bx_n) * by_n, 0);
    for (int index = 0; index < bx_n * by_n; ++index) {
      int bx = -1, by = -1;
      K::tr_tiled_block(index, bx_n, by_n, &bx, &by);
      REQUIRE(bx >= 0);
      REQUIRE(bx < bx_n);
      REQUIRE(by >= 0);
      REQUIRE(by < by_n);
      ++seen[static_cast<size_t>(by) * bx_n + bx];
    }
    for (int count : seen) CHECK(count == 1);
  }
}

TEST_CASE("block order: tiles of TR_TILE_BLOCKS x TR_TILE_BLOCKS, each row by row") {
  const int t = TR_TILE_BLOCKS;
  REQUIRE(t > 1);
  // Two tiles and a cut one across, two tile rows and a cut one down.
  const int bx_n = 2 * t + 1, by_n = 2 * t + 2;
  int index = 0;
  for (int tile_y = 0; tile_y < by_n; tile_y += t) {
    const int h = tile_y + t <= by_n ? t : by_n - tile_y;
    for (int tile_x = 0; tile_x < bx_n; tile_x += t) {
      const int w = tile_x + t <= bx_n ? t : bx_n - tile_x;
      for (int y = tile_y; y < tile_y + h; ++y)
        for (int x = tile_x; x < tile_x + w; ++x, ++index) {
          int bx = -1, by = -1;
          K::tr_tiled_block(index, bx_n, by_n, &bx, &by);
          CAPTURE(index);
          CHECK(bx == x);
          CHECK(by == y);
        }
    }
  }
  CHECK(index == bx_n * by_n);
}
