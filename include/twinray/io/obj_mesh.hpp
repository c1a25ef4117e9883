// load_obj_mesh(): a Wavefront OBJ file as a Mesh<T>, through tinyobjloader (Debian
// libtinyobjloader-dev). twinray::io links tinyobjloader::tinyobjloader_double and
// defines TWINRAY_WITH_TINYOBJLOADER when it finds it; without it this header is
// empty and scene files cannot name .obj meshes.
//
// Read: vertex positions and faces (tinyobjloader triangulates polygons: a quad along a
// shortest diagonal, larger ones by ear clipping), vertex normals (`vn`, normalized; a
// triangle some corner of which has none, or a zero one, is flat) and texture
// coordinates (`vt`; a triangle some corner of which has none gets none). Materials
// (`mtllib`, `usemtl`) are io/obj_model.hpp's; groups are ignored. The file is size-checked before
// it is read, and the vertex and triangle counts before the mesh is built, so a hostile file cannot
// exhaust memory. Errors are twinray::Error(InvalidInput) whose message starts with the file name,
// and the line where there is one: `bunny.obj:12: vertex index 90 is out of range: the file has
// 34`.
#pragma once

#include <array>
#include <charconv>
#include <cstdio>
#include <cmath>
#include <cstring>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#ifdef TWINRAY_WITH_TINYOBJLOADER
#include <tiny_obj_loader.h>
#endif

#include <twinray/core/error.hpp>
#include <twinray/io/small_file.hpp>
#include <twinray/scene/shapes.hpp>

namespace twinray {
namespace io {

#ifdef TWINRAY_WITH_TINYOBJLOADER

struct ObjLimits {
  long long max_file_bytes = 256ll << 20;  // 256 MiB of text
  long long max_vertices = 1ll << 24;      // 16 Mi positions
  long long max_triangles = 1ll << 24;     // 16 Mi triangles after fanning
};

namespace detail {

// The strict pass over the text, before tinyobjloader sees it. tinyobjloader drops
// what it cannot use (a face with an index out of range or fewer than three corners, a
// truncated last line) and reads `nan` as a number; a mesh that silently loses faces
// is worse than a refusal. So every line is checked here, and the first bad one is
// named as `file:line` with the text exactly as the file wrote it. It also counts the
// records, so the limits hold (and a file with no faces is refused) before
// tinyobjloader allocates anything.
// A name an OBJ line gives (`mtllib spot.mtl`, `usemtl spot`), and where.
struct ObjReference {
  std::string name;
  long long line = 0;
};

struct ObjCounts {
  long long vertices = 0, texcoords = 0, normals = 0, triangles = 0;
  std::vector<ObjReference> libraries;  // `mtllib` files, in order
  std::vector<ObjReference> uses;       // `usemtl` lines
};

inline bool obj_space(char c) {
  return c == ' ' || c == '\t' || c == '\r';
}

// Splits one line into its whitespace-separated tokens (at most `max` of them; the
// count is exact up to max + 1).
struct ObjLine {
  static constexpr int kMax = 8;
  std::string_view token[kMax];
  int count = 0;  // every token, even those past kMax
};

inline ObjLine split_obj_line(std::string_view line) {
  ObjLine out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && obj_space(line[i])) ++i;
    if (i >= line.size()) break;
    size_t j = i;
    while (j < line.size() && !obj_space(line[j])) ++j;
    if (out.count < ObjLine::kMax) out.token[out.count] = line.substr(i, j - i);
    ++out.count;
    i = j;
  }
  return out;
}

inline std::string obj_where(const std::string& name, long long line) {
  return name + ":" + std::to_string(line) + ": ";
}

// A coordinate: the whole token a number (std::from_chars, as JSON numbers are read),
// finite, and finite in T too.
template <class T>
void obj_number(std::string_view token, const std::string& name, long long line, const char* what) {
  double value = 0;
  const char* first = token.data();
  const char* last = first + token.size();
  if (first != last && *first == '+') ++first;  // from_chars takes no '+'
  auto result = std::from_chars(first, last, value);
  // The token is copied into a message only when one is thrown: this runs for every
  // coordinate of the file.
  auto refuse = [&](const std::string& before, const std::string& after) {
    throw invalid_input(obj_where(name, line) + what + " " + before + std::string(token) + after);
  };
  if (result.ptr != last || result.ec == std::errc::invalid_argument)
    refuse("'", "' is not a number");
  if (result.ec == std::errc::result_out_of_range) refuse("", " is outside the range of double");
  if (!std::isfinite(value)) refuse("", " is not a finite number");
  if (!std::isfinite(static_cast<T>(value)))
    refuse("", std::string(" overflows ") + (sizeof(T) == sizeof(float) ? "float" : "double"));
}

// One index of a face corner, as written: nonzero, and in range (positive: 1 to the
// file's count; negative: back from the records before this line).
inline void obj_index(std::string_view token, long long total, long long before, const char* what,
                      const std::string& name, long long line) {
  long long value = 0;
  const char* first = token.data();
  const char* last = first + token.size();
  auto result = std::from_chars(first, last, value);
  if (token.empty() || result.ec != std::errc() || result.ptr != last)
    throw invalid_input(obj_where(name, line) + what + " index '" + std::string(token) +
                        "' is not an integer");
  if (value == 0)
    throw invalid_input(obj_where(name, line) + what + " index 0: OBJ indices start at 1");
  if (value > total)
    throw invalid_input(obj_where(name, line) + what + " index " + std::string(token) +
                        " is out of range: the file has " + std::to_string(total));
  if (value < 0 && -value > before)
    throw invalid_input(obj_where(name, line) + what + " index " + std::string(token) +
                        " is out of range: " + std::to_string(before) + " before this line");
}

// Checks every line and counts the records; see above.
template <class T>
ObjCounts scan_obj(const std::string& text, const std::string& name) {
  // First the totals (positive indices may name records further down the file).
  ObjCounts total;
  for (size_t i = 0, n = text.size(); i < n;) {
    size_t end = text.find('\n', i);
    if (end == std::string::npos) end = n;
    size_t p = i;
    while (p < end && (text[p] == ' ' || text[p] == '\t')) ++p;
    if (p + 1 < end && text[p] == 'v') {
      char c = text[p + 1];
      if (c == ' ' || c == '\t')
        ++total.vertices;
      else if (p + 2 < end && (text[p + 2] == ' ' || text[p + 2] == '\t')) {
        if (c == 't') ++total.texcoords;
        if (c == 'n') ++total.normals;
      }
    }
    i = end + 1;
  }
  ObjCounts seen;
  long long line_number = 0;
  for (size_t i = 0, n = text.size(); i < n;) {
    size_t end = text.find('\n', i);
    if (end == std::string::npos) end = n;
    ++line_number;
    std::string_view line(text.data() + i, end - i);
    i = end + 1;
    for (char c : line) {
      auto u = static_cast<unsigned char>(c);
      if (u < 0x20 && c != '\t' && c != '\r') {
        char hex[8];
        std::snprintf(hex, sizeof hex, "0x%02x", u);
        throw invalid_input(obj_where(name, line_number) + "byte " + hex + ": not a text file");
      }
    }
    ObjLine t = split_obj_line(line);
    if (t.count == 0 || t.token[0][0] == '#') continue;  // blank, or a comment line
    std::string_view key = t.token[0];
    if (key == "v" || key == "vn" || key == "vt") {
      const bool v = key == "v", vn = key == "vn";
      const int least = v || vn ? 3 : 1;
      const int most = v ? 7 : 3;  // v: x y z [w] or x y z r g b
      if (t.count - 1 < least || t.count - 1 > most || (v && t.count - 1 == 5))
        throw invalid_input(obj_where(name, line_number) + "`" + std::string(key) + "` takes " +
                            (v    ? "3 coordinates (4 with w, 6 with a colour)"
                             : vn ? "3 coordinates"
                                  : "1 to 3 coordinates") +
                            ", got " + std::to_string(t.count - 1));
      const char* what = v ? "vertex coordinate" : vn ? "normal coordinate" : "texture coordinate";
      for (int k = 1; k < t.count; ++k) obj_number<T>(t.token[k], name, line_number, what);
      ++(v ? seen.vertices : vn ? seen.normals : seen.texcoords);
    } else if (key == "f") {
      if (t.count - 1 < 3)
        throw invalid_input(obj_where(name, line_number) + "a face needs at least 3 corners, got " +
                            std::to_string(t.count - 1));
      // Corners past ObjLine::kMax are checked by splitting again (rare: n-gons).
      size_t pos = 0;
      for (int k = 0; k < t.count; ++k) {
        while (pos < line.size() && obj_space(line[pos])) ++pos;
        size_t stop = pos;
        while (stop < line.size() && !obj_space(line[stop])) ++stop;
        std::string_view corner = line.substr(pos, stop - pos);
        pos = stop;
        if (k == 0) continue;  // the key
        size_t s1 = corner.find('/');
        std::string_view vi = corner.substr(0, s1);
        obj_index(vi, total.vertices, seen.vertices, "vertex", name, line_number);
        if (s1 == std::string_view::npos) continue;
        std::string_view rest = corner.substr(s1 + 1);
        size_t s2 = rest.find('/');
        std::string_view ti = rest.substr(0, s2);
        if (s2 == std::string_view::npos || !ti.empty())
          obj_index(ti, total.texcoords, seen.texcoords, "texture coordinate", name, line_number);
        if (s2 != std::string_view::npos) {
          std::string_view ni = rest.substr(s2 + 1);
          if (ni.find('/') != std::string_view::npos)
            throw invalid_input(obj_where(name, line_number) + "face corner '" +
                                std::string(corner) + "' has more than 3 parts");
          obj_index(ni, total.normals, seen.normals, "normal", name, line_number);
        }
      }
      seen.triangles += t.count - 3;
    } else if (key == "mtllib") {
      // One or more file names, split at whitespace as tinyobjloader splits them.
      for (int k = 1; k < t.count && k < ObjLine::kMax; ++k)
        seen.libraries.push_back({std::string(t.token[k]), line_number});
    } else if (key == "usemtl" && t.count > 1) {
      seen.uses.push_back({std::string(t.token[1]), line_number});
    }
  }
  return seen;
}

// tinyobjloader's warnings, none thrown away unread: those about materials (a `usemtl`
// name no library defines, a library it was not given; io/obj_model.hpp finds both
// itself and names the line), MTL transparency (`d` and `Tr` both given: twinray reads
// neither) and unnamed groups are expected; any other one (a dropped face, an index out
// of range) is a file problem that scan_obj should have named first, and is returned so
// the load refuses the file rather than render a mesh with faces missing.
inline std::string unexpected_obj_warning(const std::string& warnings) {
  size_t i = 0;
  while (i < warnings.size()) {
    size_t end = warnings.find('\n', i);
    if (end == std::string::npos) end = warnings.size();
    std::string line = warnings.substr(i, end - i);
    i = end + 1;
    while (!line.empty() && (line.back() == ' ' || line.back() == '.' || line.back() == '\r'))
      line.pop_back();
    while (!line.empty() && (line.front() == ' ' || line.front() == '.')) line.erase(0, 1);
    if (line.empty()) continue;
    for (const char* expected :
         {"material [", "Material file [", "Looks like empty filename for mtllib",
          "Empty group name", "Both `d` and `Tr` parameters defined"})
      if (line.rfind(expected, 0) == 0) line.clear();
    if (!line.empty()) return "tinyobjloader: " + line;
  }
  return "";
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

namespace detail {

// Unit normals of the file's `vn` records, in double rounded once; a zero normal
// becomes (0, 0, 0) here and leaves the triangles that use it flat.
template <class T>
std::vector<glm::vec<3, T>> obj_unit_normals(const std::vector<tinyobj::real_t>& raw) {
  std::vector<glm::vec<3, T>> normals(raw.size() / 3);
  for (size_t i = 0; i < normals.size(); ++i) {
    glm::dvec3 n(raw[3 * i], raw[3 * i + 1], raw[3 * i + 2]);
    double len = std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z);
    if (len > 0.0 && std::isfinite(len)) normals[i] = glm::vec<3, T>(n / len);
  }
  return normals;
}

// The mesh of a parsed file, with its vertex normals and texture coordinates where
// every corner of a triangle has them, and in triangle_materials tinyobjloader's
// material id of each triangle (-1: none).
template <class T>
Mesh<T> obj_mesh_from(const tinyobj::ObjReader& reader, const std::string& name,
                      const ObjLimits& limits) {
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
  std::vector<glm::vec<3, T>> normals = obj_unit_normals<T>(attrib.normals);
  const size_t n_uvs = attrib.texcoords.size() / 2;
  size_t n_triangles = 0;
  for (const tinyobj::shape_t& shape : reader.GetShapes())
    n_triangles += shape.mesh.num_face_vertices.size();
  if (static_cast<long long>(n_triangles) > limits.max_triangles)
    throw invalid_input(name + ": " + std::to_string(n_triangles) +
                        " triangles, more than the limit of " +
                        std::to_string(limits.max_triangles));
  mesh.triangles.reserve(n_triangles);
  mesh.triangle_materials.reserve(n_triangles);
  if (!normals.empty()) mesh.normal_triangles.reserve(n_triangles);
  if (n_uvs > 0) mesh.uv_triangles.reserve(n_triangles);
  bool any_normals = false, any_uvs = false;
  const std::array<int, 3> none{-1, -1, -1};
  for (const tinyobj::shape_t& shape : reader.GetShapes()) {
    size_t offset = 0;
    for (size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f) {
      unsigned corners = shape.mesh.num_face_vertices[f];
      if (corners != 3)
        throw invalid_input(name + ": face " + std::to_string(mesh.triangles.size() + 1) +
                            " in shape '" + shape.name + "' has " + std::to_string(corners) +
                            " corners after triangulation, expected 3");
      std::array<int, 3> tri{}, nrm{}, uv{};
      bool has_normals = !normals.empty(), has_uv = n_uvs > 0;
      for (unsigned k = 0; k < 3; ++k) {
        const tinyobj::index_t& index = shape.mesh.indices[offset + k];
        if (index.vertex_index < 0 || static_cast<size_t>(index.vertex_index) >= n_vertices)
          throw invalid_input(name + ": face " + std::to_string(mesh.triangles.size() + 1) +
                              " refers to vertex " + std::to_string(index.vertex_index + 1) +
                              ", but only " + std::to_string(n_vertices) + " are defined");
        tri[k] = index.vertex_index;
        nrm[k] = index.normal_index;
        uv[k] = index.texcoord_index;
        has_normals = has_normals && nrm[k] >= 0 && static_cast<size_t>(nrm[k]) < normals.size() &&
                      normals[nrm[k]] != glm::vec<3, T>(T(0));
        has_uv = has_uv && uv[k] >= 0 && static_cast<size_t>(uv[k]) < n_uvs;
      }
      mesh.triangles.push_back(tri);
      int material = f < shape.mesh.material_ids.size() ? shape.mesh.material_ids[f] : -1;
      mesh.triangle_materials.push_back(material);
      if (!normals.empty()) mesh.normal_triangles.push_back(has_normals ? nrm : none);
      if (n_uvs > 0) mesh.uv_triangles.push_back(has_uv ? uv : none);
      any_normals = any_normals || has_normals;
      any_uvs = any_uvs || has_uv;
      offset += corners;
    }
  }
  if (mesh.triangles.empty()) throw invalid_input(name + ": no faces (`f a b c` lines)");
  if (any_normals) {
    // Zero normals no triangle uses are given a unit placeholder, so all are valid.
    for (auto& n : normals)
      if (n == glm::vec<3, T>(T(0))) n = glm::vec<3, T>(T(0), T(0), T(1));
    mesh.normals = std::move(normals);
  } else {
    mesh.normal_triangles.clear();
  }
  if (any_uvs) {
    mesh.uvs.reserve(n_uvs);
    for (size_t i = 0; i < n_uvs; ++i) {
      glm::vec<2, T> uv(static_cast<T>(attrib.texcoords[2 * i]),
                        static_cast<T>(attrib.texcoords[2 * i + 1]));
      if (!std::isfinite(uv.x) || !std::isfinite(uv.y))
        throw invalid_input(name + ": texture coordinate " + std::to_string(i + 1) +
                            " is not a finite number");
      mesh.uvs.push_back(uv);
    }
  } else {
    mesh.uv_triangles.clear();
  }
  return mesh;
}

// Parses text that scan_obj has checked (`scanned`: its counts) with tinyobjloader,
// with `mtl_text` as the text of its material libraries; the limits are checked first.
template <class T>
Mesh<T> parse_obj(const std::string& text, const ObjCounts& scanned, const std::string& name,
                  const ObjLimits& limits, const std::string& mtl_text,
                  std::vector<tinyobj::material_t>* materials) {
  if (scanned.vertices == 0) throw invalid_input(name + ": no vertices (`v x y z` lines)");
  if (scanned.triangles == 0) throw invalid_input(name + ": no faces (`f a b c` lines)");
  if (scanned.vertices > limits.max_vertices)
    throw invalid_input(name + ": " + std::to_string(scanned.vertices) +
                        " vertices, more than the limit of " + std::to_string(limits.max_vertices));
  if (scanned.triangles > limits.max_triangles)
    throw invalid_input(name + ": " + std::to_string(scanned.triangles) +
                        " triangles, more than the limit of " +
                        std::to_string(limits.max_triangles));

  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  // ParseFromString opens no other file: `mtl_text` stands for every `mtllib`.
  if (!reader.ParseFromString(without_vertex_weights(text), mtl_text, config)) {
    std::string error = reader.Error();
    while (!error.empty() && (error.back() == '\n' || error.back() == ' ')) error.pop_back();
    throw invalid_input(name + ": malformed OBJ: " + (error.empty() ? "parse failed" : error));
  }
  if (std::string problem = unexpected_obj_warning(reader.Warning()); !problem.empty())
    throw invalid_input(name + ": " + problem);
  Mesh<T> mesh = obj_mesh_from<T>(reader, name, limits);
  if (materials) *materials = reader.GetMaterials();
  return mesh;
}

}  // namespace detail

// Parses OBJ text; `name` labels errors. Throws twinray::Error(InvalidInput). The mesh
// has the file's vertex normals and texture coordinates; materials are not read
// (io/obj_model.hpp reads them), so triangle_materials is empty.
template <class T>
Mesh<T> parse_obj_mesh(const std::string& text, const std::string& name,
                       const ObjLimits& limits = {}) {
  Mesh<T> mesh =
      detail::parse_obj<T>(text, detail::scan_obj<T>(text, name), name, limits, "", nullptr);
  mesh.triangle_materials.clear();
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
