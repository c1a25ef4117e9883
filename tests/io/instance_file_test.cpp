// Assets and instances in scene files (io/scene_json.hpp): the keys are read as
// documented, and every bad value is refused by file and JSON path, by the loader or
// by validate() (scene/validate.hpp) for scenes built in C++.
#include <doctest/doctest.h>

#include <string>

#include <twinray/io/scene_json.hpp>
#include <twinray/pack/pack.hpp>

#include "support/refusal.hpp"

namespace {

using test_support::refusal;

// A scene with `assets` (JSON text of its value; none where empty) and `objects`.
std::string scene_with(const std::string& assets, const std::string& objects) {
  return R"({ "twinray": 1, "image": { "width": 4, "height": 3 },
  "camera": { "projection": "orthographic", "position": [0, 0, 5], "look_at": [0, 0, 0],
              "up": [0, 1, 0] },
  "materials": { "red": { "color": [1, 0, 0] }, "blue": { "color": [0, 0, 1] } },)" +
         (assets.empty() ? std::string() : R"( "assets": )" + assets + ",") + R"( "objects": [)" +
         objects + "] }";
}

const std::string kPair = R"({ "pair": [
    { "type": "sphere", "center": [1, 0, 0], "radius": 0.5, "material": "red" },
    { "type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "material": "blue" } ],
  "ball": { "type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "blue" } })";

}  // namespace

TEST_CASE_TEMPLATE("assets and instances are read with their maps, materials and masks", T, float,
                   double) {
  auto f = twinray::io::parse_scene<T>(scene_with(kPair, R"({ "type": "instance", "asset": "pair" },
        { "type": "instance", "asset": "ball", "material": "red", "mask": 6,
          "transform": { "translate": [1, 2, 3], "scale": [2, 1, 1] } })"),
                                       "s.json");
  REQUIRE(f.scene.assets.size() == 2);
  // Assets are numbered in the file's order: "pair", then "ball".
  CHECK(f.scene.assets[0].name == "pair");
  CHECK(f.scene.assets[0].objects.size() == 2);
  CHECK(f.scene.assets[1].name == "ball");
  CHECK(f.scene.assets[1].objects.size() == 1);
  REQUIRE(f.scene.objects.size() == 2);
  const auto& a = std::get<twinray::Instance<T>>(f.scene.objects[0]);
  const auto& b = std::get<twinray::Instance<T>>(f.scene.objects[1]);
  CHECK(a.asset == 0);
  CHECK(a.material == -1);
  CHECK(a.mask == 0xffffffffu);
  CHECK(a.to_world == glm::dmat4(1.0));
  CHECK(b.asset == 1);
  CHECK(b.material == 0);  // "red"
  CHECK(b.mask == 6u);
  CHECK(b.to_world[0][0] == 2.0);
  CHECK(b.to_world[3] == glm::dvec4(1, 2, 3, 1));
  // Packed: both assets once, with the instances in the top level.
  twinray::PackedScene<T> ps = twinray::pack_scene(f.scene);
  CHECK(ps.spheres.size() == 2);
  CHECK(ps.triangles.size() == 1);
  CHECK(ps.instances.size() == 2);
  CHECK((ps.features & TR_F_INSTANCES) != 0);
  CHECK(ps.scene_root == -1);
  CHECK(ps.instance_root >= 0);
}

TEST_CASE("bad assets and instances are refused by file and JSON path") {
  struct Bad {
    std::string assets, objects, message;
  };
  const std::string ball =
      R"({ "type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "red" })";
  const Bad cases[] = {
      {"", R"({ "type": "instance", "asset": "tree" })",
       "s.json: objects[0].asset: no asset named \"tree\"; `assets` defines none"},
      {R"({ "tree": )" + ball + "}", R"({ "type": "instance", "asset": "tre" })",
       "s.json: objects[0].asset: no asset named \"tre\" (did you mean \"tree\"?); defined: "
       "tree"},
      {R"({ "tree": )" + ball + "}", R"({ "type": "instance", "asset": 3 })",
       "s.json: objects[0].asset: must be the name of an asset, got a number (3)"},
      {R"({ "tree": [] })", "",
       "s.json: assets.tree: an asset holds at least one object, got an "
       "empty list"},
      {R"({ "tree": 5 })", "",
       "s.json: assets.tree: must be an object or a list of objects, got a "
       "number (5)"},
      {R"({ "tree": { "type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "material": "red" } })",
       "",
       "s.json: assets.tree.type: an asset holds spheres, triangles and meshes, not planes (a "
       "plane is unbounded: an instance of it could not be placed)"},
      {R"({ "tree": )" + ball + R"(, "grove": [ { "type": "instance", "asset": "tree" } ] })", "",
       "s.json: assets.grove[0].type: an asset holds no instances (instances are one level "
       "deep)"},
      {R"({ "tree": )" + ball + "}",
       R"({ "type": "instance", "asset": "tree", "material": "green" })", ""},
      {R"({ "tree": )" + ball + "}", R"({ "type": "instance", "asset": "tree", "radius": 1 })", ""},
  };
  for (const Bad& c : cases) {
    CAPTURE(c.assets);
    CAPTURE(c.objects);
    const std::string message = refusal(
        [&] { twinray::io::parse_scene<float>(scene_with(c.assets, c.objects), "s.json"); });
    if (c.message.empty())  // an unknown key or material: named
      CHECK((message.find("unknown key") != std::string::npos ||
             message.find("no material named") != std::string::npos));
    else
      CHECK(message == c.message);
  }
}

TEST_CASE("validate refuses instances of no asset, singular or projective maps, nested instances") {
  twinray::Scene<float> scene;
  scene.add_material({});
  twinray::Asset<float> ball;
  ball.name = "ball";
  ball.objects.push_back(twinray::Sphere<float>{{0, 0, 0}, 1.0f, 0});
  scene.add_asset(ball);
  scene.add_instance(0);
  twinray::validate(scene);  // fine
  SUBCASE("asset out of range") {
    scene.add_instance(1);
    CHECK(refusal([&] { twinray::validate(scene); }) ==
          "objects[1].asset: no asset with index 1 (1 defined)");
  }
  SUBCASE("singular") {
    glm::dmat4 flat(1.0);
    flat[1][1] = 0.0;
    scene.add_instance(0, flat);
    CHECK(refusal([&] { twinray::validate(scene); }) ==
          "objects[1].transform: is singular: it has no inverse to map rays by");
  }
  SUBCASE("projective") {
    glm::dmat4 p(1.0);
    p[0][3] = 0.5;
    scene.add_instance(0, p);
    CHECK(refusal([&] { twinray::validate(scene); }) ==
          "objects[1].transform: is not affine: its last row must be 0 0 0 1");
  }
  SUBCASE("not finite") {
    glm::dmat4 m(1.0);
    m[3][0] = INFINITY;
    scene.add_instance(0, m);
    CHECK(refusal([&] { twinray::validate(scene); }) ==
          "objects[1].transform: has a value that is not finite (row 0, column 3)");
  }
  SUBCASE("material out of range") {
    scene.add_instance(0, glm::dmat4(1.0), 4);
    CHECK(refusal([&] { twinray::validate(scene); }) ==
          "objects[1].material: no material with index 4 (1 defined)");
  }
  SUBCASE("nested") {
    twinray::Asset<float> grove;
    grove.name = "grove";
    grove.objects.push_back(twinray::Instance<float>{});
    scene.add_asset(grove);
    CHECK(refusal([&] { twinray::validate(scene); }) ==
          "assets.grove[0]: is an instance; an asset holds no instances (instances are one level "
          "deep)");
  }
}
