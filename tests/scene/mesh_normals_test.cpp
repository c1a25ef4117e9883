// smooth_normals and flat_normals (scene/mesh_normals.hpp): angle weighting, creases,
// welding of equal positions, sharing of equal normals, degenerate faces and what they
// refuse.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>
#include <glm/geometric.hpp>

#include <twinray/core/parallel.hpp>
#include <twinray/scene/mesh_normals.hpp>

using dvec3 = glm::dvec3;

namespace {

// The unit cube: vertex i at (i & 1, i >> 1 & 1, i >> 2 & 1); per side its outward
// normal and a quad wound counterclockwise seen from outside.
const std::array<std::array<int, 4>, 6> kCubeQuads = {
    {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}}};
const std::array<dvec3, 6> kCubeNormals = {
    {{0, 0, -1}, {0, 0, 1}, {0, -1, 0}, {0, 1, 0}, {-1, 0, 0}, {1, 0, 0}}};

// 8 shared vertices, 12 triangles (triangle f lies on side f / 2). The sides are split
// along diagonals chosen so that every corner meets one triangle of some sides and two
// of others: only angle weighting gives the symmetric (+-1, +-1, +-1) / sqrt(3).
template <class T>
twinray::Mesh<T> cube(T scale = T(1)) {
  twinray::Mesh<T> m;
  for (int i = 0; i < 8; ++i)
    m.vertices.push_back(glm::vec<3, T>(i & 1, i >> 1 & 1, i >> 2 & 1) * scale);
  for (int s = 0; s < 6; ++s) {
    const auto& q = kCubeQuads[size_t(s)];
    if (s != 3 && s != 4) {
      m.triangles.push_back({q[0], q[1], q[2]});
      m.triangles.push_back({q[0], q[2], q[3]});
    } else {
      m.triangles.push_back({q[1], q[2], q[3]});
      m.triangles.push_back({q[1], q[3], q[0]});
    }
  }
  return m;
}

// The corner normal, in double.
template <class T>
dvec3 corner(const twinray::Mesh<T>& m, size_t f, int k) {
  return dvec3(m.normals[size_t(m.normal_triangles[f][size_t(k)])]);
}

// What validate() asks: one entry per triangle, indices in range, normals finite and
// of unit length.
template <class T>
void check_well_formed(const twinray::Mesh<T>& m) {
  REQUIRE(m.normal_triangles.size() == m.triangles.size());
  for (const auto& t : m.normal_triangles)
    for (int k = 0; k < 3; ++k) {
      REQUIRE(t[size_t(k)] >= 0);
      REQUIRE(size_t(t[size_t(k)]) < m.normals.size());
    }
  for (const auto& n : m.normals) {
    REQUIRE(std::isfinite(n.x));
    REQUIRE(std::isfinite(n.y));
    REQUIRE(std::isfinite(n.z));
    REQUIRE(std::fabs(glm::length(dvec3(n)) - 1.0) < 1e-6);
  }
}

template <class T>
double tolerance() {
  return std::is_same<T, float>::value ? 1e-7 : 1e-15;
}

bool near(const dvec3& a, const dvec3& b, double tol) {
  return std::fabs(a.x - b.x) <= tol && std::fabs(a.y - b.y) <= tol && std::fabs(a.z - b.z) <= tol;
}

// A plain restatement of the definition, O(triangles) per corner: corner k of face f
// gets the sum of angle x unit normal over the non-degenerate faces at the same position
// within the crease of f's normal.
template <class T>
dvec3 reference(const twinray::Mesh<T>& m, size_t f, int k, double crease_degrees) {
  auto normal_and_angle = [&](size_t g, int c, dvec3& n, double& angle) {
    dvec3 p[3];
    for (int i = 0; i < 3; ++i) p[i] = dvec3(m.vertices[size_t(m.triangles[g][size_t(i)])]);
    n = glm::cross(p[1] - p[0], p[2] - p[0]);
    if (!(glm::length(n) > 0)) return false;
    n = glm::normalize(n);
    dvec3 a = glm::normalize(p[(c + 1) % 3] - p[c]), b = glm::normalize(p[(c + 2) % 3] - p[c]);
    angle = std::acos(std::max(-1.0, std::min(1.0, glm::dot(a, b))));
    return true;
  };
  dvec3 nf(0), sum(0);
  double angle = 0;
  REQUIRE(normal_and_angle(f, k, nf, angle));
  const dvec3 at(m.vertices[size_t(m.triangles[f][size_t(k)])]);
  const double threshold = std::cos(crease_degrees * 3.14159265358979323846 / 180.0);
  for (size_t g = 0; g < m.triangles.size(); ++g)
    for (int c = 0; c < 3; ++c) {
      dvec3 ng(0);
      if (dvec3(m.vertices[size_t(m.triangles[g][size_t(c)])]) != at) continue;
      if (!normal_and_angle(g, c, ng, angle)) continue;
      if (g == f || glm::dot(nf, ng) >= threshold) sum += angle * ng;
    }
  return glm::normalize(sum);
}

std::string error_of(double crease) {
  twinray::Mesh<double> m = cube<double>();
  try {
    twinray::smooth_normals(m, crease);
  } catch (const twinray::Error& e) {
    CHECK(e.kind() == twinray::ErrorKind::InvalidInput);
    return e.what();
  }
  return "";
}

// A bumpy n x n grid, two triangles per cell.
twinray::Mesh<double> bumpy_grid(int n) {
  twinray::Mesh<double> m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i)
      m.vertices.push_back({i, j, std::sin(i * 0.9) * std::cos(j * 1.3) * 0.8});
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      int a = j * (n + 1) + i;
      m.triangles.push_back({a, a + 1, a + n + 2});
      m.triangles.push_back({a, a + n + 2, a + n + 1});
    }
  return m;
}

}  // namespace

TEST_CASE_TEMPLATE("mesh normals: a cube keeps its edges at crease 60", T, float, double) {
  twinray::Mesh<T> m = cube<T>();
  twinray::smooth_normals(m, 60.0);
  check_well_formed(m);
  for (size_t f = 0; f < 12; ++f)
    for (int k = 0; k < 3; ++k) CHECK(corner(m, f, k) == kCubeNormals[f / 2]);
  CHECK(m.normals.size() == 6);  // equal normals share an entry
  // Faces meeting at exactly 90 degrees merge at crease 90, not at 89.
  twinray::smooth_normals(m, 89.0);
  for (size_t f = 0; f < 12; ++f) CHECK(corner(m, f, 0) == kCubeNormals[f / 2]);
  twinray::smooth_normals(m, 90.0);
  CHECK(m.normals.size() == 8);
}

TEST_CASE_TEMPLATE("mesh normals: a cube smooths fully at crease 180", T, float, double) {
  twinray::Mesh<T> m = cube<T>();
  twinray::smooth_normals(m);  // the default, 60, first: the call replaces what was there
  twinray::smooth_normals(m, 180.0);
  check_well_formed(m);
  REQUIRE(m.normals.size() == 8);
  std::array<int, 8> index_of_vertex;
  index_of_vertex.fill(-1);
  for (size_t f = 0; f < 12; ++f)
    for (int k = 0; k < 3; ++k) {
      int v = m.triangles[f][size_t(k)];
      dvec3 want = glm::normalize(dvec3(m.vertices[size_t(v)]) - dvec3(0.5));
      CHECK(near(corner(m, f, k), want, tolerance<T>()));
      // Every corner at one vertex has the same index.
      if (index_of_vertex[size_t(v)] < 0) index_of_vertex[size_t(v)] = m.normal_triangles[f][k];
      CHECK(m.normal_triangles[f][size_t(k)] == index_of_vertex[size_t(v)]);
    }
}

TEST_CASE_TEMPLATE("mesh normals: weighted by corner angle", T, float, double) {
  using vec3 = glm::vec<3, T>;
  // At the origin: a right angle of the plane z = 0 (area 1/2) and 45 degrees of the
  // plane x = 0 (area 2). Angle-weighted: (pi/4) x + (pi/2) z ~ (1, 0, 2); area-weighted
  // it would be ~ (4, 0, 1), uniform ~ (1, 0, 1).
  twinray::Mesh<T> m;
  m.vertices = {vec3(0, 0, 0), vec3(1, 0, 0), vec3(0, 1, 0), vec3(0, 2, 0), vec3(0, 2, 2)};
  m.triangles = {{0, 1, 2}, {0, 3, 4}};
  twinray::smooth_normals(m, 180.0);
  check_well_formed(m);
  const dvec3 want = dvec3(1, 0, 2) / std::sqrt(5.0);
  CHECK(near(corner(m, 0, 0), want, tolerance<T>()));
  CHECK(near(corner(m, 1, 0), want, tolerance<T>()));
  CHECK(corner(m, 0, 1) == dvec3(0, 0, 1));  // corners with one face keep its normal
  CHECK(corner(m, 1, 2) == dvec3(1, 0, 0));
  CHECK(m.normals.size() == 3);

  // Splitting the right angle into two 45 degree triangles changes nothing.
  m.vertices.push_back(vec3(1, 1, 0));
  m.triangles = {{0, 1, 5}, {0, 5, 2}, {0, 3, 4}};
  twinray::smooth_normals(m, 180.0);
  check_well_formed(m);
  for (size_t f = 0; f < 3; ++f) CHECK(near(corner(m, f, 0), want, tolerance<T>()));
}

TEST_CASE_TEMPLATE("mesh normals: each corner sums the faces within the crease of its own", T,
                   float, double) {
  using vec3 = glm::vec<3, T>;
  // Three right-angled triangles at the origin with normals (0, -sin t, cos t) for t =
  // -40, 0 and 40 degrees: the outer two are 80 degrees apart, each 40 from the middle.
  const double pi = 3.14159265358979323846;
  twinray::Mesh<T> m;
  m.vertices.push_back(vec3(0, 0, 0));
  for (int i = 0; i < 3; ++i) {
    double t = (i - 1) * 40.0 * pi / 180.0;
    m.vertices.push_back(vec3(T(i + 1), T(0), T(0)));
    m.vertices.push_back(vec3(dvec3(0, std::cos(t), std::sin(t))));
    m.triangles.push_back({0, 2 * i + 1, 2 * i + 2});
  }
  auto tilted = [&](double degrees) {
    double t = degrees * pi / 180.0;
    return dvec3(0, -std::sin(t), std::cos(t));
  };
  const double tol = std::is_same<T, float>::value ? 1e-6 : 1e-14;
  twinray::smooth_normals(m, 60.0);
  check_well_formed(m);
  CHECK(near(corner(m, 0, 0), tilted(-20), tol));  // itself and the middle
  CHECK(near(corner(m, 1, 0), tilted(0), tol));    // all three
  CHECK(near(corner(m, 2, 0), tilted(20), tol));
  twinray::smooth_normals(m, 30.0);
  for (size_t f = 0; f < 3; ++f) CHECK(near(corner(m, f, 0), tilted((int(f) - 1) * 40.0), tol));
  twinray::smooth_normals(m, 90.0);
  for (size_t f = 0; f < 3; ++f) CHECK(near(corner(m, f, 0), tilted(0), tol));
}

TEST_CASE_TEMPLATE("mesh normals: equal positions are welded", T, float, double) {
  using vec3 = glm::vec<3, T>;
  twinray::Mesh<T> shared = cube<T>();
  // Every triangle with its own copies of its vertices; some zeros written as -0.
  twinray::Mesh<T> split;
  for (int f = 0; f < 12; ++f) {
    for (int v : shared.triangles[size_t(f)]) {
      vec3 p = shared.vertices[size_t(v)];
      if (f % 3 == 0)
        for (int c = 0; c < 3; ++c) p[c] = p[c] == T(0) ? -T(0) : p[c];
      split.vertices.push_back(p);
    }
    split.triangles.push_back({3 * f, 3 * f + 1, 3 * f + 2});
  }
  REQUIRE(split.vertices.size() == 36);
  for (double crease : {180.0, 60.0}) {
    twinray::smooth_normals(shared, crease);
    twinray::smooth_normals(split, crease);
    check_well_formed(split);
    CHECK(split.normals.size() == shared.normals.size());
    for (size_t f = 0; f < 12; ++f)
      for (int k = 0; k < 3; ++k) CHECK(corner(split, f, k) == corner(shared, f, k));
  }
}

TEST_CASE_TEMPLATE("mesh normals: a flat grid", T, float, double) {
  using vec3 = glm::vec<3, T>;
  // Unevenly spaced points on the plane z = 2.5, two triangles per cell.
  const int n = 20;
  twinray::Mesh<T> m;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i)
      m.vertices.push_back(vec3(T(i * 0.37 + (i % 3) * 0.01), T(j * 0.29 + (j % 4) * 0.02), 2.5));
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      int a = j * (n + 1) + i, b = a + 1, c = a + n + 1, d = c + 1;
      if ((i + j) % 2) {
        m.triangles.push_back({a, b, d});
        m.triangles.push_back({a, d, c});
      } else {
        m.triangles.push_back({a, b, c});
        m.triangles.push_back({b, d, c});
      }
    }
  for (double crease : {0.0, 60.0, 180.0}) {
    twinray::smooth_normals(m, crease);
    check_well_formed(m);
    REQUIRE(m.normals.size() == 1);
    CHECK(m.normals[0] == vec3(0, 0, 1));
    // The bits too: no -0.
    CHECK(!std::signbit(m.normals[0].x));
    CHECK(!std::signbit(m.normals[0].y));
  }
}

TEST_CASE_TEMPLATE("mesh normals: degenerate triangles", T, float, double) {
  using vec3 = glm::vec<3, T>;
  twinray::Mesh<T> m = cube<T>();
  // Zero-area triangles: a repeated vertex, three collinear vertices, three copies of
  // one new point, and a NaN vertex.
  const T nan = std::numeric_limits<T>::quiet_NaN();
  m.vertices.push_back(vec3(0.5, 0, 0));  // 8: on the edge 0-1
  m.vertices.push_back(vec3(3, 3, 3));    // 9, 10, 11: one point
  m.vertices.push_back(vec3(3, 3, 3));
  m.vertices.push_back(vec3(3, 3, 3));
  m.vertices.push_back(vec3(nan, 0, 0));  // 12
  m.triangles.push_back({7, 7, 3});
  m.triangles.push_back({0, 8, 1});
  m.triangles.push_back({9, 10, 11});
  m.triangles.push_back({12, 5, 6});
  // A two-sided sheet: at crease 180 the two faces cancel, and each keeps its own.
  m.vertices.push_back(vec3(5, 0, 0));  // 13, 14, 15
  m.vertices.push_back(vec3(6, 0, 0));
  m.vertices.push_back(vec3(5, 1, 0));
  m.triangles.push_back({13, 14, 15});
  m.triangles.push_back({13, 15, 14});
  m.vertices.push_back(vec3(7, 7, 7));  // used by no triangle
  for (double crease : {180.0, 60.0, 0.0}) {
    twinray::smooth_normals(m, crease);
    check_well_formed(m);
    twinray::Mesh<T> reference = cube<T>();
    twinray::smooth_normals(reference, crease);
    for (size_t f = 0; f < 12; ++f)
      for (int k = 0; k < 3; ++k) CHECK(corner(m, f, k) == corner(reference, f, k));
    for (int k = 0; k < 3; ++k) {
      CHECK(corner(m, 16, k) == dvec3(0, 0, 1));
      CHECK(corner(m, 17, k) == dvec3(0, 0, -1));
    }
  }
}

TEST_CASE_TEMPLATE("mesh normals: tiny and huge coordinates", T, float, double) {
  // Edge cross products would underflow or overflow without rescaling.
  const int e = std::numeric_limits<T>::max_exponent - 8;
  for (T scale : {std::ldexp(T(1), -e), std::ldexp(T(1), e)}) {
    twinray::Mesh<T> m = cube<T>(scale);
    twinray::smooth_normals(m, 60.0);
    check_well_formed(m);
    for (size_t f = 0; f < 12; ++f)
      for (int k = 0; k < 3; ++k) CHECK(corner(m, f, k) == kCubeNormals[f / 2]);
    twinray::smooth_normals(m, 180.0);
    CHECK(near(corner(m, 0, 0), -dvec3(1) / std::sqrt(3.0), tolerance<T>()));
  }
}

TEST_CASE_TEMPLATE("mesh normals: many faces at a vertex", T, float, double) {
  using vec3 = glm::vec<3, T>;
  const double pi = 3.14159265358979323846;
  const double tol = std::is_same<T, float>::value ? 1e-6 : 1e-13;
  // Cones of 100 sides around the apex (0, 0, 1), closed by a flat base of 100 more
  // triangles around (0, 0, 0): the apex has 100 distinct face normals, which all lie
  // within half the crease of their mean for a flat cone and not for a steep one; the
  // base's centre has 100 equal ones.
  for (double height : {0.15, 1.0}) {
    twinray::Mesh<T> m;
    const int n = 100;
    m.vertices = {vec3(0, 0, height), vec3(0, 0, 0)};
    for (int i = 0; i < n; ++i) {
      double phi = 2 * pi * (i + 0.3 * (i % 3)) / n;  // unevenly spaced
      m.vertices.push_back(vec3(T(std::cos(phi)), T(std::sin(phi)), T(0)));
    }
    for (int i = 0; i < n; ++i) {
      int a = 2 + i, b = 2 + (i + 1) % n;
      m.triangles.push_back({0, a, b});
      m.triangles.push_back({1, b, a});
    }
    for (double crease : {10.0, 60.0, 180.0}) {
      twinray::smooth_normals(m, crease);
      check_well_formed(m);
      for (size_t f = 0; f < m.triangles.size(); ++f)
        for (int k = 0; k < 3; ++k) {
          INFO("height ", height, ", crease ", crease, ", triangle ", f, ", corner ", k);
          CHECK(near(corner(m, f, k), reference(m, f, k, crease), tol));
        }
      for (size_t f = 1; f < m.triangles.size(); f += 2) CHECK(corner(m, f, 0) == dvec3(0, 0, -1));
    }
  }
}

TEST_CASE("mesh normals: a bumpy grid, against the definition") {
  twinray::Mesh<double> m = bumpy_grid(40);
  twinray::smooth_normals(m, 30.0);
  check_well_formed(m);
  CHECK(m.normals.size() > m.vertices.size());  // some creases split vertices
  for (size_t f = 0; f < m.triangles.size(); ++f)
    for (int k = 0; k < 3; ++k) CHECK(near(corner(m, f, k), reference(m, f, k, 30.0), 1e-13));
}

TEST_CASE("mesh normals: the same on any number of threads") {
  // Big enough for several chunks of faces and vertices, and two blocks of vertices.
  twinray::Mesh<double> m = bumpy_grid(260);
  twinray::set_thread_count(1);
  twinray::smooth_normals(m, 30.0);
  twinray::Mesh<double> again = m;
  twinray::set_thread_count(3);
  twinray::smooth_normals(again, 30.0);
  twinray::set_thread_count(0);
  check_well_formed(m);
  CHECK(again.normals == m.normals);
  CHECK(again.normal_triangles == m.normal_triangles);
  // Spot checks on both sides of every multiple of 4096 (where chunks may end).
  for (size_t f = 0; f < m.triangles.size(); ++f)
    if (f % 4096 == 0 || f % 4096 == 4095)
      for (int k = 0; k < 3; ++k) CHECK(near(corner(m, f, k), reference(m, f, k, 30.0), 1e-13));
}

TEST_CASE("mesh normals: what smooth_normals refuses") {
  CHECK(error_of(-1) == "smooth_normals: crease_degrees must be in [0, 180], got -1");
  CHECK(error_of(181) == "smooth_normals: crease_degrees must be in [0, 180], got 181");
  CHECK(error_of(std::nan("")) == "smooth_normals: crease_degrees must be in [0, 180], got nan");
  CHECK(error_of(0) == "");
  CHECK(error_of(180) == "");
  twinray::Mesh<float> m = cube<float>();
  m.triangles[3][1] = 8;
  CHECK_THROWS_AS(twinray::smooth_normals(m), twinray::Error);
  CHECK(m.normals.empty());  // nothing changed
}

TEST_CASE_TEMPLATE("mesh normals: flat_normals clears", T, float, double) {
  twinray::Mesh<T> m = cube<T>();
  twinray::smooth_normals(m);
  REQUIRE(!m.normals.empty());
  twinray::flat_normals(m);
  CHECK(m.normals.empty());
  CHECK(m.normal_triangles.empty());
  CHECK(m.vertices.size() == 8);
  CHECK(m.triangles.size() == 12);
}
