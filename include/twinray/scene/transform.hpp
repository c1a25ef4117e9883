// Transform: where an object goes. An affine map in double, applied once to the object's
// own numbers (a sphere's center and radius, a triangle's or mesh's vertices, a plane's
// point and normal) and rounded to T once, so a placed object is an ordinary object:
// the device code never sees a matrix, and both backends render the same bits.
//
//   auto t = twinray::Transform::scale_rotate_translate({0.01, 0.01, 0.01},   // cm -> m
//                                                      {0, 1, 0}, 90.0,      // axis, degrees
//                                                      {2, 0, -3});
//   twinray::place(mesh, t);     // or: scene.add(twinray::placed(object, t))
//
// The order is the scene format's: scale, then rotate, then translate. A mesh's shared
// vertices map to bit-identical points, so the watertight triangle test still sees the
// same edges. Refused, as twinray::Error(InvalidInput): a matrix that is not affine or
// is singular, and a map that would make a sphere an ellipsoid (a sphere takes only
// uniform scale, rotation and translation), or a result that T cannot hold.
#pragma once

#include <cmath>
#include <string>
#include <variant>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>
#include <glm/vec3.hpp>

#include <twinray/core/error.hpp>
#include <twinray/scene/scene.hpp>

namespace twinray {

struct Transform {
  glm::dmat4 m{1.0};  // column-major (glm): m[column][row]

  // scale, then a rotation of `degrees` about `axis` (right-hand rule), then translate.
  static Transform scale_rotate_translate(const glm::dvec3& scale, const glm::dvec3& axis,
                                          double degrees, const glm::dvec3& translate) {
    double len = glm::length(axis);
    if (!(len > 0.0) || !std::isfinite(len))
      throw invalid_input("rotation axis must be a non-zero vector");
    glm::dvec3 a = axis / len;
    // Rodrigues' rotation formula, R = c I + s [a]x + (1 - c) a a^T. Whole quarter
    // turns are exact, so 90 degrees about an axis maps (1, 0, 0) to exact values.
    double c, s;
    double quarter = degrees / 90.0;
    if (quarter == std::floor(quarter)) {
      long long q = static_cast<long long>(std::fmod(std::fmod(quarter, 4.0) + 4.0, 4.0));
      const double cs[4][2] = {{1, 0}, {0, 1}, {-1, 0}, {0, -1}};
      c = cs[q][0];
      s = cs[q][1];
    } else {
      double radians = degrees * 3.14159265358979323846 / 180.0;
      c = std::cos(radians);
      s = std::sin(radians);
    }
    glm::dmat3 r;
    for (int col = 0; col < 3; ++col)
      for (int row = 0; row < 3; ++row) r[col][row] = (1.0 - c) * a[row] * a[col];
    for (int i = 0; i < 3; ++i) r[i][i] += c;
    // s [a]x; glm indexes [column][row], and [a]x's rows are (0, -az, ay),
    // (az, 0, -ax), (-ay, ax, 0).
    r[1][0] -= s * a.z;
    r[2][0] += s * a.y;
    r[0][1] += s * a.z;
    r[2][1] -= s * a.x;
    r[0][2] -= s * a.y;
    r[1][2] += s * a.x;
    Transform t;
    for (int col = 0; col < 3; ++col)
      for (int row = 0; row < 3; ++row) t.m[col][row] = r[col][row] * scale[col];
    t.m[3] = glm::dvec4(translate, 1.0);
    t.check();
    return t;
  }

  // A 4x4 matrix given row by row, as the scene format writes it.
  static Transform from_rows(const double rows[4][4]) {
    if (rows[3][0] != 0.0 || rows[3][1] != 0.0 || rows[3][2] != 0.0 || rows[3][3] != 1.0)
      throw invalid_input("the last row must be [0, 0, 0, 1] (an affine map)");
    Transform t;
    for (int row = 0; row < 4; ++row)
      for (int col = 0; col < 4; ++col) t.m[col][row] = rows[row][col];
    t.check();
    return t;
  }

  glm::dmat3 linear() const { return glm::dmat3(m); }
  glm::dvec3 point(const glm::dvec3& p) const { return glm::dvec3(m * glm::dvec4(p, 1.0)); }

  // Refuses a map that is singular (its linear part squashes space into a plane, so a
  // triangle would lose its area and a plane its normal) or not finite.
  void check() const {
    for (int col = 0; col < 4; ++col)
      for (int row = 0; row < 4; ++row)
        if (!std::isfinite(m[col][row])) throw invalid_input("the transform is not finite");
    glm::dmat3 l = linear();
    double det = glm::determinant(l);
    double scale = glm::length(l[0]) * glm::length(l[1]) * glm::length(l[2]);
    // Relative to the columns' lengths, so the test is the same at any scale.
    if (!(std::fabs(det) > 1e-12 * scale))
      throw invalid_input("the transform is singular (determinant " + std::to_string(det) + ")");
  }

  // The one scale factor of a similarity (rotation, reflection, uniform scale), or 0
  // when the linear part is anything else: the three columns must be orthogonal and of
  // one length, to 1e-9 relative (what rotations computed in double keep).
  double uniform_scale() const {
    glm::dmat3 l = linear();
    double s2 = glm::dot(l[0], l[0]);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        double want = i == j ? s2 : 0.0;
        if (std::fabs(glm::dot(l[i], l[j]) - want) > 1e-9 * s2) return 0.0;
      }
    return std::sqrt(s2);
  }
};

namespace detail {

template <class T>
glm::vec<3, T> placed_point(const Transform& t, const glm::vec<3, T>& p, const char* what) {
  glm::dvec3 q = t.point(glm::dvec3(p));
  glm::vec<3, T> out(q);
  if (!std::isfinite(out.x) || !std::isfinite(out.y) || !std::isfinite(out.z))
    throw invalid_input(std::string("the transform moves ") + what +
                        " outside the range of the render's precision");
  return out;
}

}  // namespace detail

template <class T>
void place(Sphere<T>& s, const Transform& t) {
  double k = t.uniform_scale();
  if (!(k > 0.0))
    throw invalid_input(
        "a sphere takes only uniform scale, rotation and translation: this transform would "
        "make it an ellipsoid");
  s.center = detail::placed_point(t, s.center, "the center");
  T radius = static_cast<T>(double(s.radius) * k);
  if (!(radius > T(0)) || !std::isfinite(radius))
    throw invalid_input("the transform scales the radius to " + std::to_string(radius));
  s.radius = radius;
}

template <class T>
void place(Triangle<T>& tri, const Transform& t) {
  for (auto& v : tri.vertices) v = detail::placed_point(t, v, "a vertex");
}

// Vertex normals map by the inverse transpose, as plane normals do.
template <class T>
void place(Mesh<T>& mesh, const Transform& t) {
  for (auto& v : mesh.vertices) v = detail::placed_point(t, v, "a vertex");
  if (mesh.normals.empty()) return;
  glm::dmat3 normal_map = glm::transpose(glm::inverse(t.linear()));
  for (auto& n : mesh.normals) n = glm::vec<3, T>(glm::normalize(normal_map * glm::dvec3(n)));
}

// Normals map by the inverse transpose, so they stay perpendicular to the plane.
template <class T>
void place(Plane<T>& plane, const Transform& t) {
  plane.point = detail::placed_point(t, plane.point, "the point");
  glm::dvec3 n = glm::transpose(glm::inverse(t.linear())) * glm::dvec3(plane.normal);
  plane.normal = glm::vec<3, T>(glm::normalize(n));
}

// An instance is placed by composing maps: t after its own.
template <class T>
void place(Instance<T>& instance, const Transform& t) {
  instance.to_world = t.m * instance.to_world;
}

template <class T>
void place(Object<T>& object, const Transform& t) {
  std::visit([&](auto& o) { place(o, t); }, object);
}

template <class T>
Object<T> placed(Object<T> object, const Transform& t) {
  place(object, t);
  return object;
}

}  // namespace twinray
