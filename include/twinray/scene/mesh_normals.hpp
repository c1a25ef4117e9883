// smooth_normals(): shading normals for a Mesh<T> computed from its faces, so that a
// tessellated curved surface shades smooth while its hard edges stay hard. Each vertex
// normal is the angle-weighted mean of the incident unit face normals (G. Thürmer and
// C. A. Wüthrich, "Computing vertex normals from polygonal facets", Journal of Graphics
// Tools 3(1), 1998): weighting by the interior angle at the vertex makes the result
// independent of how the surface was triangulated, unlike area or uniform weights.
// flat_normals(): removes shading normals.
#pragma once

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <string>
#include <type_traits>
#include <vector>
#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <twinray/core/error.hpp>
#include <twinray/core/parallel.hpp>
#include <twinray/scene/shapes.hpp>

namespace twinray {

namespace detail {

// Numbers bitwise-distinct 3-vectors in order of first occurrence (-0 == +0); open
// addressing, O(1) expected per find_or_add. A slot holds the hash's high half and the
// index + 1 (0: empty), so probing past other keys does not read them.
template <class T>
class VectorIndex {
 public:
  std::vector<glm::vec<3, T>> keys;

  explicit VectorIndex(size_t expected) {
    keys.reserve(expected);
    size_t cap = 16;
    while (cap < 2 * expected) cap *= 2;
    table_.assign(cap, 0);
  }

  int find_or_add(glm::vec<3, T> v) {
    for (int c = 0; c < 3; ++c) v[c] = v[c] == T(0) ? T(0) : v[c];
    const uint64_t h = hash(v), tag = h & ~0xffffffffull;
    for (size_t s = h & (table_.size() - 1);; s = (s + 1) & (table_.size() - 1)) {
      const uint64_t e = table_[s];
      if (e == 0) {
        if (2 * (keys.size() + 1) > table_.size()) {
          grow();
          return find_or_add(v);
        }
        keys.push_back(v);
        table_[s] = tag | keys.size();
        return int(keys.size() - 1);
      }
      const size_t i = size_t(e & 0xffffffffu) - 1;
      if ((e & ~0xffffffffull) == tag && std::memcmp(&keys[i], &v, sizeof v) == 0) return int(i);
    }
  }

 private:
  std::vector<uint64_t> table_;

  static uint64_t hash(const glm::vec<3, T>& v) {
    using Bits = std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>;
    uint64_t h = 0;
    for (int c = 0; c < 3; ++c) {  // splitmix64's finalizer over each coordinate
      Bits b;
      std::memcpy(&b, &v[c], sizeof b);
      h = (h ^ uint64_t(b)) + 0x9e3779b97f4a7c15ull;
      h = (h ^ (h >> 30)) * 0xbf58476d1ce4e5b9ull;
      h = (h ^ (h >> 27)) * 0x94d049bb133111ebull;
      h ^= h >> 31;
    }
    return h;
  }

  void grow() {
    table_.assign(table_.size() * 2, 0);
    for (size_t i = 0; i < keys.size(); ++i) {
      const uint64_t h = hash(keys[i]);
      size_t s = h & (table_.size() - 1);
      while (table_[s] != 0) s = (s + 1) & (table_.size() - 1);
      table_[s] = (h & ~0xffffffffull) | (i + 1);
    }
  }
};

}  // namespace detail

// Replaces mesh.normals and mesh.normal_triangles with angle-weighted vertex normals.
// The normal at corner k of face f sums the faces g around the same (welded) vertex
// whose unit normals are within crease_degrees of f's: dot(nf, ng) >= cos(crease), with
// 1e-12 of slack so that coplanar faces whose computed normals differ in the last bit
// still merge at crease 0; f itself always counts. 180 is fully smooth. Vertices at
// bitwise-equal positions are welded, so seams of duplicated vertices shade smooth.
// Computed in double, rounded to T once; bitwise-equal results share one entry of
// mesh.normals (a smooth closed mesh gets about one per vertex). Deterministic. O(n)
// expected for meshes of bounded valence; a vertex where d faces of distinct normals
// meet costs O(d^2) unless all lie within half the crease of their mean. Throws
// invalid_input for a crease outside [0, 180] or a vertex index out of range.
template <class T>
void smooth_normals(Mesh<T>& mesh, double crease_degrees = 60.0) {
  using dvec3 = glm::dvec3;
  using vec3 = glm::vec<3, T>;
  if (!(crease_degrees >= 0.0 && crease_degrees <= 180.0)) {
    std::ostringstream os;
    os.precision(17);
    os << "smooth_normals: crease_degrees must be in [0, 180], got " << crease_degrees;
    throw invalid_input(os.str());
  }
  const size_t nf = mesh.triangles.size();
  if (nf > size_t(INT_MAX / 3) || mesh.vertices.size() > size_t(INT_MAX))
    throw invalid_input("smooth_normals: the mesh has too many triangles or vertices");
  for (size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k) {
      int i = mesh.triangles[f][k];
      if (i < 0 || size_t(i) >= mesh.vertices.size())
        throw invalid_input("smooth_normals: triangles[" + std::to_string(f) + "][" +
                            std::to_string(k) + "]: vertex index " + std::to_string(i) +
                            " out of range (" + std::to_string(mesh.vertices.size()) +
                            " vertices)");
    }
  const double pi = 3.14159265358979323846;
  const bool all_smooth = crease_degrees >= 180.0;
  const double crease = crease_degrees * (pi / 180.0);
  const double threshold = std::cos(crease) - 1e-12;

  // Unit face normals and corner angles, in parallel; a face with zero area (or a
  // non-finite normal) is invalid and contributes nothing. Edges are scaled by a power of
  // two first, so neither tiny nor huge coordinates underflow or overflow the cross product.
  struct Face {
    Face() {}  // left uninitialized: the loop below sets every face
    dvec3 n;
    double angle[3];
    bool valid;
  };
  std::vector<Face> faces(nf);
  constexpr size_t kFaceChunk = 4096;
  parallel_for_blocks(nf, kFaceChunk, [&](size_t, size_t begin, size_t end) {
    for (size_t f = begin; f < end; ++f) {
      const auto& t = mesh.triangles[f];
      dvec3 p0(mesh.vertices[t[0]]), p1(mesh.vertices[t[1]]), p2(mesh.vertices[t[2]]);
      dvec3 a = p1 - p0, b = p2 - p1, c = p0 - p2;
      double m = 0;
      for (int i = 0; i < 3; ++i)
        m = std::max({m, std::fabs(a[i]), std::fabs(b[i]), std::fabs(c[i])});
      Face& face = faces[f];
      face.valid = false;
      if (!(m > 0) || !std::isfinite(m)) continue;
      double s = std::ldexp(1.0, -std::ilogb(m));
      a *= s, b *= s, c *= s;
      dvec3 n = glm::cross(c, a);  // = cross(p1 - p0, p2 - p0)
      double len = glm::length(n);
      if (!(len > 0) || !std::isfinite(len)) continue;
      face.n = n / len;
      // |cross| is twice the area at every corner, so atan2(|cross|, dot) is each angle.
      face.angle[0] = std::atan2(len, -glm::dot(a, c));
      face.angle[1] = std::atan2(len, -glm::dot(a, b));
      face.angle[2] = std::atan2(len, -glm::dot(b, c));
      face.valid = true;
    }
  });

  // Corners grouped by welded vertex (CSR), in face order.
  std::vector<int> weld(mesh.vertices.size());
  int nw;
  {
    detail::VectorIndex<T> positions(mesh.vertices.size());
    for (size_t i = 0; i < weld.size(); ++i) weld[i] = positions.find_or_add(mesh.vertices[i]);
    nw = int(positions.keys.size());
  }
  std::vector<int> start(size_t(nw) + 1, 0);
  for (const auto& t : mesh.triangles)
    for (int k = 0; k < 3; ++k) ++start[size_t(weld[t[k]]) + 1];
  for (int w = 0; w < nw; ++w) start[w + 1] += start[w];
  std::vector<int> corners(3 * nf), fill(start.begin(), start.end() - 1);
  for (size_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k)
      corners[size_t(fill[weld[mesh.triangles[f][k]]]++)] = int(3 * f + k);

  // One vertex: faces with equal normals merge into one group (summing their angles),
  // each group gets a result, and the vertex's distinct results go to out[0, count);
  // each corner's entry of `local` is set to its result's number there.
  struct Group {
    dvec3 n;
    double weight;
    int slot;
  };
  struct Scratch {
    std::vector<Group> groups;
    std::vector<int> group_of, order;
  };
  auto unit_or = [](const dvec3& s, const dvec3& fallback) {
    double len = glm::length(s);
    return len > 0 && std::isfinite(len) ? s / len : fallback;
  };
  std::vector<std::array<int, 3>> local(nf);
  auto solve_vertex = [&](int w, Scratch& scratch, vec3* out, int& count) {
    const int* cs = corners.data() + start[w];
    const int deg = start[w + 1] - start[w];
    std::vector<Group>& groups = scratch.groups;
    std::vector<int>& group_of = scratch.group_of;
    groups.clear();
    group_of.assign(size_t(deg), -1);
    auto face_of = [&](int i) -> const Face& { return faces[size_t(cs[i] / 3)]; };
    auto angle_of = [&](int i) { return face_of(i).angle[cs[i] % 3]; };
    if (deg <= 16) {
      for (int i = 0; i < deg; ++i) {
        if (!face_of(i).valid) continue;
        const dvec3& n = face_of(i).n;
        int g = 0;
        while (g < int(groups.size()) && groups[size_t(g)].n != n) ++g;
        if (g == int(groups.size())) groups.push_back({n, 0.0, -1});
        groups[size_t(g)].weight += angle_of(i);
        group_of[size_t(i)] = g;
      }
    } else {  // sort by normal (then corner) to find equal normals in O(d log d)
      std::vector<int>& order = scratch.order;
      order.clear();
      for (int i = 0; i < deg; ++i)
        if (face_of(i).valid) order.push_back(i);
      std::sort(order.begin(), order.end(), [&](int i, int j) {
        const dvec3 &a = face_of(i).n, &b = face_of(j).n;
        if (a.x != b.x) return a.x < b.x;
        if (a.y != b.y) return a.y < b.y;
        if (a.z != b.z) return a.z < b.z;
        return i < j;
      });
      for (size_t o = 0; o < order.size(); ++o) {
        int i = order[o];
        if (o == 0 || face_of(i).n != groups.back().n) groups.push_back({face_of(i).n, 0.0, -1});
        groups.back().weight += angle_of(i);
        group_of[size_t(i)] = int(groups.size() - 1);
      }
    }

    const size_t ng = groups.size();
    dvec3 total(0);
    for (const Group& g : groups) total += g.weight * g.n;
    bool all_in = all_smooth;  // every pair within the crease: each group's sum is the total
    if (!all_in && ng <= 32) {
      all_in = true;
      for (size_t u = 0; u < ng && all_in; ++u)
        for (size_t v = u + 1; v < ng && all_in; ++v)
          all_in = glm::dot(groups[u].n, groups[v].n) >= threshold;
    } else if (!all_in && glm::length(total) > 0) {
      // All normals within (crease - margin) / 2 of their mean are pairwise within the
      // crease (the margin covers acos's rounding).
      dvec3 mean = glm::normalize(total);
      double lo = 1;
      for (const Group& g : groups) lo = std::min(lo, glm::dot(mean, g.n));
      all_in = 2 * std::acos(std::max(-1.0, lo)) < crease - 1e-6;
    }
    count = 0;
    auto slot_of = [&](const vec3& r) {
      for (int j = 0; j < count; ++j)
        if (out[j] == r) return j;
      out[count] = r;
      return count++;
    };
    // A group alone keeps its face normal exactly; a zero sum falls back to it.
    const double total_len = glm::length(total);
    const bool total_ok = ng > 1 && all_in && total_len > 0 && std::isfinite(total_len);
    const int total_slot = total_ok ? slot_of(vec3(total / total_len)) : -1;
    for (size_t u = 0; u < ng; ++u) {
      Group& gu = groups[u];
      if (ng == 1 || total_ok) {
        gu.slot = ng == 1 ? slot_of(vec3(gu.n)) : total_slot;
        continue;
      }
      dvec3 sum(0);
      bool others = false;
      for (size_t v = 0; v < ng; ++v)
        if (v == u || all_in || glm::dot(gu.n, groups[v].n) >= threshold) {
          sum += groups[v].weight * groups[v].n;
          others |= v != u;
        }
      gu.slot = slot_of(vec3(others ? unit_or(sum, gu.n) : gu.n));
    }
    int first = -1;
    for (int i = 0; i < deg; ++i) {
      int g = group_of[size_t(i)];
      if (g < 0) continue;
      local[size_t(cs[i] / 3)][size_t(cs[i] % 3)] = groups[size_t(g)].slot;
      if (first < 0) first = groups[size_t(g)].slot;
    }
    // Corners of zero-area faces: such faces are never hit, so any unit normal will do;
    // they take the vertex's first (or +z) only to keep the output valid.
    for (int i = 0; i < deg; ++i)
      if (group_of[size_t(i)] < 0)
        local[size_t(cs[i] / 3)][size_t(cs[i] % 3)] = first >= 0 ? first : slot_of(vec3(0, 0, 1));
  };

  // Vertices in blocks (bounding the memory for results): solved in parallel, then in
  // order equal results, at any vertex, share one output normal.
  detail::VectorIndex<T> normals(mesh.vertices.size());
  std::vector<vec3> results;
  std::vector<int> counts, ids;
  constexpr int kBlock = 1 << 16, kVertexChunk = 512;
  for (int b0 = 0, b1; b0 < nw; b0 = b1) {
    b1 = b0 + std::min(kBlock, nw - b0);
    results.resize(size_t(start[b1] - start[b0]));
    counts.assign(size_t(b1 - b0), 0);
    parallel_for((b1 - b0 + kVertexChunk - 1) / kVertexChunk, 1, [&](int chunk) {
      Scratch scratch;
      const int end = std::min(b1, b0 + (chunk + 1) * kVertexChunk);
      for (int w = b0 + chunk * kVertexChunk; w < end; ++w)
        solve_vertex(w, scratch, results.data() + (start[w] - start[b0]), counts[size_t(w - b0)]);
    });
    for (int w = b0; w < b1; ++w) {
      ids.resize(size_t(counts[size_t(w - b0)]));
      for (size_t j = 0; j < ids.size(); ++j)
        ids[j] = normals.find_or_add(results[size_t(start[w] - start[b0]) + j]);
      for (int p = start[w]; p < start[w + 1]; ++p) {
        int& index = local[size_t(corners[size_t(p)] / 3)][size_t(corners[size_t(p)] % 3)];
        index = ids[size_t(index)];
      }
    }
  }
  mesh.normals = std::move(normals.keys);
  mesh.normal_triangles = std::move(local);
}

// Removes shading normals: every triangle shades with its geometric normal.
template <class T>
void flat_normals(Mesh<T>& mesh) {
  mesh.normals.clear();
  mesh.normal_triangles.clear();
}

}  // namespace twinray
