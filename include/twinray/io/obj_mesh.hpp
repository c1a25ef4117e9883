// load_obj_mesh(): a Wavefront OBJ file as a Mesh<T>, through tinyobjloader (Debian
// libtinyobjloader-dev). twinray::io links tinyobjloader::tinyobjloader_double and
// defines TWINRAY_WITH_TINYOBJLOADER when it finds it; without it only
// read_small_file() is here and scene files cannot name .obj meshes.
//
// Only geometry is read: vertex positions and faces (polygons are fanned into
// triangles). Normals, texture coordinates, groups and `mtllib`/`usemtl` are ignored:
// the mesh takes the material its scene gives it. The file is size-checked before it
// is read, and the vertex and triangle counts before the mesh is built, so a hostile
// file cannot exhaust memory. Errors are twinray::Error(InvalidInput) whose message
// starts with the file name: `bunny.obj: line 12: face index 90 out of range`.
#pragma once

#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include <sys/stat.h>

#ifdef TWINRAY_WITH_TINYOBJLOADER
#include <tiny_obj_loader.h>
#endif

#include <twinray/core/error.hpp>
#include <twinray/scene/shapes.hpp>

namespace twinray {
namespace io {

namespace detail {

// Reads a whole regular file of at most `max_bytes`; the size is checked first.
inline std::string read_small_file(const std::string& path, long long max_bytes,
                                   const std::string& what) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    int e = errno;
    throw invalid_input(path + ": cannot open " + what + ": " + std::strerror(e));
  }
  if (S_ISDIR(st.st_mode)) throw invalid_input(path + ": is a folder, not " + what);
  if (!S_ISREG(st.st_mode)) throw invalid_input(path + ": is not a regular file");
  if (st.st_size > max_bytes)
    throw invalid_input(path + ": " + what + " is " + std::to_string(st.st_size) +
                        " bytes, more than the limit of " + std::to_string(max_bytes));
  std::ifstream f(path, std::ios::binary);
  if (!f) {
    int e = errno;
    throw invalid_input(path + ": cannot open " + what + ": " + std::strerror(e));
  }
  std::string text(static_cast<size_t>(st.st_size), '\0');
  if (!text.empty() && !f.read(&text[0], static_cast<std::streamsize>(text.size())))
    throw invalid_input(path + ": cannot read " + what);
  return text;
}

}  // namespace detail

#ifdef TWINRAY_WITH_TINYOBJLOADER

struct ObjLimits {
  long long max_file_bytes = 256ll << 20;  // 256 MiB of text
  long long max_vertices = 1ll << 24;      // 16 Mi positions
  long long max_triangles = 1ll << 24;     // 16 Mi triangles after fanning
};

namespace detail {

// Counts the `v` and `f` records (and the triangles the faces fan into) without
// building anything, so the limits hold before tinyobjloader allocates.
struct ObjCounts {
  long long vertices = 0, triangles = 0;
};

inline ObjCounts count_obj(const std::string& text) {
  ObjCounts c;
  size_t i = 0, n = text.size();
  while (i < n) {
    size_t end = text.find('\n', i);
    if (end == std::string::npos) end = n;
    size_t p = i;
    while (p < end && (text[p] == ' ' || text[p] == '\t')) ++p;
    if (p + 1 < end && (text[p + 1] == ' ' || text[p + 1] == '\t')) {
      if (text[p] == 'v') {
        ++c.vertices;
      } else if (text[p] == 'f') {
        long long corners = 0;
        bool in_token = false;
        for (size_t q = p + 1; q < end; ++q) {
          bool space = text[q] == ' ' || text[q] == '\t' || text[q] == '\r';
          if (!space && !in_token) ++corners;
          in_token = !space;
        }
        if (corners >= 3) c.triangles += corners - 2;
      }
    }
    i = end + 1;
  }
  return c;
}

// tinyobjloader turns the joint ids of `vw` lines (skin weights, which twinray does not
// read) into int without a range check: undefined behaviour for `vw 1 2.5e10 1`, found
// by fuzz/fuzz_obj_mesh.cpp (tests/fuzz/regressions/obj_mesh/). Such lines become comments.
inline std::string without_vertex_weights(const std::string& text) {
  std::string out = text;
  bool line_start = true;
  for (size_t i = 0; i < out.size(); ++i) {
    char c = out[i];
    if (c == '\n' || c == '\r') {
      line_start = true;
      continue;
    }
    if (line_start && (c == ' ' || c == '\t')) continue;
    if (line_start && c == 'v' && i + 2 < out.size() && out[i + 1] == 'w' &&
        (out[i + 2] == ' ' || out[i + 2] == '\t'))
      out[i] = '#';
    line_start = false;
  }
  return out;
}

}  // namespace detail

// Parses OBJ text; `name` labels errors. Throws twinray::Error(InvalidInput).
template <class T>
Mesh<T> parse_obj_mesh(const std::string& text, const std::string& name,
                       const ObjLimits& limits = {}) {
  detail::ObjCounts counts = detail::count_obj(text);
  if (counts.vertices > limits.max_vertices)
    throw invalid_input(name + ": " + std::to_string(counts.vertices) +
                        " vertices, more than the limit of " + std::to_string(limits.max_vertices));
  if (counts.triangles > limits.max_triangles)
    throw invalid_input(name + ": " + std::to_string(counts.triangles) +
                        " triangles, more than the limit of " +
                        std::to_string(limits.max_triangles));

  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  // ParseFromString ignores `mtllib`: no other file is opened.
  if (!reader.ParseFromString(detail::without_vertex_weights(text), "", config)) {
    std::string error = reader.Error();
    while (!error.empty() && (error.back() == '\n' || error.back() == ' ')) error.pop_back();
    throw invalid_input(name + ": malformed OBJ: " + (error.empty() ? "parse failed" : error));
  }
  const tinyobj::attrib_t& attrib = reader.GetAttrib();
  Mesh<T> mesh;
  size_t n_vertices = attrib.vertices.size() / 3;
  if (n_vertices == 0) throw invalid_input(name + ": no vertices (`v x y z` lines)");
  mesh.vertices.reserve(n_vertices);
  for (size_t v = 0; v < n_vertices; ++v) {
    glm::vec<3, T> p;
    for (int k = 0; k < 3; ++k) {
      double d = static_cast<double>(attrib.vertices[3 * v + k]);
      p[k] = static_cast<T>(d);
      if (!std::isfinite(d) || !std::isfinite(p[k]))
        throw invalid_input(name + ": vertex " + std::to_string(v + 1) +
                            " has a coordinate that is not a finite number");
    }
    mesh.vertices.push_back(p);
  }
  size_t n_triangles = 0;
  for (const tinyobj::shape_t& shape : reader.GetShapes())
    n_triangles += shape.mesh.num_face_vertices.size();
  if (static_cast<long long>(n_triangles) > limits.max_triangles)
    throw invalid_input(name + ": " + std::to_string(n_triangles) +
                        " triangles, more than the limit of " +
                        std::to_string(limits.max_triangles));
  mesh.triangles.reserve(n_triangles);
  for (const tinyobj::shape_t& shape : reader.GetShapes()) {
    size_t offset = 0;
    for (size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f) {
      unsigned corners = shape.mesh.num_face_vertices[f];
      if (corners != 3)
        throw invalid_input(name + ": face " + std::to_string(mesh.triangles.size() + 1) +
                            " in shape '" + shape.name + "' has " + std::to_string(corners) +
                            " corners after triangulation, expected 3");
      std::array<int, 3> tri{};
      for (unsigned k = 0; k < 3; ++k) {
        int index = shape.mesh.indices[offset + k].vertex_index;
        if (index < 0 || static_cast<size_t>(index) >= n_vertices)
          throw invalid_input(name + ": face " + std::to_string(mesh.triangles.size() + 1) +
                              " refers to vertex " + std::to_string(index + 1) + ", but only " +
                              std::to_string(n_vertices) + " are defined");
        tri[k] = index;
      }
      mesh.triangles.push_back(tri);
      offset += corners;
    }
  }
  if (mesh.triangles.empty()) throw invalid_input(name + ": no faces (`f a b c` lines)");
  return mesh;
}

// Loads an OBJ file (size-checked before reading).
template <class T>
Mesh<T> load_obj_mesh(const std::string& path, const ObjLimits& limits = {}) {
  std::string text = detail::read_small_file(path, limits.max_file_bytes, "an OBJ file");
  return parse_obj_mesh<T>(text, path, limits);
}

#endif  // TWINRAY_WITH_TINYOBJLOADER

}  // namespace io
}  // namespace twinray
