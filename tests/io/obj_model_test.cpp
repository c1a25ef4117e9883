// OBJ models with their normals, texture coordinates, MTL materials and textures
// (io/obj_mesh.hpp, io/obj_model.hpp), and the scene-file keys that use them
// (`normals`, `crease_angle`, a mesh without `material`): what is read, how MTL maps to
// twinray's material, and the warnings (or, strict, errors) for missing pieces, each
// naming file and line. Also the public-domain spot model, from TWINRAY_TEST_MODELS_DIR
// when that folder holds it.
#include <doctest/doctest.h>

#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <stb_image_write.h>

#include <twinray/io/obj_model.hpp>
#include <twinray/io/scene_json.hpp>

#include "support/refusal.hpp"

using namespace twinray;
using test_support::refusal;
using test_support::TempDir;

namespace {

void write(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// A 2 x 1 PNG: a red texel, then a white one.
void write_png(const std::string& path) {
  const unsigned char rgb[] = {255, 0, 0, 255, 255, 255};
  REQUIRE(stbi_write_png(path.c_str(), 2, 1, 3, rgb, 6) != 0);
}

// Two quads (four triangles) in two `usemtl` groups, with uvs and normals on the first.
const char* kObj =
    "mtllib look.mtl\n"                                       // line 1
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\n"  // 2-7
    "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"                        // 8-11
    "vn 0 0 1\nvn 0 0 2\n"                                    // 12-13
    "usemtl red\n"                                            // 14
    "f 1/1/1 2/2/2 3/3/1 4/4/1\n"                             // 15
    "usemtl shiny\n"                                          // 16
    "f 2 5 6 3\n";                                            // 17

const char* kMtl =
    "newmtl red\n"  // 1
    "Ka 0.1 0.2 0.3\nKd 1 0.5 0\nKs 0 0 0\nNs 12\nillum 2\n"
    "map_Kd red.png\n"  // 7
    "newmtl shiny\n"    // 8
    "Kd 0.2 0.2 0.2\nKs 0.6 0.6 0.9\nNs 200\nillum 3\nd 0.3\nNi 1.33\n";

}  // namespace

TEST_CASE_TEMPLATE("OBJ: vertex normals and texture coordinates are read per corner", T, float,
                   double) {
  Mesh<T> m = io::parse_obj_mesh<T>(kObj, "look.obj");
  REQUIRE(m.triangles.size() == 4);
  REQUIRE(m.normals.size() == 2);
  CHECK(m.normals[1] == glm::vec<3, T>(0, 0, 1));  // `vn 0 0 2`, normalized
  REQUIRE(m.normal_triangles.size() == 4);
  CHECK(m.normal_triangles[0] == std::array<int, 3>{0, 1, 0});
  CHECK(m.normal_triangles[2] == std::array<int, 3>{-1, -1, -1});  // no vn: flat
  REQUIRE(m.uv_triangles.size() == 4);
  CHECK(m.uvs[m.uv_triangles[0][1]] == glm::vec<2, T>(1, 0));
  CHECK(m.uv_triangles[3] == std::array<int, 3>{-1, -1, -1});
  CHECK(m.triangle_materials.empty());  // parse_obj_mesh reads no materials

  // A zero normal leaves its triangle flat; a file without vn or vt has neither.
  Mesh<T> zero =
      io::parse_obj_mesh<T>("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 0\nf 1//1 2//1 3//1\n", "z.obj");
  CHECK(zero.normals.empty());
  CHECK(zero.normal_triangles.empty());
  Mesh<T> bare = io::parse_obj_mesh<T>("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "b.obj");
  CHECK(bare.normals.empty());
  CHECK(bare.uvs.empty());
}

TEST_CASE_TEMPLATE("MTL: materials map onto Blinn-Phong, per usemtl group, with textures", T, float,
                   double) {
  TempDir temp("twinray-obj-model-test");
  const std::string dir = temp.str();
  write(dir + "/look.obj", kObj);
  write(dir + "/look.mtl", kMtl);
  write_png(dir + "/red.png");
  io::ObjModel<T> model = io::load_obj_model<T>(dir + "/look.obj");
  CHECK(model.warnings.empty());
  REQUIRE(model.materials.size() == 2);
  CHECK(model.material_names == std::vector<std::string>{"red", "shiny"});
  const Material<T>& red = model.materials[0];
  CHECK(red.color == glm::vec<3, T>(T(1), T(0.5), T(0)));
  CHECK(red.kd == T(1));
  CHECK(red.ka == T((0.1 + 0.2 + 0.3) / 3));
  CHECK(red.ks == T(0));
  CHECK(red.shininess == T(12));
  CHECK(red.glaze == T(0));
  REQUIRE(red.texture == 0);
  const Material<T>& shiny = model.materials[1];
  CHECK(shiny.ks == T((0.6 + 0.6 + 0.9) / 3));
  CHECK(shiny.glaze == shiny.ks);  // illum 3 with a non-zero Ks
  // d 0.3: transmission 0.7, cut to 1 - glaze; Ni: the index.
  CHECK(shiny.transmission == T(1) - shiny.glaze);
  CHECK(shiny.ior == T(1.33));
  CHECK(red.transmission == T(0));
  CHECK(red.ior == T(1.5));
  CHECK(shiny.texture == -1);
  REQUIRE(model.textures.size() == 1);
  CHECK(model.textures[0].width == 2);
  CHECK(model.textures[0].texels[0] == T(1));  // red, linear
  CHECK(model.textures[0].texels[1] == T(0));
  CHECK(model.mesh.triangle_materials == std::vector<int>{0, 0, 1, 1});
}

TEST_CASE("MTL: missing pieces are warnings naming file and line, strict makes them errors") {
  TempDir temp("twinray-obj-model-test");
  const std::string dir = temp.str();
  write(dir + "/look.obj", kObj);
  // No look.mtl at all: both groups take the default material.
  io::ObjModel<float> no_library = io::load_obj_model<float>(dir + "/look.obj");
  REQUIRE(no_library.warnings.size() == 3);
  CHECK(no_library.warnings[0].rfind(
            dir + "/look.obj:1: mtllib look.mtl: " + dir + "/look.mtl: cannot open an MTL file",
            0) == 0);
  CHECK(no_library.warnings[1] == dir +
                                      "/look.obj:14: usemtl red: no material of that name in "
                                      "look.mtl; the default material is used");
  CHECK(no_library.mesh.triangle_materials == std::vector<int>{-1, -1, -1, -1});
  io::ObjModelOptions strict;
  strict.strict = true;
  std::string error = refusal([&] { io::load_obj_model<float>(dir + "/look.obj", strict); });
  CHECK(error.rfind(dir + "/look.obj:1: mtllib look.mtl: ", 0) == 0);
  CHECK(error.find("(--strict)") != std::string::npos);

  // The library is there, its texture is not; and one group names no material.
  write(dir + "/look.mtl", kMtl);
  std::string obj = kObj;
  obj.replace(obj.find("usemtl shiny"), 12, "usemtl gold");
  write(dir + "/look.obj", obj);
  io::ObjModel<float> partial = io::load_obj_model<float>(dir + "/look.obj");
  REQUIRE(partial.warnings.size() == 2);
  CHECK(partial.warnings[0] == dir +
                                   "/look.obj:16: usemtl gold: no material of that name in "
                                   "look.mtl; the default material is used");
  CHECK(partial.warnings[1].rfind(
            dir + "/look.mtl:7: map_Kd red.png: " + dir + "/red.png: cannot open an image file",
            0) == 0);
  CHECK(partial.warnings[1].find("; material red is not textured") != std::string::npos);
  CHECK(partial.materials[0].texture == -1);
  CHECK(partial.mesh.triangle_materials == std::vector<int>{0, 0, -1, -1});

  // An image that is not one: the same warning, with the decoder's reason.
  write(dir + "/red.png", "not a png");
  io::ObjModel<float> broken = io::load_obj_model<float>(dir + "/look.obj");
  REQUIRE(broken.warnings.size() == 2);
  CHECK(broken.warnings[1].find("not a PNG or JPEG image") != std::string::npos);
}

TEST_CASE("scene files: OBJ materials, the material override, normals and crease_angle") {
  TempDir temp("twinray-obj-model-test");
  const std::string dir = temp.str();
  write(dir + "/look.obj", kObj);
  write(dir + "/look.mtl", kMtl);
  write_png(dir + "/red.png");
  auto scene_with = [&](const std::string& mesh_keys) {
    std::string text = R"({ "twinray": 1, "image": { "width": 4, "height": 3 },
      "camera": { "projection": "perspective", "position": [0, 0, 5], "look_at": [0, 0, 0],
                  "up": [0, 1, 0] },
      "materials": { "m": {} },
      "objects": [ { "type": "mesh", "obj": "look.obj")" +
                       mesh_keys + " } ] }";
    write(dir + "/scene.json", text);
    return dir + "/scene.json";
  };
  // No `material`: the file's materials, named FILE:NAME, and its texture.
  io::SceneFile<float> f = io::load_scene<float>(scene_with(""));
  CHECK(f.warnings.empty());
  REQUIRE(f.scene.materials.size() == 3);
  CHECK(f.material_names[1] == "look.obj:red");
  CHECK(f.material_names[2] == "look.obj:shiny");
  REQUIRE(f.scene.textures.size() == 1);
  CHECK(f.scene.materials[1].texture == 0);
  const auto& mesh = std::get<Mesh<float>>(f.scene.objects[0]);
  CHECK(mesh.triangle_materials == std::vector<int>{1, 1, 2, 2});
  CHECK(mesh.normals.size() == 2);  // "normals": "file" by default

  // `material` overrides them all.
  io::SceneFile<float> over = io::load_scene<float>(scene_with(R"(, "material": "m")"));
  const auto& plain = std::get<Mesh<float>>(over.scene.objects[0]);
  CHECK(plain.triangle_materials.empty());
  CHECK(plain.material == 0);

  // flat drops the file's normals; smooth computes them (one per corner group).
  io::SceneFile<float> flat = io::load_scene<float>(scene_with(R"(, "normals": "flat")"));
  CHECK(std::get<Mesh<float>>(flat.scene.objects[0]).normal_triangles.empty());
  io::SceneFile<float> smooth =
      io::load_scene<float>(scene_with(R"(, "normals": "smooth", "crease_angle": 30)"));
  const auto& s = std::get<Mesh<float>>(smooth.scene.objects[0]);
  REQUIRE(s.normal_triangles.size() == 4);
  CHECK(s.normals[s.normal_triangles[0][0]] == glm::vec3(0, 0, 1));  // a flat model: +z

  // What is refused, by file and JSON path.
  std::string path = dir + "/scene.json";
  CHECK(refusal([&] { io::load_scene<float>(scene_with(R"(, "crease_angle": 30)")); }) ==
        path +
            ": objects[0].crease_angle: applies to \"normals\": \"smooth\" only (normals are "
            "\"file\")");
  CHECK(refusal([&] {
          io::load_scene<float>(scene_with(R"(, "normals": "smooth", "crease_angle": 200)"));
        }) == path + ": objects[0].crease_angle: must be in [0, 180] degrees, got 200");
  CHECK(refusal([&] {
          io::load_scene<float>(scene_with(R"(, "normals": "round")"));
        }).rfind(path + ": objects[0].normals: ", 0) == 0);

  // Warnings reach the SceneFile; limits.strict makes them errors with exit status 2.
  std::remove((dir + "/red.png").c_str());
  io::SceneFile<float> warned = io::load_scene<float>(scene_with(""));
  REQUIRE(warned.warnings.size() == 1);
  CHECK(warned.warnings[0].rfind(dir + "/look.mtl:7: map_Kd red.png: ", 0) == 0);
  io::SceneLimits strict;
  strict.strict = true;
  CHECK(refusal([&] {
          io::load_scene<float>(scene_with(""), strict);
        }).rfind(path + ": objects[0].obj: " + dir + "/look.mtl:7: map_Kd red.png: ", 0) == 0);
  // With `material`, the file's materials are not read, so what they lack is no warning.
  io::SceneFile<float> overridden =
      io::load_scene<float>(scene_with(R"(, "material": "m")"), strict);
  CHECK(overridden.warnings.empty());
  CHECK(overridden.scene.textures.empty());
}

TEST_CASE("scene files: an OBJ file named by several objects and assets is read once") {
  TempDir temp("twinray-obj-once-test");
  const std::string dir = temp.str();
  write(dir + "/look.obj", kObj);
  write(dir + "/look.mtl", kMtl);  // red.png is missing: one warning per read of the file
  write(dir + "/scene.json", R"({ "twinray": 1, "image": { "width": 4, "height": 3 },
      "camera": { "projection": "perspective", "position": [0, 0, 5], "look_at": [0, 0, 0],
                  "up": [0, 1, 0] },
      "materials": { "m": {} },
      "assets": { "a": [ { "type": "mesh", "obj": "look.obj" },
                         { "type": "mesh", "obj": "look.obj", "material": "m" } ] },
      "objects": [
        { "type": "mesh", "obj": "look.obj" },
        { "type": "mesh", "obj": "./look.obj", "transform": { "translate": [5, 0, 0] } },
        { "type": "mesh", "obj": "look.obj", "material": "m", "normals": "flat" },
        { "type": "instance", "asset": "a" } ] })");
  io::SceneFile<float> f = io::load_scene<float>(dir + "/scene.json");
  // One read with materials: its warning once, its two materials, the default one (m)
  // and its texture (none: red.png is missing) added once.
  CHECK(f.warnings.size() == 1);
  CHECK(f.scene.materials.size() == 3);
  CHECK(f.material_names == std::vector<std::string>{"m", "look.obj:red", "look.obj:shiny"});
  write(dir + "/single.json", R"({ "twinray": 1, "image": { "width": 4, "height": 3 },
      "camera": { "projection": "perspective", "position": [0, 0, 5], "look_at": [0, 0, 0],
                  "up": [0, 1, 0] },
      "objects": [ { "type": "mesh", "obj": "look.obj" } ] })");
  io::SceneFile<float> one = io::load_scene<float>(dir + "/single.json");
  const auto& alone = std::get<Mesh<float>>(one.scene.objects[0]);
  REQUIRE(f.scene.objects.size() == 4);
  const auto& first = std::get<Mesh<float>>(f.scene.objects[0]);
  const auto& moved = std::get<Mesh<float>>(f.scene.objects[1]);
  const auto& flat = std::get<Mesh<float>>(f.scene.objects[2]);
  // Each object is the mesh read alone, then placed and shaded as its own keys say.
  // Materials by name: "m" comes first in the scene, so the indices are one higher.
  auto names = [](const io::SceneFile<float>& file, const Mesh<float>& mesh) {
    std::vector<std::string> out;
    for (int m : mesh.triangle_materials) out.push_back(file.material_names.at(size_t(m)));
    return out;
  };
  const std::vector<std::string> materials = names(one, alone);
  CHECK(materials == std::vector<std::string>{"look.obj:red", "look.obj:red", "look.obj:shiny",
                                              "look.obj:shiny"});
  CHECK(first.vertices == alone.vertices);
  CHECK(first.triangles == alone.triangles);
  CHECK(names(f, first) == materials);
  CHECK(first.normals == alone.normals);
  CHECK(names(f, moved) == materials);
  CHECK(moved.vertices[0] == alone.vertices[0] + glm::vec3(5, 0, 0));
  CHECK(flat.triangles == alone.triangles);
  CHECK(flat.triangle_materials.empty());
  CHECK(flat.material == 0);
  CHECK(flat.normal_triangles.empty());
  REQUIRE(f.scene.assets.size() == 1);
  REQUIRE(f.scene.assets[0].objects.size() == 2);
  const auto& in_asset = std::get<Mesh<float>>(f.scene.assets[0].objects[0]);
  const auto& in_asset_m = std::get<Mesh<float>>(f.scene.assets[0].objects[1]);
  CHECK(in_asset.vertices == alone.vertices);
  CHECK(names(f, in_asset) == materials);
  CHECK(in_asset.normals == alone.normals);
  CHECK(in_asset_m.material == 0);
  CHECK(in_asset_m.normals == alone.normals);  // "file" normals: flat was another object's
  // Every copy counts towards the scene's triangles.
  io::SceneLimits limits;
  limits.max_total_triangles = 4 * 5 - 1;
  CHECK(refusal([&] { io::load_scene<float>(dir + "/scene.json", limits); }) ==
        dir +
            "/scene.json: objects[2].obj: the scene has more than 19 triangles in all (the "
            "limit)");
}

// The public-domain spot model (Keenan Crane, CC0), when TWINRAY_TEST_MODELS_DIR holds it.
TEST_CASE("spot: loads with its material, texture and uvs, and smooth normals are computed") {
  const std::string dir = TWINRAY_TEST_MODELS_DIR;
  if (!std::ifstream(dir + "/spot.obj")) {
    MESSAGE("skipped: " << dir << "/spot.obj is not there");
    return;
  }
  io::ObjModel<float> spot = io::load_obj_model<float>(dir + "/spot.obj");
  CHECK(spot.warnings.empty());
  CHECK(spot.mesh.triangles.size() == 5856);
  CHECK(spot.mesh.vertices.size() == 2930);
  CHECK(spot.mesh.uvs.size() == 3225);
  CHECK(spot.mesh.uv_triangles.size() == 5856);
  for (const auto& k : spot.mesh.uv_triangles) CHECK(k[0] >= 0);
  CHECK(spot.mesh.normals.empty());  // the file has no vn
  REQUIRE(spot.materials.size() == 1);
  REQUIRE(spot.textures.size() == 1);
  CHECK(spot.textures[0].width == 1024);
  CHECK(spot.textures[0].height == 1024);
  CHECK(spot.materials[0].texture == 0);
  smooth_normals(spot.mesh, 60.0);
  CHECK(spot.mesh.normal_triangles.size() == 5856);
}
