// The OBJ parser's pieces and passes (io/obj_mesh.hpp): the text is cut into pieces
// parsed in parallel, so the mesh, the first error and its line number must not depend
// on where the cuts fall or on the thread count; a file read a buffer at a time gives
// what the same text in memory gives; and the MTL reader refuses bad values by file and
// line.
#include <doctest/doctest.h>

#include <fstream>
#include <string>
#include <vector>

#include <twinray/core/parallel.hpp>
#include <twinray/io/obj_model.hpp>

#include "support/refusal.hpp"

using namespace twinray;
using test_support::refusal;
using test_support::TempDir;

namespace {

// Every kind of record and corner, across what the pieces cut: relative and forward
// indices, polygons (a concave one), usemtl groups, CRLF, comments and blank lines, a
// face before any usemtl, and a last line without its newline.
const std::string kVaried =
    "# varied\r\nmtllib a.mtl b.mtl\n\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
    "vt 0 0\nvt 1 0\nvt 1 1 0\nvt 0.5\nvn 0 0 1\nvn 0 0 0\n"
    "f 1/1/1 2/2/1 3/3/1\r\n"  // before any usemtl
    "usemtl red\n"
    "f -4/-4/-2 -3/-3/-2 -2/-2/-2 -1/-1/-2\n"  // a quad, relative
    "o thing\ng part\ns 1\n"
    "v 2 0 0\nv 3 0.5 0\nv 2 1 0\nv 2.5 0.5 0\n"
    "usemtl \n"      // a usemtl without a name
    "f 2 5 8 6 7\n"  // concave: reflex at 8
    "usemtl green\n"
    "f 1//2 2//2 4//2\n"  // a zero normal: flat
    "f 9 10 11\n"         // forward references
    "v 0 2 0\nv 1 2 0\nv 1 3 0\n"
    "f 3/4 4/4 9/4";

template <class T>
void check_same(const Mesh<T>& a, const Mesh<T>& b) {
  CHECK(a.vertices == b.vertices);
  CHECK(a.triangles == b.triangles);
  CHECK(a.normals == b.normals);
  CHECK(a.normal_triangles == b.normal_triangles);
  CHECK(a.uvs == b.uvs);
  CHECK(a.uv_triangles == b.uv_triangles);
  CHECK(a.triangle_materials == b.triangle_materials);
}

io::detail::ObjRead<double> read_text(const std::string& text, long long chunk_bytes) {
  io::ObjLimits limits;
  limits.chunk_bytes = chunk_bytes;
  return io::detail::read_obj<double>(io::detail::ObjSource(text), "v.obj", limits, true);
}

// Restores the process's thread count when a test ends.
struct ThreadCount {
  explicit ThreadCount(int n) { set_thread_count(n); }
  ~ThreadCount() { set_thread_count(0); }
};

}  // namespace

TEST_CASE("OBJ pieces: the mesh does not depend on the piece size or the thread count") {
  io::detail::ObjRead<double> whole = read_text(kVaried, 1 << 20);
  const Mesh<double>& m = whole.mesh;
  // What the file says, read once in one piece.
  REQUIRE(m.vertices.size() == 11);
  REQUIRE(m.triangles.size() == 1 + 2 + 3 + 1 + 1 + 1);
  CHECK(m.triangles[0] == std::array<int, 3>{0, 1, 2});
  // The concave pentagon 2 5 8 6 7 (0-based 1 4 7 5 6): no triangle may cover the notch
  // at corner 8 (2.5, 0.5), so 1-4-7 must not be cut off as an ear from corner 1's side.
  double area = 0;
  for (int t = 3; t < 6; ++t) {
    auto [a, b, c] = m.triangles[t];
    glm::dvec3 n = glm::cross(m.vertices[b] - m.vertices[a], m.vertices[c] - m.vertices[a]);
    CHECK(n.z >= 0.0);  // the polygon's facing, +z
    area += 0.5 * n.z;
  }
  // The shoelace area of (1, 0) (2, 0) (2.5, 0.5) (3, 0.5) (2, 1): the triangles
  // cover the polygon once.
  CHECK(area == doctest::Approx(0.875));
  CHECK(whole.counts.uses.size() == 3);
  CHECK(whole.counts.uses[1].name.empty());
  CHECK(whole.counts.uses[2].line == 26);
  REQUIRE(whole.counts.libraries.size() == 2);
  CHECK(whole.counts.libraries[1].name == "b.mtl");
  CHECK(m.triangle_materials == std::vector<int>{-1, 0, 0, 1, 1, 1, 2, 2, 2});
  CHECK(m.uv_triangles[0] == std::array<int, 3>{0, 1, 2});
  CHECK(m.uv_triangles[6] == std::array<int, 3>{-1, -1, -1});  // no vt at all
  CHECK(m.uv_triangles[8] == std::array<int, 3>{3, 3, 3});     // the last line, no newline
  CHECK(m.uvs[3] == glm::dvec2(0.5, 0.0));                     // `vt u`: v is 0
  CHECK(m.normal_triangles[1] == std::array<int, 3>{0, 0, 0});
  CHECK(m.normal_triangles[6] == std::array<int, 3>{-1, -1, -1});  // its normal is zero
  CHECK(m.normals[1] == glm::dvec3(0, 0, 1));  // the unused zero normal, a placeholder

  for (int threads : {1, 2, 3}) {
    ThreadCount count(threads);
    for (long long chunk : {1ll, 2ll, 3ll, 5ll, 8ll, 13ll, 40ll, 100ll}) {
      CAPTURE(threads);
      CAPTURE(chunk);
      io::detail::ObjRead<double> cut = read_text(kVaried, chunk);
      check_same(m, cut.mesh);
      REQUIRE(cut.counts.uses.size() == whole.counts.uses.size());
      for (size_t k = 0; k < cut.counts.uses.size(); ++k)
        CHECK(cut.counts.uses[k].line == whole.counts.uses[k].line);
      CHECK(cut.counts.lines == whole.counts.lines);
    }
  }
}

TEST_CASE("OBJ pieces: the first bad line is named wherever the pieces are cut") {
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  struct Bad {
    std::string text, message;
  };
  const Bad cases[] = {
      // A bad number above a face with too few corners (the first pass finds the face,
      // the second the number): the number, the earlier line, is named.
      {tri + "vn 0 x 1\nf 1 2 3\nf 1 2\n", "m.obj:4: normal coordinate 'x' is not a number"},
      {tri + "vn 0 x 1\nf 1 2 3\n\x02\n", "m.obj:4: normal coordinate 'x' is not a number"},
      {tri + "f 1 2 3\nf 1 2\nvn 0 x 1\n", "m.obj:5: a face needs at least 3 corners, got 2"},
      {tri + "f 1 2 3\nf 1 2 -4\nf 1 2\n",
       "m.obj:5: vertex index -4 is out of range: 3 before "
       "this line"},
      {tri + "f 1 2 3\nf 1 2 3 4\nv 0 0 1\nf -1 2 3 -5\n",
       "m.obj:7: vertex index -5 is out of range: 4 before this line"},
      {tri + "f 1 2 3\n" + std::string(40, '#') + "\nf 1 2 3 \x7f\x01\n",
       "m.obj:6: byte 0x01: not a text file"},
  };
  for (const Bad& c : cases)
    for (int threads : {1, 2})
      for (long long chunk : {1ll, 4ll, 9ll, 1ll << 20}) {
        CAPTURE(c.text);
        CAPTURE(chunk);
        ThreadCount count(threads);
        io::ObjLimits limits;
        limits.chunk_bytes = chunk;
        CHECK(refusal([&] { io::parse_obj_mesh<float>(c.text, "m.obj", limits); }) == c.message);
      }
}

TEST_CASE("OBJ pieces: a file read a buffer at a time is the text read in memory") {
  TempDir temp("twinray-obj-parser-test");
  const std::string path = temp.str() + "/v.obj";
  std::ofstream(path, std::ios::binary) << kVaried;
  io::ObjLimits limits;
  for (long long chunk : {1ll, 7ll, 1ll << 20}) {
    limits.chunk_bytes = chunk;
    check_same(io::load_obj_mesh<double>(path, limits),
               io::parse_obj_mesh<double>(kVaried, "v.obj", limits));
  }
  // A line longer than the read buffer (1 MiB) is read whole.
  std::string long_line = "# " + std::string(5 << 19, 'x') + "\n";
  std::string text = "v 0 0 0\n" + long_line + "v 1 0 0\nv 0 1 0\n" + long_line + "f 1 2 3\n";
  std::ofstream(path, std::ios::binary) << text;
  for (long long chunk : {1ll << 20, 4ll << 20}) {
    limits.chunk_bytes = chunk;
    Mesh<float> mesh = io::load_obj_mesh<float>(path, limits);
    CHECK(mesh.vertices.size() == 3);
    CHECK(mesh.triangles.size() == 1);
  }
  std::ofstream(path, std::ios::binary) << text << "f 1 2 4\n";
  CHECK(refusal([&] { io::load_obj_mesh<float>(path, limits); }) ==
        path + ":7: vertex index 4 is out of range: the file has 3");
}

TEST_CASE("OBJ limits: records of each kind, corners of a face") {
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  io::ObjLimits limits;
  limits.max_vertices = 3;
  CHECK(refusal([&] {
          io::parse_obj_mesh<float>(tri + "vn 0 0 1\nvn 0 0 1\nvn 0 0 1\nvn 0 0 1\nf 1 2 3\n",
                                    "l.obj", limits);
        }) == "l.obj: 4 normals, more than the limit of 3");
  CHECK(refusal([&] {
          io::parse_obj_mesh<float>(tri + "vt 0\nvt 0\nvt 0\nvt 0\nf 1 2 3\n", "l.obj", limits);
        }) == "l.obj: 4 texture coordinates, more than the limit of 3");
  limits = {};
  limits.max_face_corners = 4;
  CHECK(refusal([&] {
          io::parse_obj_mesh<float>(tri + "v 1 1 0\nv 2 2 0\nf 1 2 4 3\nf 1 2 5 4 3\n", "c.obj",
                                    limits);
        }) == "c.obj:7: a face of 5 corners, more than the limit of 4");
}

TEST_CASE("MTL: malformed values are refused by file and line") {
  using io::detail::parse_mtl;
  struct Bad {
    std::string text, message;
  };
  const Bad cases[] = {
      {"newmtl a\nKd 1 0.5\n", "m.mtl:2: Kd takes 1 value (grey) or 3 (r g b), got 2"},
      {"newmtl a\nKd spectral x.spd\n",
       "m.mtl:2: Kd takes 1 value (grey) or 3 (r g b), got 2 (spectral and xyz colours are not "
       "read)"},
      {"newmtl a\nKs 1 nan 0\n", "m.mtl:2: Ks value nan is not a finite number"},
      {"newmtl a\nNs\n", "m.mtl:2: Ns takes 1 value, got 0"},
      {"newmtl a\nillum two\n", "m.mtl:2: illum takes one model number 0 to 10, got 'two'"},
      {"newmtl a\nillum 11\n", "m.mtl:2: illum takes one model number 0 to 10, got '11'"},
      {"Kd 1 1 1\nnewmtl a\n", "m.mtl:1: Kd before the first newmtl: which material is it for?"},
      {"newmtl\n", "m.mtl:1: newmtl needs a material name"},
      {"newmtl a\nmap_Kd -s 2 2\n", "m.mtl:2: map_Kd names no texture file"},
      {"newmtl a\nmap_Kd -zoom 2 a.png\n",
       "m.mtl:2: map_Kd option '-zoom' is not an MTL "
       "texture option"},
      {std::string("newmtl a\n\0\n", 11), "m.mtl:2: byte 0x00: not a text file"},
  };
  for (const Bad& c : cases) {
    CAPTURE(c.text);
    CHECK(refusal([&] { parse_mtl(c.text, "m.mtl"); }) == c.message);
  }
  // Options before the file name are skipped; a name may hold spaces; colours take one
  // value for grey; without Kd a textured material shows its texture as painted.
  auto m = parse_mtl(
      "# a library\nnewmtl wood grain\nmap_Kd -s 2 2 -clamp on -o 0.5 my wood.png\n"
      "Ka 0.25\nd 0.5\nnewmtl plain\n",
      "m.mtl");
  REQUIRE(m.size() == 2);
  CHECK(m[0].name == "wood grain");
  CHECK(m[0].map_kd == "my wood.png");
  CHECK(m[0].map_kd_line == 3);
  CHECK(m[0].ka[2] == 0.25);
  CHECK(m[0].kd[0] == 1.0);
  CHECK(m[1].kd[0] == 0.8);  // no Kd, no texture: grey
  CHECK(m[1].line == 6);
  CHECK((m[0].has_d && m[0].d == 0.5 && !m[1].has_d));
}

TEST_CASE("MTL: a material defined twice keeps its first definition, with a warning") {
  TempDir temp("twinray-obj-parser-test");
  const std::string dir = temp.str();
  std::ofstream(dir + "/a.obj") << "mtllib a.mtl b.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"
                                   "usemtl red\nf 1 2 3\n";
  std::ofstream(dir + "/a.mtl") << "newmtl red\nKd 1 0 0\n";
  std::ofstream(dir + "/b.mtl") << "\nnewmtl red\nKd 0 1 0\n";
  io::ObjModel<float> model = io::load_obj_model<float>(dir + "/a.obj");
  REQUIRE(model.materials.size() == 1);
  CHECK(model.materials[0].color == glm::vec3(1, 0, 0));
  REQUIRE(model.warnings.size() == 1);
  CHECK(model.warnings[0] == dir + "/b.mtl:2: newmtl red: defined before, in " + dir +
                                 "/a.mtl:1; this definition is not used");
  // Without materials, no library is read: a missing one is no warning, even strict.
  std::remove((dir + "/a.mtl").c_str());
  io::ObjModelOptions mesh_only;
  mesh_only.materials = false;
  mesh_only.strict = true;
  io::ObjModel<float> plain = io::load_obj_model<float>(dir + "/a.obj", mesh_only);
  CHECK(plain.warnings.empty());
  CHECK(plain.materials.empty());
  CHECK(plain.mesh.triangle_materials.empty());
}
