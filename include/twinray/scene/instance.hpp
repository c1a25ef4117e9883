// Assets and instances: an asset is a list of objects packed once, with a BVH of its
// own, and not rendered by itself; an Instance<T> places it in the world through an
// affine map (any invertible one: rotation, non-uniform scale, mirroring). Rays enter
// the asset through the inverse map (device/instance.h), so a thousand instances cost
// one asset's memory and a few hundred bytes each.
//
//   twinray::Asset<float> tree{"tree", {twinray::Object<float>(trunk), ...}};
//   int id = scene.add_asset(tree);
//   scene.add_instance(id, twinray::Transform::scale_rotate_translate(...).m);
//
// One level: an asset holds spheres, triangles and meshes, never instances (as in
// OSPRay), and no planes (an unbounded plane has no box to place).
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/mat4x4.hpp>

namespace twinray {

// The inverse of an affine map (last row 0 0 0 1): the inverse of its 3x3 linear part
// by cofactors over the determinant, and the translation mapped back by it. False (and
// `inverse` unset) where the determinant is 0 or anything is not finite. A few dozen
// operations, against a general 4x4 inverse's hundreds: a top level of 10,000
// instances takes one per instance per build.
inline bool affine_inverse(const glm::dmat4& m, glm::dmat4& inverse) {
  // m[column][row]; a..i the rows of the linear part.
  const double a = m[0][0], b = m[1][0], c = m[2][0];
  const double d = m[0][1], e = m[1][1], f = m[2][1];
  const double g = m[0][2], h = m[1][2], i = m[2][2];
  const double c00 = e * i - f * h, c01 = f * g - d * i, c02 = d * h - e * g;
  const double det = a * c00 + b * c01 + c * c02;
  if (!(det != 0.0) || !std::isfinite(det)) return false;
  const double r = 1.0 / det;
  glm::dmat4 out(1.0);
  out[0][0] = c00 * r, out[1][0] = (c * h - b * i) * r, out[2][0] = (b * f - c * e) * r;
  out[0][1] = c01 * r, out[1][1] = (a * i - c * g) * r, out[2][1] = (c * d - a * f) * r;
  out[0][2] = c02 * r, out[1][2] = (b * g - a * h) * r, out[2][2] = (a * e - b * d) * r;
  const glm::dvec3 t(m[3]);
  for (int row = 0; row < 3; ++row)
    out[3][row] = -(out[0][row] * t.x + out[1][row] * t.y + out[2][row] * t.z);
  for (int col = 0; col < 4; ++col)
    for (int row = 0; row < 3; ++row)
      if (!std::isfinite(out[col][row])) return false;
  inverse = out;
  return true;
}

template <class T>
struct Instance {
  int asset = 0;             // index into Scene<T>::assets
  glm::dmat4 to_world{1.0};  // the asset's space to the world (glm: m[column][row])
  int material = -1;         // replaces the asset's materials; -1 keeps them
  uint32_t mask = 0xffffffffu;
};

}  // namespace twinray
