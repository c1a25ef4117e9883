// The wide node's box test: the bit mask of the children a ray enters, which the host
// builds with x86's compare and movemask (TR_LANES_LE), is exactly the per-box slab test
// (tr_ray_enters_box) lane by lane, in float and double, at widths 2, 4 and 8, with the
// values that stress a compare: equal entry and exit distances, empty slots, infinite
// and NaN slab distances.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "device/device_test_util.hpp"

using test::K;
using test::make_ray;
using test::vec3;

namespace {

// The mask a bit per lane, the definition the movemask must match.
template <class T>
unsigned lanes_le_by_lane(const T* a, const T* b, int n) {
  unsigned mask = 0u;
  for (int k = 0; k < n; ++k) mask |= (unsigned)(a[k] <= b[k]) << k;
  return mask;
}

template <class T>
T pick_value(std::mt19937& rng) {
  const T specials[] = {T(0),
                        T(-0.0),
                        T(1),
                        std::numeric_limits<T>::max(),
                        std::numeric_limits<T>::infinity(),
                        -std::numeric_limits<T>::infinity(),
                        std::numeric_limits<T>::quiet_NaN(),
                        std::numeric_limits<T>::denorm_min()};
  std::uniform_int_distribution<int> which(0, 11);
  const int w = which(rng);
  if (w < 8) return specials[w];
  return std::uniform_real_distribution<T>(T(-2), T(2))(rng);
}

// One node of width W: six rows of W boxes, as the packer lays them out (min x, y, z,
// then max x, y, z), with the links after them; slot `empty` has the empty box.
template <class T>
std::vector<T> random_node(std::mt19937& rng, int W, int empty) {
  std::vector<T> node(static_cast<size_t>(8 * W), T(0));
  std::uniform_real_distribution<T> coord(T(-4), T(4)), size(T(0), T(3));
  for (int k = 0; k < W; ++k) {
    for (int axis = 0; axis < 3; ++axis) {
      T lo = coord(rng), extent = size(rng);
      if (rng() % 8 == 0) extent = T(0);  // a flat box: entry and exit can be equal
      if (rng() % 8 == 0) lo = T(0);      // a face through the ray's origin
      node[static_cast<size_t>((TR_BVH_MIN_X + axis) * W + k)] = k == empty ? INFINITY : lo;
      node[static_cast<size_t>((TR_BVH_MAX_X + axis) * W + k)] =
          k == empty ? -INFINITY : lo + extent;
    }
  }
  return node;
}

template <class T>
vec3<T> random_direction(std::mt19937& rng) {
  std::uniform_real_distribution<T> u(T(-1), T(1));
  vec3<T> d(u(rng), u(rng), u(rng));
  // Axis-parallel rays: a slab distance is then 0 * inf = NaN where the origin lies on
  // the box's face.
  if (rng() % 4 == 0) d.x = T(0);
  if (rng() % 6 == 0) d.y = T(0);
  if (d.x == T(0) && d.y == T(0) && d.z == T(0)) d.z = T(1);
  return d;
}

template <class T>
void check_widths() {
  std::mt19937 rng(20261207u);
  long long entered = 0, missed = 0;
  for (int W : {2, 4, 8}) {
    for (int trial = 0; trial < 20000; ++trial) {
      const std::vector<T> node = random_node<T>(rng, W, trial % (W + 1));
      std::uniform_real_distribution<T> coord(T(-3), T(3));
      vec3<T> o(coord(rng), coord(rng), coord(rng));
      if (trial % 5 == 0) o.x = T(0);
      const auto br = K<T>::tr_box_ray(make_ray<T>(o, random_direction<T>(rng)));
      const T tmax = trial % 7 == 0 ? T(INFINITY) : std::uniform_real_distribution<T>(0, 6)(rng);
      T t_entry[TR_BVH_MAX_WIDTH];
      const unsigned mask = K<T>::tr_ray_hits_boxes(node.data(), &br, tmax, W, t_entry);
      const auto planes = K<T>::tr_box_planes(node.data(), br.rows, W);
      unsigned expected = 0u;
      for (int k = 0; k < W; ++k) {
        T t = T(-1);
        const vec3<T> box_near(planes.near_x[k], planes.near_y[k], planes.near_z[k]);
        const vec3<T> box_far(planes.far_x[k], planes.far_y[k], planes.far_z[k]);
        expected |= (unsigned)K<T>::tr_ray_enters_box(box_near, box_far, br.o, br.inv_d,
                                                      br.inv_d_far, tmax, &t)
                    << k;
        CHECK(t == t_entry[k]);
      }
      CHECK(mask == expected);
      for (int k = 0; k < W; ++k) ((expected >> k) & 1u ? entered : missed)++;
    }
  }
  // Both answers were exercised, often (a few percent of the lanes are entered).
  CHECK(entered > 2000);
  CHECK(missed > 100000);
}

template <class T>
void check_lanes_le() {
  std::mt19937 rng(7u);
  for (int n : {2, 4, 8}) {
    for (int trial = 0; trial < 20000; ++trial) {
      T a[8], b[8];
      for (int k = 0; k < 8; ++k) {
        a[k] = pick_value<T>(rng);
        b[k] = rng() % 3 == 0 ? a[k] : pick_value<T>(rng);
      }
      CHECK(TR_LANES_LE(a, b, n) == lanes_le_by_lane(a, b, n));
    }
  }
}

}  // namespace

TEST_CASE_TEMPLATE("box test: the mask of entered children is the slab test lane by lane", T, float,
                   double) {
  check_widths<T>();
}

TEST_CASE_TEMPLATE("box test: the host's movemask of a <= b matches the compare lane by lane", T,
                   float, double) {
  if (!TR_HOST_LANE_MASKS) {
    MESSAGE("this host builds the mask lane by lane (no x86 movemask): nothing to compare");
    return;
  }
  check_lanes_le<T>();
}
