// The scene loader (io/scene_json.hpp) and the OBJ loader (io/obj_mesh.hpp), through
// the API: the shipped scene files hold what they say, limits hold before allocation,
// and messages have the form `FILE: JSON.PATH: problem`.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include <unistd.h>

#include <twinray/core/process.hpp>
#include <twinray/io/scene_json.hpp>

#include <twinray/scene/demo_scene.hpp>

namespace {

const std::string kScenes = TWINRAY_SCENES_DIR;

// The message of the InvalidInput error `f` throws ("" when it throws none).
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const twinray::Error& e) {
    CHECK(e.kind() == twinray::ErrorKind::InvalidInput);
    return e.what();
  }
  return "";
}

const char* kSmall = R"({
  "twinray": 1,
  "image": { "width": 4, "height": 3 },
  "camera": { "projection": "orthographic", "position": [0, 0, 5], "look_at": [0, 0, 0],
              "up": [0, 1, 0] },
  "materials": { "m": {} },
  "objects": [
    { "type": "mesh", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
      "triangles": [[0, 1, 2], [0, 1, 3]], "material": "m" }
  ]
})";

// kSmall with `object` in front of its mesh.
std::string with_object(const std::string& object) {
  std::string text = kSmall;
  text.replace(text.find(R"({ "type": "mesh")"), 0, object + ",");
  return text;
}

template <class T>
void check_equal(const twinray::Material<T>& a, const twinray::Material<T>& b) {
  CHECK(a.color == b.color);
  CHECK(a.ka == b.ka);
  CHECK(a.kd == b.kd);
  CHECK(a.ks == b.ks);
  CHECK(a.shininess == b.shininess);
  CHECK(a.glaze == b.glaze);
}

template <class T>
void check_equal(const twinray::Object<T>& a, const twinray::Object<T>& b) {
  REQUIRE(a.index() == b.index());
  if (auto* s = std::get_if<twinray::Sphere<T>>(&a)) {
    auto& t = std::get<twinray::Sphere<T>>(b);
    CHECK(s->center == t.center);
    CHECK(s->radius == t.radius);
    CHECK(s->material == t.material);
  } else if (auto* s = std::get_if<twinray::Triangle<T>>(&a)) {
    auto& t = std::get<twinray::Triangle<T>>(b);
    CHECK(s->vertices == t.vertices);
    CHECK(s->material == t.material);
  } else if (auto* s = std::get_if<twinray::Plane<T>>(&a)) {
    auto& t = std::get<twinray::Plane<T>>(b);
    CHECK(s->point == t.point);
    CHECK(s->normal == t.normal);
    CHECK(s->material == t.material);
  } else {
    auto& s2 = std::get<twinray::Mesh<T>>(a);
    auto& t = std::get<twinray::Mesh<T>>(b);
    CHECK(s2.vertices == t.vertices);
    CHECK(s2.triangles == t.triangles);
    CHECK(s2.material == t.material);
  }
}

}  // namespace

TEST_CASE_TEMPLATE("demo.json holds exactly the scene of include/twinray/scene/demo_scene.hpp", T,
                   float, double) {
  twinray::io::SceneFile<T> f = twinray::io::load_scene<T>(kScenes + "/demo.json");
  twinray::demo::DemoSetup<T> d = twinray::demo::make_demo_scene<T>(400, 400);
  REQUIRE(f.scene.materials.size() == d.scene.materials.size());
  for (size_t i = 0; i < d.scene.materials.size(); ++i)
    check_equal(f.scene.materials[i], d.scene.materials[i]);
  CHECK(f.material_names ==
        std::vector<std::string>{"green", "cyan", "dark_blue", "lime", "magenta"});
  REQUIRE(f.scene.objects.size() == d.scene.objects.size());
  for (size_t i = 0; i < d.scene.objects.size(); ++i) {
    CAPTURE(i);
    check_equal(f.scene.objects[i], d.scene.objects[i]);
  }
  REQUIRE(f.scene.lights.size() == 1);
  CHECK(f.scene.lights[0].position == d.scene.lights[0].position);
  CHECK(f.scene.lights[0].intensity == d.scene.lights[0].intensity);
  CHECK(f.scene.lights[0].color == d.scene.lights[0].color);
  CHECK(f.scene.background == d.scene.background);
  CHECK(f.camera.projection == d.camera.projection);
  CHECK(f.camera.position == d.camera.position);
  CHECK(f.camera.look_at == d.camera.look_at);
  CHECK(f.camera.up == d.camera.up);
  CHECK(!f.camera.focal_length.has_value());
  CHECK(f.camera.viewplane_height == d.camera.viewplane_height);
  CHECK(f.camera.width == 400);
  CHECK(f.camera.height == 400);
  twinray::RenderOptions defaults;
  CHECK(f.options.spp == defaults.spp);
  CHECK(f.options.max_depth == defaults.max_depth);
  CHECK(f.options.shadows == defaults.shadows);
  CHECK(f.options.glaze == defaults.glaze);
  CHECK(f.options.terms == defaults.terms);
  CHECK(f.animation.is_null());
}

TEST_CASE("every shipped scene loads, in float and double") {
  for (const char* name :
       {"demo.json", "torus.json", "three_lights.json", "seed/ambient_only.json",
        "seed/diffuse_only.json", "seed/specular_only.json", "seed/no_shadows.json",
        "seed/no_glaze.json", "seed/all_glazed.json", "seed/orthographic.json"}) {
    CAPTURE(name);
    CHECK(error_of([&] { twinray::io::load_scene<float>(kScenes + "/" + name); }) == "");
    CHECK(error_of([&] { twinray::io::load_scene<double>(kScenes + "/" + name); }) == "");
  }
  twinray::io::SceneFile<float> torus = twinray::io::load_scene<float>(kScenes + "/torus.json");
  auto& mesh = std::get<twinray::Mesh<float>>(torus.scene.objects[0]);
  CHECK(mesh.vertices.size() == 40 * 20);
  CHECK(mesh.triangles.size() == 2 * 40 * 20);  // quads fanned into two triangles
  CHECK(torus.scene.lights.size() == 2);
  CHECK(torus.material_names.back() == "objects[2].material");  // the inline one
  CHECK(torus.options.spp == 4);
  twinray::io::SceneFile<float> three =
      twinray::io::load_scene<float>(kScenes + "/three_lights.json");
  CHECK(three.scene.lights.size() == 3);
}

TEST_CASE("messages: FILE: JSON.PATH: problem") {
  std::string text = kSmall;
  text.replace(text.find("[[0, 1, 2]"), 10, "[[0, 1, 4]");
  CHECK(error_of([&] { twinray::io::parse_scene<float>(text, "scene.json"); }) ==
        "scene.json: objects[0].triangles[0][2]: vertex index 4 out of range: the mesh has 4 "
        "vertices (indices 0 to 3)");
  std::string sphere =
      with_object(R"({ "type": "sphere", "center": [0, 0, 0], "radius": -1, "material": "m" })");
  CHECK(error_of([&] { twinray::io::parse_scene<float>(sphere, "scene.json"); }) ==
        "scene.json: objects[0].radius: must be > 0, got -1");
}

TEST_CASE("precision: a value that fits a double but not a float") {
  std::string text = kSmall;
  text.replace(text.find("[1, 0, 0]"), 9, "[1e300, 0, 0]");
  CHECK(error_of([&] { twinray::io::parse_scene<double>(text, "s.json"); }) == "");
  CHECK(error_of([&] { twinray::io::parse_scene<float>(text, "s.json"); }) ==
        "s.json: objects[0].vertices[1][0]: 1e+300 overflows float (largest 3.40282347e+38)");
}

TEST_CASE("limits hold before the scene is built") {
  twinray::io::SceneLimits limits;
  limits.max_file_bytes = 100;
  CHECK(error_of([&] {
          twinray::io::parse_scene<float>(kSmall, "s.json", "", limits);
        }).find("s.json: ") == 0);
  CHECK(error_of([&] {
          twinray::io::parse_scene<float>(kSmall, "s.json", "", limits);
        }).find("more than the limit of 100") != std::string::npos);

  limits = {};
  limits.max_nesting = 3;
  CHECK(error_of([&] { twinray::io::parse_scene<float>(kSmall, "s.json", "", limits); }) ==
        "s.json: objects[0].vertices: nested deeper than 3 levels");

  limits = {};
  limits.max_json_values = 20;
  CHECK(error_of([&] {
          twinray::io::parse_scene<float>(kSmall, "s.json", "", limits);
        }).find("more than 20 JSON values") != std::string::npos);

  limits = {};
  limits.max_mesh_vertices = 3;
  CHECK(error_of([&] { twinray::io::parse_scene<float>(kSmall, "s.json", "", limits); }) ==
        "s.json: objects[0].vertices: 4 vertices, more than the limit of 3");

  limits = {};
  limits.max_total_triangles = 1;
  CHECK(error_of([&] { twinray::io::parse_scene<float>(kSmall, "s.json", "", limits); }) ==
        "s.json: objects[0].triangles: the scene has more than 1 triangles in all (the limit)");

  limits = {};
  limits.max_objects = 0;
  CHECK(error_of([&] { twinray::io::parse_scene<float>(kSmall, "s.json", "", limits); }) ==
        "s.json: objects: 1 objects, more than the limit of 0");
}

TEST_CASE("the default limits follow the memory the process may use") {
  using namespace twinray::io;
  const long long memory = twinray::usable_memory_bytes();
  REQUIRE(memory > 0);  // Linux reports its physical pages
  CHECK(memory <= static_cast<long long>(::sysconf(_SC_PHYS_PAGES)) * ::sysconf(_SC_PAGE_SIZE));
  const long long triangles = memory_triangle_limit();
  CHECK(triangles == std::clamp(memory / kPeakBytesPerTriangle, 1ll << 24, (1ll << 31) - 1));
  CHECK(memory_vertex_limit() == std::min(3 * triangles, (1ll << 31) - 1));
  CHECK(memory_obj_file_limit() == std::max(256ll << 20, memory));
  SceneLimits scene;
  CHECK(scene.max_total_triangles == triangles);
  CHECK(scene.max_mesh_vertices == memory_vertex_limit());
  CHECK(scene.max_obj_file_bytes == memory_obj_file_limit());
  ObjLimits obj;
  CHECK(obj.max_triangles == triangles);
  CHECK(obj.max_vertices == memory_vertex_limit());
  CHECK(obj.max_file_bytes == memory_obj_file_limit());
  // The process's peak resident memory is at least what it holds now.
  std::vector<char> held(64 << 20);
  std::memset(held.data(), 1, held.size());
  CHECK(std::count(held.begin(), held.end(), 1) == static_cast<long long>(held.size()));
  CHECK(twinray::peak_resident_bytes() >= static_cast<long long>(held.size()));
}

TEST_CASE("OBJ: faces triangulated, relative indices, and clear errors") {
  using twinray::io::parse_obj_mesh;
  twinray::Mesh<double> quad =
      parse_obj_mesh<double>("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n", "q.obj");
  CHECK(quad.vertices.size() == 4);
  REQUIRE(quad.triangles.size() == 2);
  // A quad is split along its shorter diagonal (here both are as short: 1-3); a convex
  // polygon comes out as a fan from its first corner.
  CHECK(quad.triangles[0] == std::array<int, 3>{0, 1, 3});
  CHECK(quad.triangles[1] == std::array<int, 3>{1, 2, 3});
  twinray::Mesh<double> pentagon = parse_obj_mesh<double>(
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 0.5 0\nf 1 2 3 4 5\n", "p.obj");
  REQUIRE(pentagon.triangles.size() == 3);
  CHECK(pentagon.triangles[0] == std::array<int, 3>{0, 1, 2});
  CHECK(pentagon.triangles[1] == std::array<int, 3>{0, 2, 3});
  CHECK(pentagon.triangles[2] == std::array<int, 3>{0, 3, 4});
  // Negative indices count back from the last vertex; v/vt/vn forms are accepted.
  twinray::Mesh<float> rel =
      parse_obj_mesh<float>("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf -3//1 -2//1 -1//1\n", "r.obj");
  REQUIRE(rel.triangles.size() == 1);
  CHECK(rel.triangles[0] == std::array<int, 3>{0, 1, 2});
  // Coordinates are parsed as doubles, then rounded once to the render's type.
  twinray::Mesh<float> f =
      parse_obj_mesh<float>("v 0.1 0.2 0.3\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "p.obj");
  CHECK(f.vertices[0].x == static_cast<float>(0.1));

  CHECK(error_of([] { parse_obj_mesh<float>("v 0 0 0\nv 1 0 0\nv 0 1 0\n", "n.obj"); }) ==
        "n.obj: no faces (`f a b c` lines)");
  CHECK(error_of([] { parse_obj_mesh<float>("# empty\n", "e.obj"); }) ==
        "e.obj: no vertices (`v x y z` lines)");
  CHECK(error_of([] {
          parse_obj_mesh<float>("v 1e300 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "big.obj");
        }) == "big.obj:1: vertex coordinate 1e300 overflows float");
  twinray::io::ObjLimits limits;
  limits.max_vertices = 2;
  CHECK(error_of([&] {
          parse_obj_mesh<float>("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "l.obj", limits);
        }) == "l.obj: 3 vertices, more than the limit of 2");
  limits = {};
  limits.max_triangles = 1;
  CHECK(error_of([&] {
          parse_obj_mesh<float>("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 4 3\n", "t.obj", limits);
        }) == "t.obj: 2 triangles, more than the limit of 1");
  CHECK(error_of([] { twinray::io::load_obj_mesh<float>("/nonexistent/x.obj"); }) ==
        "/nonexistent/x.obj: cannot open an OBJ file: No such file or directory");
}

// Every refused line is named as file:line, with what the file wrote there.
TEST_CASE("OBJ: each malformed line is refused by file and line, as written") {
  using twinray::io::parse_obj_mesh;
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";  // lines 1-3
  struct Bad {
    std::string text, message;
  };
  const Bad cases[] = {
      {tri + "f 1 2 7\n", "m.obj:4: vertex index 7 is out of range: the file has 3"},
      {tri + "f 1 2 3 4 9\n", "m.obj:4: vertex index 4 is out of range: the file has 3"},
      {tri + "f 1 2 3\nf -1 -2 -4\n",
       "m.obj:5: vertex index -4 is out of range: 3 before this line"},
      {tri + "f 0 1 2\n", "m.obj:4: vertex index 0: OBJ indices start at 1"},
      {tri + "f 1 2 3x\n", "m.obj:4: vertex index '3x' is not an integer"},
      {tri + "f 1 2 3 #\n", "m.obj:4: vertex index '#' is not an integer"},
      {tri + "f 1/1 2/1 3/1\n",
       "m.obj:4: texture coordinate index 1 is out of range: the file has 0"},
      {tri + "vn 0 0 1\nf 1//1 2//2 3//1\n",
       "m.obj:5: normal index 2 is out of range: the file has 1"},
      {tri + "f 1/ 2 3\n", "m.obj:4: texture coordinate index '' is not an integer"},
      {tri + "f 1/1/1/1 2 3\nvt 0 0\nvn 0 0 1\n",
       "m.obj:4: face corner '1/1/1/1' has more than 3 parts"},
      {tri + "f 1 2\n", "m.obj:4: a face needs at least 3 corners, got 2"},
      {tri + "f\n", "m.obj:4: a face needs at least 3 corners, got 0"},
      {tri + "f 1 2 3\nv 0 0",
       "m.obj:5: `v` takes 3 coordinates (4 with w, 6 with a colour), got 2"},
      {"v nan 1 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
       "m.obj:1: vertex coordinate nan is not a finite number"},
      {"v 0 inf 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
       "m.obj:1: vertex coordinate inf is not a finite number"},
      {"v 0 1e999 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
       "m.obj:1: vertex coordinate 1e999 is outside the range of double"},
      {"v 0 0 0\nv 1 0,5 0\nv 0 1 0\nf 1 2 3\n",
       "m.obj:2: vertex coordinate '0,5' is not a number"},
      {tri + "vn 0 nan 1\nf 1 2 3\n", "m.obj:4: normal coordinate nan is not a finite number"},
      {tri + "vt 0 0 0 0\nf 1 2 3\n", "m.obj:4: `vt` takes 1 to 3 coordinates, got 4"},
      {tri + "f 1 2 3\n\x01", "m.obj:5: byte 0x01: not a text file"},
      {std::string("v 0 0 0\0", 8), "m.obj:1: byte 0x00: not a text file"},
      {tri, "m.obj: no faces (`f a b c` lines)"},
  };
  for (const Bad& c : cases) {
    CAPTURE(c.text);
    CHECK(error_of([&] { parse_obj_mesh<float>(c.text, "m.obj"); }) == c.message);
  }
  // What a well-formed file may hold: comments, objects, groups, smoothing, materials,
  // w and vertex colours, texture coordinates and normals, forward references, CRLF.
  auto mesh = parse_obj_mesh<double>(
      "# a comment\r\nmtllib x.mtl\no thing\ng part\ns 1\nusemtl red\n"
      "v 0 0 0 1\nv 1 0 0 0.5 0.5 0.5\nv +0 1 0\nvt 0 0\nvt 1 0 0\nvn 0 0 1\n"
      "f 1/1/1 2/2/1 3//1\r\nf 1 2 4\nv 1 1 -1e-3\n",
      "ok.obj");
  CHECK(mesh.vertices.size() == 4);
  CHECK(mesh.triangles.size() == 2);
}

TEST_CASE("transform: objects are placed once, at load") {
  using vec3 = glm::vec<3, float>;
  auto file = twinray::io::parse_scene<float>(
      with_object(R"({ "type": "sphere", "center": [1, 0, 0], "radius": 0.5, "material": "m",
                       "transform": { "scale": 2, "rotate": { "axis": [0, 0, 1], "degrees": 90 },
                                      "translate": [0, 0, -4] } })"),
      "t.json");
  auto& s = std::get<twinray::Sphere<float>>(file.scene.objects[0]);
  CHECK(s.center == vec3(0, 2, -4));
  CHECK(s.radius == 1.0f);
  // The same placement as a matrix, on the mesh.
  std::string text = kSmall;
  text.replace(
      text.find(R"("material": "m" })"), 0,
      R"("transform": { "matrix": [[0, -2, 0, 0], [2, 0, 0, 0], [0, 0, 2, -4], [0, 0, 0, 1]] }, )");
  auto mesh_file = twinray::io::parse_scene<float>(text, "t.json");
  auto& mesh = std::get<twinray::Mesh<float>>(mesh_file.scene.objects[0]);
  CHECK(mesh.vertices[1] == vec3(0, 2, -4));
  CHECK(mesh.vertices[3] == vec3(0, 0, -2));
  // A plane keeps a normal perpendicular to it.
  auto plane = twinray::io::parse_scene<double>(
      with_object(R"({ "type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "material": "m",
                       "transform": { "rotate": { "axis": [1, 0, 0], "degrees": 90 } } })"),
      "t.json");
  CHECK(std::get<twinray::Plane<double>>(plane.scene.objects[0]).normal == glm::dvec3(0, 0, 1));
}

TEST_CASE("transform: what is refused, by file and JSON path") {
  struct Bad {
    std::string object, message;
  };
  const std::string sphere =
      R"({ "type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m", "transform": )";
  const std::string tri =
      R"({ "type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "material": "m", "transform": )";
  const Bad cases[] = {
      {sphere + R"({ "scale": [1, 2, 1] } })",
       "t.json: objects[0].transform: a sphere takes only uniform scale, rotation and translation: "
       "this transform would make it an ellipsoid"},
      {tri + R"({ "scale": [1, 0, 1] } })",
       "t.json: objects[0].transform.scale: must not be 0: a zero scale flattens the object (a "
       "singular transform)"},
      {tri + R"({ "matrix": [[1, 0, 0, 0], [0, 1, 0, 0], [1, 1, 0, 0], [0, 0, 0, 1]] } })",
       "t.json: objects[0].transform.matrix: the transform is singular (determinant 0.000000)"},
      {tri + R"({ "matrix": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 1, 1]] } })",
       "t.json: objects[0].transform.matrix: the last row must be [0, 0, 0, 1] (an affine map)"},
      {tri + R"({ "matrix": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]] } })",
       "t.json: objects[0].transform.matrix: must be 4 rows of 4 numbers (row-major), got an array "
       "of 3"},
      {tri +
           R"({ "matrix": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]], "translate": [1, 0, 0] } })",
       "t.json: objects[0].transform.translate: a transform takes either \"matrix\" or "
       "\"translate\", "
       "\"rotate\" and \"scale\", not both"},
      {tri + R"({ "rotate": { "axis": [0, 0, 0], "degrees": 10 } } })",
       "t.json: objects[0].transform.rotate.axis: must be a non-zero vector, got [0,0,0]"},
      {tri + R"({ "rotate": { "axis": [0, 1, 0] } } })",
       "t.json: objects[0].transform.rotate.degrees: missing (required)"},
      {tri + R"({ "translate": [1, "2", 3] } })",
       "t.json: objects[0].transform.translate[1]: must be a number, got a string (\"2\")"},
      {tri + R"({ "move": [1, 2, 3] } })", ""},  // the unknown-key message is checked below
  };
  for (const Bad& c : cases) {
    CAPTURE(c.object);
    std::string message =
        error_of([&] { twinray::io::parse_scene<float>(with_object(c.object), "t.json"); });
    if (c.message.empty())
      CHECK(message.rfind("t.json: objects[0].transform.move: unknown key", 0) == 0);
    else
      CHECK(message == c.message);
  }
}

// A path moves the placed object: the transform puts it in the world, then the path
// translates it so that its anchor (here the mesh's box center) sits on the path.
TEST_CASE("transform: animation paths move the placed object") {
  std::string text = kSmall;
  text.replace(text.find(R"("material": "m" })"), 0,
               R"("transform": { "scale": 2, "rotate": { "axis": [0, 1, 0], "degrees": 90 } }, )");
  text.replace(text.rfind("]\n}"), 3,
               R"(],
  "animation": { "frames": 3, "paths": [ { "target": "objects[0]", "type": "keyframes",
    "keys": [ { "frame": 0, "position": [5, 5, 5] }, { "frame": 2, "position": [7, 5, 5] } ] } ] }
})");
  auto file = twinray::io::parse_scene<double>(text, "a.json");
  auto at = [&](long long frame) {
    auto f = file;
    twinray::io::apply_frame(f, frame);
    return std::get<twinray::Mesh<double>>(f.scene.objects[0]).vertices;
  };
  // Placed: (0,0,0) (1,0,0) (0,1,0) (0,0,1) -> (0,0,0) (0,0,-2) (0,2,0) (2,0,0), box
  // center (1, 1, -1); the path puts that center on (5, 5, 5), then (6, 5, 5).
  auto v0 = at(0), v1 = at(1);
  CHECK(v0[0] == glm::dvec3(4, 4, 6));
  CHECK(v0[1] == glm::dvec3(4, 4, 4));
  CHECK(v0[3] == glm::dvec3(6, 4, 6));
  CHECK(v1[3] == glm::dvec3(7, 4, 6));
}

// Statements twinray does not read pass: material lines (parse_obj_mesh reads no
// materials), unnamed groups, smoothing groups, lines and points, skin weights.
TEST_CASE("OBJ: statements twinray does not read are passed over") {
  auto mesh = twinray::io::parse_obj_mesh<float>(
      "mtllib x.mtl\nusemtl red\ng\ns off\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvw 1 2.5e10 1\n"
      "l 1 2\np 3\nf 1 2 3\n",
      "m.obj");
  CHECK(mesh.triangles.size() == 1);
  CHECK(mesh.triangle_materials.empty());
}

TEST_CASE("mask: an object's ray-query mask, all ones where absent") {
  std::string text = with_object(
      R"({ "type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m", "mask": 6 },
         { "type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "material": "m", "mask": 0 },
         { "type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "material": "m",
           "mask": 4294967295 })");
  text.replace(text.find(R"("material": "m" })"), 17, R"("material": "m", "mask": 9 })");
  auto f = twinray::io::parse_scene<float>(text, "scene.json");
  REQUIRE(f.scene.objects.size() == 4);
  auto mask = [&](size_t i) {
    return std::visit([](const auto& o) { return o.mask; }, f.scene.objects[i]);
  };
  CHECK(mask(0) == 6u);
  CHECK(mask(1) == 0u);
  CHECK(mask(2) == 0xffffffffu);
  CHECK(mask(3) == 9u);  // the mesh
  auto plain = twinray::io::parse_scene<float>(kSmall, "scene.json");
  CHECK(std::get<twinray::Mesh<float>>(plain.scene.objects[0]).mask == 0xffffffffu);
  for (const char* bad : {"-1", "4294967296", "1.5", "\"7\"", "true"}) {
    CAPTURE(bad);
    std::string sphere = with_object(
        std::string(R"({ "type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m", )") +
        R"("mask": )" + bad + " }");
    CHECK(error_of([&] { twinray::io::parse_scene<float>(sphere, "scene.json"); }) ==
          std::string("scene.json: objects[0].mask: must be an integer in [0, 4294967295], got ") +
              bad);
  }
}
