// Packing: the host's scene types turned into the one memory layout both backends read
// (the buffer structs of device/types.h, one flat array per primitive type).
//
// Two parts, so that a frame loop pays only for what changed:
//  - pack_scene(scene): the geometry and materials, with the BVH. Done once per scene;
//    a backend uploads the result once (backend/backend.hpp).
//  - pack_frame(scene, request): camera, lights, options and pixel rectangle, as the
//    TrParams and TrLight arrays of one render. Microseconds; done every frame.
// The Features mask of a render (device/features.h) comes from both parts.
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>

#include <twinray/core/large_array.hpp>
#include <twinray/core/options.hpp>
#include <twinray/core/parallel.hpp>
#include <twinray/device/code.hpp>
#include <twinray/pack/bvh.hpp>
#include <twinray/scene/camera.hpp>
#include <twinray/scene/scene.hpp>
#include <twinray/scene/validate.hpp>

namespace twinray {

// Whether pack_scene builds a BVH: from the measured threshold on (bvh::worth_building),
// always, or never (benchmarks and tests compare the two).
enum class BvhPolicy { Auto, Always, Never };

// How pack_scene builds the BVH: whether, and how many children per node (2, 4 or 8).
// The width changes speed only, never a pixel. Backends say which is fastest on them
// (RenderBackend::preferred_bvh_width); any backend renders any width.
struct PackOptions {
  BvhPolicy bvh = BvhPolicy::Auto;
  int bvh_width = bvh::kCpuWidth;
};

// What a render needs to know of a packed scene besides its arrays: their sizes, the
// background and which features the geometry uses. A backend that has uploaded the
// arrays keeps only this.
template <class T>
struct SceneSummary {
  int n_spheres = 0, n_triangles = 0, n_planes = 0, n_bvh_nodes = 0;
  int n_instances = 0, scene_root = -1, instance_root = -1;
  glm::vec<3, T> background{T(0), T(0), T(0)};
  Environment<T> environment;
  unsigned features = 0;  // the geometry bits of PackedScene::features
  bool any_glazed = false;
  bool any_transmissive = false;
};

// The packed geometry of a scene: what a backend uploads once and keeps across frames.
template <class T>
struct PackedScene {
  using Code = device::Code<T>;
  LargeVector<typename Code::Sphere> spheres;
  LargeVector<typename Code::Triangle> triangles;
  LargeVector<typename Code::Plane> planes;
  LargeVector<typename Code::Material> materials;
  // The BVH (device/types.h, "The BVH"): bvh_width() children per node; empty without one.
  bvh::WideNodes<T> bvh_nodes;
  LargeVector<int> bvh_prims;
  // One per triangle, in the same order, when some mesh has normals or uvs; else empty.
  LargeVector<typename Code::TriangleAttr> triangle_attrs;
  LargeVector<typename Code::Texture> textures;
  LargeVector<T> texels;  // every texture's linear RGB, one after the other
  // For ray queries: each triangle's index in its mesh (0 for a lone triangle), in the
  // triangles' order; and each object's mask, by object index, where some object's is
  // not all ones (TR_F_MASKS), else empty.
  LargeVector<int> triangle_faces;
  LargeVector<unsigned> object_masks;
  // Instances (TR_F_INSTANCES), in the top-level BVH's leaf order; the BVH's nodes
  // hold the scene's own tree (root scene_root: node 0, or -1 without one), each placed
  // asset's, and the top level's (root instance_root; -1 without instances).
  LargeVector<typename Code::Instance> instances;
  int scene_root = -1, instance_root = -1;
  // Each asset's BVH root node and box (-1 and empty for an asset nothing places): what
  // update_instances() rebuilds the top level from.
  std::vector<int> asset_roots;
  std::vector<bvh::Box> asset_boxes;
  glm::vec<3, T> background{T(0), T(0), T(0)};
  Environment<T> environment;  // its texture is one of `textures`
  // Bits of the geometry: TR_F_SPHERES, TR_F_TRIANGLES, TR_F_PLANES, TR_F_BVH2/4/8,
  // TR_F_ATTRIBUTES, TR_F_TEXTURES, TR_F_MASKS.
  unsigned features = 0;
  bool any_glazed = false;        // some material has glaze > 0
  bool any_transmissive = false;  // some material has transmission > 0 (glass)

  SceneSummary<T> summary() const {
    SceneSummary<T> s;
    s.n_spheres = static_cast<int>(spheres.size());
    s.n_triangles = static_cast<int>(triangles.size());
    s.n_planes = static_cast<int>(planes.size());
    s.n_bvh_nodes = bvh_node_count();
    s.n_instances = static_cast<int>(instances.size());
    s.scene_root = scene_root;
    s.instance_root = instance_root;
    s.background = background;
    s.environment = environment;
    s.features = features;
    s.any_glazed = any_glazed;
    s.any_transmissive = any_transmissive;
    return s;
  }

  int bvh_node_count() const { return bvh_nodes.size(); }
  // Children per BVH node (2, 4 or 8); 0 without a BVH.
  int bvh_width() const { return bvh_nodes.empty() ? 0 : bvh_nodes.width(); }
  // Bytes of bvh_nodes before the top level's nodes (node instance_root on), which
  // update_instances() rebuilds; the scene's own tree and the assets' stay. Instances only.
  size_t top_level_offset() const {
    return static_cast<size_t>(instance_root) * bvh::WideNodes<T>::node_bytes(bvh_width());
  }

  // Bytes the arrays hold (what an upload sends).
  size_t bytes() const {
    return spheres.size() * sizeof(spheres[0]) + triangles.size() * sizeof(triangles[0]) +
           planes.size() * sizeof(planes[0]) + materials.size() * sizeof(materials[0]) +
           bvh_nodes.bytes() + bvh_prims.size() * sizeof(int) +
           triangle_attrs.size() * sizeof(typename Code::TriangleAttr) +
           textures.size() * sizeof(typename Code::Texture) + texels.size() * sizeof(T) +
           triangle_faces.size() * sizeof(int) + object_masks.size() * sizeof(unsigned) +
           instances.size() * sizeof(typename Code::Instance);
  }
};

// A pixel rectangle of the frame: columns [x, x + width), rows [y, y + height). The
// default, width or height 0, is the whole frame.
struct PixelRect {
  int x = 0, y = 0, width = 0, height = 0;
  bool whole_frame() const { return width == 0 || height == 0; }
};

// Everything one render takes besides the scene's geometry: the camera, the lights,
// the options (shading switches, the sample plan: spp, sampler, seed and adaptive_spp,
// and the output: the shaded image or one AOV) and the pixel rectangle. A frame loop
// changes any of these freely; the backend neither repacks nor re-uploads the scene.
template <class T>
struct RenderRequest {
  Camera<T> camera;
  std::vector<Light<T>> lights;
  RenderOptions options;
  PixelRect rect;  // default: the whole frame

  RenderRequest() = default;
  RenderRequest(Camera<T> camera_, std::vector<Light<T>> lights_, RenderOptions options_,
                PixelRect rect_ = {})
      : camera(std::move(camera_)),
        lights(std::move(lights_)),
        options(std::move(options_)),
        rect(rect_) {}
};

// The per-render data as the device code reads it.
template <class T>
struct PackedFrame {
  typename device::Code<T>::Params params{};
  std::vector<typename device::Code<T>::Light> lights;
  unsigned features = 0;  // everything this scene and request use (device/features.h)

  typename device::Code<T>::SceneRef ref(const PackedScene<T>& scene) const;
};

// The device code's view of a packed scene, with these parameters and lights.
template <class T>
typename device::Code<T>::SceneRef scene_ref(const PackedScene<T>& scene,
                                             const typename device::Code<T>::Params* params,
                                             const typename device::Code<T>::Light* lights) {
  typename device::Code<T>::SceneRef s;
  s.params = params;
  s.spheres = scene.spheres.data();
  s.triangles = scene.triangles.data();
  s.planes = scene.planes.data();
  s.materials = scene.materials.data();
  s.lights = lights;
  s.bvh_nodes = scene.bvh_nodes.empty() ? nullptr : scene.bvh_nodes.boxes(0);
  s.bvh_prims = scene.bvh_prims.data();
  s.triangle_attrs = scene.triangle_attrs.data();
  s.textures = scene.textures.data();
  s.texels = scene.texels.data();
  s.object_masks = scene.object_masks.data();
  s.triangle_faces = scene.triangle_faces.data();
  s.instances = scene.instances.data();
  return s;
}

template <class T>
typename device::Code<T>::SceneRef PackedFrame<T>::ref(const PackedScene<T>& scene) const {
  return scene_ref(scene, &params, lights.data());
}

// The parameters ray queries read (device/ray_query.h): the scene's counts and its
// geometry's Features bits; no camera, no lights.
template <class T>
typename device::Code<T>::Params query_params(const SceneSummary<T>& ps) {
  typename device::Code<T>::Params p{};
  p.n_spheres = ps.n_spheres;
  p.n_triangles = ps.n_triangles;
  p.n_planes = ps.n_planes;
  p.n_bvh_nodes = ps.n_bvh_nodes;
  p.n_instances = ps.n_instances;
  p.scene_root = ps.scene_root;
  p.instance_root = ps.instance_root;
  p.features = static_cast<int>(ps.features);
  return p;
}

namespace detail {

// Triangle f's vertex normals and uvs, where the mesh gives them.
template <class T, class Attr>
void pack_attributes(const Mesh<T>& m, size_t f, Attr& a) {
  if (!m.normal_triangles.empty() && m.normal_triangles[f][0] >= 0) {
    const auto& k = m.normal_triangles[f];
    const glm::vec<3, T>&n0 = m.normals[k[0]], &n1 = m.normals[k[1]], &n2 = m.normals[k[2]];
    a.n0x = n0.x, a.n0y = n0.y, a.n0z = n0.z;
    a.n1x = n1.x, a.n1y = n1.y, a.n1z = n1.z;
    a.n2x = n2.x, a.n2y = n2.y, a.n2z = n2.z;
    a.flags |= TR_ATTR_NORMALS;
  }
  if (!m.uv_triangles.empty() && m.uv_triangles[f][0] >= 0) {
    const auto& k = m.uv_triangles[f];
    a.u0 = m.uvs[k[0]].x, a.v0 = m.uvs[k[0]].y;
    a.u1 = m.uvs[k[1]].x, a.v1 = m.uvs[k[1]].y;
    a.u2 = m.uvs[k[2]].x, a.v2 = m.uvs[k[2]].y;
    a.flags |= TR_ATTR_UV;
  }
}

}  // namespace detail

namespace detail {

// How many primitives of each kind a run of objects packs into (instances: none).
struct ObjectCounts {
  size_t spheres = 0, triangles = 0, planes = 0;
  bool attributes = false;
};
template <class T>
void count_objects(const std::vector<Object<T>>& objects, size_t begin, size_t end,
                   ObjectCounts& n) {
  for (size_t i = begin; i < end; ++i) {
    const Object<T>& o = objects[i];
    if (std::holds_alternative<Sphere<T>>(o)) ++n.spheres;
    if (std::holds_alternative<Triangle<T>>(o)) ++n.triangles;
    if (std::holds_alternative<Plane<T>>(o)) ++n.planes;
    if (auto* m = std::get_if<Mesh<T>>(&o)) {
      n.triangles += m->triangles.size();
      n.attributes = n.attributes || !m->normal_triangles.empty() || !m->uv_triangles.empty();
    }
  }
}

// The primitives of `objects` (already checked) packed into ps's spheres, triangles
// (with their faces and attributes), planes and, as `bvh` says, BVH. start[c + 1]
// holds the counts of chunk c of kValidateChunk objects (start[0] zeros); each
// primitive's `object` is its object's index in `objects`. Instances are skipped.
template <class T>
void pack_objects(const std::vector<Object<T>>& objects, std::vector<ObjectCounts> start,
                  BvhPolicy bvh, int bvh_width, PackedScene<T>& ps) {
  constexpr size_t kChunk = kValidateChunk;
  const size_t n_objects = objects.size();
  const size_t n_chunks = block_count(n_objects, kChunk);
  bool with_attrs = false;
  for (size_t c = 1; c <= n_chunks; ++c) {
    with_attrs = with_attrs || start[c].attributes;
    start[c].spheres += start[c - 1].spheres;
    start[c].triangles += start[c - 1].triangles;
    start[c].planes += start[c - 1].planes;
  }
  const size_t n_spheres = start[n_chunks].spheres, n_triangles = start[n_chunks].triangles;
  // Every primitive of every object, packed, in chunks of objects on every thread (a big
  // mesh's faces split between the threads too): put_sphere(k, sphere) for the k-th
  // sphere in object order, put_triangle(k, triangle, mesh, face) for the k-th triangle
  // (mesh null for a lone triangle), put_plane(k, plane).
  auto for_each_primitive = [&](const auto& put_sphere, const auto& put_triangle,
                                const auto& put_plane) {
    parallel_for_blocks(n_objects, kChunk, [&](size_t chunk, size_t begin, size_t end) {
      ObjectCounts at = start[chunk];
      for (size_t i = begin; i < end; ++i) {
        const int object = static_cast<int>(i);
        const Object<T>& o = objects[i];
        auto triangle = [object](const glm::vec<3, T>& a, const glm::vec<3, T>& b,
                                 const glm::vec<3, T>& c, int material) {
          return typename device::Code<T>::Triangle{a.x, a.y, a.z, b.x,      b.y,   b.z,
                                                    c.x, c.y, c.z, material, object};
        };
        if (auto* s = std::get_if<Sphere<T>>(&o)) {
          put_sphere(at.spheres++,
                     typename device::Code<T>::Sphere{s->center.x, s->center.y, s->center.z,
                                                      s->radius, s->material, object, 0, 0});
        } else if (auto* t = std::get_if<Triangle<T>>(&o)) {
          put_triangle(at.triangles++,
                       triangle(t->vertices[0], t->vertices[1], t->vertices[2], t->material),
                       static_cast<const Mesh<T>*>(nullptr), size_t(0));
        } else if (auto* p = std::get_if<Plane<T>>(&o)) {
          glm::vec<3, T> n = glm::normalize(p->normal);
          put_plane(at.planes++,
                    typename device::Code<T>::Plane{p->point.x, p->point.y, p->point.z, n.x, n.y,
                                                    n.z, p->material, object});
        } else if (auto* m = std::get_if<Mesh<T>>(&o)) {
          const size_t first = at.triangles;
          parallel_for(static_cast<int>(m->triangles.size()), 8192, [&](int face) {
            const size_t f = static_cast<size_t>(face);
            const auto& v = m->triangles[f];
            put_triangle(first + f,
                         triangle(m->vertices[v[0]], m->vertices[v[1]], m->vertices[v[2]],
                                  m->material_of(f)),
                         m, f);
          });
          at.triangles += m->triangles.size();
        }
      }
    });
  };
  // A triangle into slot `to` of the packed arrays, with its attributes if any.
  auto store_triangle = [&](size_t to, const typename device::Code<T>::Triangle& t,
                            const Mesh<T>* m, size_t f) {
    ps.triangles[to] = t;
    ps.triangle_faces[to] = m ? static_cast<int>(f) : 0;
    if (with_attrs && m) detail::pack_attributes(*m, f, ps.triangle_attrs[to]);
  };
  auto store_plane = [&](size_t k, const typename device::Code<T>::Plane& p) { ps.planes[k] = p; };
  ps.planes.resize(start[n_chunks].planes);

  const bool with_bvh =
      (n_spheres + n_triangles > 0) &&
      (bvh == BvhPolicy::Always ||
       (bvh == BvhPolicy::Auto && bvh::worth_building(static_cast<long long>(n_spheres),
                                                      static_cast<long long>(n_triangles))));
  auto allocate_bounded = [&] {
    ps.spheres.resize(n_spheres);
    ps.triangles.resize(n_triangles);
    ps.triangle_faces.resize(n_triangles);
    if (with_attrs) ps.triangle_attrs.resize(n_triangles);  // flags 0: flat, no uv
  };
  if (!with_bvh) {
    allocate_bounded();
    for_each_primitive([&](size_t k, const auto& s) { ps.spheres[k] = s; }, store_triangle,
                       store_plane);
  } else {
    // The BVH is built from each primitive's box first; the primitives are then placed
    // in the order the leaves list them, so a leaf's primitives lie side by side in
    // memory and a ray that walks the tree reads them in order (hits report the object
    // id stored in the primitive, which moves with it). bvh_prims then runs through
    // each array in order. Spheres and triangles are packed a second time, straight
    // into their slots: no copy in object order. For a million spheres that copy was
    // 32 MB of fresh pages, which cost more than the second pass over the objects where
    // the memory is new to the process (docs/performance.md, "BVH build").
    const int n_sph = static_cast<int>(n_spheres);
    LargeVector<bvh::PrimRef<T>> refs(n_spheres + n_triangles);
    for_each_primitive(
        [&](size_t k, const auto& s) {
          refs[k] = {bvh::primitive_box<T>(s), static_cast<int>(k)};
        },
        [&](size_t k, const auto& t, const Mesh<T>*, size_t) {
          const size_t id = n_spheres + k;
          refs[id] = {bvh::primitive_box<T>(t), static_cast<int>(id)};
        },
        store_plane);
    bvh::Bvh<T> tree = bvh::build<T>(std::move(refs), n_sph, bvh_width);
    // Where each leaf-order primitive goes (a scan), and each primitive id's slot.
    ps.bvh_prims.resize(tree.order.size());
    int sphere_at = 0, triangle_at = 0;
    for (size_t i = 0; i < tree.order.size(); ++i)
      ps.bvh_prims[i] = tree.order[i] < n_sph ? sphere_at++ : n_sph + triangle_at++;
    LargeVector<int> slot(tree.order.size());
    parallel_for(static_cast<int>(tree.order.size()), 8192, [&](int i) {
      slot[static_cast<size_t>(tree.order[static_cast<size_t>(i)])] =
          ps.bvh_prims[static_cast<size_t>(i)];
    });
    // Nothing reads the leaf order past this point: its pages go back to the arrays
    // recycled within the build (core/large_array.hpp), for the primitives' below,
    // where a million spheres' 32 MB had found only 24 kept and faulted the rest in.
    LargeVector<int>().swap(tree.order);
    allocate_bounded();
    for_each_primitive(
        [&](size_t k, const auto& s) { ps.spheres[static_cast<size_t>(slot[k])] = s; },
        [&](size_t k, const auto& t, const Mesh<T>* m, size_t f) {
          store_triangle(static_cast<size_t>(slot[n_spheres + k]) - n_spheres, t, m, f);
        },
        [](size_t, const auto&) {});  // planes: packed above
    ps.bvh_nodes = std::move(tree.nodes);
  }
}

// The counts of `objects`, chunk by chunk (pack_objects' `start`), on this thread.
template <class T>
std::vector<ObjectCounts> object_counts(const std::vector<Object<T>>& objects) {
  const size_t n_chunks = block_count(objects.size(), kValidateChunk);
  std::vector<ObjectCounts> start(n_chunks + 1);
  for (size_t c = 0; c < n_chunks; ++c)
    count_objects(objects, c * kValidateChunk, std::min(objects.size(), (c + 1) * kValidateChunk),
                  start[c + 1]);
  return start;
}

// Appends `from` (one asset, packed by pack_objects with a BVH) to `to`'s spheres,
// triangles and BVH: its primitive ids, leaf positions and node links are moved past
// `to`'s. Returns the node index of its root. Where `to` holds no bounded primitives
// yet, the arrays are moved, not copied.
template <class T>
int append_asset(PackedScene<T>& to, PackedScene<T>&& from) {
  const size_t to_sph = to.spheres.size(), to_tri = to.triangles.size();
  const size_t from_sph = from.spheres.size(), from_tri = from.triangles.size();
  if (to_sph + to_tri == 0 && to.bvh_nodes.empty()) {
    to.spheres = std::move(from.spheres);
    to.triangles = std::move(from.triangles);
    to.triangle_faces = std::move(from.triangle_faces);
    to.triangle_attrs = std::move(from.triangle_attrs);
    to.bvh_prims = std::move(from.bvh_prims);
    to.bvh_nodes = std::move(from.bvh_nodes);
    return 0;
  }
  const int total_sph = static_cast<int>(to_sph + from_sph);
  // Primitive ids: spheres first, then triangles, over both.
  for (size_t i = 0; i < to.bvh_prims.size(); ++i)
    if (to.bvh_prims[i] >= static_cast<int>(to_sph)) to.bvh_prims[i] += static_cast<int>(from_sph);
  const int leaf_base = static_cast<int>(to.bvh_prims.size());
  for (size_t i = 0; i < from.bvh_prims.size(); ++i) {
    const int id = from.bvh_prims[i];
    to.bvh_prims.push_back(id < static_cast<int>(from_sph) ? static_cast<int>(to_sph) + id
                                                           : total_sph + static_cast<int>(to_tri) +
                                                                 (id - static_cast<int>(from_sph)));
  }
  to.spheres.insert(to.spheres.end(), from.spheres.begin(), from.spheres.end());
  to.triangles.insert(to.triangles.end(), from.triangles.begin(), from.triangles.end());
  to.triangle_faces.insert(to.triangle_faces.end(), from.triangle_faces.begin(),
                           from.triangle_faces.end());
  if (!to.triangle_attrs.empty() || !from.triangle_attrs.empty()) {
    to.triangle_attrs.resize(to_tri);  // flags 0 where a side had none
    if (from.triangle_attrs.empty())
      to.triangle_attrs.resize(to_tri + from_tri);
    else
      to.triangle_attrs.insert(to.triangle_attrs.end(), from.triangle_attrs.begin(),
                               from.triangle_attrs.end());
  }
  const int node_base = to.bvh_nodes.size();
  const int width = from.bvh_nodes.width();
  if (to.bvh_nodes.empty()) to.bvh_nodes = bvh::WideNodes<T>(width);
  to.bvh_nodes.resize(static_cast<size_t>(node_base + from.bvh_nodes.size()));
  if (!from.bvh_nodes.empty())
    std::memcpy(to.bvh_nodes.boxes(node_base), from.bvh_nodes.boxes(0), from.bvh_nodes.bytes());
  for (int i = node_base; i < to.bvh_nodes.size(); ++i) {
    int* links = to.bvh_nodes.links(i);
    for (int k = 0; k < width; ++k) {
      if (links[width + k] == 0) links[k] += node_base;
      if (links[width + k] > 0) links[k] += leaf_base;
    }
  }
  return node_base;
}

// The box of the tree whose root is node `root`: its children's boxes together.
template <class T>
bvh::Box tree_box(const bvh::WideNodes<T>& nodes, int root) {
  bvh::Box box;
  const int w = nodes.width();
  const T* b = nodes.boxes(root);
  for (int k = 0; k < w; ++k) {
    if (nodes.links(root)[w + k] < 0) continue;
    for (int a = 0; a < 3; ++a) {
      box.lo[a] = std::min(box.lo[a], double(b[(TR_BVH_MIN_X + a) * w + k]));
      box.hi[a] = std::max(box.hi[a], double(b[(TR_BVH_MAX_X + a) * w + k]));
    }
  }
  return box;
}

// An asset's box placed in the world: its 8 corners mapped in double, and then grown on
// every side by 2^-16 of the coordinates' size. The walk tests this box with the
// world's ray but the asset's primitives with the ray mapped by the rounded inverse
// (device/instance.h), whose rounding moves a hit by a few units in the last place of
// the coordinates: the margin keeps such a hit inside the box.
inline bvh::Box placed_box(const bvh::Box& box, const glm::dmat4& m) {
  bvh::Box out;
  for (int c = 0; c < 8; ++c) {
    glm::dvec4 p(c & 1 ? box.hi[0] : box.lo[0], c & 2 ? box.hi[1] : box.lo[1],
                 c & 4 ? box.hi[2] : box.lo[2], 1.0);
    glm::dvec4 q = m * p;
    double xyz[3] = {q.x, q.y, q.z};
    out.grow(xyz);
  }
  for (int a = 0; a < 3; ++a) {
    double margin = (std::fabs(out.lo[a]) + std::fabs(out.hi[a]) + (out.hi[a] - out.lo[a])) *
                    std::ldexp(1.0, -16);
    out.lo[a] -= margin;
    out.hi[a] += margin;
  }
  return out;
}

// Each asset that an instance of `scene` places, packed once and appended to ps with its
// BVH: ps.asset_roots and ps.asset_boxes (-1 and an empty box for an asset nothing
// places).
template <class T>
void pack_assets(const Scene<T>& scene, int bvh_width, PackedScene<T>& ps) {
  ps.asset_roots.assign(scene.assets.size(), -1);
  ps.asset_boxes.assign(scene.assets.size(), bvh::Box{});
  std::vector<char> used(scene.assets.size(), 0);
  for (const Object<T>& o : scene.objects)
    if (auto* in = std::get_if<Instance<T>>(&o)) used[static_cast<size_t>(in->asset)] = 1;
  for (size_t a = 0; a < scene.assets.size(); ++a) {
    if (!used[a]) continue;
    const std::vector<Object<T>>& objects = scene.assets[a].objects;
    PackedScene<T> piece;
    pack_objects(objects, object_counts(objects), BvhPolicy::Always, bvh_width, piece);
    if (piece.bvh_nodes.empty())
      throw invalid_input((scene.assets[a].name.empty() ? "assets[" + std::to_string(a) + "]"
                                                        : "assets." + scene.assets[a].name) +
                          ": holds no sphere and no triangle, so an instance has nothing to place");
    ps.asset_boxes[a] = tree_box(piece.bvh_nodes, 0);
    ps.asset_roots[a] = append_asset(ps, std::move(piece));
  }
}

// The top-level BVH over the instances' world boxes, appended to ps's nodes (its root:
// ps.instance_root), and ps.instances in its leaf order. The assets are ps's already
// (pack_assets).
template <class T>
void pack_top_level(const Scene<T>& scene, int bvh_width, PackedScene<T>& ps) {
  std::vector<int> object_of;  // the instances' object indices, in object order
  for (size_t i = 0; i < scene.objects.size(); ++i)
    if (std::holds_alternative<Instance<T>>(scene.objects[i]))
      object_of.push_back(static_cast<int>(i));
  const int n = static_cast<int>(object_of.size());
  auto instance = [&](int k) -> const Instance<T>& {
    return std::get<Instance<T>>(
        scene.objects[static_cast<size_t>(object_of[static_cast<size_t>(k)])]);
  };
  // Each instance's world box, on every thread.
  LargeVector<bvh::PrimRef<T>> refs(static_cast<size_t>(n));
  parallel_for(n, 512, [&](int k) {
    const Instance<T>& in = instance(k);
    const bvh::Box& box = ps.asset_boxes[static_cast<size_t>(in.asset)];
    refs[static_cast<size_t>(k)] = {bvh::rounded_box<T>(placed_box(box, in.to_world)), k};
  });
  bvh::Bvh<T> top = bvh::build<T>(std::move(refs), 0, bvh_width);
  // The instances in the leaves' order, with both maps rounded to T once.
  ps.instances.resize(top.order.size());
  parallel_for(static_cast<int>(top.order.size()), 512, [&](int k) {
    const int id = top.order[static_cast<size_t>(k)];
    const Instance<T>& in = instance(id);
    typename device::Code<T>::Instance& d = ps.instances[static_cast<size_t>(k)];
    glm::dmat4 to_object(1.0);
    affine_inverse(in.to_world, to_object);  // checked by validate_object
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) {
        d.to_object[4 * r + c] = static_cast<T>(to_object[c][r]);
        d.to_world[4 * r + c] = static_cast<T>(in.to_world[c][r]);
      }
    d.root = ps.asset_roots[static_cast<size_t>(in.asset)];
    d.object = object_of[static_cast<size_t>(id)];
    d.material = in.material;
    d.mask = in.mask;
  });
  // The top level's nodes after the assets': inner links move with them, leaf links
  // index ps.instances.
  const int node_base = ps.bvh_nodes.size();
  const int w = top.nodes.width();
  if (ps.bvh_nodes.empty()) ps.bvh_nodes = bvh::WideNodes<T>(w);
  ps.bvh_nodes.resize(static_cast<size_t>(node_base + top.nodes.size()));
  std::memcpy(ps.bvh_nodes.boxes(node_base), top.nodes.boxes(0), top.nodes.bytes());
  for (int i = node_base; i < ps.bvh_nodes.size(); ++i) {
    int* links = ps.bvh_nodes.links(i);
    for (int k = 0; k < w; ++k)
      if (links[w + k] == 0) links[k] += node_base;
  }
  ps.instance_root = node_base;
}

}  // namespace detail

// Packs the geometry and materials of `scene` (checked first: validate(scene)), with a
// BVH over its spheres and triangles as `options` say. A scene with instances always
// gets a BVH: each placed asset's, then the top level's over its instances. Lights are
// per frame (pack_frame). Throws InvalidInput for a BVH width other than 2, 4 or 8.
template <class T>
PackedScene<T> pack_scene(const Scene<T>& scene, PackOptions options = {}) {
  if (!bvh::valid_width(options.bvh_width))
    throw invalid_input("bvh_width: " + std::to_string(options.bvh_width) + " is not 2, 4 or 8");
  // The build frees arrays just before it asks for others as large: their pages are
  // reused instead of faulted in afresh (core/large_array.hpp, "Recycling").
  LargeArrayRecycling recycling;
  // Objects in chunks on every thread: first each chunk's counts (a scan gives every
  // chunk its place in each array), then the copies. The arrays list primitives in
  // object order (with a BVH, in the order of its leaves: below), whatever the thread
  // count. Each chunk is counted as it is validated, while its objects are in the
  // caches: for spheres_1e6's 184 MB of objects one pass takes about three quarters of
  // the time of two (bench/twinray_bench.cpp).
  const size_t n_objects = scene.objects.size();
  const size_t n_chunks = block_count(n_objects, kValidateChunk);
  std::vector<detail::ObjectCounts> start(n_chunks + 1);
  std::atomic<bool> any_instance{false};
  validate_geometry(scene, [&](size_t chunk, size_t begin, size_t end) {
    detail::count_objects(scene.objects, begin, end, start[chunk + 1]);
    for (size_t i = begin; i < end; ++i)
      if (std::holds_alternative<Instance<T>>(scene.objects[i])) any_instance = true;
  });
  const bool instances = any_instance.load();
  PackedScene<T> ps;
  ps.background = scene.background;
  ps.environment = scene.environment;
  for (const Material<T>& m : scene.materials) {
    ps.materials.push_back({m.color.x, m.color.y, m.color.z, m.ka, m.kd, m.ks, m.shininess, m.glaze,
                            m.transmission, m.ior, m.absorption.x, m.absorption.y, m.absorption.z,
                            m.texture, 0});
    if (m.glaze > T(0)) ps.any_glazed = true;
    if (m.transmission > T(0)) ps.any_transmissive = true;
  }
  for (const Texture<T>& t : scene.textures) {
    ps.textures.push_back({t.width, t.height, static_cast<int>(ps.texels.size()), 0});
    ps.texels.insert(ps.texels.end(), t.texels.begin(), t.texels.end());
  }
  detail::pack_objects(scene.objects, std::move(start), instances ? BvhPolicy::Always : options.bvh,
                       options.bvh_width, ps);
  ps.scene_root = ps.bvh_nodes.empty() ? -1 : 0;
  if (instances) {
    detail::pack_assets(scene, options.bvh_width, ps);
    detail::pack_top_level(scene, options.bvh_width, ps);
    ps.features |= TR_F_INSTANCES;
  }
  if (!ps.spheres.empty()) ps.features |= TR_F_SPHERES;
  if (!ps.triangles.empty()) ps.features |= TR_F_TRIANGLES;
  if (!ps.planes.empty()) ps.features |= TR_F_PLANES;
  if (!ps.bvh_nodes.empty()) ps.features |= bvh::width_feature(ps.bvh_width());
  if (!ps.triangle_attrs.empty()) ps.features |= TR_F_ATTRIBUTES;
  auto mask_of = [](const Object<T>& o) {
    return std::visit([](const auto& x) { return x.mask; }, o);
  };
  for (const Object<T>& o : scene.objects)
    if (mask_of(o) != 0xffffffffu) ps.features |= TR_F_MASKS;
  if (ps.features & TR_F_MASKS) {
    ps.object_masks.resize(n_objects);
    for (size_t i = 0; i < n_objects; ++i) ps.object_masks[i] = mask_of(scene.objects[i]);
  }
  for (const Material<T>& m : scene.materials)
    if (m.texture >= 0) ps.features |= TR_F_TEXTURES;
  return ps;
}

// The instances of a scene packed by pack_scene moved (their maps, materials or masks
// changed; the same assets, the same objects otherwise): only the top-level BVH and the
// instance array are built again, in place; the assets stay packed. Checks the
// instances first; returns false (and changes nothing) where `ps` holds no instances
// or `scene` has other assets than it was packed with, where pack_scene is the way.
template <class T>
bool update_instances(PackedScene<T>& ps, const Scene<T>& scene) {
  if (!(ps.features & TR_F_INSTANCES) || ps.asset_roots.size() != scene.assets.size()) return false;
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    auto* in = std::get_if<Instance<T>>(&scene.objects[i]);
    if (!in) continue;
    validate_object(scene, i);
    if (ps.asset_roots[static_cast<size_t>(in->asset)] < 0) return false;  // not packed
  }
  const int width = ps.bvh_width();
  LargeArrayRecycling recycling;
  ps.bvh_nodes.resize(static_cast<size_t>(ps.instance_root));  // the assets' nodes stay
  detail::pack_top_level(scene, width, ps);
  return true;
}

template <class T>
PackedScene<T> pack_scene(const Scene<T>& scene, BvhPolicy bvh) {
  PackOptions options;
  options.bvh = bvh;
  return pack_scene(scene, options);
}

// The Features mask of a render: the scene's geometry bits, and what the options,
// lights and environment switch on.
template <class T>
unsigned features_of(const SceneSummary<T>& ps, const std::vector<Light<T>>& lights,
                     const RenderOptions& options) {
  unsigned f = ps.features & ~TR_F_MASKS;  // masks are for ray queries; renders see every object
  if (options.output == Output::Shaded) {
    bool lit = !lights.empty();
    for (const Light<T>& l : lights)
      if (l.shape != LightShape::Point) f |= TR_F_AREA_LIGHTS;
    if (ps.environment.enabled()) f |= TR_F_ENVIRONMENT;
    if (lit && (options.terms & kAmbient)) f |= TR_F_AMBIENT;
    if (lit && (options.terms & kDiffuse)) f |= TR_F_DIFFUSE;
    if (lit && (options.terms & kSpecular)) f |= TR_F_SPECULAR;
    if (options.shadows && (f & (TR_F_DIFFUSE | TR_F_SPECULAR))) f |= TR_F_SHADOWS;
    if (options.glaze && options.max_depth > 1 && ps.any_glazed) f |= TR_F_GLAZE;
    if (ps.any_transmissive) f |= TR_F_DIELECTRIC;
  }
  return f;
}

// The rectangle a request renders: the whole frame when none is given. Throws
// InvalidInput for a rectangle that is not inside the frame.
template <class T>
PixelRect resolve_rect(const RenderRequest<T>& request) {
  const int w = request.camera.width, h = request.camera.height;
  if (request.rect.whole_frame()) return PixelRect{0, 0, w, h};
  const PixelRect& r = request.rect;
  if (r.x < 0 || r.y < 0 || r.width < 0 || r.height < 0 || r.x > w - r.width || r.y > h - r.height)
    throw invalid_input("rect: [" + std::to_string(r.x) + ", " + std::to_string(r.y) + "] + " +
                        std::to_string(r.width) + " x " + std::to_string(r.height) +
                        " is not inside the " + std::to_string(w) + " x " + std::to_string(h) +
                        " frame");
  return r;
}

// Packs one render of the scene `ps` summarizes (checked first: the camera, lights and
// options).
template <class T>
PackedFrame<T> pack_frame(const SceneSummary<T>& ps, const RenderRequest<T>& request) {
  const Camera<T>& camera = request.camera;
  const RenderOptions& options = request.options;
  validate(camera);
  validate_lights(request.lights);
  validate(options);
  const PixelRect rect = resolve_rect(request);
  PackedFrame<T> frame;
  for (const Light<T>& l : request.lights) {
    // Each of an area light's n x n samples carries 1/n^2 of it (device/area_light.h).
    const bool point = l.shape == LightShape::Point;
    const int n = point ? 1 : l.samples;
    glm::vec<3, T> rgb = l.color * l.intensity;
    if (n > 1) rgb = rgb / static_cast<T>(n * n);
    typename device::Code<T>::Light light{};
    light.px = l.position.x, light.py = l.position.y, light.pz = l.position.z;
    light.r = rgb.x, light.g = rgb.y, light.b = rgb.z;
    light.e1x = l.edge1.x, light.e1y = l.edge1.y, light.e1z = l.edge1.z;
    light.e2x = l.edge2.x, light.e2y = l.edge2.y, light.e2z = l.edge2.z;
    light.radius = l.radius;
    light.shape = static_cast<int>(l.shape);
    light.samples = n;
    frame.lights.push_back(light);
  }
  CameraFrame<T> cf = camera.frame();
  auto& p = frame.params;
  p.origin_x = cf.origin.x, p.origin_y = cf.origin.y, p.origin_z = cf.origin.z;
  p.first_pixel_x = cf.first_pixel.x, p.first_pixel_y = cf.first_pixel.y,
  p.first_pixel_z = cf.first_pixel.z;
  p.du_x = cf.du.x, p.du_y = cf.du.y, p.du_z = cf.du.z;
  p.dv_x = cf.dv.x, p.dv_y = cf.dv.y, p.dv_z = cf.dv.z;
  p.ortho_dir_x = cf.ortho_dir.x, p.ortho_dir_y = cf.ortho_dir.y, p.ortho_dir_z = cf.ortho_dir.z;
  p.bg_r = ps.background.x, p.bg_g = ps.background.y, p.bg_b = ps.background.z;
  p.environment = ps.environment.texture;
  if (ps.environment.enabled()) {
    const typename Environment<T>::Frame e = ps.environment.frame();
    p.env_right_x = e.right.x, p.env_right_y = e.right.y, p.env_right_z = e.right.z;
    p.env_up_x = e.up.x, p.env_up_y = e.up.y, p.env_up_z = e.up.z;
    p.env_forward_x = e.forward.x, p.env_forward_y = e.forward.y, p.env_forward_z = e.forward.z;
  }
  p.env_turns = std::fmod(ps.environment.rotate_degrees, T(360)) / T(360);  // exact remainder
  p.env_intensity = ps.environment.intensity;
  p.width = camera.width;
  p.height = camera.height;
  p.rect_x = rect.x, p.rect_y = rect.y, p.rect_w = rect.width, p.rect_h = rect.height;
  p.stats_x = rect.x, p.stats_y = rect.y, p.stats_w = rect.width, p.stats_h = rect.height;
  p.projection = static_cast<int>(camera.projection);
  const bool shaded = options.output == Output::Shaded;
  p.spp = shaded ? options.spp : 1;
  p.sampler = static_cast<int>(options.sampler);
  p.seed = options.seed;
  p.adaptive_spp = shaded ? options.adaptive_spp : 0;
  p.adaptive_threshold = static_cast<T>(options.adaptive_threshold);
  p.max_depth = options.max_depth;
  p.n_spheres = ps.n_spheres;
  p.n_triangles = ps.n_triangles;
  p.n_planes = ps.n_planes;
  p.n_lights = static_cast<int>(frame.lights.size());
  p.n_bvh_nodes = ps.n_bvh_nodes;
  p.n_instances = ps.n_instances;
  p.scene_root = ps.scene_root;
  p.instance_root = ps.instance_root;
  frame.features = features_of(ps, request.lights, options);
  p.features = static_cast<int>(frame.features);
  if (p.adaptive_spp > 0) {
    // The adaptive criterion compares each pixel with its 8 neighbours' first-pass
    // means (device/adaptive.h): the first pass covers the rectangle and a border of
    // one pixel, clipped to the frame, so a rectangle's pixels get the same bits as in
    // a whole-frame render.
    p.stats_x = std::max(0, rect.x - 1);
    p.stats_y = std::max(0, rect.y - 1);
    p.stats_w = std::min(camera.width, rect.x + rect.width + 1) - p.stats_x;
    p.stats_h = std::min(camera.height, rect.y + rect.height + 1) - p.stats_y;
  }
  return frame;
}

}  // namespace twinray
