// triangulate_polygon (scene/polygon.hpp): n - 2 triangles that cover the polygon once,
// all facing its way, for convex, concave, tilted and reversed polygons; the quad rule;
// degenerate and self-intersecting polygons still give n - 2 triangles; the work limit.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include <twinray/scene/polygon.hpp>

using glm::dvec3;
using Triangles = std::vector<std::array<int, 3>>;

namespace {

Triangles cut(const std::vector<dvec3>& p) {
  Triangles out;
  long long work = 0;
  REQUIRE(twinray::triangulate_polygon(p, out, work, 1ll << 40));
  REQUIRE(out.size() == p.size() - 2);
  return out;
}

// Twice the area of the triangles, and the least of their normals along `facing`:
// triangles that cover a simple polygon once, all facing its way, sum to its area.
struct Cover {
  double area2 = 0, least = 1e300;
};

Cover cover(const std::vector<dvec3>& p, const Triangles& t, dvec3 facing) {
  Cover c;
  for (auto [a, b, k] : t) {
    double along = glm::dot(glm::cross(p[b] - p[a], p[k] - p[a]), glm::normalize(facing));
    c.area2 += along;
    c.least = std::min(c.least, along);
  }
  return c;
}

}  // namespace

TEST_CASE("polygon: random star-shaped polygons, tilted and reversed, are covered once") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 400; ++trial) {
    const int n = 5 + trial % 40;
    // Star-shaped about the origin (so simple: no gap between angles reaches pi), with
    // deep notches.
    std::vector<double> angle(n);
    for (int k = 0; k < n; ++k) angle[k] = (k + 0.9 * unit(rng)) * 2 * M_PI / n;
    const glm::dmat4 place =
        glm::rotate(glm::translate(glm::dmat4(1.0), dvec3(3, -2, 7)), unit(rng) * 6.0,
                    glm::normalize(dvec3(unit(rng), unit(rng), unit(rng)) + dvec3(0.01)));
    std::vector<dvec3> p;
    for (double a : angle) {
      double r = 0.2 + unit(rng);
      p.push_back(dvec3(place * glm::dvec4(r * std::cos(a), r * std::sin(a), 0, 1)));
    }
    if (trial % 2) std::reverse(p.begin(), p.end());
    const dvec3 facing = twinray::newell_normal(p);
    CAPTURE(trial);
    Cover c = cover(p, cut(p), facing);
    CHECK(c.area2 == doctest::Approx(glm::length(facing)).epsilon(1e-9));
    CHECK(c.least > -1e-12);
  }
}

TEST_CASE("polygon: a convex polygon is a fan from its first corner, and the quad rule") {
  std::vector<dvec3> hexagon;
  for (int k = 0; k < 6; ++k)
    hexagon.push_back(dvec3(std::cos(k * M_PI / 3), std::sin(k * M_PI / 3), 0));
  CHECK(cut(hexagon) == Triangles{{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 4, 5}});
  // A long quad: along the shorter diagonal, 1-3 here.
  std::vector<dvec3> quad = {{0, 0, 0}, {1, -0.2, 0}, {4, 0, 0}, {1, 0.2, 0}};
  CHECK(cut(quad) == Triangles{{0, 1, 3}, {1, 2, 3}});
  quad = {{-1, 0, 0}, {0, -3, 0}, {1, 0, 0}, {0, 3, 0}};
  CHECK(cut(quad) == Triangles{{0, 1, 2}, {0, 2, 3}});
  // A concave quad (a dart, reflex at corner 3): the shorter diagonal 1-3 would leave
  // the quad, so 0-2 is taken.
  quad = {{0, 0, 0}, {2, -1, 0}, {4, 0, 0}, {2, -0.5, 0}};
  std::reverse(quad.begin() + 1, quad.end());  // counter-clockwise: 0 3 2 1 as written
  Triangles dart = cut(quad);
  Cover c = cover(quad, dart, twinray::newell_normal(quad));
  CHECK(c.least > 0.0);
  CHECK(c.area2 == doctest::Approx(glm::length(twinray::newell_normal(quad))));
}

TEST_CASE("polygon: degenerate and self-intersecting polygons still give n - 2 triangles") {
  // Collinear corners, repeated corners, a bow tie, all corners on one point.
  cut({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}, {4, 0, 0}});
  cut({{0, 0, 0}, {1, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 1, 0}});
  cut({{0, 0, 0}, {2, 2, 0}, {2, 0, 0}, {0, 2, 0}, {1, 3, 0}, {-1, 1, 0}});
  cut(std::vector<dvec3>(9, dvec3(1, 2, 3)));
}

TEST_CASE("polygon: the work limit stops a cut that would cost more") {
  std::vector<dvec3> comb;  // many reflex corners: each ear test walks them
  for (int k = 0; k < 200; ++k) {
    comb.push_back(dvec3(k, 0, 0));
    comb.push_back(dvec3(k + 0.5, k % 2 ? 1.0 : 3.0, 0));
  }
  comb.push_back(dvec3(200, -1, 0));
  comb.push_back(dvec3(0, -1, 0));
  Triangles out;
  long long work = 0;
  CHECK_FALSE(twinray::triangulate_polygon(comb, out, work, 1000));
  work = 0;
  CHECK(twinray::triangulate_polygon(comb, out, work, 1ll << 40));
  CHECK(out.size() == comb.size() - 2);
  CHECK(work > 1000);
}
