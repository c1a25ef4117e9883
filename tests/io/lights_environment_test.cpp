// Area lights and the environment in scene files (io/scene_json.hpp) and the environment
// image reader (io/texture_image.hpp): every key read as documented, and every bad
// value refused by file and JSON path.
#include <doctest/doctest.h>

#include <fstream>
#include <string>

#include <twinray/io/scene_json.hpp>
#include <twinray/io/texture_image.hpp>

#include "support/refusal.hpp"

namespace {

const std::string kScenes = TWINRAY_SCENES_DIR;

using test_support::refusal;

// A scene with `lights` and, inside `image`, `image_extra`.
std::string scene_with(const std::string& lights, const std::string& image_extra = "") {
  return R"({ "twinray": 1, "image": { "width": 4, "height": 3)" + image_extra + R"( },
  "camera": { "projection": "orthographic", "position": [0, 0, 5], "look_at": [0, 0, 0],
              "up": [0, 1, 0] },
  "lights": [)" +
         lights + R"(] })";
}

// A flat-RGBE Radiance HDR file (Ward, Graphics Gems II) of w x h pixels: pixel x has
// mantissa 128 + x on every channel and the given exponent byte e, so it holds
// (128 + x) 2^(e - 136).
std::string hdr_bytes(int w, int h, unsigned char exponent) {
  std::string s = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y " + std::to_string(h) + " +X " +
                  std::to_string(w) + "\n";
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const unsigned char m = static_cast<unsigned char>(128 + x);
      s += std::string{char(m), char(m), char(m), char(exponent)};
    }
  return s;
}

// `bytes` written to `name` in `dir`; its path.
std::string write_in(const test_support::TempDir& dir, const std::string& name,
                     const std::string& bytes) {
  const std::string path = dir.str() + "/" + name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

}  // namespace

TEST_CASE_TEMPLATE("rect and sphere lights are read with their samples", T, float, double) {
  auto f = twinray::io::parse_scene<T>(
      scene_with(R"({ "type": "rect", "corner": [1, 2, 3], "edge1": [2, 0, 0],
                      "edge2": [0, 0, 1], "intensity": 5, "samples": 6 },
                    { "type": "sphere", "center": [0, 4, 0], "radius": 0.5, "intensity": 2,
                      "color": [1, 0.5, 0.25] },
                    { "type": "point", "position": [0, 1, 0], "intensity": 1 })"),
      "s.json");
  REQUIRE(f.scene.lights.size() == 3);
  const auto& rect = f.scene.lights[0];
  CHECK(rect.shape == twinray::LightShape::Rect);
  CHECK(rect.position == glm::vec<3, T>(1, 2, 3));
  CHECK(rect.edge1 == glm::vec<3, T>(2, 0, 0));
  CHECK(rect.edge2 == glm::vec<3, T>(0, 0, 1));
  CHECK(rect.intensity == T(5));
  CHECK(rect.samples == 6);
  const auto& sphere = f.scene.lights[1];
  CHECK(sphere.shape == twinray::LightShape::Sphere);
  CHECK(sphere.position == glm::vec<3, T>(0, 4, 0));
  CHECK(sphere.radius == T(0.5));
  CHECK(sphere.samples == twinray::kDefaultLightSamples);
  CHECK(sphere.color == glm::vec<3, T>(1, 0.5, 0.25));
  CHECK(f.scene.lights[2].shape == twinray::LightShape::Point);
  CHECK(f.scene.lights[2].samples == 1);
}

TEST_CASE("bad area lights are refused by file and JSON path") {
  struct Bad {
    std::string light, message;
  };
  const std::string rect = R"({ "type": "rect", "corner": [0, 0, 0], "intensity": 1, )";
  const Bad cases[] = {
      {rect + R"("edge1": [1, 0, 0] })", "s.json: lights[0].edge2: missing (required)"},
      {rect + R"("edge1": [1, 0, 0], "edge2": [2, 0, 0] })",
       "s.json: lights[0].edge2: must span an area with edge1 (not zero, not parallel to it), got "
       "[1, 0, 0] and [2, 0, 0]"},
      {rect + R"("edge1": [1, 0, 0], "edge2": [0, 1, 0], "samples": 0 })",
       "s.json: lights[0].samples: must be an integer in [1, 64], got 0"},
      {rect + R"("edge1": [1, 0, 0], "edge2": [0, 1, 0], "samples": 65 })",
       "s.json: lights[0].samples: must be an integer in [1, 64], got 65"},
      {rect + R"("edge1": [1, 0, 0], "edge2": [0, 1, 0], "samples": 2.5 })",
       "s.json: lights[0].samples: must be an integer in [1, 64], got 2.5"},
      {R"({ "type": "sphere", "center": [0, 0, 0], "radius": 0, "intensity": 1 })",
       "s.json: lights[0].radius: must be > 0, got 0"},
      {R"({ "type": "sphere", "position": [0, 0, 0], "radius": 1, "intensity": 1 })", ""},
      {R"({ "type": "point", "position": [0, 0, 0], "intensity": 1, "samples": 4 })", ""},
      {R"({ "type": "disk", "center": [0, 0, 0], "intensity": 1 })",
       "s.json: lights[0].type: must be \"point\", \"rect\", \"sphere\", got \"disk\""},
  };
  for (const Bad& c : cases) {
    CAPTURE(c.light);
    const std::string message =
        refusal([&] { twinray::io::parse_scene<float>(scene_with(c.light), "s.json"); });
    if (c.message.empty())  // an unknown key: named, with the keys the type takes
      CHECK(message.find("unknown key") != std::string::npos);
    else
      CHECK(message == c.message);
  }
}

TEST_CASE_TEMPLATE("an environment is read from PNG, JPEG or Radiance HDR, beside the scene", T,
                   float, double) {
  // The shipped sky: HDR values (its sun is 40), read relative to the scene's folder.
  auto f = twinray::io::load_scene<T>(kScenes + "/glass.json");
  const auto& env = f.scene.environment;
  REQUIRE(env.enabled());
  const twinray::Texture<T>& sky = f.scene.textures.at(static_cast<size_t>(env.texture));
  CHECK(sky.hdr);
  CHECK(sky.width == 256);
  CHECK(sky.height == 128);
  T brightest = 0;
  for (T v : sky.texels) brightest = v > brightest ? v : brightest;
  CHECK(brightest > T(10));
  CHECK(env.up == glm::vec<3, T>(0, -1, 0));
  // A file of our own: its values as the RGBE encoding says, above 1.
  test_support::TempDir dir("twinray-env-read");
  const std::string hdr = write_in(dir, "a.hdr", hdr_bytes(20, 2, 136 + 4));
  const twinray::Texture<T> t = twinray::io::load_environment<T>(hdr);
  CHECK(t.width == 20);
  CHECK(t.height == 2);
  CHECK(t.texels[0] == T(128 * 16));
  CHECK(t.texels[3 * 19 + 2] == T((128 + 19) * 16));
  // The same file is refused as a material's texture.
  CHECK(refusal([&] { twinray::io::load_texture<T>(hdr); }).find("is a Radiance HDR image") !=
        std::string::npos);
  auto g = twinray::io::parse_scene<T>(
      scene_with("", R"(, "environment": { "file": ")" + hdr +
                         R"(", "rotate_degrees": -30, "intensity": 0.5 })"),
      "s.json");
  CHECK(g.scene.environment.rotate_degrees == T(-30));
  CHECK(g.scene.environment.intensity == T(0.5));
  CHECK(g.scene.environment.up == glm::vec<3, T>(0, 1, 0));
}

TEST_CASE("bad environments are refused by file and JSON path") {
  test_support::TempDir dir("twinray-env-refused");
  const std::string hdr = write_in(dir, "b.hdr", hdr_bytes(4, 2, 136));
  const std::string junk = write_in(dir, "junk.hdr", "#?RADIANCE\nnot really\n");
  struct Bad {
    std::string env, message;
  };
  const Bad cases[] = {
      {R"({ "rotate_degrees": 3 })", "s.json: image.environment.file: missing (required)"},
      {R"({ "file": "" })",
       "s.json: image.environment.file: must name an image file (PNG, JPEG or Radiance HDR)"},
      {R"({ "file": "/nonexistent/sky.hdr" })",
       "s.json: image.environment.file: /nonexistent/sky.hdr: cannot open an image file: No such "
       "file or directory"},
      {R"({ "file": ")" + junk + R"(" })", "not a PNG, JPEG or Radiance HDR image"},
      {R"({ "file": ")" + hdr + R"(", "intensity": -1 })",
       "s.json: image.environment.intensity: must be >= 0, got -1"},
      {R"({ "file": ")" + hdr + R"(", "up": [0, 0, 0] })",
       "s.json: image.environment.up: must be a non-zero vector of finite length, got [0, 0, 0]"},
      {R"({ "file": ")" + hdr + R"(", "rotate": 3 })", "unknown key"},
      {R"("sky.hdr")", "s.json: image.environment: must be an object, got a string (\"sky.hdr\")"},
  };
  for (const Bad& c : cases) {
    CAPTURE(c.env);
    const std::string message = refusal([&] {
      twinray::io::parse_scene<float>(scene_with("", R"(, "environment": )" + c.env), "s.json");
    });
    if (c.message.rfind("s.json", 0) == 0)
      CHECK(message == c.message);
    else
      CHECK(message.find(c.message) != std::string::npos);
  }
  // Through the API: an HDR texture as a material's, and an environment index out of range.
  twinray::Scene<float> scene;
  scene.add_texture(twinray::io::load_environment<float>(hdr));
  twinray::Material<float> m;
  m.texture = 0;
  scene.add_material(m);
  CHECK(refusal([&] { twinray::validate(scene); })
            .find("materials[0].texture: is a high-dynamic-range "
                  "image") == 0);
  scene.materials[0].texture = -1;
  scene.environment.texture = 3;
  CHECK(refusal([&] { twinray::validate(scene); }) ==
        "image.environment.texture: no texture with index 3 (1 defined)");
}
