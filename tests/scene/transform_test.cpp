// Transform (scene/transform.hpp): the order scale, rotate, translate; exact quarter
// turns; what each object type does with it; and what it refuses.
#include <doctest/doctest.h>

#include <string>

#include <twinray/scene/transform.hpp>

using twinray::Transform;
using dvec3 = glm::dvec3;

namespace {

std::string error_of(void (*f)()) {
  try {
    f();
  } catch (const twinray::Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST_CASE("transform: scale, then rotate, then translate") {
  // Scale x by 2, a quarter turn about +z (x -> y), then move by (10, 0, 0).
  auto t = Transform::scale_rotate_translate({2, 1, 1}, {0, 0, 1}, 90, {10, 0, 0});
  CHECK(t.point({1, 0, 0}) == dvec3(10, 2, 0));
  CHECK(t.point({0, 1, 0}) == dvec3(9, 0, 0));
  CHECK(t.point({0, 0, 3}) == dvec3(10, 0, 3));
  // Right-hand rule about +y: z -> x.
  auto y = Transform::scale_rotate_translate({1, 1, 1}, {0, 5, 0}, 90, {0, 0, 0});
  CHECK(y.point({0, 0, 1}) == dvec3(1, 0, 0));
  CHECK(Transform::scale_rotate_translate({1, 1, 1}, {1, 0, 0}, -270, {0, 0, 0}).point({0, 1, 0}) ==
        dvec3(0, 0, 1));
  // An arbitrary angle: rotations keep lengths.
  auto r = Transform::scale_rotate_translate({1, 1, 1}, {1, 2, 3}, 37, {0, 0, 0});
  CHECK(glm::length(r.point({3, -1, 2})) == doctest::Approx(std::sqrt(14.0)).epsilon(1e-14));
  CHECK(r.uniform_scale() == doctest::Approx(1.0));
}

TEST_CASE("transform: a row-major matrix") {
  const double rows[4][4] = {{0, -1, 0, 5}, {1, 0, 0, 6}, {0, 0, 2, 7}, {0, 0, 0, 1}};
  auto t = Transform::from_rows(rows);
  CHECK(t.point({1, 0, 0}) == dvec3(5, 7, 7));
  CHECK(t.point({0, 0, 1}) == dvec3(5, 6, 9));
  const double projective[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 1, 1}};
  CHECK_THROWS_WITH(Transform::from_rows(projective),
                    "the last row must be [0, 0, 0, 1] (an affine map)");
  CHECK(std::string(error_of([] {
          const double f[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {1, 1, 0, 0}, {0, 0, 0, 1}};
          Transform::from_rows(f);
        })).rfind("the transform is singular", 0) == 0);
}

TEST_CASE_TEMPLATE("transform: each object type", T, float, double) {
  using vec3 = glm::vec<3, T>;
  auto t = Transform::scale_rotate_translate({3, 3, 3}, {0, 0, 1}, 90, {1, 2, 3});
  twinray::Sphere<T> s{vec3(1, 0, 0), T(0.5), 0};
  twinray::place(s, t);
  CHECK(s.center == vec3(1, 5, 3));
  CHECK(s.radius == T(1.5));
  twinray::Plane<T> p{vec3(0, 0, 0), vec3(1, 0, 0), 0};
  twinray::place(p, Transform::scale_rotate_translate({1, 4, 1}, {0, 0, 1}, 0, {0, 0, 0}));
  CHECK(p.normal == vec3(1, 0, 0));
  // A shear: the normal follows the inverse transpose, so it stays perpendicular.
  const double shear[4][4] = {{1, 1, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
  twinray::Plane<T> q{vec3(0, 0, 0), vec3(0, 1, 0), 0};
  twinray::place(q, Transform::from_rows(shear));
  glm::dvec3 along = Transform::from_rows(shear).point({1, 0, 0});  // a direction in the plane
  CHECK(std::abs(glm::dot(glm::dvec3(q.normal), along)) < 1e-6);
  twinray::Mesh<T> m;
  m.vertices = {vec3(0, 0, 0), vec3(1, 0, 0), vec3(0, 1, 0)};
  m.triangles = {{0, 1, 2}};
  twinray::place(m, Transform::scale_rotate_translate({2, 2, 2}, {0, 1, 0}, 0, {0, 0, -1}));
  CHECK(m.vertices[1] == vec3(2, 0, -1));
  // A sphere refuses what would make it an ellipsoid.
  twinray::Sphere<T> e{vec3(0, 0, 0), T(1), 0};
  CHECK_THROWS_WITH(
      twinray::place(e, Transform::scale_rotate_translate({1, 2, 1}, {0, 1, 0}, 0, {0, 0, 0})),
      "a sphere takes only uniform scale, rotation and translation: this transform would make it "
      "an ellipsoid");
}

TEST_CASE("transform: a result the precision cannot hold is refused") {
  twinray::Triangle<float> tri;
  tri.vertices = {glm::vec3(1e30f, 0, 0), glm::vec3(0, 1, 0), glm::vec3(0, 0, 1)};
  CHECK_THROWS_WITH(twinray::place(tri, Transform::scale_rotate_translate({1e10, 1e10, 1e10},
                                                                          {0, 1, 0}, 0, {0, 0, 0})),
                    "the transform moves a vertex outside the range of the render's precision");
}
