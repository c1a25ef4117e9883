// pack_scene() copies objects into flat arrays on every thread; the arrays must list
// the primitives in object order (mesh faces in face order), each with its object id,
// and be the same bytes at any thread count.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstring>
#include <vector>

#include <twinray/twinray.hpp>

namespace {

using twinray::Mesh;
using twinray::Scene;
template <class T>
using Code = twinray::device::Code<T>;

// Spheres, triangles, planes and meshes mixed over several chunks of objects, with
// one mesh big enough that its faces are split between threads too.
template <class T>
Scene<T> mixed_scene() {
  using vec3 = glm::vec<3, T>;
  Scene<T> scene;
  scene.add_material({});
  scene.add_material({});
  for (int i = 0; i < 13000; ++i) {
    const T x = T(i % 100), y = T(i / 100);
    if (i % 5 == 0) {
      scene.add(
          twinray::Triangle<T>{{vec3(x, y, -3), vec3(x + 1, y, -3), vec3(x, y + 1, -3)}, i % 2});
    } else if (i % 997 == 0) {
      scene.add(twinray::Plane<T>{vec3(0, y, 0), vec3(0, 1, T(i)), 1});
    } else if (i == 7001) {
      Mesh<T> m;  // 2 x 120 x 100 faces, with uvs
      for (int v = 0; v <= 100; ++v)
        for (int u = 0; u <= 120; ++u) {
          m.vertices.push_back(vec3(T(u), T(v), -8));
          m.uvs.push_back({T(u) / 120, T(v) / 100});
        }
      for (int v = 0; v < 100; ++v)
        for (int u = 0; u < 120; ++u) {
          int a = v * 121 + u;
          m.triangles.push_back({a, a + 1, a + 122});
          m.triangles.push_back({a, a + 122, a + 121});
        }
      m.uv_triangles = m.triangles;
      m.material = 1;
      scene.add(m);
    } else if (i % 1000 == 3) {
      Mesh<T> m;  // two faces, no attributes
      m.vertices = {vec3(x, y, -4), vec3(x + 1, y, -4), vec3(x, y + 1, -4), vec3(x + 1, y + 1, -4)};
      m.triangles = {{0, 1, 2}, {1, 3, 2}};
      scene.add(m);
    } else {
      scene.add(twinray::Sphere<T>{vec3(x, y, -5), T(0.25), i % 2});
    }
  }
  return scene;
}

template <class T>
twinray::PackedScene<T> pack_flat(const Scene<T>& scene, int threads) {
  twinray::set_thread_count(threads);
  twinray::PackOptions options;
  options.bvh = twinray::BvhPolicy::Never;
  twinray::PackedScene<T> ps = twinray::pack_scene(scene, options);
  twinray::set_thread_count(0);
  return ps;
}

template <class A, class B>
bool same_bytes(const A& a, const B& b) {
  static_assert(sizeof a[0] == sizeof b[0], "arrays of one element type");
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof a[0]) == 0);
}

}  // namespace

TEST_CASE_TEMPLATE("pack: primitives in object order, the same at any thread count", T, float,
                   double) {
  const Scene<T> scene = mixed_scene<T>();

  // What object order means, written out one object at a time.
  std::vector<typename Code<T>::Sphere> spheres;
  std::vector<typename Code<T>::Triangle> triangles;
  std::vector<int> plane_objects;
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    const int object = static_cast<int>(i);
    const auto& o = scene.objects[i];
    auto add = [&](const glm::vec<3, T>& a, const glm::vec<3, T>& b, const glm::vec<3, T>& c,
                   int material) {
      triangles.push_back({a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z, material, object});
    };
    if (auto* s = std::get_if<twinray::Sphere<T>>(&o))
      spheres.push_back(
          {s->center.x, s->center.y, s->center.z, s->radius, s->material, object, 0, 0});
    if (auto* t = std::get_if<twinray::Triangle<T>>(&o))
      add(t->vertices[0], t->vertices[1], t->vertices[2], t->material);
    if (std::holds_alternative<twinray::Plane<T>>(o)) plane_objects.push_back(object);
    if (auto* m = std::get_if<Mesh<T>>(&o))
      for (const auto& f : m->triangles)
        add(m->vertices[f[0]], m->vertices[f[1]], m->vertices[f[2]], m->material);
  }
  REQUIRE(triangles.size() > 24000);  // the big mesh is there

  const twinray::PackedScene<T> one = pack_flat(scene, 1);
  CHECK(same_bytes(one.spheres, spheres));
  CHECK(same_bytes(one.triangles, triangles));
  REQUIRE(one.planes.size() == plane_objects.size());
  for (size_t k = 0; k < plane_objects.size(); ++k) CHECK(one.planes[k].object == plane_objects[k]);
  // uvs only on the big mesh's faces, which follow every triangle of objects before it.
  REQUIRE(one.triangle_attrs.size() == triangles.size());
  size_t with_uv = 0;
  for (size_t k = 0; k < triangles.size(); ++k) {
    const bool big_mesh = triangles[k].object == 7001;
    CHECK(((one.triangle_attrs[k].flags & TR_ATTR_UV) != 0) == big_mesh);
    with_uv += big_mesh;
  }
  CHECK(with_uv == 24000);

  for (int threads : {2, 3, 8}) {
    CAPTURE(threads);
    const twinray::PackedScene<T> many = pack_flat(scene, threads);
    CHECK(same_bytes(many.spheres, one.spheres));
    CHECK(same_bytes(many.triangles, one.triangles));
    CHECK(same_bytes(many.planes, one.planes));
    CHECK(same_bytes(many.triangle_attrs, one.triangle_attrs));
  }
}

TEST_CASE_TEMPLATE("pack: with a BVH, the same primitives and attributes in leaf order", T, float,
                   double) {
  // With a BVH the primitives are packed straight into the order the leaves list them,
  // with no copy in object order: each must still be the flat pack's primitive, with
  // its own attributes, and the result the same bytes at any thread count.
  const Scene<T> scene = mixed_scene<T>();
  const twinray::PackedScene<T> flat = pack_flat(scene, 1);
  // Each element's bytes, sorted: equal multisets of primitives (with attributes).
  auto sorted_records = [](const auto& prims, const auto* attrs) {
    std::vector<std::vector<unsigned char>> records;
    for (size_t k = 0; k < prims.size(); ++k) {
      const auto* p = reinterpret_cast<const unsigned char*>(&prims[k]);
      std::vector<unsigned char> r(p, p + sizeof prims[k]);
      if (attrs) {
        const auto* a = reinterpret_cast<const unsigned char*>(&(*attrs)[k]);
        r.insert(r.end(), a, a + sizeof(*attrs)[k]);
      }
      records.push_back(std::move(r));
    }
    std::sort(records.begin(), records.end());
    return records;
  };
  REQUIRE(flat.triangle_attrs.size() == flat.triangles.size());
  const auto flat_spheres =
      sorted_records(flat.spheres, static_cast<const decltype(flat.spheres)*>(nullptr));
  const auto flat_triangles = sorted_records(flat.triangles, &flat.triangle_attrs);
  twinray::PackOptions options;
  options.bvh = twinray::BvhPolicy::Always;
  twinray::set_thread_count(1);
  const twinray::PackedScene<T> one = twinray::pack_scene(scene, options);
  twinray::set_thread_count(0);
  REQUIRE((one.features & TR_F_BVH) != 0u);
  REQUIRE(one.triangle_attrs.size() == one.triangles.size());
  CHECK(same_bytes(one.planes, flat.planes));
  CHECK(sorted_records(one.spheres, static_cast<const decltype(one.spheres)*>(nullptr)) ==
        flat_spheres);
  CHECK(sorted_records(one.triangles, &one.triangle_attrs) == flat_triangles);
  CHECK_FALSE(same_bytes(one.triangles, flat.triangles));  // reordered, not object order
  for (int threads : {2, 3}) {
    CAPTURE(threads);
    twinray::set_thread_count(threads);
    const twinray::PackedScene<T> many = twinray::pack_scene(scene, options);
    twinray::set_thread_count(0);
    CHECK(same_bytes(many.spheres, one.spheres));
    CHECK(same_bytes(many.triangles, one.triangles));
    CHECK(same_bytes(many.triangle_attrs, one.triangle_attrs));
    CHECK(same_bytes(many.bvh_prims, one.bvh_prims));
  }
}
