// Bad scenes, cameras and options are refused before rendering, with a message that
// names the value (the path a scene file would use) and the problem.
#include <doctest/doctest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <string>
#include <vector>

#include <twinray/core/parallel.hpp>
#include <twinray/scene/validate.hpp>

#include "support/refusal.hpp"

using namespace twinray;
using test_support::refusal;

namespace {

Scene<float> one_sphere() {
  Scene<float> s;
  s.add_material({});
  s.add(Sphere<float>{{0, 0, -1}, 0.5f, 0});
  return s;
}
}  // namespace

TEST_CASE("camera refusals name the field") {
  Camera<float> cam;
  cam.up = glm::vec3(4, -1, 6);  // parallel to position - look_at
  CHECK(refusal([&] { validate(cam); }).find("camera.up: must not be parallel") == 0);
  cam = Camera<float>();
  cam.up = glm::vec3(0, 0, 0);
  CHECK(refusal([&] { validate(cam); }) == "camera.up: must be non-zero");
  cam = Camera<float>();
  cam.width = 0;
  CHECK(refusal([&] { validate(cam); }).find("image.width: must be in [1, 65536], got 0") == 0);
  cam = Camera<float>();
  cam.height = -3;
  CHECK(refusal([&] { validate(cam); }).find("image.height") == 0);
  cam = Camera<float>();
  cam.look_at = cam.position;
  CHECK(refusal([&] { validate(cam); }).find("camera.look_at: must differ") == 0);
  cam = Camera<float>();
  cam.position.x = NAN;
  CHECK(refusal([&] { validate(cam); }).find("camera.position: must be finite") == 0);
  cam = Camera<float>();
  cam.focal_length = -1.0f;
  CHECK(refusal([&] { validate(cam); }) == "camera.focal_length: must be > 0, got -1");
  cam = Camera<float>();
  cam.width = 65536, cam.height = 65536;
  CHECK(refusal([&] { validate(cam); }).find("image: width x height must be at most") == 0);
  CHECK_NOTHROW(validate(Camera<float>()));
}

TEST_CASE("scene refusals name the object and the problem") {
  Scene<float> s = one_sphere();
  std::get<Sphere<float>>(s.objects[0]).radius = -1;
  CHECK(refusal([&] { validate(s); }) == "objects[0].radius: must be > 0, got -1");
  s = one_sphere();
  s.add(Plane<float>{{0, 1, 0}, {0, 0, 0}, 0});
  CHECK(refusal([&] { validate(s); }) == "objects[1].normal: must be non-zero, got [0, 0, 0]");
  s = one_sphere();
  s.add(Sphere<float>{{0, 0, 0}, 1, 3});
  CHECK(refusal([&] { validate(s); }) ==
        "objects[1].material: no material with index 3 (1 defined)");
  s = one_sphere();
  Mesh<float> m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.triangles = {{0, 1, 3}};
  s.add(m);
  CHECK(refusal([&] { validate(s); }) ==
        "objects[1].triangles[0][2]: vertex index 3 out of range (3 vertices)");
  s = one_sphere();
  s.materials[0].glaze = 1.5f;
  CHECK(refusal([&] { validate(s); }) == "materials[0].glaze: must be in [0, 1], got 1.5");
  s = one_sphere();
  s.materials[0].glaze = 0.5f;
  s.materials[0].transmission = 0.75f;
  CHECK(refusal([&] { validate(s); }) ==
        "materials[0].transmission: must be in [0, 0.5], got 0.75");
  s = one_sphere();
  s.materials[0].ior = 0.f;
  CHECK(refusal([&] { validate(s); }) == "materials[0].ior: must be > 0, got 0");
  s = one_sphere();
  s.materials[0].absorption.z = -1.f;
  CHECK(refusal([&] { validate(s); }) == "materials[0].absorption[2]: must be >= 0, got -1");
  s = one_sphere();
  s.add_light({{0, 0, 0}, -2.f, {1, 1, 1}});
  CHECK(refusal([&] { validate(s); }) == "lights[0].intensity: must be >= 0, got -2");
  s = one_sphere();
  s.add_light({{0, 0, 0}, 1e38f, {4, 1, 1}});  // each finite, the product is not
  CHECK(refusal([&] { validate(s); }) ==
        "lights[0].intensity: intensity x color[0] overflows float: 9.99999968e+37 x 4");
  s = one_sphere();
  s.add(Triangle<float>{{glm::vec3(0), glm::vec3(INFINITY, 0, 0), glm::vec3(0, 1, 0)}, 0});
  CHECK(refusal([&] { validate(s); }).find("objects[1].vertices[1]: must be finite") == 0);
  s = one_sphere();
  Mesh<float> bad_vertex;
  bad_vertex.vertices = {{0, 0, 0}, {1, 0, 0}, {0, NAN, 0}};
  bad_vertex.triangles = {{0, 1, 2}};
  s.add(bad_vertex);
  CHECK(refusal([&] { validate(s); }).find("objects[1].vertices[2]: must be finite") == 0);
  s = one_sphere();
  s.add(Plane<float>{{0, INFINITY, 0}, {0, 1, 0}, 0});
  CHECK(refusal([&] { validate(s); }).find("objects[1].point: must be finite") == 0);
  s = one_sphere();
  std::get<Sphere<float>>(s.objects[0]).center.z = NAN;
  CHECK(refusal([&] { validate(s); }).find("objects[0].center: must be finite") == 0);
  s = one_sphere();
  s.background = glm::vec3(0, 2, 0);
  CHECK(refusal([&] { validate(s); }) == "image.background[1]: must be in [0, 1], got 2");
  CHECK_NOTHROW(validate(one_sphere()));
}

TEST_CASE("the first bad object is named, whatever the thread count") {
  // Objects are checked in chunks of 4096 on every thread. The first bad object is the
  // last of its chunk, and the next chunks start with bad ones, which threads that
  // take those chunks find first.
  Scene<float> s;
  s.add_material({});
  for (int i = 0; i < 20000; ++i) s.add(Sphere<float>{{float(i), 0, -5}, 0.25f, 0});
  std::get<Sphere<float>>(s.objects[8191]).material = 7;
  std::get<Sphere<float>>(s.objects[8192]).radius = 0;
  std::get<Sphere<float>>(s.objects[12288]).center.y = NAN;
  std::get<Sphere<float>>(s.objects[16384]).radius = -2;
  for (int threads : {1, 2, 3, 8}) {
    CAPTURE(threads);
    set_thread_count(threads);
    CHECK(refusal([&] { validate(s); }) ==
          "objects[8191].material: no material with index 7 (1 defined)");
  }
  std::get<Sphere<float>>(s.objects[8191]).material = 0;
  std::get<Sphere<float>>(s.objects[8192]).radius = 0.25f;
  for (int threads : {1, 8}) {
    CAPTURE(threads);
    set_thread_count(threads);
    CHECK(refusal([&] {
            validate(s);
          }).find("objects[12288].center: must be finite, got [12288, ") == 0);
  }
  set_thread_count(0);
}

TEST_CASE("validate_geometry's callback sees every chunk that passed, once, and no later one") {
  // pack_scene counts primitives in this callback, so each object must be in exactly
  // one reported chunk when the scene is valid, whatever the thread count.
  Scene<float> s;
  s.add_material({});
  const size_t n = 3 * kValidateChunk + 17;
  for (size_t i = 0; i < n; ++i) s.add(Sphere<float>{{float(i), 0, -5}, 0.25f, 0});
  for (int threads : {1, 2, 3, 8}) {
    CAPTURE(threads);
    set_thread_count(threads);
    std::vector<std::atomic<int>> seen(n);
    std::atomic<int> calls{0};
    validate_geometry(s, [&](size_t chunk, size_t begin, size_t end) {
      CHECK(begin == chunk * kValidateChunk);
      CHECK(end == std::min(n, begin + kValidateChunk));
      for (size_t i = begin; i < end; ++i) seen[i]++;
      calls++;
    });
    CHECK(calls == 4);
    size_t once = 0;
    for (auto& k : seen) once += k == 1 ? 1 : 0;
    CHECK(once == n);
  }
  // A bad object in the third chunk: the first two may have been reported, the bad one's
  // chunk is not, and the refusal is the one validate() gives.
  std::get<Sphere<float>>(s.objects[2 * kValidateChunk + 5]).radius = -1;
  for (int threads : {1, 8}) {
    CAPTURE(threads);
    set_thread_count(threads);
    std::atomic<bool> bad_chunk_reported{false};
    const std::string message = refusal([&] {
      validate_geometry(s, [&](size_t chunk, size_t, size_t) {
        if (chunk == 2) bad_chunk_reported = true;
      });
    });
    CHECK(message.find("objects[" + std::to_string(2 * kValidateChunk + 5) + "].radius") == 0);
    CHECK_FALSE(bad_chunk_reported);
  }
  set_thread_count(0);
}

TEST_CASE("option refusals") {
  RenderOptions o;
  o.spp = 0;
  CHECK(refusal([&] { validate(o); }) == "render.spp: must be in [1, 65536], got 0");
  o = RenderOptions();
  o.max_depth = 0;
  CHECK(refusal([&] { validate(o); }) == "render.max_depth: must be in [1, 1024], got 0");
  CHECK_NOTHROW(validate(RenderOptions()));
}

TEST_CASE("mesh attribute and texture refusals name the entry") {
  Scene<float> s;
  s.add_material({});
  Mesh<float> m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.triangles = {{0, 1, 2}};
  m.normals = {{0, 0, 1}};
  m.normal_triangles = {{0, 0, 1}};
  s.add(m);
  CHECK(refusal([&] { validate(s); }) ==
        "objects[0].normal_triangles[0][2]: normal index 1 out of range (1 defined)");
  auto& mesh = std::get<Mesh<float>>(s.objects[0]);
  mesh.normal_triangles = {{-1, -1, -1}};  // a flat triangle
  validate(s);
  mesh.normals = {{0, 0, 2}};
  CHECK(refusal([&] { validate(s); }) ==
        "objects[0].normals[0]: must have unit length, got [0, 0, 2]");
  mesh.normals = {{0, 0, 1}};
  mesh.uvs = {{0, NAN}};
  CHECK(refusal([&] { validate(s); }).find("objects[0].uvs[0]: must be finite") == 0);
  mesh.uvs.clear();
  mesh.triangle_materials = {1};
  CHECK(refusal([&] { validate(s); }) ==
        "objects[0].triangle_materials[0]: no material with index 1 (1 defined)");
  mesh.triangle_materials = {0};
  validate(s);

  s.materials[0].texture = 0;
  CHECK(refusal([&] { validate(s); }) ==
        "materials[0].texture: no texture with index 0 (0 defined)");
  Texture<float> t;
  t.width = 1;
  t.height = 1;
  t.texels = {0.5f, 1.5f, 0};
  s.add_texture(t);
  CHECK(refusal([&] { validate(s); }) == "textures[0].texels[1]: must be in [0, 1], got 1.5");
  s.textures[0].texels = {0.5f, 1};
  CHECK(refusal([&] { validate(s); }) == "textures[0].texels: has 2 values, 1 x 1 texels need 3");
  s.textures[0].texels = {0.5f, 1, 0};
  validate(s);
}
