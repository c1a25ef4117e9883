// Tests of the real `twinray` program (docs/command-line.md): exit statuses, malformed scene
// files, atomic outputs, the OpenCL backend missing, the progress bar, bit-exact images:
// demo.json against examples/demo.cpp, and CPU against OpenCL; and `bench --against`.
#include <doctest/doctest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <sched.h>
#include <signal.h>
#include <sys/wait.h>

#include <twinray/io/pfm.hpp>

#include "support/subprocess.hpp"

using test_support::contains;
using test_support::fresh_folder;
using test_support::listing;
using test_support::read_file;
using test_support::Result;
using test_support::run;
using test_support::write_file;

namespace {

const std::string kTwinray = TWINRAY_EXE;
const std::string kDemo = TWINRAY_DEMO_EXE;
const std::string kScenes = TWINRAY_SCENES_DIR;
const std::string kWork = TWINRAY_TEST_WORK_DIR;

Result run_twinray(std::vector<std::string> args, const std::string& cwd = "",
                   const std::vector<std::string>& env = {}) {
  args.insert(args.begin(), kTwinray);
  return run(args, cwd, env);
}

// A small valid scene using every key of docs/scene-format.md; the malformed files below
// are this with one mistake each.
const std::string kGoodScene = R"({
  "twinray": 1,
  "image": { "width": 8, "height": 6, "background": [0, 0, 0] },
  "camera": { "projection": "perspective", "position": [0, 0, 5], "look_at": [0, 0, 0],
              "up": [0, 1, 0], "focal_length": 5, "viewplane_height": 4 },
  "render": { "spp": 1, "max_depth": 2, "shadows": true, "glaze": true,
              "terms": ["ambient", "diffuse"] },
  "materials": {
    "red": { "color": [1, 0, 0], "ka": 0.1, "kd": 0.7, "ks": 0.2, "shininess": 10, "glaze": 0.1 },
    "clear": { "glaze": 0.2, "transmission": 0.5, "ior": 1.3, "absorption": [0.1, 0.2, 0.3] }
  },
  "lights": [ { "type": "point", "position": [2, 2, 2], "intensity": 5, "color": [1, 1, 1] } ],
  "objects": [
    { "type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "red" },
    { "type": "plane", "point": [0, -1, 0], "normal": [0, 1, 0], "material": "red" },
    { "type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "material": "red" },
    { "type": "mesh", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
      "triangles": [[0, 1, 2], [0, 1, 3]], "material": { "color": [0, 1, 0] } }
  ]
})";

const std::string kInlineMesh =
    R"({ "type": "mesh", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
      "triangles": [[0, 1, 2], [0, 1, 3]], "material": { "color": [0, 1, 0] } })";

// kGoodScene with `from` replaced by `to` (which must occur exactly once).
std::string edit(const std::string& from, const std::string& to) {
  size_t at = kGoodScene.find(from);
  REQUIRE_MESSAGE(at != std::string::npos, "not in the scene: " << from);
  REQUIRE_MESSAGE(kGoodScene.find(from, at + 1) == std::string::npos, "twice: " << from);
  std::string s = kGoodScene;
  s.replace(at, from.size(), to);
  return s;
}

struct BadScene {
  BadScene(std::string t, std::string m, std::string a = "")
      : text(std::move(t)), message(std::move(m)), also(std::move(a)) {}
  std::string text;
  std::string message;  // must appear right after "FILE: " in the error
  std::string also;     // and this anywhere in it
};

std::vector<BadScene> bad_scenes() {
  std::string deep = "[";
  for (int i = 0; i < 80; ++i) deep += "[";
  for (int i = 0; i < 81; ++i) deep += "]";
  return {
      // JSON itself
      {"", "invalid JSON at line 1, column 1"},
      {kGoodScene.substr(0, kGoodScene.size() - 20), "invalid JSON"},
      {edit(R"("material": "red" },
    { "type": "plane")",
            R"("material": "red" },,
    { "type": "plane")"),
       "invalid JSON at line 14"},
      {edit("[0, 0, 5]", "[0, NaN, 5]"), "invalid JSON at line 4",
       "(near camera.position[1]): syntax error"},
      {"[1, 2, 3]", "(top level): must be an object, got an array of 3"},
      {edit(R"("radius": 1,)", R"("radius": 1, "radius": 2,)"), "objects[0].radius: duplicate key"},
      {edit(R"("twinray": 1,)", R"("twinray": 1, "animation": { "path": )" + deep + "},"),
       "animation.path[0][0]", "]: nested deeper than 64 levels"},
      // the document
      {edit(R"("twinray": 1,)", ""), "twinray: missing (required)"},
      {edit(R"("twinray": 1,)", R"("twinray": 2,)"), "twinray: unsupported format version 2"},
      {edit(R"("twinray": 1,)", R"("twinray": 1, "lihgts": [],)"),
       "lihgts: unknown key (did you mean \"lights\"?)"},
      {edit(R"("twinray": 1,)", R"("twinray": 1, "animation": 5,)"),
       "animation: must be an object, got a number (5)"},
      // image
      {edit(R"("width": 8,)", R"("width": 0,)"),
       "image.width: must be an integer in [1, 65536], got 0"},
      {edit(R"("width": 8,)", R"("width": 8.5,)"), "image.width: must be an integer"},
      {edit(R"("width": 8,)", R"("width": "8",)"), "image.width: must be an integer"},
      {edit(R"("width": 8,)", R"("width": 99999999999999999999999,)"), "image.width: must be"},
      {edit(R"("width": 8, "height": 6,)", R"("width": 65536, "height": 65536,)"),
       "image: width x height must be at most"},
      {edit(R"("height": 6,)", ""), "image.height: missing (required)"},
      {edit(R"("background": [0, 0, 0])", R"("background": [0, 0])"),
       "image.background: must be an array of 3 numbers, got an array of 2"},
      {edit(R"("background": [0, 0, 0])", R"("background": [0, 2, 0])"),
       "image.background[1]: must be in [0, 1], got 2"},
      // glass
      {edit(R"("transmission": 0.5,)", R"("transmission": 1.5,)"),
       "materials.clear.transmission: must be in [0, 1], got 1.5"},
      {edit(R"("transmission": 0.5,)", R"("transmission": 0.9,)"),
       "materials.clear.transmission: glaze + transmission must be at most 1, got 0.2 + 0.9"},
      {edit(R"("ior": 1.3,)", R"("ior": 0,)"), "materials.clear.ior: must be > 0, got 0"},
      {edit(R"("absorption": [0.1, 0.2, 0.3])", R"("absorption": [0.1, -0.2, 0.3])"),
       "materials.clear.absorption[1]: must be >= 0, got -0.2"},
      // camera
      {edit(R"("projection": "perspective")", R"("projection": "fisheye")"),
       "camera.projection: must be \"perspective\", \"orthographic\", got \"fisheye\""},
      {edit(R"("up": [0, 1, 0])", R"("up": [0, 0, 2])"),
       "camera.up: must not be parallel to look_at - position"},
      {edit(R"("up": [0, 1, 0])", R"("up": [0, 0, 0])"), "camera.up: must be non-zero"},
      {edit(R"("look_at": [0, 0, 0])", R"("look_at": [0, 0, 5])"),
       "camera.look_at: must differ from camera.position"},
      {edit(R"("focal_length": 5)", R"("focal_length": -1)"),
       "camera.focal_length: must be > 0, got -1"},
      {edit(R"("focal_length": 5)", R"("fov": 60)"), "camera.fov: unknown key"},
      {edit(R"("position": [0, 0, 5])", R"("position": [0, 0, 1e999])"),
       "camera.position[2]: number out of range"},
      // render
      {edit(R"("spp": 1)", R"("spp": 0)"), "render.spp: must be an integer in [1, 65536], got 0"},
      {edit(R"("max_depth": 2)", R"("max_depth": -3)"), "render.max_depth: must be an integer"},
      {edit(R"("shadows": true)", R"("shadows": "yes")"),
       "render.shadows: must be true or false, got a string (\"yes\")"},
      {edit(R"(["ambient", "diffuse"])", R"(["ambient", "glossy"])"),
       "render.terms[1]: must be \"ambient\", \"diffuse\", \"specular\", got \"glossy\""},
      {edit(R"(["ambient", "diffuse"])", R"(["ambient", "ambient"])"),
       "render.terms[1]: \"ambient\" is listed twice"},
      // materials
      {edit(R"("kd": 0.7)", R"("kd": -0.5)"), "materials.red.kd: must be >= 0, got -0.5"},
      {edit(R"("glaze": 0.1)", R"("glaze": 1.5)"),
       "materials.red.glaze: must be in [0, 1], got 1.5"},
      {edit(R"("color": [1, 0, 0])", R"("color": [1, 0, 0, 0])"),
       "materials.red.color: must be an array of 3 numbers, got an array of 4"},
      {edit(R"("shininess": 10,)", R"("shininess": 10, "roughness": 0.5,)"),
       "materials.red.roughness: unknown key"},
      {edit(R"("materials": {)", R"("materials": { "blue": 3,)"),
       "materials.blue: must be an object, got a number (3)"},
      // lights
      {edit(R"("type": "point")", R"("type": "spot")"), "lights[0].type: must be \"point\""},
      {edit(R"("intensity": 5)", R"("intensity": -1)"),
       "lights[0].intensity: must be >= 0, got -1"},
      {edit(R"("position": [2, 2, 2], )", ""), "lights[0].position: missing (required)"},
      {edit(R"([ { "type": "point", "position": [2, 2, 2], "intensity": 5, "color": [1, 1, 1] } ])",
            R"({ "sun": 1 })"),
       "lights: must be an array, got an object"},
      // objects
      {edit(R"("type": "sphere")", R"("type": "cube")"), "objects[0].type: must be \"sphere\""},
      {edit(R"("radius": 1,)", R"("radius": -1,)"), "objects[0].radius: must be > 0, got -1"},
      {edit(R"("radius": 1,)", R"("radius": 1e39,)"), "objects[0].radius: 1e+39 overflows float"},
      {edit(R"("radius": 1,)", R"("radius": 1e-50,)"), "objects[0].radius: must be > 0"},
      {edit(R"("radius": 1, "material": "red")", R"("radius": 1, "material": "rde")"),
       "objects[0].material: no material named \"rde\" (did you mean \"red\"?)"},
      {edit(R"("radius": 1, "material": "red")", R"("radius": 1)"),
       "objects[0].material: missing (required)"},
      {edit(R"("radius": 1, "material": "red")",
            R"("radius": 1, "material": "red", "transform": { "scale": [1, 2, 1] })"),
       "objects[0].transform: a sphere takes only uniform scale, rotation and translation: this "
       "transform would make it an ellipsoid"},
      {edit(R"("normal": [0, 1, 0])", R"("normal": [0, 0, 0])"),
       "objects[1].normal: must be a non-zero vector"},
      {edit(R"("vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]])",
            R"("vertices": [[0, 0, 0], [1, 0, 0]])"),
       "objects[2].vertices: must be an array of 3 points, got an array of 2"},
      {edit(R"("vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]])",
            R"("vertices": [[0, 0, 0], ["1", 0, 0], [0, 1, 0]])"),
       "objects[2].vertices[1][0]: must be a number, got a string (\"1\")"},
      {edit("[[0, 1, 2], [0, 1, 3]]", "[[0, 1, 2], [0, 1, 7]]"),
       "objects[3].triangles[1][2]: vertex index 7 out of range: the mesh has 4 vertices"},
      {edit("[[0, 1, 2], [0, 1, 3]]", "[[-1, 1, 2], [0, 1, 3]]"),
       "objects[3].triangles[0][0]: must be an integer in [0, 3], got -1"},
      {edit("[[0, 1, 2], [0, 1, 3]]", "[[0, 1.5, 2], [0, 1, 3]]"),
       "objects[3].triangles[0][1]: must be an integer in [0, 3], got 1.5"},
      {edit("[[0, 1, 2], [0, 1, 3]]", "[[0, 1, 2], [0, 1]]"),
       "objects[3].triangles[1]: must be an array of 3 vertex indices"},
      {edit(R"("material": { "color": [0, 1, 0] })", R"("material": { "color": [0, 1.5, 0] })"),
       "objects[3].material.color[1]: must be in [0, 1], got 1.5"},
      {edit(kInlineMesh, R"({ "type": "mesh", "obj": "missing.obj", "material": "red" })"),
       "objects[3].obj: missing.obj: cannot open an OBJ file: No such file or directory"},
      {edit(kInlineMesh, R"({ "type": "mesh", "obj": "broken.obj", "material": "red" })"),
       "objects[3].obj: broken.obj:4: vertex index 9 is out of range: the file has 3"},
      {edit(kInlineMesh, R"({ "type": "mesh", "obj": "quad.obj", "material": "red" })"),
       "objects[3].obj: quad.obj:5: vertex index -5 is out of range: 4 before this line"},
      {edit(kInlineMesh, R"({ "type": "mesh", "obj": "nan.obj", "material": "red" })"),
       "objects[3].obj: nan.obj:2: vertex coordinate nan is not a finite number"},
      {edit(kInlineMesh, R"({ "type": "mesh", "obj": "cut.obj", "material": "red" })"),
       "objects[3].obj: cut.obj:5: a face needs at least 3 corners, got 2"},
      {edit(kInlineMesh, R"({ "type": "mesh", "obj": "binary.obj", "material": "red" })"),
       "objects[3].obj: binary.obj:1: byte 0x00: not a text file"},
      {edit(kInlineMesh, R"({ "type": "mesh", "obj": "empty.obj", "material": "red" })"),
       "objects[3].obj: empty.obj: no vertices"},
      {edit(kInlineMesh,
            R"({ "type": "mesh", "obj": "good.obj", "vertices": [], "material": "red" })"),
       "objects[3].vertices: a mesh takes either \"obj\" or \"vertices\""},
  };
}

// The files a scene of the table may name.
void write_aux_files(const std::string& dir) {
  write_file(dir + "/good.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 4 3\n");
  write_file(dir + "/broken.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
  write_file(dir + "/empty.obj", "# nothing here\n");
  write_file(dir + "/quad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf -1 -2 -3 -5\n");
  write_file(dir + "/nan.obj", "v 0 0 0\nv nan 1 0\nv 0 1 0\nf 1 2 3\n");
  write_file(dir + "/cut.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2");
  write_file(dir + "/binary.obj", std::string("ELF\0\x02\x01", 6));
}

}  // namespace

TEST_CASE("the good scene of the malformed-file table renders (status 0)") {
  std::string dir = fresh_folder(kWork, "good_scene");
  write_aux_files(dir);
  write_file(dir + "/good.json", kGoodScene);
  Result r = run_twinray({"render", "good.json", "-o", "out.png", "--backend", "cpu"}, dir);
  CHECK_MESSAGE(r.status == 0, r.err);
  CHECK(std::filesystem::file_size(dir + "/out.png") > 0);
  // And with the mesh from an .obj file.
  write_file(dir + "/obj.json",
             edit(kInlineMesh, R"({ "type": "mesh", "obj": "good.obj", "material": "red" })"));
  r = run_twinray({"render", "obj.json", "-o", "obj.pfm", "--backend", "cpu"}, dir);
  CHECK_MESSAGE(r.status == 0, r.err);
}

TEST_CASE("malformed scene files: status 2, the file and JSON path named, no output") {
  std::vector<BadScene> cases = bad_scenes();
  CHECK(cases.size() >= 30);
  for (size_t i = 0; i < cases.size(); ++i) {
    const BadScene& c = cases[i];
    std::string dir = fresh_folder(kWork, "bad_scene_" + std::to_string(i));
    write_aux_files(dir);
    std::string name = "bad_" + std::to_string(i) + ".json";
    write_file(dir + "/" + name, c.text);
    std::vector<std::string> before = listing(dir);
    CAPTURE(i);
    CAPTURE(c.message);

    // No earlier output: none is written.
    Result r = run_twinray({"render", name, "-o", "out.png", "--backend", "cpu"}, dir);
    CAPTURE(r.err);
    CHECK(r.status == 2);
    CHECK(contains(r.err, "twinray: " + name + ": " + c.message));
    CHECK(contains(r.err, c.also));
    CHECK(r.out.empty());
    CHECK(listing(dir) == before);  // no output, no temporary file

    // An earlier output stays as it was.
    write_file(dir + "/out.png", "an earlier, good image");
    r = run_twinray({"render", name, "-o", "out.png", "--backend", "cpu"}, dir);
    CHECK(r.status == 2);
    CHECK(read_file(dir + "/out.png") == "an earlier, good image");
  }
}

TEST_CASE("a scene file that is missing or a folder: status 2") {
  std::string dir = fresh_folder(kWork, "missing_scene");
  Result r = run_twinray({"render", "nothing.json", "-o", "out.png"}, dir);
  CHECK(r.status == 2);
  CHECK(contains(r.err, "nothing.json: cannot open a scene file: No such file or directory"));
  std::filesystem::create_directories(dir + "/folder.json");
  r = run_twinray({"render", "folder.json", "-o", "out.png"}, dir);
  CHECK(r.status == 2);
  CHECK(contains(r.err, "folder.json: is a folder"));
  CHECK(listing(dir) == std::vector<std::string>{"folder.json"});
}

TEST_CASE("status 0: render writes the image and prints one summary line") {
  std::string dir = fresh_folder(kWork, "status0");
  Result r = run_twinray({"render", "demo", "-o", "demo.png", "--backend", "cpu", "--width", "64",
                          "--height", "48", "--spp", "2"},
                         dir);
  REQUIRE_MESSAGE(r.status == 0, r.err);
  CHECK(listing(dir) == std::vector<std::string>{"demo.png"});  // no temporary left
  CHECK(read_file(dir + "/demo.png").substr(1, 3) == "PNG");
  // One line: output, size, spp, precision, backend, device, time.
  CHECK(std::count(r.out.begin(), r.out.end(), '\n') == 1);
  CHECK(contains(r.out, "demo.png: shaded, 64x48, 2 spp, float, backend cpu ("));
  for (const char* part : {"), load ", " ms, pack ", " ms, render ", " ms, total ", " MiB\n"})
    CHECK_MESSAGE(contains(r.out, part), part);
  // Not a terminal: no progress bar on stderr.
  CHECK(r.err.find('\r') == std::string::npos);

  for (const char* ext : {"pfm", "ppm"}) {
    std::string out = std::string("demo.") + ext;
    r = run_twinray({"render", "demo", "-o", out, "--backend", "cpu", "--width", "16", "--height",
                     "8", "--precision", "double"},
                    dir);
    CHECK_MESSAGE(r.status == 0, r.err);
    std::string bytes = read_file(dir + "/" + out);
    CHECK(bytes.substr(0, 9) == (std::string(ext) == "pfm" ? "PF\n16 8\n-" : "P6\n16 8\n2"));
  }
  twinray::Image<float> pfm = twinray::io::read_pfm(dir + "/demo.pfm");
  CHECK(pfm.width == 16);
  CHECK(pfm.height == 8);
}

TEST_CASE("status 0: --help, --version and info") {
  Result r = run_twinray({"--help"});
  CHECK(r.status == 0);
  CHECK(contains(r.out, "render"));
  CHECK(contains(r.out, "info"));
  r = run_twinray({"render", "--help"});
  CHECK(r.status == 0);
  for (const char* option : {"--backend", "--device", "--precision", "--width", "--height", "--spp",
                             "--max-depth", "--camera", "--no-shadows", "--no-glaze", "--terms",
                             "--frame", "--threads", "--aov", "--quiet"})
    CHECK_MESSAGE(contains(r.out, option), option);
  r = run_twinray({"--version"});
  CHECK(r.status == 0);
  CHECK(contains(r.out, "twinray 0."));
  r = run_twinray({"info"});
  CHECK(r.status == 0);
  CHECK(contains(r.out, "OpenCL"));
  CHECK(contains(r.out, "scene format:    version 1"));
}

TEST_CASE("status 1: writing the output fails at run time") {
  std::string dir = fresh_folder(kWork, "status1");
  std::filesystem::create_directories(dir + "/taken.png");  // a folder where the file goes
  Result r = run_twinray(
      {"render", "demo", "-o", "taken.png", "--backend", "cpu", "--width", "8", "--height", "8"},
      dir);
  CHECK(r.status == 1);
  CHECK(contains(r.err, "taken.png: cannot replace the file"));
  CHECK(std::filesystem::is_directory(dir + "/taken.png"));
  CHECK(listing(dir) == std::vector<std::string>{"taken.png"});  // no temporary left
}

TEST_CASE("status 2: bad command lines, refused before any work") {
  std::string dir = fresh_folder(kWork, "status2");
  struct Case {
    std::vector<std::string> args;
    std::string message;
  };
  std::vector<Case> cases = {
      {{}, "A subcommand is required"},
      {{"paint"}, "unknown subcommand \"paint\""},
      {{"render", "demo"}, "--output is required"},
      {{"render", "-o", "x.png"}, "SCENE is required"},
      {{"render", "demo", "-o", "x.png", "--bogus"}, "--bogus"},
      {{"render", "demo", "-o", "x.png", "--backend", "gpu"}, "--backend"},
      {{"render", "demo", "-o", "x.png", "--precision", "half"}, "--precision"},
      {{"render", "demo", "-o", "x.png", "--width", "0"}, "--width"},
      {{"render", "demo", "-o", "x.png", "--spp", "-2"}, "--spp"},
      {{"render", "demo", "-o", "x.png", "--max-depth", "abc"}, "--max-depth"},
      {{"render", "demo", "-o", "x.png", "--camera", "fisheye"}, "--camera"},
      {{"render", "demo", "-o", "x.png", "--terms", "ambient,glossy"}, "unknown term \"glossy\""},
      {{"render", "demo", "-o", "x.png", "--terms", "diffuse,diffuse"}, "given twice"},
      {{"render", "demo", "-o", "x.png", "--aov", "albedo"}, "--aov"},
      {{"render", "demo", "-o", "x.png", "--aov", "depth"}, "the output must be .pfm"},
      {{"render", "demo", "-o", "x.jpg"}, "unknown image format \".jpg\""},
      {{"render", "demo", "-o", "x"}, "unknown image format \"\""},
      {{"render", "demo", "-o", "no/such/folder/x.png"},
       "the folder no/such/folder does not exist"},
      {{"render", "demo", "-o", "x.png", "--frame", "3"}, "--frame 3: demo has no animation"},
      {{"render", "demo", "-o", "x.png", "--threads", "0"}, "--threads"},
      {{"render", "demo", "-o", "x.png", "--width", "65536", "--height", "65536"},
       "is more than the limit of"},
      {{"render", "demo", "-o", "x.png", "--max-triangles", "0"},
       "--max-triangles: must be a whole number from 1 to 2^63, got \"0\""},
      {{"render", "demo", "-o", "x.png", "--max-triangles", "2.5"}, "whole number"},
      {{"render", "demo", "-o", "x.png", "--max-triangles", "5M"},
       "--max-triangles: must be a whole number such as 50000000 or 5e7, got \"5M\""},
      {{"render", "demo", "-o", "x.png", "--max-triangles", "1e10"},
       "--max-triangles: at most 2147483647"},
      {{"render", "demo", "-o", "x.png", "--max-obj-size", "4X"},
       "--max-obj-size: must be a number of bytes, optionally with K, M, G or T, got \"4X\""},
      {{"render", "demo", "-o", "x.png", "--max-obj-size", "-1"}, "--max-obj-size"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args = c.args;
    Result r = run_twinray(args, dir);
    CAPTURE(c.message);
    CAPTURE(r.err);
    CHECK(r.status == 2);
    CHECK(contains(r.err, c.message));
    CHECK(listing(dir).empty());
  }
  // --frame outside the scene's animation: refused, and says why (tests/io/animation_test.cpp has
  // the frames that are in it).
  write_file(dir + "/anim.json",
             edit(R"("twinray": 1,)", R"("twinray": 1, "animation": { "frames": 10 },)"));
  Result r = run_twinray({"render", "anim.json", "-o", "x.png", "--frame", "10"}, dir);
  CHECK(r.status == 2);
  CHECK(contains(r.err, "frame 10 is not in the animation, which has 10 frames (0 to 9)"));
}

TEST_CASE("status 3: --backend opencl with no OpenCL platform says so") {
  std::string dir = fresh_folder(kWork, "status3");
  std::string vendors = fresh_folder(kWork, "status3_empty_vendors");
  std::vector<std::string> no_opencl = {"OCL_ICD_VENDORS=" + vendors};
  Result r = run_twinray({"render", "demo", "-o", "x.png", "--backend", "opencl"}, dir, no_opencl);
  CHECK(r.status == 3);
  CHECK(contains(r.err, "the requested backend is not available: no OpenCL device found"));
  CHECK(listing(dir).empty());
  // An earlier output stays.
  write_file(dir + "/x.png", "earlier");
  r = run_twinray({"render", "demo", "-o", "x.png", "--backend", "opencl"}, dir, no_opencl);
  CHECK(r.status == 3);
  CHECK(read_file(dir + "/x.png") == "earlier");
  // auto falls back to the CPU and says so.
  r = run_twinray({"render", "demo", "-o", "y.png", "--width", "8", "--height", "8"}, dir,
                  no_opencl);
  CHECK_MESSAGE(r.status == 0, r.err);
  CHECK(contains(r.err, "backend auto: using the CPU"));
  CHECK(contains(r.out, "backend cpu"));
  // info still works and says there is none.
  r = run_twinray({"info"}, dir, no_opencl);
  CHECK(r.status == 0);
  CHECK(contains(r.out, "OpenCL devices: none"));
}

TEST_CASE("a CPU-only run never loads an OpenCL platform") {
  // The ICD loader opens the libraries named in OCL_ICD_VENDORS when a program first asks
  // for the platforms; glibc's LD_DEBUG=files logs every library opened. A marker ICD
  // that no run may open shows whether a platform (PoCL and its LLVM, about 70 MiB) was
  // loaded.
  const std::string dir = fresh_folder(kWork, "cpu_only");
  const std::string vendors = fresh_folder(kWork, "cpu_only_vendors");
  write_file(vendors + "/marker.icd", "libtwinray_marker_icd.so\n");
  const std::vector<std::string> env = {"OCL_ICD_VENDORS=" + vendors, "LD_DEBUG=files"};
  const std::string marker = "libtwinray_marker_icd.so";
  // The probe works: `info` asks for the platforms, and the loader tries the marker.
  Result r = run_twinray({"info"}, dir, env);
  CHECK(r.status == 0);
  CHECK(contains(r.err, marker));
  r = run_twinray(
      {"render", "demo", "-o", "cpu.png", "--backend", "cpu", "--width", "16", "--height", "12"},
      dir, env);
  CHECK(r.status == 0);
  CHECK_FALSE(contains(r.err, marker));
  r = run_twinray(
      {"bench", "demo", "--backend", "cpu", "--runs", "1", "--width", "16", "--height", "12"}, dir,
      env);
  CHECK(r.status == 0);
  CHECK_FALSE(contains(r.err, marker));
}

TEST_CASE("status 3: an OpenCL device index that does not exist") {
  std::string dir = fresh_folder(kWork, "status3_device");
  Result r =
      run_twinray({"render", "demo", "-o", "x.png", "--backend", "opencl", "--device", "99"}, dir);
  CHECK(r.status == 3);
  CHECK(contains(r.err, "no OpenCL device with index 99"));
  CHECK(listing(dir).empty());
}

TEST_CASE(
    "without the background build, a new block program's first frame takes the pixel kernel") {
  // TWINRAY_OPENCL_BACKGROUND_BUILD=0: no helper process. On CPU devices the first
  // process that asks for a block program renders with the pixel kernel (its program
  // compiles in about half the time on PoCL) and notes the request in the cache
  // folder; the next builds the block program itself and leaves its marker. Same image.
  std::string dir = fresh_folder(kWork, "tiered_kernel");
  std::vector<std::string> env = {"TWINRAY_CACHE_DIR=" + dir + "/cache", "TWINRAY_OPENCL_KERNEL",
                                  "TWINRAY_OPENCL_FIRST_FRAME",
                                  "TWINRAY_OPENCL_BACKGROUND_BUILD=0"};
  Result cpu = run_twinray(
      {"render", "demo", "-o", "cpu.pfm", "--width", "64", "--height", "48", "--backend", "cpu"},
      dir, env);
  REQUIRE_MESSAGE(cpu.status == 0, cpu.err);
  std::vector<std::string> kernels, cache_files;
  for (const char* out : {"first.pfm", "second.pfm"}) {
    Result r = run_twinray(
        {"render", "demo", "-o", out, "--width", "64", "--height", "48", "--backend", "opencl"},
        dir, env);
    REQUIRE_MESSAGE(r.status == 0, r.err);
    const size_t at = r.out.find(", kernel ");
    REQUIRE(at != std::string::npos);
    kernels.push_back(r.out.substr(at + 9, r.out.find(',', at + 9) - at - 9));
    CHECK(read_file(dir + "/" + out) == read_file(dir + "/cpu.pfm"));
    std::string kinds;  // the kinds of file in the cache folder, by extension
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(dir + "/cache", ec))
      kinds += e.path().extension().string();
    cache_files.push_back(kinds);
  }
  Result info = run_twinray({"info"}, dir, env);
  const size_t type = info.out.find("type:");  // device [0]'s
  REQUIRE(type != std::string::npos);
  if (info.out.compare(info.out.find_first_not_of(' ', type + 5), 3, "CPU") == 0) {
    // A CPU device, such as PoCL's (GPUs keep the pixel kernel). No build lock: nothing
    // was built in the background; the marker comes with the second process's build.
    CHECK(kernels == std::vector<std::string>{"pixel", "blocks"});
    CHECK(cache_files[0] == ".asked");
    CHECK((cache_files[1] == ".asked.seen" || cache_files[1] == ".seen.asked"));
  } else {
    CHECK(kernels == std::vector<std::string>{"pixel", "pixel"});
  }
}

namespace {
// Every file under `dir`, as paths relative to it, sorted; temporaries left out.
std::vector<std::string> files_under(const std::string& dir) {
  std::vector<std::string> files;
  std::error_code ec;
  for (auto it = std::filesystem::recursive_directory_iterator(dir, ec);
       !ec && it != std::filesystem::recursive_directory_iterator(); it.increment(ec))
    if (it->is_regular_file() && it->path().string().find(".tmp") == std::string::npos)
      files.push_back(std::filesystem::relative(it->path(), dir).string());
  std::sort(files.begin(), files.end());
  return files;
}

// The kernel a `twinray render` summary line names.
std::string kernel_named(const std::string& out) {
  const size_t at = out.find(", kernel ");
  if (at == std::string::npos) return "";
  return out.substr(at + 9, out.find_first_of(",\n", at + 9) - at - 9);
}

// How many files of twinray's cache folder `cache` end in `extension`.
int count_files(const std::string& cache, const std::string& extension) {
  int n = 0;
  for (const std::string& f : files_under(cache))
    n += f.size() > extension.size() &&
         f.compare(f.size() - extension.size(), extension.size(), extension) == 0;
  return n;
}

// The process id the build lock in `cache` holds; 0 where there is none.
long lock_pid(const std::string& cache) {
  for (const std::string& f : files_under(cache))
    if (contains(f, ".lock")) {
      long pid = 0;
      std::istringstream(read_file(cache + "/" + f)) >> pid;
      return pid;
    }
  return 0;
}

// The running (not zombie) build helper processes whose TWINRAY_CACHE_DIR is `cache`.
std::vector<long> helpers_of(const std::string& cache) {
  std::vector<long> pids;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator("/proc", ec)) {
    const std::string name = e.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    const std::string stat = read_file(e.path().string() + "/stat");
    const size_t paren = stat.rfind(')');
    if (paren == std::string::npos || paren + 2 >= stat.size() || stat[paren + 2] == 'Z') continue;
    const std::string cmdline = read_file(e.path().string() + "/cmdline");
    const std::string environ = read_file(e.path().string() + "/environ");
    if (contains(cmdline, "--opencl-build-helper") &&
        contains(std::string(1, '\0') + environ,
                 std::string(1, '\0') + "TWINRAY_CACHE_DIR=" + cache + std::string(1, '\0')))
      pids.push_back(std::stol(name));
  }
  return pids;
}

// Waits, at most five minutes, until no build helper of `cache` runs; whether none does.
bool helpers_done(const std::string& cache) {
  const auto start = std::chrono::steady_clock::now();
  while (!helpers_of(cache).empty()) {
    if (std::chrono::steady_clock::now() - start > std::chrono::minutes(5)) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

// Whether `twinray info` names PoCL's own kernel cache (the block kernel is the CPU
// device's choice, and the block program is built in the background).
bool pocl_kernel_cache() {
  return contains(run_twinray({"info"}).out, "PoCL's own kernel cache holds the programs");
}

// The environment of the background-build tests: fresh caches in `dir`, the backend's
// own kernel choices.
std::vector<std::string> background_env(const std::string& dir) {
  return {"TWINRAY_CACHE_DIR=" + dir + "/twinray", "POCL_CACHE_DIR=" + dir + "/pocl",
          "TWINRAY_OPENCL_KERNEL", "TWINRAY_OPENCL_FIRST_FRAME", "TWINRAY_OPENCL_BACKGROUND_BUILD"};
}

std::vector<std::string> small_render(const std::string& out, const char* backend) {
  return {"render", "demo", "-o", out, "--backend", backend, "--width", "64", "--height", "48"};
}
}  // namespace

TEST_CASE(
    "the first OpenCL process leaves a detached build of the block program: processes during it "
    "take the pixel kernel, after it the block kernel, the same bits") {
  // On PoCL with its kernel cache: the first process renders with the pixel kernel and
  // returns while a detached helper process builds the block program into the caches
  // (the build lock holds its id). A process started meanwhile renders with the pixel
  // kernel and starts no second build. Once the helper is done (the marker written, the
  // lock gone), the next process finds everything it runs in PoCL's cache and adds
  // nothing to it. TWINRAY_TEST_BUILD_PAUSE_MS holds the helper between its build and
  // its marker, so the build is surely under way while the first two processes run.
  if (!pocl_kernel_cache()) return;
  const std::string dir = fresh_folder(kWork, "startup_caches");
  const std::string cache = dir + "/twinray";
  std::vector<std::string> env = background_env(dir);
  Result cpu = run_twinray(small_render("cpu.pfm", "cpu"), dir, env);
  REQUIRE_MESSAGE(cpu.status == 0, cpu.err);
  const std::string reference = read_file(dir + "/cpu.pfm");
  std::vector<std::string> paused = env;
  paused.push_back("TWINRAY_TEST_BUILD_PAUSE_MS=6000");

  Result first = run_twinray(small_render("first.pfm", "opencl"), dir, paused);
  REQUIRE_MESSAGE(first.status == 0, first.err);
  CHECK(kernel_named(first.out) == "pixel");
  CHECK(read_file(dir + "/first.pfm") == reference);
  // The first process did not wait for the build: its helper runs, and holds the lock.
  const std::vector<long> helper = helpers_of(cache);
  CHECK(helper.size() == 1);
  CHECK(helper == std::vector<long>{lock_pid(cache)});
  CHECK(count_files(cache, ".seen") == 0);
  // It builds at idle priority (once its parent has gone): no CPU a foreground process
  // wants goes to it.
  bool idle = false;
  for (int i = 0; i < 300 && !idle && !helper.empty(); ++i) {
    idle = sched_getscheduler(static_cast<pid_t>(helper[0])) == SCHED_IDLE;
    if (!idle) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  CHECK(idle);

  Result during = run_twinray(small_render("during.pfm", "opencl"), dir, paused);
  REQUIRE_MESSAGE(during.status == 0, during.err);
  CHECK(kernel_named(during.out) == "pixel");
  CHECK(read_file(dir + "/during.pfm") == reference);
  CHECK(helpers_of(cache) == helper);  // no second build
  CHECK(helper == std::vector<long>{lock_pid(cache)});

  REQUIRE(helpers_done(cache));
  CHECK(count_files(cache, ".seen") == 1);
  CHECK(count_files(cache, ".lock") == 0);
  // What PoCL compiled: the files of its program folders (its top folder holds only
  // temporaries of its own).
  auto compiled = [&] {
    std::vector<std::string> files;
    for (const std::string& f : files_under(dir + "/pocl"))
      if (contains(f, "/")) files.push_back(f);
    return files;
  };
  const std::vector<std::string> after_build = compiled();
  bool block_code = false;  // PoCL keeps a kernel's code in a folder named after it
  for (const std::string& f : after_build)
    block_code = block_code || contains(f, "/tr_kernel_render_blocks/");
  CHECK(block_code);
  Result after = run_twinray(small_render("after.pfm", "opencl"), dir, env);
  REQUIRE_MESSAGE(after.status == 0, after.err);
  CHECK(kernel_named(after.out) == "blocks");
  CHECK(read_file(dir + "/after.pfm") == reference);
  CHECK(compiled() == after_build);
  CHECK(helpers_of(cache).empty());
}

TEST_CASE("a killed build helper leaves no marker, and the next process renders and builds again") {
  // SIGKILL to the helper at two moments: at once, while it compiles, and in the pause
  // between its build and its marker (TWINRAY_TEST_BUILD_PAUSE_MS). Either way it leaves
  // no marker and a stale lock, which the next process ignores: it renders the CPU
  // backend's bits with the pixel kernel and starts the build again, after which a
  // process renders them with the block kernel.
  if (!pocl_kernel_cache()) return;
  const std::string dir = fresh_folder(kWork, "killed_helper");
  Result cpu = run_twinray(small_render("cpu.pfm", "cpu"), dir);
  REQUIRE_MESSAGE(cpu.status == 0, cpu.err);
  const std::string reference = read_file(dir + "/cpu.pfm");
  for (const char* moment : {"compiling", "before-marker"}) {
    CAPTURE(std::string(moment));
    const std::string sub = fresh_folder(dir, moment);
    const std::string cache = sub + "/twinray";
    std::vector<std::string> env = background_env(sub);
    std::vector<std::string> paused = env;
    paused.push_back("TWINRAY_TEST_BUILD_PAUSE_MS=60000");
    Result first = run_twinray(small_render("first.pfm", "opencl"), sub, paused);
    REQUIRE_MESSAGE(first.status == 0, first.err);
    CHECK(kernel_named(first.out) == "pixel");
    const long helper = lock_pid(cache);
    REQUIRE(helpers_of(cache) == std::vector<long>{helper});
    if (std::string(moment) == "before-marker") {
      // In the pause: PoCL holds the compiled program, the marker is not yet written.
      const auto start = std::chrono::steady_clock::now();
      auto compiled = [&] {
        for (const std::string& f : files_under(sub + "/pocl"))
          if (contains(f, "/tr_kernel_render_blocks/")) return true;
        return false;
      };
      while (!compiled() && std::chrono::steady_clock::now() - start < std::chrono::minutes(5))
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      CHECK(compiled());
    }
    ::kill(static_cast<pid_t>(helper), SIGKILL);
    const auto start = std::chrono::steady_clock::now();
    while (!helpers_of(cache).empty() &&
           std::chrono::steady_clock::now() - start < std::chrono::seconds(60))
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    REQUIRE(helpers_of(cache).empty());
    CHECK(count_files(cache, ".seen") == 0);
    CHECK(lock_pid(cache) == helper);  // the stale lock is left

    Result next = run_twinray(small_render("next.pfm", "opencl"), sub, env);
    REQUIRE_MESSAGE(next.status == 0, next.err);
    CHECK(kernel_named(next.out) == "pixel");
    CHECK(read_file(sub + "/next.pfm") == reference);
    // A new build replaced the stale lock, unless it already ended.
    CHECK((lock_pid(cache) != helper || count_files(cache, ".seen") == 1));
    REQUIRE(helpers_done(cache));
    CHECK(count_files(cache, ".seen") == 1);
    CHECK(count_files(cache, ".lock") == 0);
    Result later = run_twinray(small_render("later.pfm", "opencl"), sub, env);
    REQUIRE_MESSAGE(later.status == 0, later.err);
    CHECK(kernel_named(later.out) == "blocks");
    CHECK(read_file(sub + "/later.pfm") == reference);
  }
}

TEST_CASE(
    "an OpenCL process killed while it compiles leaves caches the next processes render from") {
  // SIGKILL to a first process with empty caches as soon as PoCL writes its first cache
  // file (programs are being built). A marker left in twinray's cache folder means its
  // program reached PoCL's cache. The next two processes render the CPU backend's bits.
  std::string dir = fresh_folder(kWork, "killed_build");
  Result cpu = run_twinray(small_render("cpu.pfm", "cpu"), dir);
  REQUIRE_MESSAGE(cpu.status == 0, cpu.err);
  const std::string reference = read_file(dir + "/cpu.pfm");
  const std::vector<std::string> env = background_env(dir);
  std::vector<std::string> argv = small_render("killed.pfm", "opencl");
  argv.insert(argv.begin(), kTwinray);
  test_support::RunOptions options;
  options.cwd = dir;
  options.env = env;
  test_support::Process p = test_support::Process::start(argv, options);
  const auto start = std::chrono::steady_clock::now();
  // Polls until PoCL's first file, or the process ends on its own (then it is collected).
  auto running = [&] {
    siginfo_t status{};
    return waitid(P_PID, static_cast<id_t>(p.pid()), &status, WEXITED | WNOHANG | WNOWAIT) == 0 &&
           status.si_pid == 0;
  };
  while (files_under(dir + "/pocl").empty() && running() &&
         std::chrono::steady_clock::now() - start < std::chrono::seconds(120))
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  ::kill(p.pid(), SIGKILL);
  p.finish();
  bool marker = false, block_code = false;
  for (const std::string& f : files_under(dir + "/twinray"))
    marker = marker || contains(f, ".seen");
  for (const std::string& f : files_under(dir + "/pocl"))
    block_code = block_code || contains(f, "/tr_kernel_render_blocks/");
  CHECK((!marker || block_code));
  for (const char* out : {"next.pfm", "later.pfm"}) {
    CAPTURE(std::string(out));
    Result r = run_twinray(small_render(out, "opencl"), dir, env);
    REQUIRE_MESSAGE(r.status == 0, r.err);
    CHECK(read_file(dir + "/" + out) == reference);
  }
  CHECK(helpers_done(dir + "/twinray"));
}

namespace {
// The bytes of `scene` rendered by the command into dir/out.pfm on one backend and
// precision; a failed render fails the test case.
std::string render_pfm(const std::string& dir, const std::string& scene, const char* backend,
                       const char* precision) {
  Result r = run_twinray(
      {"render", scene, "-o", "out.pfm", "--backend", backend, "--precision", precision}, dir);
  REQUIRE_MESSAGE(r.status == 0, r.err);
  return read_file(dir + "/out.pfm");
}
}  // namespace

TEST_CASE("demo.json renders the same bits as the built-in demo, on both backends") {
  std::string dir = fresh_folder(kWork, "demo_json");
  for (const char* precision : {"float", "double"}) {
    std::string reference;
    for (const char* backend : {"cpu", "opencl"})
      for (std::string scene : {std::string("demo"), kScenes + "/demo.json"}) {
        CAPTURE(scene);
        CAPTURE(std::string(backend));
        CAPTURE(std::string(precision));
        std::string bytes = render_pfm(dir, scene, backend, precision);
        CHECK(bytes.size() == 16 + 400 * 400 * 12);  // "PF\n400 400\n-1.0\n" + RGB floats
        if (reference.empty())
          reference = bytes;
        else
          CHECK(bytes == reference);
      }
  }
}

// The command's CPU backend is compiled for the build machine (-march=native); under clang
// its float vec3, and with AVX its double vec3, are native vectors (device/code.hpp), which
// the library's own test programs, built for generic x86-64, do not run. Here they walk a
// BVH over a mesh with every lane loop, against PoCL's kernel of the same text.
TEST_CASE("the BVH torus renders the same bits on both backends, float and double") {
  std::string dir = fresh_folder(kWork, "torus_both");
  for (const char* precision : {"float", "double"}) {
    std::string cpu_bytes;
    for (const char* backend : {"cpu", "opencl"}) {
      CAPTURE(std::string(backend));
      CAPTURE(std::string(precision));
      std::string bytes = render_pfm(dir, kScenes + "/torus.json", backend, precision);
      CHECK(bytes.size() == 16 + 480 * 360 * 12);  // "PF\n480 360\n-1.0\n" + RGB floats
      if (cpu_bytes.empty())
        cpu_bytes = bytes;
      else
        CHECK(bytes == cpu_bytes);
    }
  }
}

TEST_CASE("the seed's comparisons: examples/demo.cpp and the scene files give the same PNGs") {
  std::string dir = fresh_folder(kWork, "seed");
  for (const char* backend : {"cpu", "opencl"}) {
    std::string demo_dir = fresh_folder(kWork, std::string("seed_demo_") + backend);
    Result d = run({kDemo, "--backend", backend, demo_dir});
    REQUIRE_MESSAGE(d.status == 0, d.err);
    struct Variant {
      std::string name;
      std::string scene;
      std::vector<std::string> flags;  // the same variant from demo.json and flags
    };
    std::vector<Variant> variants = {
        {"demo", "demo.json", {}},
        {"ambient_only", "seed/ambient_only.json", {"--terms", "ambient"}},
        {"diffuse_only", "seed/diffuse_only.json", {"--terms", "diffuse"}},
        {"specular_only", "seed/specular_only.json", {"--terms", "specular"}},
        {"no_shadows", "seed/no_shadows.json", {"--no-shadows"}},
        {"no_glaze", "seed/no_glaze.json", {"--no-glaze"}},
        {"all_glazed", "seed/all_glazed.json", {}},
        {"orthographic", "seed/orthographic.json", {"--camera", "orthographic"}},
    };
    for (const Variant& v : variants) {
      CAPTURE(std::string(backend));
      CAPTURE(v.name);
      std::string expected = read_file(demo_dir + "/" + v.name + ".png");
      REQUIRE(!expected.empty());
      Result r = run_twinray(
          {"render", kScenes + "/" + v.scene, "-o", "file.png", "--backend", backend}, dir);
      REQUIRE_MESSAGE(r.status == 0, r.err);
      CHECK(read_file(dir + "/file.png") == expected);
      if (v.name == "all_glazed") continue;  // no flag glazes every material
      std::vector<std::string> args = {
          "render", kScenes + "/demo.json", "-o", "flags.png", "--backend", backend};
      args.insert(args.end(), v.flags.begin(), v.flags.end());
      r = run_twinray(args, dir);
      REQUIRE_MESSAGE(r.status == 0, r.err);
      CHECK(read_file(dir + "/flags.png") == expected);
    }
  }
}

TEST_CASE(
    "AOVs: depth, normal, shading normal, uv and object index, the same bits on both "
    "backends") {
  std::string dir = fresh_folder(kWork, "aov");
  for (const char* precision : {"float", "double"})
    for (std::string scene :
         {std::string("demo"), kScenes + "/torus.json", kScenes + "/models.json"})
      for (const char* aov : {"depth", "normal", "object", "shading-normal", "uv"}) {
        // The mesh attributes' AOVs on the scene that has them.
        bool attribute_aov = std::string(aov) == "shading-normal" || std::string(aov) == "uv";
        if (attribute_aov != (scene == kScenes + "/models.json")) continue;
        CAPTURE(std::string(precision));
        CAPTURE(scene);
        CAPTURE(std::string(aov));
        Result cpu = run_twinray({"render", scene, "-o", "cpu.pfm", "--aov", aov, "--backend",
                                  "cpu", "--precision", precision},
                                 dir);
        REQUIRE_MESSAGE(cpu.status == 0, cpu.err);
        CHECK(contains(cpu.out, std::string(aov) + " AOV"));
        Result cl = run_twinray({"render", scene, "-o", "cl.pfm", "--aov", aov, "--backend",
                                 "opencl", "--precision", precision},
                                dir);
        REQUIRE_MESSAGE(cl.status == 0, cl.err);
        CHECK(read_file(dir + "/cpu.pfm") == read_file(dir + "/cl.pfm"));

        // The values mean what docs/command-line.md says.
        twinray::Image<float> img = twinray::io::read_pfm(dir + "/cpu.pfm");
        if (std::string(aov) == "object") {
          std::set<float> seen;
          bool integral = true;
          for (float v : img.rgb) {
            seen.insert(v);
            integral = integral && v == std::floor(v) && v >= -1.0f;
          }
          CHECK(integral);
          CHECK(seen.count(-1.0f) == 1);  // the sky above the floor
          CHECK(seen.size() >= 4);
        } else if (std::string(aov) == "depth") {
          size_t finite = 0, bad = 0;
          for (float v : img.rgb) {
            bad += v > 0.0f || std::isinf(v) ? 0u : 1u;
            finite += std::isfinite(v) ? 1u : 0u;
          }
          CHECK(bad == 0);
          CHECK(finite > img.rgb.size() / 2);
        } else if (std::string(aov) == "uv") {
          // (u, v, 0): the textured torus's coordinates lie in [0, 1]; 0 elsewhere.
          size_t bad = 0, inside = 0;
          for (size_t p = 0; p < img.rgb.size(); p += 3) {
            float u = img.rgb[p], v = img.rgb[p + 1];
            bad += img.rgb[p + 2] == 0.0f && u >= 0.0f && u <= 1.0f && v >= 0.0f && v <= 1.0f ? 0u
                                                                                              : 1u;
            inside += u > 0.0f && v > 0.0f ? 1u : 0u;
          }
          CHECK(bad == 0);
          CHECK(inside > img.rgb.size() / 3 / 20);
        } else {
          size_t bad = 0, unit = 0;
          for (size_t p = 0; p < img.rgb.size(); p += 3) {
            float x = img.rgb[p], y = img.rgb[p + 1], z = img.rgb[p + 2];
            float len2 = x * x + y * y + z * z;
            bool is_unit = std::fabs(len2 - 1.0f) < 1e-4f;
            bad += len2 == 0.0f || is_unit ? 0u : 1u;
            unit += is_unit ? 1u : 0u;
          }
          CHECK(bad == 0);
          CHECK(unit > img.rgb.size() / 6);
        }
      }
}

TEST_CASE(
    "OBJ materials: a missing texture is a warning naming file and line, --strict makes it status "
    "2") {
  std::string dir = fresh_folder(kWork, "strict");
  write_file(dir + "/box.obj",
             "mtllib box.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n"
             "usemtl paint\nf 1/1 2/2 3/3\n");
  write_file(dir + "/box.mtl", "newmtl paint\nKd 1 1 1\nmap_Kd gone.png\n");
  std::string scene = kGoodScene;
  scene.replace(scene.find(kInlineMesh), kInlineMesh.size(),
                R"({ "type": "mesh", "obj": "box.obj" })");
  write_file(dir + "/scene.json", scene);
  auto has = [&](const std::string& name) {
    std::vector<std::string> files = listing(dir);
    return std::find(files.begin(), files.end(), name) != files.end();
  };
  const std::string path = dir + "/scene.json";
  Result warned = run_twinray({"render", path, "-o", "out.png", "--backend", "cpu"}, dir);
  REQUIRE_MESSAGE(warned.status == 0, warned.err);
  CHECK(contains(warned.err, "twinray: warning: " + dir + "/box.mtl:3: map_Kd gone.png: "));
  CHECK(contains(warned.err, "; material paint is not textured"));
  CHECK(has("out.png"));

  Result strict =
      run_twinray({"render", path, "-o", "strict.png", "--backend", "cpu", "--strict"}, dir);
  CHECK(strict.status == 2);
  CHECK(contains(strict.err, path + ": objects[3].obj: " + dir + "/box.mtl:3: map_Kd gone.png"));
  CHECK(contains(strict.err, "(--strict)"));
  CHECK_FALSE(has("strict.png"));
}

TEST_CASE("the progress bar: on a terminal only, and not with --quiet") {
  std::string dir = fresh_folder(kWork, "progress");
  // Long enough that the bar is drawn at least once (it is drawn when rendering starts).
  std::vector<std::string> args = {kTwinray, "render",  "demo", "-o",       "x.png", "--backend",
                                   "cpu",    "--width", "64",   "--height", "64"};
  Result tty = test_support::run_on_terminal(args, dir);
  CHECK(tty.status == 0);
  CHECK(contains(tty.out, "rendering 64x64 ["));
  CHECK(contains(tty.out, "\r\033[K"));
  CHECK(contains(tty.out, "x.png: shaded, 64x64"));

  args.push_back("--quiet");
  Result quiet = test_support::run_on_terminal(args, dir);
  CHECK(quiet.status == 0);
  CHECK(!contains(quiet.out, "rendering 64x64 ["));
  CHECK(contains(quiet.out, "x.png: shaded, 64x64"));
}

TEST_CASE("command-line options override the scene file") {
  std::string dir = fresh_folder(kWork, "overrides");
  write_file(dir + "/s.json", kGoodScene);
  Result r = run_twinray({"render", "s.json", "-o", "o.pfm", "--backend", "cpu", "--width", "20",
                          "--height", "10", "--spp", "3"},
                         dir);
  REQUIRE_MESSAGE(r.status == 0, r.err);
  CHECK(contains(r.out, "20x10, 3 spp"));
  twinray::Image<float> img = twinray::io::read_pfm(dir + "/o.pfm");
  CHECK(img.width == 20);
  CHECK(img.height == 10);
  // --threads, --max-depth, --no-shadows change nothing that a bad value would.
  r = run_twinray({"render", "s.json", "-o", "p.pfm", "--backend", "cpu", "--threads", "1",
                   "--max-depth", "1", "--no-shadows"},
                  dir);
  CHECK_MESSAGE(r.status == 0, r.err);
}

TEST_CASE("--max-triangles and --max-obj-size set the loader's limits") {
  std::string dir = fresh_folder(kWork, "limits");
  write_file(dir + "/s.json", kGoodScene);  // 3 triangles
  Result r = run_twinray(
      {"render", "s.json", "-o", "a.pfm", "--backend", "cpu", "--max-triangles", "2"}, dir);
  CHECK(r.status == 2);
  CHECK(contains(r.err,
                 "s.json: objects[3].triangles: the scene has more than 2 triangles in "
                 "all (the limit)"));
  CHECK(listing(dir) == std::vector<std::string>{"s.json"});
  r = run_twinray({"render", "s.json", "-o", "a.pfm", "--backend", "cpu", "--max-triangles", "3"},
                  dir);
  CHECK_MESSAGE(r.status == 0, r.err);

  // An OBJ file of 48 bytes: refused over 40 bytes, read under 1 KiB.
  write_file(dir + "/t.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n");
  write_file(dir + "/o.json", edit(kInlineMesh, R"({ "type": "mesh", "obj": "t.obj" })"));
  r = run_twinray({"render", "o.json", "-o", "b.pfm", "--backend", "cpu", "--max-obj-size", "40"},
                  dir);
  CHECK(r.status == 2);
  CHECK(contains(r.err, "t.obj: an OBJ file is 48 bytes, more than the limit of 40"));
  r = run_twinray({"render", "o.json", "-o", "b.pfm", "--backend", "cpu", "--max-obj-size", "1K"},
                  dir);
  CHECK_MESSAGE(r.status == 0, r.err);
  r = run_twinray({"render", "o.json", "-o", "c.pfm", "--backend", "cpu", "--max-triangles", "2",
                   "--max-obj-size", "1KiB"},
                  dir);
  CHECK(r.status == 2);
  // The file may add what the scene's earlier objects left: 2 - 1 triangles.
  CHECK(contains(r.err, "objects[3].obj: t.obj: 2 triangles, more than the limit of 1"));
}

namespace {

// A comparison program for `bench --against`: a script that records its arguments and
// prints, for the scene it is given, two rows in the CSV of bench/embree_bench.cpp (the slower
// one first), or fails as `mode` says.
std::string fake_comparator(const std::string& dir, const std::string& mode) {
  const std::string path = dir + "/compare_" + mode + ".sh";
  std::string row = ",float,192,108,1,8,0.1,%s,%s,%s,1000,1.00,10\"\n";
  auto line = [&](const char* backend, const char* ms) {
    char text[200];
    std::snprintf(text, sizeof text, row.c_str(), ms, ms, ms);
    return std::string("echo \"$2,") + backend + text;
  };
  std::string script = "#!/bin/sh\necho \"$@\" >> '" + dir + "/args.txt'\n";
  if (mode == "fails") script += "exit 4\n";
  script +=
      "echo scene,backend,precision,width,height,spp,primitives,build_ms,render_ms_min,"
      "render_ms_median,render_ms_max,rays,mrays_per_s,peak_mib\n";
  if (mode != "silent") script += line("fake-slow", "4.0") + line("fake-fast", "2.0");
  write_file(path, script);
  std::filesystem::permissions(path, std::filesystem::perms::owner_all);
  return path;
}

std::vector<std::string> csv_fields(const std::string& line) {
  std::vector<std::string> out(1);
  for (char c : line)
    if (c == ',')
      out.emplace_back();
    else
      out.back().push_back(c);
  return out;
}

}  // namespace

TEST_CASE("bench --against: interleaved rounds, and CPU over the comparator's fastest row") {
  const std::string dir = fresh_folder(kWork, "bench_against");
  const std::vector<std::string> size = {"--width", "192", "--height", "108", "--runs", "1"};
  auto bench = [&](std::vector<std::string> args) {
    args.insert(args.begin(), "bench");
    args.insert(args.end(), size.begin(), size.end());
    return run_twinray(args, dir);
  };
  Result r =
      bench({"demo", "--backend", "cpu", "--rounds", "2", "--against", fake_comparator(dir, "ok")});
  REQUIRE(r.status == 0);
  CHECK(contains(r.out, "scene,rays,twinray_cpu_ms,twinray_opencl_ms,comparator_ms,"));
  const std::string row = r.out.substr(r.out.find("\ndemo,") + 1);
  std::vector<std::string> f = csv_fields(row.substr(0, row.find('\n')));
  REQUIRE(f.size() == 13);
  CHECK(f[4] == "2.0");        // the fastest row
  CHECK(f[5] == "fake-fast");  // and its name
  CHECK(f[3].empty());         // OpenCL was not run
  CHECK(f[9].empty());
  const double cpu = std::stod(f[2]), ratio = std::stod(f[6]);
  CHECK(cpu > 0.0);
  // Two rounds: the median of cpu_i / 2 is the median of cpu_i over 2 (cpu printed to 0.1).
  CHECK(std::abs(ratio - cpu / 2.0) <= 0.05 / 2.0 + 0.001);
  CHECK(std::stod(f[7]) <= ratio);
  CHECK(std::stod(f[8]) >= ratio);
  CHECK(f[11] == "0.1");  // the comparator's build, from its fastest row
  // One call per round, with the scene and the frame's size.
  const std::string args = read_file(dir + "/args.txt");
  CHECK(std::count(args.begin(), args.end(), '\n') == 2);
  CHECK(contains(args, "--scenes demo --runs 1 --obj-dir . --width 192 --height 108"));
  // The order alternates: round 1 twinray, then the comparator; round 2 the other way.
  const size_t round2 = r.err.find("round 2 of 2");
  REQUIRE(round2 != std::string::npos);
  const std::string first = r.err.substr(0, round2), second = r.err.substr(round2);
  REQUIRE(contains(first, "twinray: demo,cpu,"));
  REQUIRE(contains(second, "twinray: demo,cpu,"));
  CHECK(first.find("twinray: demo,cpu,") < first.find("twinray: demo,fake-slow,"));
  CHECK(second.find("twinray: demo,fake-slow,") < second.find("twinray: demo,cpu,"));

  // A comparator that fails, or prints no row for the scene: status 1, named.
  r = bench(
      {"demo", "--backend", "cpu", "--rounds", "1", "--against", fake_comparator(dir, "fails")});
  CHECK(r.status == 1);
  CHECK(contains(r.err, "compare_fails.sh (for demo) failed"));
  r = bench(
      {"demo", "--backend", "cpu", "--rounds", "1", "--against", fake_comparator(dir, "silent")});
  CHECK(r.status == 1);
  CHECK(contains(r.err, "printed no CSV row for the scene"));
  // Refused before any work: status 2.
  CHECK(bench({"demo", "--precision", "double", "--against", fake_comparator(dir, "ok")}).status ==
        2);
  CHECK(bench({"demo", "--plot", "p.png"}).status == 2);
  CHECK(bench({"demo", "--markdown"}).status == 2);

  // --markdown: the same figures as a table, under a caption that names the machine,
  // the compiler and the command that repeats the run.
  r = bench({"demo", "--backend", "cpu", "--rounds", "1", "--against", fake_comparator(dir, "ok"),
             "--markdown"});
  REQUIRE(r.status == 0);
  CHECK(!contains(r.out, "scene,rays,"));
  CHECK(contains(r.out, "Measured "));
  CHECK(contains(r.out, " hardware threads"));
  CHECK(contains(r.out, "twinray built by "));
  CHECK(contains(r.out, "192x108, 1 spp"));
  CHECK(contains(r.out, "Command: `twinray bench demo --against "));
  CHECK(contains(r.out, "--rounds 1 --runs 1 --backend cpu --width 192 --height 108 --markdown`"));
  CHECK(contains(r.out, "| scene | rays per frame | twinray CPU ms |"));
  const std::string md_row = r.out.substr(r.out.find("\n| demo |") + 1);
  CHECK(contains(md_row.substr(0, md_row.find('\n')), "| 2.0 (fake-fast) |"));

  // A scene with a BVH, one round: the build columns, and the cost-per-ray plot where
  // gnuplot is installed (scripts/packages.txt has it).
  const bool gnuplot = run({"sh", "-c", "command -v gnuplot"}).status == 0;
  std::vector<std::string> mesh_args = {
      "mesh_1e3", "--backend", "cpu", "--rounds", "1", "--against", fake_comparator(dir, "ok")};
  if (gnuplot) mesh_args.insert(mesh_args.end(), {"--plot", "cost.png"});
  r = bench(mesh_args);
  REQUIRE(r.status == 0);
  const std::string mesh_row = r.out.substr(r.out.find("\nmesh_1e3,") + 1);
  std::vector<std::string> g = csv_fields(mesh_row.substr(0, mesh_row.find('\n')));
  REQUIRE(g.size() == 13);
  // The CPU line's build over the comparator's 0.1 ms (the build printed to 0.1 ms).
  const double build = std::stod(g[10]), build_ratio = std::stod(g[12]);
  CHECK(build > 0.0);
  CHECK(g[11] == "0.1");
  CHECK(std::abs(build_ratio - build / 0.1) <= 0.05 / 0.1 + 0.001);
  if (!gnuplot) {
    MESSAGE("skipped the plot: no gnuplot");
    return;
  }
  CHECK(read_file(dir + "/cost.png").rfind("\x89PNG", 0) == 0);
  CHECK(!std::filesystem::exists(dir + "/cost.png.tmp"));
}

TEST_CASE("bench --interleave: the backends' timed frames alternate, frame by frame") {
  const std::string dir = fresh_folder(kWork, "bench_interleave");
  const std::vector<std::string> args = {"bench", "demo",    "--backend", "all",      "--runs",
                                         "3",     "--width", "32",        "--height", "24"};
  std::vector<std::string> interleaved = args;
  interleaved.push_back("--interleave");
  Result r = run_twinray(interleaved, dir);
  REQUIRE_MESSAGE(r.status == 0, r.err);
  // Each step's frames in the order they ran: cpu then opencl, then the other way.
  std::map<std::string, std::vector<double>> times;
  std::vector<std::string> order;
  const std::regex step(R"(demo float: step (\d+): (\w+) ([0-9.]+) ms (\w+) ([0-9.]+) ms)");
  for (std::sregex_iterator it(r.err.begin(), r.err.end(), step), end; it != end; ++it) {
    const std::smatch& m = *it;
    CHECK(std::stoi(m[1]) == static_cast<int>(order.size()) / 2 + 1);
    for (int k : {2, 4}) {
      order.push_back(m[k]);
      times[m[k]].push_back(std::stod(m[k + 1]));
    }
  }
  CHECK(order == std::vector<std::string>{"cpu", "opencl", "opencl", "cpu", "cpu", "opencl"});
  CHECK(contains(r.err, "demo float: opencl / cpu per step: median "));
  // The backends pack alike (BVH8): they render from one packed scene (one BVH note).
  const std::string bvh_note = "demo float: BVH8 ";
  CHECK(r.err.find(bvh_note) != std::string::npos);
  CHECK(r.err.find(bvh_note) == r.err.rfind(bvh_note));
  // Both rows, each with the median of its own frames (printed to 0.1 ms).
  for (const char* backend : {"cpu", "opencl"}) {
    CAPTURE(std::string(backend));
    const size_t at = r.out.find(std::string("\ndemo,") + backend + ",");
    REQUIRE(at != std::string::npos);
    std::vector<std::string> f =
        csv_fields(r.out.substr(at + 1, r.out.find('\n', at + 1) - at - 1));
    REQUIRE(f.size() == 14);
    std::vector<double> t = times[backend];
    REQUIRE(t.size() == 3);
    std::sort(t.begin(), t.end());
    CHECK(std::abs(std::stod(f[9]) - t[1]) <= 0.051);
    CHECK(std::abs(std::stod(f[8]) - t[0]) <= 0.051);
  }
  // Without the flag the backends run one after the other: no steps.
  r = run_twinray(args, dir);
  REQUIRE_MESSAGE(r.status == 0, r.err);
  CHECK_FALSE(contains(r.err, "step 1:"));
  CHECK(contains(r.out, "\ndemo,cpu,"));
  CHECK(contains(r.out, "\ndemo,opencl,"));

  // With --against, each round interleaves, and opencl_over_cpu is the median over the
  // rounds of each round's median per step (one round here: that round's).
  std::vector<std::string> against = interleaved;
  against.insert(against.end(), {"--rounds", "1", "--against", fake_comparator(dir, "ok")});
  r = run_twinray(against, dir);
  REQUIRE_MESSAGE(r.status == 0, r.err);
  const std::regex per_step(R"(demo float: opencl / cpu per step: median ([0-9.]+) )");
  std::smatch m;
  REQUIRE(std::regex_search(r.err, m, per_step));
  const std::string row = r.out.substr(r.out.find("\ndemo,") + 1);
  std::vector<std::string> f = csv_fields(row.substr(0, row.find('\n')));
  REQUIRE(f.size() == 13);
  CHECK(f[9] == m[1].str());
}
