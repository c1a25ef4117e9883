// triangulate_polygon(): a polygon's corners cut into triangles, for mesh loaders
// (an OBJ face may have any number of corners; the renderer takes triangles).
//
// A quad is cut along its shorter diagonal, where that diagonal lies inside it (ties:
// the diagonal 1-3); a concave quad along the other one. Larger polygons are cut by
// ear clipping (Eberly, "Triangulation by Ear Clipping", 2002) in the coordinate plane
// most nearly parallel to them, found from their Newell normal (Sutherland, Sproull and
// Schumacker 1974), so non-planar faces from modelling tools still cut cleanly. A
// polygon with no ear left (self-intersecting or degenerate) has its next corner
// clipped anyway, so there are always n - 2 triangles.
#pragma once

#include <array>
#include <cmath>
#include <vector>

#include <glm/glm.hpp>

namespace twinray {

// Newell's normal of a closed polygon: its direction is the polygon's facing (corners
// counter-clockwise seen from it), its length twice the area, for non-planar polygons
// too.
inline glm::dvec3 newell_normal(const std::vector<glm::dvec3>& p) {
  glm::dvec3 n(0.0);
  for (size_t i = 0, count = p.size(); i < count; ++i) {
    const glm::dvec3& a = p[i];
    const glm::dvec3& b = p[(i + 1) % count];
    n.x += (a.y - b.y) * (a.z + b.z);
    n.y += (a.z - b.z) * (a.x + b.x);
    n.z += (a.x - b.x) * (a.y + b.y);
  }
  return n;
}

// Writes the n - 2 triangles of corners p[0..n) (n >= 3) to `out`, as corner numbers
// in the polygon's order. `work` counts the point-in-triangle tests spent (ear
// clipping costs O(n r) for r reflex corners, O(n^3) for pathological polygons); the
// call returns false, with `out` incomplete, once it passes `work_limit`.
inline bool triangulate_polygon(const std::vector<glm::dvec3>& p,
                                std::vector<std::array<int, 3>>& out, long long& work,
                                long long work_limit) {
  const int n = static_cast<int>(p.size());
  out.clear();
  if (n < 3) return true;
  if (n == 3) {
    out.push_back({0, 1, 2});
    return true;
  }
  const glm::dvec3 normal = newell_normal(p);
  if (n == 4) {
    auto faces = [&](int a, int b, int c) {
      return glm::dot(glm::cross(p[b] - p[a], p[c] - p[a]), normal) > 0.0;
    };
    const glm::dvec3 d02 = p[2] - p[0], d13 = p[3] - p[1];
    const bool inside02 = faces(0, 1, 2) && faces(0, 2, 3);
    const bool inside13 = faces(0, 1, 3) && faces(1, 2, 3);
    const bool along02 =
        glm::dot(d02, d02) < glm::dot(d13, d13) ? inside02 || !inside13 : inside02 && !inside13;
    if (along02) {
      out.push_back({0, 1, 2});
      out.push_back({0, 2, 3});
    } else {
      out.push_back({0, 1, 3});
      out.push_back({1, 2, 3});
    }
    return true;
  }

  // Project onto the plane that drops the normal's largest axis, turned so that the
  // polygon runs counter-clockwise.
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (std::abs(normal[k]) > std::abs(normal[axis])) axis = k;
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  const double flip = normal[axis] < 0.0 ? -1.0 : 1.0;
  std::vector<glm::dvec2> q(static_cast<size_t>(n));
  std::vector<int> prev(static_cast<size_t>(n)), next(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    q[i] = glm::dvec2(p[i][u], flip * p[i][v]);
    prev[i] = (i + n - 1) % n;
    next[i] = (i + 1) % n;
  }
  auto cross = [](const glm::dvec2& a, const glm::dvec2& b) { return a.x * b.y - a.y * b.x; };
  auto convex = [&](int a, int b, int c) { return cross(q[b] - q[a], q[c] - q[b]) > 0.0; };
  // An ear: a convex corner b whose triangle (a, b, c) holds no other corner (only a
  // reflex one can lie inside; corners on the triangle's edges count as inside).
  auto is_ear = [&](int a, int b, int c) {
    if (!convex(a, b, c)) return false;
    for (int k = next[c]; k != a; k = next[k]) {
      ++work;
      if (q[k] == q[a] || q[k] == q[b] || q[k] == q[c] || convex(prev[k], k, next[k])) continue;
      if (cross(q[b] - q[a], q[k] - q[a]) >= 0.0 && cross(q[c] - q[b], q[k] - q[b]) >= 0.0 &&
          cross(q[a] - q[c], q[k] - q[c]) >= 0.0)
        return false;
    }
    return true;
  };
  int left = n, a = 0, misses = 0;
  while (left > 3) {
    if (work > work_limit) return false;
    const int b = next[a], c = next[b];
    if (is_ear(a, b, c) || misses >= left) {
      out.push_back({a, b, c});
      next[a] = c;
      prev[c] = a;
      --left;
      misses = 0;
    } else {
      a = next[a];
      ++misses;
    }
  }
  out.push_back({a, next[a], next[next[a]]});
  return true;
}

}  // namespace twinray
