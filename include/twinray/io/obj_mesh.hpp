// load_obj_mesh(): a Wavefront OBJ file as a Mesh<T>, read by twinray's own strict
// parser.
//
// Read: vertex positions (`v x y z`, with an optional w or r g b, ignored), faces
// (`f`, corners `v`, `v/vt`, `v//vn` or `v/vt/vn`, positive or negative indices) cut
// into triangles by scene/polygon.hpp, vertex normals (`vn`, normalized; a triangle
// some corner of which has none, or a zero one, is flat), texture coordinates (`vt u
// [v [w]]`; a triangle some corner of which has none gets none), and the names of
// `mtllib` and `usemtl` lines, which io/obj_model.hpp turns into materials. Other lines
// (o, g, s, l, p, curves) are ignored.
//
// Strict: the first malformed line is refused as twinray::Error(InvalidInput) naming the
// file and line and what the file wrote there (`bunny.obj:12: vertex index 90 is out of
// range: the file has 34`): an index out of range, zero or not an integer, a face with
// fewer than three corners, a coordinate that is not a finite number (in T too), the
// wrong number of coordinates, a byte that is not text. Nothing is dropped silently.
//
// Memory and time: the text is never held whole. It is cut at line starts into pieces
// (ObjLimits::chunk_bytes) and read twice, each time in parallel over the pieces
// (core/parallel.hpp). The first pass counts each piece's records, so the limits are
// checked before anything is allocated and the mesh's arrays are allocated once, at
// their final size; the second parses each piece straight into its place in them (a
// piece's first vertex, triangle and line numbers are the counts of the pieces before
// it). Peak memory is the mesh, one read buffer per thread, and 16 bytes per face of
// more than three corners; polygons are cut into triangles last, when every vertex they
// name is known. The result does not depend on the piece size or the thread count.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include <twinray/core/error.hpp>
#include <twinray/core/parallel.hpp>
#include <twinray/core/process.hpp>
#include <twinray/io/small_file.hpp>
#include <twinray/scene/polygon.hpp>
#include <twinray/scene/shapes.hpp>

namespace twinray {
namespace io {

// The loaders' default limits follow the memory this process may use
// (core/process.hpp, usable_memory_bytes): the most triangles a scene may hold is that
// memory over kPeakBytesPerTriangle, the process's peak per triangle while an OBJ mesh
// is read, packed and rendered in double, at most the 398 measured on PoCL for a mesh
// with a normal and a texture coordinate per corner, in a process that also compiled
// the OpenCL program (positions only: 165; float: 95; docs/models.md, "Large meshes",
// measured with bench/large_mesh.sh). A vertex record costs a tenth as much, so a mesh
// may hold three per triangle (a triangle soup). The OBJ text is streamed, never held
// whole; its limit, the memory itself, only stops a load that cannot be a mesh this
// machine can hold.
constexpr long long kPeakBytesPerTriangle = 400;

// usable_memory_bytes(), read once per process: every loader's limits default to it.
inline long long loader_memory_bytes() {
  static const long long memory = usable_memory_bytes();
  return memory;
}
inline long long memory_triangle_limit() {
  const long long memory = loader_memory_bytes();
  const long long floor = 1ll << 24, ceiling = (1ll << 31) - 1;  // indices are int
  return memory > 0 ? std::clamp(memory / kPeakBytesPerTriangle, floor, ceiling) : floor;
}
inline long long memory_vertex_limit() {
  return std::min(3 * memory_triangle_limit(), (1ll << 31) - 1);
}
inline long long memory_obj_file_limit() {
  return std::max(256ll << 20, loader_memory_bytes());
}

struct ObjLimits {
  long long max_file_bytes = memory_obj_file_limit();  // bytes of text
  long long max_vertices = memory_vertex_limit();      // records of each kind: v, vt, vn
  long long max_triangles = memory_triangle_limit();   // triangles after triangulation
  int max_face_corners = 1 << 16;                      // corners of one face
  // The text is parsed in pieces of about this many bytes, in parallel. The mesh does
  // not depend on it; tests make it small to cut files at every line.
  long long chunk_bytes = 4ll << 20;
};

namespace detail {

// A name an OBJ line gives (`mtllib spot.mtl`, `usemtl spot`), and where.
struct ObjReference {
  std::string name;
  long long line = 0;
};

// How many records of each kind a file, a piece of it, or the pieces before one hold.
struct ObjTally {
  long long lines = 0, vertices = 0, texcoords = 0, normals = 0;
  long long triangles = 0;  // after triangulation
  long long polygons = 0;   // faces of more than 3 corners
  long long use_lines = 0;  // `usemtl` lines

  void add(const ObjTally& o) {
    lines += o.lines, vertices += o.vertices, texcoords += o.texcoords, normals += o.normals;
    triangles += o.triangles, polygons += o.polygons, use_lines += o.use_lines;
  }
};

// The records of a file, or of one piece of it, with the names its lines give.
struct ObjCounts : ObjTally {
  std::vector<ObjReference> libraries;  // `mtllib` files, in order
  std::vector<ObjReference> uses;       // the use_lines `usemtl` lines (name "" for none)
};

inline bool obj_space(char c) {
  return c == ' ' || c == '\t' || c == '\r';
}

// The next whitespace-separated token of `line` from `pos` on; false at the end.
inline bool next_obj_token(std::string_view line, size_t& pos, std::string_view& token) {
  while (pos < line.size() && obj_space(line[pos])) ++pos;
  if (pos >= line.size()) return false;
  size_t end = pos;
  while (end < line.size() && !obj_space(line[end])) ++end;
  token = line.substr(pos, end - pos);
  pos = end;
  return true;
}

// The text of a line after `pos`, without surrounding whitespace (a name that may hold
// spaces: `usemtl`, `newmtl`, `map_Kd`).
inline std::string_view obj_rest(std::string_view line, size_t pos) {
  while (pos < line.size() && obj_space(line[pos])) ++pos;
  size_t end = line.size();
  while (end > pos && obj_space(line[end - 1])) --end;
  return line.substr(pos, end - pos);
}

inline std::string obj_where(const std::string& name, long long line) {
  return name + ":" + std::to_string(line) + ": ";
}

inline bool obj_control(unsigned char u) {
  return u < 0x20 && u != '\t' && u != '\r';
}

// Whether a line is text: no control character other than tab and carriage return.
// Eight bytes at a time: (x - 0x20..) & ~x & 0x80.. is non-zero exactly when some byte
// of x is below 0x20 ("hasless", Anderson, Bit Twiddling Hacks); only then are the
// bytes looked at one by one, since tabs and a CRLF's carriage return are text.
inline bool obj_is_text(std::string_view line) {
  const char* p = line.data();
  size_t n = line.size();
  if (n > 0 && p[n - 1] == '\r') --n;
  std::uint64_t below = 0;
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    std::uint64_t x;
    std::memcpy(&x, p + i, 8);
    below |= (x - 0x2020202020202020ull) & ~x & 0x8080808080808080ull;
  }
  for (; i < n; ++i) below |= static_cast<unsigned char>(p[i]) < 0x20u;
  if (below == 0) return true;
  for (char c : line)
    if (obj_control(static_cast<unsigned char>(c))) return false;
  return true;
}

// What is wrong with a line that is not text: "byte 0x00: not a text file".
inline std::string obj_binary_byte(std::string_view line) {
  for (char c : line)
    if (obj_control(static_cast<unsigned char>(c))) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "0x%02x", static_cast<unsigned char>(c));
      return std::string("byte ") + hex + ": not a text file";
    }
  return "";
}

// A coordinate: the whole token a number (std::from_chars, as JSON numbers are read),
// finite, and finite in T too.
template <class T>
double obj_number(std::string_view token, const std::string& name, long long line,
                  const char* what) {
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
  return value;
}

// One index of a face corner, as written: nonzero, and in range (positive: 1 to the
// file's count; negative: back from the `before` records above this line). Returns it
// counted from 0.
inline int obj_index(std::string_view token, long long total, long long before, const char* what,
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
  return static_cast<int>(value > 0 ? value - 1 : before + value);
}

// What is wrong with a face of `corners` corners, or "" when nothing is: at least 3, and
// at most the limit.
inline std::string obj_face_corners_problem(long long corners, const ObjLimits& limits) {
  if (corners < 3) return "a face needs at least 3 corners, got " + std::to_string(corners);
  if (corners > limits.max_face_corners)
    return "a face of " + std::to_string(corners) + " corners, more than the limit of " +
           std::to_string(limits.max_face_corners);
  return "";
}

enum class ObjKey { Other, Vertex, Texcoord, Normal, Face, Library, UseMaterial };

// What a line holds, from its first token; `rest` is set to where that token ends.
// Blank and comment lines, and statements twinray does not read, are Other.
inline ObjKey obj_key(std::string_view line, size_t& rest) {
  std::string_view key;
  rest = 0;
  if (!next_obj_token(line, rest, key)) return ObjKey::Other;
  if (key == "v") return ObjKey::Vertex;
  if (key == "vt") return ObjKey::Texcoord;
  if (key == "vn") return ObjKey::Normal;
  if (key == "f") return ObjKey::Face;
  if (key == "mtllib") return ObjKey::Library;
  if (key == "usemtl") return ObjKey::UseMaterial;
  return ObjKey::Other;
}

// The OBJ text: a string in memory, or a file read a buffer at a time.
class ObjSource {
 public:
  explicit ObjSource(const std::string& text)
      : text_(&text), size_(static_cast<long long>(text.size())) {}
  ObjSource(std::string path, long long size) : path_(std::move(path)), size_(size) {}

  long long size() const { return size_; }

  // The first line start at or after `at` (size() when no line starts there).
  long long line_start_from(long long at) const {
    if (at <= 0) return 0;
    if (at >= size_) return size_;
    long long found = size_;
    scan(at - 1, size_, [&](const char* data, long long offset, size_t n) {
      const void* nl = std::memchr(data, '\n', n);
      if (!nl) return true;
      found = offset + (static_cast<const char*>(nl) - data) + 1;
      return false;
    });
    return found;
  }

  // Calls f(line, number) for each line in [begin, end), two line starts, numbering
  // them from `first_line`. A line is the text before a '\n' (the last one of the file
  // may have none).
  template <class F>
  void for_each_line(long long begin, long long end, long long first_line, F&& f) const {
    long long number = first_line;
    if (text_) {
      const char* data = text_->data();
      for (long long i = begin; i < end;) {
        const void* nl = std::memchr(data + i, '\n', static_cast<size_t>(end - i));
        long long stop = nl ? static_cast<const char*>(nl) - data : end;
        f(std::string_view(data + i, static_cast<size_t>(stop - i)), number++);
        i = stop + 1;
      }
      return;
    }
    std::ifstream in = open();
    in.seekg(begin);
    std::vector<char> buffer(kBuffer);
    size_t held = 0;
    for (long long pos = begin;;) {
      if (held == buffer.size()) buffer.resize(buffer.size() * 2);  // a line longer than it
      size_t want = static_cast<size_t>(
          std::min<long long>(static_cast<long long>(buffer.size() - held), end - pos));
      read(in, buffer.data() + held, want);
      pos += static_cast<long long>(want);
      held += want;
      size_t start = 0;
      while (const void* nl = std::memchr(buffer.data() + start, '\n', held - start)) {
        size_t stop = static_cast<size_t>(static_cast<const char*>(nl) - buffer.data());
        f(std::string_view(buffer.data() + start, stop - start), number++);
        start = stop + 1;
      }
      if (pos == end) {
        if (start < held) f(std::string_view(buffer.data() + start, held - start), number++);
        return;
      }
      std::memmove(buffer.data(), buffer.data() + start, held - start);
      held -= start;
    }
  }

 private:
  static constexpr size_t kBuffer = 1 << 20;

  std::ifstream open() const {
    std::ifstream in(path_, std::ios::binary);
    if (!in) {
      int e = errno;
      throw invalid_input(path_ + ": cannot open an OBJ file: " + std::strerror(e));
    }
    return in;
  }

  void read(std::ifstream& in, char* to, size_t n) const {
    if (n > 0 && !in.read(to, static_cast<std::streamsize>(n)))
      throw invalid_input(path_ + ": cannot read an OBJ file (did it change while being read?)");
  }

  // Hands [from, to) to visit(data, offset, n) a block at a time while it returns true.
  template <class Visit>
  void scan(long long from, long long to, Visit&& visit) const {
    if (text_) {
      visit(text_->data() + from, from, static_cast<size_t>(to - from));
      return;
    }
    std::ifstream in = open();
    in.seekg(from);
    std::vector<char> block(64 << 10);
    for (long long pos = from; pos < to;) {
      size_t n =
          static_cast<size_t>(std::min<long long>(static_cast<long long>(block.size()), to - pos));
      read(in, block.data(), n);
      if (!visit(block.data(), pos, n)) return;
      pos += static_cast<long long>(n);
    }
  }

  const std::string* text_ = nullptr;
  std::string path_;
  long long size_ = 0;
};

// One piece of the file, and what the first pass found in it. Line numbers in
// `counts` and `problem_line` count from the piece's first line (1).
struct ObjPiece {
  long long begin = 0, end = 0;
  ObjCounts counts;
  long long problem_line = 0;  // the first line the first pass refuses (0: none)
  std::string problem;
  ObjTally before;  // set between the passes: the records of the pieces before this one

  long long first_line() const { return before.lines + 1; }
};

// The first pass over a piece: counts its records; notes its first line that is not
// text, or a face with too few or too many corners. It goes on counting after that
// line, so that the totals are right for checking the lines before it.
inline void scan_obj_piece(const ObjSource& source, ObjPiece& piece, const ObjLimits& limits) {
  ObjCounts& c = piece.counts;
  source.for_each_line(piece.begin, piece.end, 1, [&](std::string_view line, long long number) {
    ++c.lines;
    auto note = [&](std::string problem) {
      if (piece.problem_line == 0) {
        piece.problem_line = number;
        piece.problem = std::move(problem);
      }
    };
    if (!obj_is_text(line)) return note(obj_binary_byte(line));
    size_t pos = 0;
    switch (obj_key(line, pos)) {
      case ObjKey::Vertex:
        ++c.vertices;
        break;
      case ObjKey::Texcoord:
        ++c.texcoords;
        break;
      case ObjKey::Normal:
        ++c.normals;
        break;
      case ObjKey::Face: {
        // The corners: starts of tokens after the key, counted without branches.
        long long corners = 0;
        unsigned space = 1;
        for (size_t i = pos; i < line.size(); ++i) {
          const unsigned is_space = obj_space(line[i]);
          corners += space & (is_space ^ 1u);
          space = is_space;
        }
        if (std::string problem = obj_face_corners_problem(corners, limits); !problem.empty())
          return note(std::move(problem));
        c.triangles += corners - 2;
        c.polygons += corners > 3;
        break;
      }
      case ObjKey::Library:
        // One or more file names, split at whitespace.
        for (std::string_view token; next_obj_token(line, pos, token);)
          c.libraries.push_back({std::string(token), number});
        break;
      case ObjKey::UseMaterial:
        ++c.use_lines;
        c.uses.push_back({std::string(obj_rest(line, pos)), number});
        break;
      case ObjKey::Other:
        break;
    }
  });
}

// A face of more than 3 corners, fanned into triangles [first, first + corners - 2)
// by the second pass and cut properly once every vertex is known.
struct ObjPolygon {
  int first_triangle = 0;
  int corners = 0;
  long long line = 0;
};

// The second pass over a piece: parses each line into its place in the mesh (or,
// with `mesh` null, only checks it). The counters start at the piece's `before` and
// count every record above the current line, which is what negative indices need.
template <class T>
struct ObjPieceParser {
  Mesh<T>* mesh;  // null: check only
  ObjPolygon* polygons;
  const ObjCounts& total;
  const std::string& name;
  const ObjLimits& limits;
  long long vertices, texcoords, normals, triangles, polygon_count, use;
  std::vector<std::array<int, 3>> corners;  // of the current face: v, vt, vn (-1: none)

  ObjPieceParser(Mesh<T>* mesh, ObjPolygon* polygons, const ObjCounts& total, const ObjPiece& piece,
                 const std::string& name, const ObjLimits& limits)
      : mesh(mesh),
        polygons(polygons),
        total(total),
        name(name),
        limits(limits),
        vertices(piece.before.vertices),
        texcoords(piece.before.texcoords),
        normals(piece.before.normals),
        triangles(piece.before.triangles),
        polygon_count(piece.before.polygons),
        use(piece.before.use_lines - 1) {}

  // A line of text: the first pass has checked that every line this one sees is.
  void line(std::string_view text, long long number) {
    size_t pos = 0;
    switch (const ObjKey key = obj_key(text, pos)) {
      case ObjKey::Vertex:
      case ObjKey::Texcoord:
      case ObjKey::Normal:
        record(key, text, pos, number);
        break;
      case ObjKey::Face:
        face(text, pos, number);
        break;
      case ObjKey::UseMaterial:
        ++use;
        break;
      case ObjKey::Library:
      case ObjKey::Other:
        break;
    }
  }

  void record(ObjKey key, std::string_view text, size_t pos, long long number) {
    std::string_view token[8];
    int count = 0;
    for (std::string_view t; next_obj_token(text, pos, t); ++count)
      if (count < 8) token[count] = t;
    const bool v = key == ObjKey::Vertex, vn = key == ObjKey::Normal;
    const int least = v || vn ? 3 : 1;
    const int most = v ? 7 : 3;  // v: x y z [w] or x y z r g b
    if (count < least || count > most || (v && count == 5))
      throw invalid_input(obj_where(name, number) + "`" +
                          (v    ? "v"
                           : vn ? "vn"
                                : "vt") +
                          "` takes " +
                          (v    ? "3 coordinates (4 with w, 6 with a colour)"
                           : vn ? "3 coordinates"
                                : "1 to 3 coordinates") +
                          ", got " + std::to_string(count));
    const char* what = v ? "vertex coordinate" : vn ? "normal coordinate" : "texture coordinate";
    double value[8] = {};
    for (int k = 0; k < count; ++k) value[k] = obj_number<T>(token[k], name, number, what);
    if (v) {
      if (mesh) mesh->vertices[vertices] = glm::vec<3, T>(glm::dvec3(value[0], value[1], value[2]));
      ++vertices;
    } else if (vn) {
      // Unit length, in double rounded once; a zero normal stays zero and leaves the
      // triangles that use it flat.
      if (mesh) {
        glm::dvec3 n(value[0], value[1], value[2]);
        double length = std::sqrt(glm::dot(n, n));
        mesh->normals[normals] = length > 0.0 && std::isfinite(length) ? glm::vec<3, T>(n / length)
                                                                       : glm::vec<3, T>(T(0));
      }
      ++normals;
    } else {
      if (mesh) mesh->uvs[texcoords] = glm::vec<2, T>(glm::dvec2(value[0], value[1]));
      ++texcoords;
    }
  }

  // One index as most files write it (digits, perhaps a '-'), resolved against `total`
  // records and `before` this line; false for anything else, which the careful
  // obj_index() then reads or refuses with its message.
  static bool quick_index(const char*& p, const char* end, long long total, long long before,
                          int& out) {
    const bool negative = p < end && *p == '-';
    const char* digits = p + negative;
    const char* q = digits;
    long long value = 0;
    while (q < end && static_cast<unsigned>(*q - '0') < 10u && q - digits < 18)
      value = value * 10 + (*q++ - '0');
    if (q == digits || (q < end && *q != '/')) return false;
    if (!negative && value >= 1 && value <= total)
      out = static_cast<int>(value - 1);
    else if (negative && value >= 1 && value <= before)
      out = static_cast<int>(before - value);
    else
      return false;
    p = q;
    return true;
  }

  // A corner as most files write it: `v`, `v/t`, `v//n` or `v/t/n`.
  bool quick_corner(std::string_view corner, std::array<int, 3>& c) const {
    const char* p = corner.data();
    const char* end = p + corner.size();
    if (!quick_index(p, end, total.vertices, vertices, c[0])) return false;
    if (p == end) return true;
    ++p;  // '/'
    if (p < end && *p != '/') {
      if (!quick_index(p, end, total.texcoords, texcoords, c[1])) return false;
      if (p == end) return true;
    }
    if (p == end) return false;  // `v/`
    ++p;                         // '/'
    return quick_index(p, end, total.normals, normals, c[2]) && p == end;
  }

  void face(std::string_view text, size_t pos, long long number) {
    corners.clear();
    for (std::string_view corner; next_obj_token(text, pos, corner);) {
      std::array<int, 3> c{-1, -1, -1};
      if (quick_corner(corner, c)) {
        corners.push_back(c);
        continue;
      }
      c = {-1, -1, -1};
      size_t s1 = corner.find('/');
      c[0] = obj_index(corner.substr(0, s1), total.vertices, vertices, "vertex", name, number);
      if (s1 != std::string_view::npos) {
        std::string_view rest = corner.substr(s1 + 1);
        size_t s2 = rest.find('/');
        std::string_view ti = rest.substr(0, s2);
        if (s2 == std::string_view::npos || !ti.empty())
          c[1] = obj_index(ti, total.texcoords, texcoords, "texture coordinate", name, number);
        if (s2 != std::string_view::npos) {
          std::string_view ni = rest.substr(s2 + 1);
          if (ni.find('/') != std::string_view::npos)
            throw invalid_input(obj_where(name, number) + "face corner '" + std::string(corner) +
                                "' has more than 3 parts");
          c[2] = obj_index(ni, total.normals, normals, "normal", name, number);
        }
      }
      corners.push_back(c);
    }
    // The first pass counted this face's triangles with the same check, so the arrays
    // hold exactly what is written below.
    const long long n = static_cast<long long>(corners.size());
    if (std::string problem = obj_face_corners_problem(n, limits); !problem.empty())
      throw invalid_input(obj_where(name, number) + problem);
    if (mesh) {
      // A fan from the first corner; faces of more than 3 corners are cut again later.
      for (long long k = 1; k + 1 < n; ++k) {
        const size_t t = static_cast<size_t>(triangles + k - 1);
        const auto &a = corners[0], &b = corners[k], &c = corners[k + 1];
        mesh->triangles[t] = {a[0], b[0], c[0]};
        if (!mesh->uv_triangles.empty()) mesh->uv_triangles[t] = {a[1], b[1], c[1]};
        if (!mesh->normal_triangles.empty()) mesh->normal_triangles[t] = {a[2], b[2], c[2]};
        if (!mesh->triangle_materials.empty()) mesh->triangle_materials[t] = static_cast<int>(use);
      }
      if (n > 3)
        polygons[polygon_count] = {static_cast<int>(triangles), static_cast<int>(n), number};
    }
    triangles += n - 2;
    polygon_count += n > 3;
  }
};

// Cuts the fanned faces of more than 3 corners into proper triangles (scene/polygon.hpp).
template <class T>
void triangulate_obj_polygons(Mesh<T>& mesh, const std::vector<ObjPolygon>& polygons,
                              const std::string& name) {
  // Ear clipping is quadratic in a face's corners and worse for pathological ones; the
  // whole file may spend this many point tests before it is refused, so that no file
  // can make the load run for minutes.
  long long polygon_triangles = 0;
  for (const ObjPolygon& p : polygons) polygon_triangles += p.corners - 2;
  const long long budget = 200000000ll + 256ll * polygon_triangles;
  std::atomic<long long> spent{0};
  constexpr size_t kGrain = 4096;
  parallel_for_blocks(polygons.size(), kGrain, [&](size_t, size_t first, size_t last) {
    std::vector<glm::dvec3> points;
    std::vector<std::array<int, 3>> cut;
    std::vector<int> v, vt, vn;
    for (size_t i = first; i < last; ++i) {
      const ObjPolygon& polygon = polygons[i];
      const size_t t0 = static_cast<size_t>(polygon.first_triangle);
      const int n = polygon.corners;
      // The corners back from the fan: (c0, c1, c2), (c0, c2, c3), ...
      auto corners_of = [&](const std::vector<std::array<int, 3>>& fan, std::vector<int>& out) {
        out.clear();
        if (fan.empty()) return;
        out.push_back(fan[t0][0]);
        out.push_back(fan[t0][1]);
        for (int k = 0; k + 2 < n; ++k) out.push_back(fan[t0 + k][2]);
      };
      corners_of(mesh.triangles, v);
      corners_of(mesh.uv_triangles, vt);
      corners_of(mesh.normal_triangles, vn);
      points.clear();
      for (int c : v) points.push_back(glm::dvec3(mesh.vertices[c]));
      long long work = 0;
      const long long left = budget - spent.load(std::memory_order_relaxed);
      if (!triangulate_polygon(points, cut, work, left))
        throw invalid_input(obj_where(name, polygon.line) + "a face of " + std::to_string(n) +
                            " corners: cutting it into triangles would take too long (is it "
                            "self-intersecting?)");
      spent += work;
      for (size_t k = 0; k < cut.size(); ++k) {
        const auto& c = cut[k];
        mesh.triangles[t0 + k] = {v[c[0]], v[c[1]], v[c[2]]};
        if (!vt.empty()) mesh.uv_triangles[t0 + k] = {vt[c[0]], vt[c[1]], vt[c[2]]};
        if (!vn.empty()) mesh.normal_triangles[t0 + k] = {vn[c[0]], vn[c[1]], vn[c[2]]};
      }
    }
  });
}

// Keeps a triangle's normals and texture coordinates only where all three corners have
// them (and its normals are not zero); drops the arrays when no triangle keeps any.
template <class T>
void settle_obj_attributes(Mesh<T>& mesh) {
  const std::array<int, 3> none{-1, -1, -1};
  constexpr size_t kGrain = 1 << 16;
  const size_t blocks = block_count(mesh.triangles.size(), kGrain);
  std::vector<char> any_normals(blocks), any_uvs(blocks);
  const glm::vec<3, T> zero(T(0));
  parallel_for_blocks(mesh.triangles.size(), kGrain, [&](size_t block, size_t first, size_t last) {
    for (size_t t = first; t < last; ++t) {
      if (!mesh.normal_triangles.empty()) {
        auto& c = mesh.normal_triangles[t];
        bool keep = c[0] >= 0 && c[1] >= 0 && c[2] >= 0 && mesh.normals[c[0]] != zero &&
                    mesh.normals[c[1]] != zero && mesh.normals[c[2]] != zero;
        if (keep)
          any_normals[block] = 1;
        else
          c = none;
      }
      if (!mesh.uv_triangles.empty()) {
        auto& c = mesh.uv_triangles[t];
        if (c[0] >= 0 && c[1] >= 0 && c[2] >= 0)
          any_uvs[block] = 1;
        else
          c = none;
      }
    }
  });
  auto any = [](const std::vector<char>& flags) {
    return std::find(flags.begin(), flags.end(), 1) != flags.end();
  };
  if (any(any_normals)) {
    // Zero normals no triangle uses get a unit placeholder, so that all are valid.
    for (auto& normal : mesh.normals)
      if (normal == zero) normal = glm::vec<3, T>(T(0), T(0), T(1));
  } else {
    std::vector<glm::vec<3, T>>().swap(mesh.normals);
    std::vector<std::array<int, 3>>().swap(mesh.normal_triangles);
  }
  if (!any(any_uvs)) {
    std::vector<glm::vec<2, T>>().swap(mesh.uvs);
    std::vector<std::array<int, 3>>().swap(mesh.uv_triangles);
  }
}

template <class T>
struct ObjRead {
  Mesh<T> mesh;      // triangle_materials: the ordinal of each triangle's `usemtl` line (-1:
                     // none above it), or empty when the file has no `usemtl` line
  ObjCounts counts;  // the file's
};

// Reads an OBJ text; see the top of this file. `with_materials`: fill
// mesh.triangle_materials.
template <class T>
ObjRead<T> read_obj(const ObjSource& source, const std::string& name, const ObjLimits& limits,
                    bool with_materials) {
  // The pieces, cut at line starts.
  std::vector<ObjPiece> pieces;
  const long long size = source.size(), step = std::max<long long>(1, limits.chunk_bytes);
  for (long long begin = 0; begin < size || pieces.empty();) {
    ObjPiece piece;
    piece.begin = begin;
    piece.end = source.line_start_from(std::max(begin + step, begin + 1));
    begin = piece.end;
    pieces.push_back(std::move(piece));
    if (size == 0) break;
  }
  const int n_pieces = static_cast<int>(pieces.size());
  parallel_for(n_pieces, 1, [&](int k) { scan_obj_piece(source, pieces[k], limits); });

  // What lies before each piece, and the file's totals.
  ObjRead<T> out;
  ObjCounts& total = out.counts;
  for (ObjPiece& piece : pieces) {
    piece.before = total;
    const ObjCounts& c = piece.counts;
    total.add(c);
    for (const ObjReference& r : c.libraries)
      total.libraries.push_back({r.name, r.line + piece.before.lines});
    for (const ObjReference& r : c.uses)
      total.uses.push_back({r.name, r.line + piece.before.lines});
  }

  // The second pass over pieces 0 to last_piece, lines before last_line: into `mesh`,
  // or only checked when it is null. Of the lines it refuses, the first in the file is
  // thrown.
  auto second_pass = [&](int last_piece, long long last_line, Mesh<T>* mesh,
                         std::vector<ObjPolygon>* polygons) {
    std::vector<std::exception_ptr> errors(static_cast<size_t>(last_piece + 1));
    parallel_for(last_piece + 1, 1, [&](int k) {
      const ObjPiece& piece = pieces[k];
      ObjPieceParser<T> parser(mesh, polygons ? polygons->data() : nullptr, total, piece, name,
                               limits);
      try {
        source.for_each_line(piece.begin, piece.end, piece.first_line(),
                             [&](std::string_view line, long long number) {
                               if (number < last_line) parser.line(line, number);
                             });
      } catch (const Error&) {
        errors[k] = std::current_exception();
      }
    });
    for (std::exception_ptr& e : errors)
      if (e) std::rethrow_exception(e);
  };
  // The first line refused, in file order: the first pass's, unless a line above it
  // fails the second pass's checks.
  for (int k = 0; k < n_pieces; ++k) {
    if (pieces[k].problem_line == 0) continue;
    const long long line = pieces[k].before.lines + pieces[k].problem_line;
    second_pass(k, line, nullptr, nullptr);
    throw invalid_input(obj_where(name, line) + pieces[k].problem);
  }

  if (total.vertices == 0) throw invalid_input(name + ": no vertices (`v x y z` lines)");
  if (total.triangles == 0) throw invalid_input(name + ": no faces (`f a b c` lines)");
  auto over = [&](long long count, long long limit, const char* what) {
    if (count > limit)
      throw invalid_input(name + ": " + std::to_string(count) + " " + what +
                          ", more than the limit of " + std::to_string(limit));
  };
  // Indices are int: no count may pass 2^31 - 1, whatever the limits say.
  const long long records = std::min<long long>(limits.max_vertices, (1ll << 31) - 1);
  over(total.vertices, records, "vertices");
  over(total.texcoords, records, "texture coordinates");
  over(total.normals, records, "normals");
  over(total.triangles, std::min<long long>(limits.max_triangles, (1ll << 31) - 1), "triangles");

  Mesh<T>& mesh = out.mesh;
  const size_t n_triangles = static_cast<size_t>(total.triangles);
  mesh.vertices.resize(static_cast<size_t>(total.vertices));
  mesh.triangles.resize(n_triangles);
  if (total.normals > 0) {
    mesh.normals.resize(static_cast<size_t>(total.normals));
    mesh.normal_triangles.resize(n_triangles);
  }
  if (total.texcoords > 0) {
    mesh.uvs.resize(static_cast<size_t>(total.texcoords));
    mesh.uv_triangles.resize(n_triangles);
  }
  if (with_materials && !total.uses.empty()) mesh.triangle_materials.resize(n_triangles);
  std::vector<ObjPolygon> polygons(static_cast<size_t>(total.polygons));
  second_pass(n_pieces - 1, total.lines + 1, &mesh, &polygons);
  triangulate_obj_polygons(mesh, polygons, name);
  settle_obj_attributes(mesh);
  return out;
}

}  // namespace detail

// Parses OBJ text; `name` labels errors. Throws twinray::Error(InvalidInput). The mesh
// has the file's vertex normals and texture coordinates; materials are not read
// (io/obj_model.hpp reads them), so triangle_materials is empty.
template <class T>
Mesh<T> parse_obj_mesh(const std::string& text, const std::string& name,
                       const ObjLimits& limits = {}) {
  if (static_cast<long long>(text.size()) > limits.max_file_bytes)
    throw invalid_input(name + ": an OBJ file is " + std::to_string(text.size()) +
                        " bytes, more than the limit of " + std::to_string(limits.max_file_bytes));
  return detail::read_obj<T>(detail::ObjSource(text), name, limits, false).mesh;
}

// Loads an OBJ file, read a buffer at a time (its size is checked first).
template <class T>
Mesh<T> load_obj_mesh(const std::string& path, const ObjLimits& limits = {}) {
  detail::ObjSource source(path,
                           detail::checked_file_size(path, limits.max_file_bytes, "an OBJ file"));
  return detail::read_obj<T>(source, path, limits, false).mesh;
}

}  // namespace io
}  // namespace twinray
