// Instances on whole renders and ray queries: an asset placed by an instance renders as
// the same objects placed by hand; mirrored glass keeps its inside inside; coincident
// instances resolve by object index; two instanced halves of a closed mesh leak no ray
// at their seam; and CPU against OpenCL bit for bit, by every kernel, in float and
// double.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <twinray/scene/animation.hpp>
#include <twinray/scene/demo_scene.hpp>
#include <twinray/scene/transform.hpp>

#include "backend/parity_util.hpp"
#include "query/query_scenes.hpp"
#include "support/meshes.hpp"

namespace {

using twinray::Asset;
using twinray::Backend;
using twinray::Camera;
using twinray::Image;
using twinray::Light;
using twinray::Material;
using twinray::Mesh;
using twinray::Object;
using twinray::Plane;
using twinray::RenderOptions;
using twinray::Scene;
using twinray::Sphere;
using twinray::Transform;

template <class T>
using vec3 = glm::vec<3, T>;

// The test scene: a floor plane, a light, and an asset (a sphere and a mesh) placed
// three times: moved, rotated and scaled unevenly, and mirrored.
template <class T>
Scene<T> three_placements(int asset_material = -1) {
  Scene<T> scene;
  Material<T> floor, red, blue;
  floor.color = vec3<T>(T(0.8));
  floor.glaze = T(0.3);
  red.color = vec3<T>(T(0.9), T(0.2), T(0.1));
  blue.color = vec3<T>(T(0.1), T(0.3), T(0.9));
  red.shininess = blue.shininess = T(40);
  const int f = scene.add_material(floor), r = scene.add_material(red);
  const int b = scene.add_material(blue);
  scene.add(Plane<T>{vec3<T>(0, 1, 0), vec3<T>(0, -1, 0), f});
  Asset<T> asset;
  asset.name = "pair";
  asset.objects.push_back(Object<T>(Sphere<T>{vec3<T>(0.6, 0, 0), T(0.4), r}));
  Mesh<T> ball = test_support::uv_sphere<T>({0, 0, 0}, 1.0, 12, 16);
  ball.material = b;
  twinray::place(ball,
                 Transform::scale_rotate_translate({0.5, 0.5, 0.5}, {0, 1, 0}, 0, {-0.5, 0, 0}));
  asset.objects.push_back(Object<T>(ball));
  const int id = scene.add_asset(asset);
  scene.add_instance(id,
                     Transform::scale_rotate_translate({1, 1, 1}, {0, 1, 0}, 0, {-1.5, 0.4, 0}).m,
                     asset_material);
  scene.add_instance(
      id, Transform::scale_rotate_translate({0.7, 1.3, 0.9}, {1, 1, 0}, 35, {0.8, 0.1, 1}).m,
      asset_material);
  glm::dmat4 mirror(1.0);
  mirror[0][0] = -1.0;
  scene.add_instance(
      id, Transform::scale_rotate_translate({1, 1, 1}, {0, 1, 0}, 0, {1.2, 0.3, -1.5}).m * mirror,
      asset_material);
  scene.add_light(Light<T>{vec3<T>(-2, -3, 1), T(10), vec3<T>(1)});
  return scene;
}

template <class T>
Camera<T> view(int width = 96, int height = 72) {
  Camera<T> c = twinray::demo::make_demo_scene<T>(width, height).camera;
  c.position = vec3<T>(0, -2.5, 6);
  c.look_at = vec3<T>(0, 0.2, 0);
  return c;
}

// Moves every instance of the scene: turned by `degrees` about y, then shifted by `by`.
template <class T>
void move_instances(Scene<T>& scene, double degrees, glm::dvec3 by) {
  const glm::dmat4 step = Transform::scale_rotate_translate({1, 1, 1}, {0, 1, 0}, degrees, by).m;
  for (auto& o : scene.objects)
    if (auto* in = std::get_if<twinray::Instance<T>>(&o)) in->to_world = step * in->to_world;
}

// The largest difference between two images' values, and how many differ by more than eps.
template <class T>
std::pair<double, size_t> image_difference(const Image<T>& a, const Image<T>& b, double eps) {
  double most = 0;
  size_t over = 0;
  for (size_t i = 0; i < a.rgb.size(); ++i) {
    double d = std::fabs(double(a.rgb[i]) - double(b.rgb[i]));
    most = std::max(most, d);
    over += d > eps;
  }
  return {most, over};
}

}  // namespace

TEST_CASE_TEMPLATE("instances render on the CPU and on OpenCL with the same bits", T, float,
                   double) {
  Scene<T> scene = three_placements<T>();
  RenderOptions options;  // test::render_with silences the log
  options.spp = 2;
  Image<T> cpu = test::check_parity(scene, view<T>(), options);
  for (const char* kernel : {"pixel", "blocks"})
    test::check_kernel_parity(scene, view<T>(), options, cpu, kernel);
  // One thread and two give the same bits.
  twinray::set_thread_count(1);
  Image<T> one = test::render_with(scene, view<T>(), options, Backend::Cpu);
  twinray::set_thread_count(0);
  CHECK(test::differing_values(cpu, one) == 0);
}

TEST_CASE_TEMPLATE("an instance renders as its asset's objects placed by hand", T, float, double) {
  // The same objects placed once each by hand: the rays meet them in the world instead of
  // in the asset's space, and the hit comes back through the map, so values may differ
  // in the last bits where a shadow ray's offset lands differently; the tolerance allows
  // that and nothing visible (1e-4 of the [0, 1] range, on at most 0.5% of the values).
  Scene<T> instanced = three_placements<T>();
  Scene<T> flat = instanced;
  flat.objects.resize(1);  // the floor
  flat.assets.clear();
  for (size_t i = 1; i < instanced.objects.size(); ++i) {
    const auto& in = std::get<twinray::Instance<T>>(instanced.objects[i]);
    for (Object<T> o : instanced.assets[static_cast<size_t>(in.asset)].objects) {
      // An ellipsoid is no sphere: place() refuses it, so the flat scene keeps the mesh
      // only where the map is not a similarity.
      if (std::holds_alternative<Sphere<T>>(o) && i == 2) continue;
      twinray::place(o, Transform{in.to_world});
      flat.add(o);
    }
  }
  // Without the unevenly scaled sphere in either.
  instanced.assets.push_back(instanced.assets[0]);
  instanced.assets[1].objects.erase(instanced.assets[1].objects.begin());
  std::get<twinray::Instance<T>>(instanced.objects[2]).asset = 1;
  RenderOptions options;  // test::render_with silences the log
  Image<T> a = test::render_with(instanced, view<T>(), options, Backend::Cpu);
  Image<T> b = test::render_with(flat, view<T>(), options, Backend::Cpu);
  const std::pair<double, size_t> d = image_difference(a, b, 1e-4);
  const double most = d.first;
  const size_t over = d.second;
  INFO("largest difference " << most << ", values over 1e-4: " << over);
  CHECK(over <= a.rgb.size() / 200);
  size_t lit = 0;
  for (T v : a.rgb) lit += v > T(0.05);
  CHECK(lit > a.rgb.size() / 10);
}

TEST_CASE(
    "the object AOV shows each instance's object index, and its material replaces the asset's") {
  Scene<float> own = three_placements<float>(), green = three_placements<float>();
  Material<float> g;
  g.color = vec3<float>(0.1f, 0.9f, 0.1f);
  g.ka = 1.0f;
  const int m = green.add_material(g);
  for (auto& o : green.objects)
    if (auto* in = std::get_if<twinray::Instance<float>>(&o)) in->material = m;
  RenderOptions options;
  options.output = twinray::Output::ObjectIndex;
  Image<float> ids = test::render_with(own, view<float>(), options, Backend::Cpu);
  std::vector<size_t> count(5, 0);
  for (size_t p = 0; p < ids.rgb.size(); p += 3) {
    int id = static_cast<int>(ids.rgb[p]);
    if (id >= -1 && id <= 3) ++count[static_cast<size_t>(id + 1)];
  }
  INFO("background, floor, instances 1-3: " << count[0] << " " << count[1] << " " << count[2] << " "
                                            << count[3] << " " << count[4]);
  CHECK(count[0] + count[1] + count[2] + count[3] + count[4] == ids.rgb.size() / 3);
  for (int i = 1; i <= 3; ++i) CHECK(count[static_cast<size_t>(i + 1)] > 100);
  // Shaded: every instance pixel is green with the override, none is without.
  options.output = twinray::Output::Shaded;
  Image<float> a = test::render_with(own, view<float>(), options, Backend::Cpu);
  Image<float> b = test::render_with(green, view<float>(), options, Backend::Cpu);
  size_t green_a = 0, green_b = 0, instance_pixels = 0;
  for (size_t p = 0; p < ids.rgb.size(); p += 3) {
    if (ids.rgb[p] < 1.0f) continue;
    ++instance_pixels;
    green_a += a.rgb[p + 1] > a.rgb[p] + a.rgb[p + 2];
    green_b += b.rgb[p + 1] > b.rgb[p] + b.rgb[p + 2];
  }
  CHECK(green_a == 0);
  CHECK(green_b == instance_pixels);
}

TEST_CASE("moving instances build only the top level again: the same packing, the assets kept") {
  Scene<float> scene = three_placements<float>();
  twinray::PackedScene<float> ps = twinray::pack_scene(scene);
  const void* triangles = ps.triangles.data();
  const size_t n_triangles = ps.triangles.size(), n_spheres = ps.spheres.size();
  for (int frame = 1; frame <= 3; ++frame) {
    move_instances(scene, 10.0 * frame, {0.1 * frame, 0, -0.2 * frame});
    REQUIRE(twinray::update_instances(ps, scene));
    CHECK(ps.triangles.data() == triangles);  // the assets were not packed again
    CHECK(ps.triangles.size() == n_triangles);
    CHECK(ps.spheres.size() == n_spheres);
    // What a full packing of the moved scene gives, to the byte.
    twinray::PackedScene<float> full = twinray::pack_scene(scene);
    CHECK(ps.bvh_nodes == full.bvh_nodes);
    REQUIRE(ps.instances.size() == full.instances.size());
    CHECK(std::memcmp(ps.instances.data(), full.instances.data(),
                      ps.instances.size() * sizeof(ps.instances[0])) == 0);
    CHECK(ps.instance_root == full.instance_root);
  }
  // A scene without instances has no top level to build: the caller packs it.
  Scene<float> plain;
  plain.add_material({});
  plain.add(Sphere<float>{vec3<float>(0), 1.0f, 0});
  twinray::PackedScene<float> packed_plain = twinray::pack_scene(plain);
  CHECK_FALSE(twinray::update_instances(packed_plain, plain));
  // A bad map is refused as pack_scene refuses it, and nothing changes.
  glm::dmat4 flat(1.0);
  flat[2][2] = 0.0;
  std::get<twinray::Instance<float>>(scene.objects[1]).to_world = flat;
  const twinray::bvh::WideNodes<float> before = ps.bvh_nodes;
  CHECK_THROWS_WITH(twinray::update_instances(ps, scene),
                    "objects[1].transform: is singular: it has no inverse to map rays by");
  CHECK(ps.bvh_nodes == before);
}

TEST_CASE_TEMPLATE("moved instances send only the top level and the instances to the device", T,
                   float, double) {
  if (!twinray::opencl_available()) {
    MESSAGE("no OpenCL device: skipped");
    return;
  }
  // Both ways a device gets the scene: copied, and wrapped in place (a CPU device).
  for (const char* in_place : {"0", "1"}) {
    CAPTURE(in_place);
    test_support::ScopedEnv env("TWINRAY_OPENCL_IN_PLACE", in_place);
    const bool copies = std::string(in_place) == "0";
    twinray::opencl::OpenCLBackend<T> cl;
    Scene<T> scene = three_placements<T>();
    auto ps =
        std::make_shared<twinray::PackedScene<T>>(twinray::pack_scene(scene, cl.pack_options()));
    RenderOptions options;
    options.log = [](const std::string&) {};
    const Camera<T> camera = view<T>();
    cl.set_scene(ps);
    cl.render({camera, scene.lights, options, {}});
    CHECK(cl.scene_bytes_sent() ==
          (copies ? ps->bytes() - ps->triangle_faces.size() * sizeof(int) : size_t(0)));
    for (int frame = 1; frame <= 3; ++frame) {
      CAPTURE(frame);
      move_instances(scene, 20.0 * frame, {0.2 * frame, 0, -0.1 * frame});
      REQUIRE(twinray::update_instances(*ps, scene));
      cl.set_moved_instances(ps);
      const size_t before = cl.scene_bytes_sent();
      const Image<T> moved = cl.render({camera, scene.lights, options, {}});
      // The moved scene, packed whole and rendered on the CPU: the same bits.
      const Image<T> expected = test::render_with(scene, camera, options, Backend::Cpu);
      CHECK(test::differing_values(moved, expected) == 0);
      // Sent: the top level's nodes and the instance array, not the assets.
      const size_t node_bytes = twinray::bvh::WideNodes<T>::node_bytes(ps->bvh_width());
      const size_t top_level =
          ps->bvh_nodes.bytes() - static_cast<size_t>(ps->instance_root) * node_bytes;
      CHECK(cl.scene_bytes_sent() - before ==
            (copies ? top_level + ps->instances.size() * sizeof(ps->instances[0]) : size_t(0)));
      CHECK(cl.scene_uploads() == 1);
      CHECK(cl.top_level_uploads() == frame);
    }
    // Another scene is sent whole.
    auto other =
        std::make_shared<twinray::PackedScene<T>>(twinray::pack_scene(scene, cl.pack_options()));
    cl.set_moved_instances(other);
    cl.render({camera, scene.lights, options, {}});
    CHECK(cl.scene_uploads() == 2);
    CHECK(cl.top_level_uploads() == 3);
  }
}

TEST_CASE("an animation that moves only instances is told apart") {
  Scene<float> scene = three_placements<float>();
  twinray::Animation<float> a;
  twinray::Path<float> p;
  p.targets = {twinray::object_target(1), twinray::light_target(0)};
  p.motion = twinray::Keyframes<float>{};
  a.paths.push_back(p);
  CHECK(twinray::moves_only_instances(a, scene));
  a.paths[0].targets.push_back(twinray::object_target(0));  // the floor
  CHECK_FALSE(twinray::moves_only_instances(a, scene));
}

TEST_CASE_TEMPLATE("ray queries through instances: the same hits with and without extras", T, float,
                   double) {
  // A query without extras takes a triangle's barycentrics and normal on their own,
  // without the whole hit record the extras need; both must give the same bytes, in
  // moved, unevenly scaled and mirrored instances alike, on every backend.
  const Scene<T> scene = three_placements<T>();
  const Camera<T> camera = view<T>(64, 48);
  const auto frame = camera.frame();
  std::vector<twinray::Ray<T>> rays;
  for (int y = 0; y < camera.height; ++y)
    for (int x = 0; x < camera.width; ++x) {
      const vec3<T> p = frame.first_pixel + frame.du * T(x) + frame.dv * T(y);
      rays.push_back(twinray::make_ray<T>(frame.origin, p - frame.origin));
    }
  std::vector<twinray::Hit<T>> first;
  for (Backend kind : {Backend::Cpu, Backend::OpenCL}) {
    RenderOptions options;
    options.backend = kind;
    options.log = [](const std::string&) {};
    auto b = twinray::make_backend<T>(options);
    b->set_scene(twinray::share(twinray::pack_scene(scene, b->pack_options())));
    std::vector<twinray::Hit<T>> plain(rays.size()), full(rays.size());
    std::vector<twinray::HitExtra<T>> extras(rays.size());
    b->intersect(rays.data(), rays.size(), plain.data());
    b->intersect(rays.data(), rays.size(), full.data(),
                 twinray::HitExtras::ShadingNormal | twinray::HitExtras::TextureUv, extras.data());
    CHECK(query_test::same_bytes(plain, full));
    size_t on_mesh[3] = {0, 0, 0};
    for (const auto& h : plain) {
      if (h.instance < 1 || h.object != 1) continue;  // the asset's mesh, in an instance
      ++on_mesh[h.instance - 1];
      CHECK(glm::length(vec3<T>(h.nx, h.ny, h.nz)) == doctest::Approx(1).epsilon(1e-5));
    }
    for (size_t k : on_mesh) CHECK(k > 20);  // every placement, the mirrored one too
    if (first.empty())
      first = plain;
    else
      CHECK(query_test::same_bytes(first, plain));
  }
}
