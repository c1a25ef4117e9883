// pack(): turns Scene<T> + Camera<T> + RenderOptions into the one memory layout both
// backends read (the buffer structs of device/types.h, one flat array per primitive
// type) and the Features mask of what this scene and these options use.
#pragma once

#include <algorithm>
#include <vector>
#include <glm/geometric.hpp>

#include <twinray/core/bvh.hpp>
#include <twinray/core/device_code.hpp>
#include <twinray/core/options.hpp>
#include <twinray/core/validate.hpp>
#include <twinray/scene/camera.hpp>
#include <twinray/scene/scene.hpp>

namespace twinray {

template <class T>
struct PackedScene {
  using Code = device::Code<T>;
  typename Code::Params params{};
  std::vector<typename Code::Sphere> spheres;
  std::vector<typename Code::Triangle> triangles;
  std::vector<typename Code::Plane> planes;
  std::vector<typename Code::Material> materials;
  std::vector<typename Code::Light> lights;
  std::vector<typename Code::BvhNode> bvh_nodes;
  std::vector<int> bvh_prims;
  unsigned features = 0;  // what this scene and these options use (device/features.h)

  typename Code::SceneRef ref() const {
    typename Code::SceneRef s;
    s.params = &params;
    s.spheres = spheres.data();
    s.triangles = triangles.data();
    s.planes = planes.data();
    s.materials = materials.data();
    s.lights = lights.data();
    s.bvh_nodes = bvh_nodes.data();
    s.bvh_prims = bvh_prims.data();
    return s;
  }
};

// Features a render needs, from what was packed and the options.
template <class T>
unsigned features_of(const PackedScene<T>& ps, const RenderOptions& options) {
  unsigned f = 0;
  if (!ps.spheres.empty()) f |= TR_F_SPHERES;
  if (!ps.triangles.empty()) f |= TR_F_TRIANGLES;
  if (!ps.planes.empty()) f |= TR_F_PLANES;
  if (!ps.bvh_nodes.empty()) f |= TR_F_BVH;
  if (options.output == Output::Shaded) {
    bool lit = !ps.lights.empty();
    if (lit && (options.terms & kAmbient)) f |= TR_F_AMBIENT;
    if (lit && (options.terms & kDiffuse)) f |= TR_F_DIFFUSE;
    if (lit && (options.terms & kSpecular)) f |= TR_F_SPECULAR;
    if (options.shadows && (f & (TR_F_DIFFUSE | TR_F_SPECULAR))) f |= TR_F_SHADOWS;
    bool any_glazed =
        std::any_of(ps.materials.begin(), ps.materials.end(),
                    [](const typename device::Code<T>::Material& m) { return m.glaze > T(0); });
    if (options.glaze && options.max_depth > 1 && any_glazed) f |= TR_F_GLAZE;
  }
  return f;
}

template <class T>
PackedScene<T> pack(const Scene<T>& scene, const Camera<T>& camera, const RenderOptions& options) {
  validate(scene);
  validate(camera);
  validate(options);
  PackedScene<T> ps;

  for (const Material<T>& m : scene.materials)
    ps.materials.push_back(
        {m.color.x, m.color.y, m.color.z, m.ka, m.kd, m.ks, m.shininess, m.glaze});
  for (const PointLight<T>& l : scene.lights) {
    glm::vec<3, T> rgb = l.color * l.intensity;
    ps.lights.push_back({l.position.x, l.position.y, l.position.z, rgb.x, rgb.y, rgb.z});
  }
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    int object = static_cast<int>(i);
    const Object<T>& o = scene.objects[i];
    auto add_triangle = [&](const glm::vec<3, T>& a, const glm::vec<3, T>& b,
                            const glm::vec<3, T>& c, int material) {
      ps.triangles.push_back({a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z, material, object});
    };
    if (auto* s = std::get_if<Sphere<T>>(&o)) {
      ps.spheres.push_back(
          {s->center.x, s->center.y, s->center.z, s->radius, s->material, object, 0, 0});
    } else if (auto* t = std::get_if<Triangle<T>>(&o)) {
      add_triangle(t->vertices[0], t->vertices[1], t->vertices[2], t->material);
    } else if (auto* p = std::get_if<Plane<T>>(&o)) {
      glm::vec<3, T> n = glm::normalize(p->normal);
      ps.planes.push_back({p->point.x, p->point.y, p->point.z, n.x, n.y, n.z, p->material, object});
    } else if (auto* m = std::get_if<Mesh<T>>(&o)) {
      for (const auto& f : m->triangles)
        add_triangle(m->vertices[f[0]], m->vertices[f[1]], m->vertices[f[2]], m->material);
    }
  }

  // Spheres and triangles go into a BVH from the measured threshold on (core/bvh.hpp).
  if (bvh::worth_building(static_cast<long long>(ps.spheres.size()),
                          static_cast<long long>(ps.triangles.size())))
    bvh::build(ps, options.threads);

  CameraFrame<T> cf = camera.frame();
  auto& p = ps.params;
  p.origin_x = cf.origin.x, p.origin_y = cf.origin.y, p.origin_z = cf.origin.z;
  p.first_pixel_x = cf.first_pixel.x, p.first_pixel_y = cf.first_pixel.y,
  p.first_pixel_z = cf.first_pixel.z;
  p.du_x = cf.du.x, p.du_y = cf.du.y, p.du_z = cf.du.z;
  p.dv_x = cf.dv.x, p.dv_y = cf.dv.y, p.dv_z = cf.dv.z;
  p.ortho_dir_x = cf.ortho_dir.x, p.ortho_dir_y = cf.ortho_dir.y, p.ortho_dir_z = cf.ortho_dir.z;
  p.bg_r = scene.background.x, p.bg_g = scene.background.y, p.bg_b = scene.background.z;
  p.width = camera.width;
  p.height = camera.height;
  p.projection = static_cast<int>(camera.projection);
  p.spp = options.output == Output::Shaded ? options.spp : 1;
  p.sampler = static_cast<int>(options.sampler);
  p.seed = options.seed;
  p.adaptive_spp = 0;  // backend/adaptive.hpp sets it for its own passes
  p.adaptive_threshold = static_cast<T>(options.adaptive_threshold);
  p.max_depth = options.max_depth;
  p.n_spheres = static_cast<int>(ps.spheres.size());
  p.n_triangles = static_cast<int>(ps.triangles.size());
  p.n_planes = static_cast<int>(ps.planes.size());
  p.n_lights = static_cast<int>(ps.lights.size());
  p.n_bvh_nodes = static_cast<int>(ps.bvh_nodes.size());
  ps.features = features_of(ps, options);
  p.features = static_cast<int>(ps.features);
  return ps;
}

}  // namespace twinray
