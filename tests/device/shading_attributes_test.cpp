// Vertex normals, texture coordinates and texture lookups in the shared device code
// (intersect_triangle.h tr_triangle_attributes, texture.h), called on the host: the
// interpolation, the shadow-terminator lift (Hanika 2021) and bilinear repeat filtering.
#include <doctest/doctest.h>

#include <cmath>
#include <vector>

#include "device/device_test_util.hpp"

using test::Code;
using test::K;
using test::make_ray;
using test::vec3;

namespace {

template <class T>
typename Code<T>::Triangle flat_triangle() {
  // In the z = 0 plane, counter-clockwise seen from +z: geometric normal +z.
  return {T(0), T(0), T(0), T(2), T(0), T(0), T(0), T(2), T(0), 0, 0};
}

template <class T>
typename Code<T>::TriangleAttr attributes(vec3<T> n0, vec3<T> n1, vec3<T> n2) {
  typename Code<T>::TriangleAttr a{};
  a.n0x = n0.x, a.n0y = n0.y, a.n0z = n0.z;
  a.n1x = n1.x, a.n1y = n1.y, a.n1z = n1.z;
  a.n2x = n2.x, a.n2y = n2.y, a.n2z = n2.z;
  a.u0 = T(0), a.v0 = T(0), a.u1 = T(1), a.v1 = T(0), a.u2 = T(0), a.v2 = T(1);
  a.flags = TR_ATTR_NORMALS | TR_ATTR_UV;
  return a;
}

// The hit record of a vertical ray onto the triangle at (x, y), from above (or from
// below), made as tr_record_hit makes it.
template <class T>
typename Code<T>::Hit hit_at(const typename Code<T>::Triangle& tri,
                             const typename Code<T>::TriangleAttr& attr, T x, T y,
                             bool from_below = false) {
  T side = from_below ? T(-1) : T(1);
  auto ray = make_ray<T>(vec3<T>(x, y, T(5) * side), vec3<T>(T(0), T(0), -side));
  auto tr = K<T>::tr_triangle_ray(ray);
  T t = K<T>::tr_triangle_t(&tri, ray, &tr);
  REQUIRE(t > T(0));
  typename Code<T>::Hit hit = test::no_hit<T>();
  vec3<T> bary;
  K<T>::tr_triangle_record(&tri, ray, &tr, t, &hit, &bary);
  hit.ns = hit.n;
  hit.shadow_p = hit.p;
  hit.shadow_perr = hit.perr;
  K<T>::tr_triangle_attributes(&attr, &tri, bary, ray.d, &hit);
  return hit;
}

}  // namespace

TEST_CASE_TEMPLATE("vertex normals and uvs are interpolated by the barycentrics", T, float,
                   double) {
  auto tri = flat_triangle<T>();
  vec3<T> up(T(0), T(0), T(1));
  vec3<T> tilted = glm::normalize(vec3<T>(T(1), T(0), T(1)));
  auto attr = attributes<T>(up, tilted, up);
  auto hit = hit_at<T>(tri, attr, T(0.5), T(0.5));  // barycentrics (0.5, 0.25, 0.25)
  glm::dvec3 expect =
      glm::normalize(glm::dvec3(up) * 0.5 + glm::dvec3(tilted) * 0.25 + glm::dvec3(up) * 0.25);
  CHECK(double(hit.ns.x) == doctest::Approx(expect.x).epsilon(1e-6));
  CHECK(double(hit.ns.z) == doctest::Approx(expect.z).epsilon(1e-6));
  CHECK(hit.n == up);  // the geometric normal is kept
  CHECK(double(hit.u) == doctest::Approx(0.25));
  CHECK(double(hit.v) == doctest::Approx(0.25));
}

TEST_CASE_TEMPLATE("vertex normals equal to the geometric one leave the shadow origin alone", T,
                   float, double) {
  auto tri = flat_triangle<T>();
  vec3<T> up(T(0), T(0), T(1));
  auto hit = hit_at<T>(tri, attributes<T>(up, up, up), T(0.3), T(0.7));
  CHECK(hit.shadow_p == hit.p);
  CHECK(hit.shadow_perr == hit.perr);
  CHECK(hit.ns == up);
}

// Normals tilted outward, as on a coarse sphere: p lies below each vertex's tangent
// plane, and the shadow origin is lifted by sum b_i (-(p - p_i).n_i) n_i (Hanika 2021).
TEST_CASE_TEMPLATE("the shadow terminator: the shadow origin is lifted onto the smooth surface", T,
                   float, double) {
  auto tri = flat_triangle<T>();
  glm::dvec3 c(2.0 / 3, 2.0 / 3, -1.0);  // a sphere's center below the triangle
  glm::dvec3 corners[3] = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}};
  vec3<T> n[3];
  for (int i = 0; i < 3; ++i) n[i] = vec3<T>(glm::normalize(corners[i] - c));
  auto hit = hit_at<T>(tri, attributes<T>(n[0], n[1], n[2]), T(0.5), T(0.5));
  const double b[3] = {0.5, 0.25, 0.25};
  glm::dvec3 p(0.5, 0.5, 0.0), lift(0.0);
  for (int i = 0; i < 3; ++i) {
    double d = glm::dot(p - corners[i], glm::dvec3(n[i]));
    REQUIRE(d < 0.0);
    lift += glm::dvec3(n[i]) * (-d * b[i]);
  }
  glm::dvec3 expect = p + lift;
  CHECK(double(hit.shadow_p.z) > 0.0);  // off the flat facet, on the side the ray came from
  for (int k = 0; k < 3; ++k)
    CHECK(double(hit.shadow_p[k]) == doctest::Approx(expect[k]).epsilon(1e-5));
  CHECK(hit.shadow_perr.z > hit.perr.z);  // the lift's rounding is in the bound

  // Seen from below, the normals are turned to that side, where p lies above every
  // tangent plane (the surface is concave from there): nothing to lift.
  auto below = hit_at<T>(tri, attributes<T>(n[0], n[1], n[2]), T(0.5), T(0.5), true);
  CHECK(below.shadow_p == below.p);
  CHECK(below.ns == hit.ns);  // the shading normal is reported as given, not turned
}

TEST_CASE_TEMPLATE("opposite vertex normals that cancel keep the geometric normal", T, float,
                   double) {
  auto tri = flat_triangle<T>();
  vec3<T> a(T(1), T(0), T(0));
  auto attr = attributes<T>(a, -a, a);
  // Barycentrics (0, 0.5, 0.5) at (1, 1): 0.5 (-a) + 0.5 a = 0.
  auto hit = hit_at<T>(tri, attr, T(1), T(1));
  CHECK(hit.ns == hit.n);
}

TEST_CASE_TEMPLATE("textures: bilinear between texel centers, repeat wrap, row 0 at v = 1", T,
                   float, double) {
  // 2 x 2 texels: row 0 (top) red, green; row 1 blue, white.
  std::vector<T> texels = {1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 1, 1};
  typename Code<T>::Texture texture{2, 2, 0, 0};
  typename Code<T>::SceneRef s{};
  s.textures = &texture;
  s.texels = texels.data();
  auto at = [&](T u, T v) { return K<T>::tr_texture_rgb(&s, 0, u, v); };
  // Texel centers: exact values.
  CHECK(at(T(0.25), T(0.75)) == vec3<T>(1, 0, 0));
  CHECK(at(T(0.75), T(0.75)) == vec3<T>(0, 1, 0));
  CHECK(at(T(0.25), T(0.25)) == vec3<T>(0, 0, 1));
  CHECK(at(T(0.75), T(0.25)) == vec3<T>(1, 1, 1));
  // Halfway between the top two: an even mix.
  CHECK(at(T(0.5), T(0.75)) == vec3<T>(T(0.5), T(0.5), 0));
  // Repeat: u + 1, u - 3 and v + 2 read the same texel; past the right edge the left
  // column is the neighbour (u = 1 is halfway between green and red again).
  CHECK(at(T(1.25), T(2.75)) == vec3<T>(1, 0, 0));
  CHECK(at(T(-2.75), T(0.75)) == vec3<T>(1, 0, 0));
  CHECK(at(T(1.0), T(0.75)) == vec3<T>(T(0.5), T(0.5), 0));
  CHECK(at(T(0.0), T(0.75)) == vec3<T>(T(0.5), T(0.5), 0));
  // Not finite: read as 0 (the corner texels' mix), never out of bounds.
  vec3<T> nan_uv = at(T(NAN), T(INFINITY));
  CHECK(std::isfinite(nan_uv.x));
}
