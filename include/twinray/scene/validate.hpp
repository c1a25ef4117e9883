// validate(): refuses a scene, camera or options that cannot render correctly, before
// anything is packed or allocated. Messages name the offending value by the path a
// scene file would use (`objects[3].radius: must be > 0, got -1`).
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>
#include <vector>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <glm/geometric.hpp>

#include <twinray/core/error.hpp>
#include <twinray/core/options.hpp>
#include <twinray/core/parallel.hpp>
#include <twinray/scene/camera.hpp>
#include <twinray/scene/scene.hpp>

namespace twinray {

// Largest image side and pixel count: a framebuffer must fit comfortably in memory
// (limits.max_pixels x 3 x sizeof(double) = 1.5 GiB).
struct Limits {
  static constexpr int max_image_side = 65536;
  static constexpr long long max_pixels = 1ll << 26;
  static constexpr int max_spp = 1 << 16;
  static constexpr int max_depth = 1024;
};

namespace detail {

template <class T>
std::string format_number(T v) {
  std::ostringstream os;
  os.precision(std::is_same<T, float>::value ? 9 : 17);
  os << v;
  return os.str();
}

template <class T>
std::string format_vec(const glm::vec<3, T>& v) {
  return "[" + format_number(v.x) + ", " + format_number(v.y) + ", " + format_number(v.z) + "]";
}

[[noreturn]] inline void refuse(const std::string& path, const std::string& problem) {
  throw invalid_input(path + ": " + problem);
}

// A count that must lie in [1, most].
inline void require_count(const char* path, long long value, long long most) {
  if (value < 1 || value > most)
    refuse(path, "must be in [1, " + std::to_string(most) + "], got " + std::to_string(value));
}

// A path is a string, or a function that makes it: the checks below format a value's
// path only when they refuse it, so validating a million primitives formats no strings.
inline std::string path_text(const std::string& path) {
  return path;
}
template <class MakePath, class = decltype(std::declval<const MakePath&>()())>
std::string path_text(const MakePath& make_path) {
  return make_path();
}

template <class Path, class T>
void require_finite(const Path& path, const glm::vec<3, T>& v) {
  if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
    refuse(path_text(path), "must be finite, got " + format_vec(v));
}

template <class Path, class T>
void require_range(const Path& path, T v, T lo, T hi, bool lo_open = false) {
  bool ok = std::isfinite(v) && (lo_open ? v > lo : v >= lo) && v <= hi;
  if (!ok) {
    std::string want = std::isinf(hi) ? std::string(lo_open ? "> " : ">= ") + format_number(lo)
                                      : "in [" + format_number(lo) + ", " + format_number(hi) + "]";
    refuse(path_text(path), "must be " + want + ", got " + format_number(v));
  }
}

inline std::string at(const std::string& base, size_t i) {
  return base + "[" + std::to_string(i) + "]";
}

// Index triples into an array of `count`: none, or one per triangle; each all valid
// or, where `may_be_absent`, all -1.
inline void validate_corner_indices(const std::string& path,
                                    const std::vector<std::array<int, 3>>& triples,
                                    size_t triangles, size_t count, const char* what) {
  if (triples.empty()) return;
  if (triples.size() != triangles)
    refuse(path, "has " + std::to_string(triples.size()) + " entries for " +
                     std::to_string(triangles) + " triangles");
  for (size_t f = 0; f < triples.size(); ++f) {
    const auto& k = triples[f];
    if (k[0] == -1 && k[1] == -1 && k[2] == -1) continue;
    for (int c = 0; c < 3; ++c)
      if (k[c] < 0 || static_cast<size_t>(k[c]) >= count)
        refuse(at(path, f) + "[" + std::to_string(c) + "]",
               std::string(what) + " index " + std::to_string(k[c]) + " out of range (" +
                   std::to_string(count) + " defined)");
  }
}

// Vertex normals of unit length (to 1e-3: they were normalized in double and rounded),
// finite uvs, per-triangle materials in range.
template <class T>
void validate_mesh_attributes(const std::string& base, const Mesh<T>& m, size_t materials) {
  for (size_t i = 0; i < m.normals.size(); ++i) {
    auto path = [&] { return at(base + ".normals", i); };
    require_finite(path, m.normals[i]);
    double len = glm::length(glm::dvec3(m.normals[i]));
    if (!(std::fabs(len - 1.0) <= 1e-3))
      refuse(path(), "must have unit length, got " + format_vec(m.normals[i]));
  }
  for (size_t i = 0; i < m.uvs.size(); ++i)
    if (!std::isfinite(m.uvs[i].x) || !std::isfinite(m.uvs[i].y))
      refuse(at(base + ".uvs", i), "must be finite, got [" + format_number(m.uvs[i].x) + ", " +
                                       format_number(m.uvs[i].y) + "]");
  validate_corner_indices(base + ".normal_triangles", m.normal_triangles, m.triangles.size(),
                          m.normals.size(), "normal");
  validate_corner_indices(base + ".uv_triangles", m.uv_triangles, m.triangles.size(), m.uvs.size(),
                          "uv");
  if (!m.triangle_materials.empty() && m.triangle_materials.size() != m.triangles.size())
    refuse(base + ".triangle_materials", "has " + std::to_string(m.triangle_materials.size()) +
                                             " entries for " + std::to_string(m.triangles.size()) +
                                             " triangles");
  for (size_t f = 0; f < m.triangle_materials.size(); ++f)
    if (m.triangle_materials[f] < 0 || static_cast<size_t>(m.triangle_materials[f]) >= materials)
      refuse(at(base + ".triangle_materials", f),
             "no material with index " + std::to_string(m.triangle_materials[f]) + " (" +
                 std::to_string(materials) + " defined)");
}

// A texture's size and texels: width x height x 3 values, each in [0, 1] (finite and >= 0
// in a high-dynamic-range one). Returns the number of values.
template <class T>
long long validate_texture(const std::string& base, const Texture<T>& t) {
  if (t.width < 1 || t.height < 1)
    refuse(base, "must be at least 1 x 1 texels, got " + std::to_string(t.width) + " x " +
                     std::to_string(t.height));
  long long values = 3ll * t.width * t.height;
  if (static_cast<long long>(t.texels.size()) != values)
    refuse(base + ".texels", "has " + std::to_string(t.texels.size()) + " values, " +
                                 std::to_string(t.width) + " x " + std::to_string(t.height) +
                                 " texels need " + std::to_string(values));
  const T top = t.hdr ? std::numeric_limits<T>::max() : T(1);
  for (size_t i = 0; i < t.texels.size(); ++i)
    if (!(t.texels[i] >= T(0) && t.texels[i] <= top))
      refuse(at(base + ".texels", i),
             std::string(t.hdr ? "must be finite and >= 0" : "must be in [0, 1]") + ", got " +
                 format_number(t.texels[i]));
  return values;
}

}  // namespace detail

// Each validate() throws twinray::Error(InvalidInput) naming the first bad value, and
// returns normally when everything can be rendered. Pure functions: any thread may call
// them, also on the same object, as long as nobody modifies it meanwhile.

// Camera: image size in [1, Limits::max_image_side] pixels per side and at most
// Limits::max_pixels in all; finite position, look_at and up; up not parallel to the
// view direction; viewplane_height and focal_length (world units) > 0.
template <class T>
void validate(const Camera<T>& camera) {
  using detail::refuse;
  detail::require_count("image.width", camera.width, Limits::max_image_side);
  detail::require_count("image.height", camera.height, Limits::max_image_side);
  if (static_cast<long long>(camera.width) * camera.height > Limits::max_pixels)
    refuse("image", "width x height must be at most " + std::to_string(Limits::max_pixels) +
                        " pixels, got " + std::to_string(camera.width) + " x " +
                        std::to_string(camera.height));
  detail::require_finite("camera.position", camera.position);
  detail::require_finite("camera.look_at", camera.look_at);
  detail::require_finite("camera.up", camera.up);
  glm::vec<3, T> view = camera.look_at - camera.position;
  T view_len = glm::length(view);
  if (!(view_len > T(0)) || !std::isfinite(view_len))
    refuse("camera.look_at",
           "must differ from camera.position, both are " + detail::format_vec(camera.position));
  T up_len = glm::length(camera.up);
  if (!(up_len > T(0)) || !std::isfinite(up_len)) refuse("camera.up", "must be non-zero");
  // sin of the angle between up and the view direction; below ~1e-6 rad the basis
  // U = up x W loses most of its bits.
  T sin_angle = glm::length(glm::cross(camera.up / up_len, view / view_len));
  if (!(sin_angle > T(1e-6)))
    refuse("camera.up", "must not be parallel to look_at - position, got up " +
                            detail::format_vec(camera.up) + " and view direction " +
                            detail::format_vec(view));
  detail::require_range("camera.viewplane_height", camera.viewplane_height, T(0), T(INFINITY),
                        true);
  if (camera.focal_length)
    detail::require_range("camera.focal_length", *camera.focal_length, T(0), T(INFINITY), true);
}

namespace detail {

// An instance's map: finite, affine (last row 0 0 0 1) and invertible, with a finite
// inverse (device/instance.h maps rays by it).
template <class Base>
void validate_instance_map(const Base& base, const glm::dmat4& m) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(m[c][r]))
        refuse(base() + ".transform", "has a value that is not finite (row " + std::to_string(r) +
                                          ", column " + std::to_string(c) + ")");
  if (m[0][3] != 0.0 || m[1][3] != 0.0 || m[2][3] != 0.0 || m[3][3] != 1.0)
    refuse(base() + ".transform", "is not affine: its last row must be 0 0 0 1");
  glm::dmat4 inverse;
  if (!affine_inverse(m, inverse))
    refuse(base() + ".transform", "is singular: it has no inverse to map rays by");
}

// The object at path base() of a scene with `materials` materials and `assets` assets;
// in_asset: an object of an asset, which may be no plane and no instance.
template <class T, class Base>
void validate_object_at(const Object<T>& object, const Base& base, size_t materials, size_t assets,
                        bool in_asset) {
  auto field = [&base](const char* name) { return [&base, name] { return base() + name; }; };
  auto check_material = [&](int material) {
    if (material < 0 || static_cast<size_t>(material) >= materials)
      refuse(base() + ".material", "no material with index " + std::to_string(material) + " (" +
                                       std::to_string(materials) + " defined)");
  };
  if (auto* s = std::get_if<Sphere<T>>(&object)) {
    detail::require_finite(field(".center"), s->center);
    detail::require_range(field(".radius"), s->radius, T(0), T(INFINITY), true);
    check_material(s->material);
  } else if (auto* t = std::get_if<Triangle<T>>(&object)) {
    for (int v = 0; v < 3; ++v)
      detail::require_finite([&] { return base() + ".vertices[" + std::to_string(v) + "]"; },
                             t->vertices[v]);
    check_material(t->material);
  } else if (auto* p = std::get_if<Plane<T>>(&object)) {
    detail::require_finite(field(".point"), p->point);
    detail::require_finite(field(".normal"), p->normal);
    T len = glm::length(p->normal);
    if (!(len > T(0)) || !std::isfinite(len))
      refuse(base() + ".normal", "must be non-zero, got " + detail::format_vec(p->normal));
    check_material(p->material);
  } else if (auto* m = std::get_if<Mesh<T>>(&object)) {
    for (size_t v = 0; v < m->vertices.size(); ++v)
      detail::require_finite([&] { return at(base() + ".vertices", v); }, m->vertices[v]);
    for (size_t f = 0; f < m->triangles.size(); ++f)
      for (int k = 0; k < 3; ++k) {
        int index = m->triangles[f][k];
        if (index < 0 || static_cast<size_t>(index) >= m->vertices.size())
          refuse(at(base() + ".triangles", f) + "[" + std::to_string(k) + "]",
                 "vertex index " + std::to_string(index) + " out of range (" +
                     std::to_string(m->vertices.size()) + " vertices)");
      }
    check_material(m->material);
    detail::validate_mesh_attributes(base(), *m, materials);
  } else if (auto* in = std::get_if<Instance<T>>(&object)) {
    if (in_asset)
      refuse(base(), "is an instance; an asset holds no instances (instances are one level deep)");
    if (in->asset < 0 || static_cast<size_t>(in->asset) >= assets)
      refuse(base() + ".asset", "no asset with index " + std::to_string(in->asset) + " (" +
                                    std::to_string(assets) + " defined)");
    if (in->material != -1) check_material(in->material);
    validate_instance_map(base, in->to_world);
  }
  if (in_asset && std::holds_alternative<Plane<T>>(object))
    refuse(base(),
           "is a plane; an asset holds spheres, triangles and meshes (a plane is "
           "unbounded, so an instance could not be placed in the BVH)");
}

// An object that will be objects[i] of a scene with `materials` materials and `assets`
// assets: finite geometry, radius > 0, non-zero plane normal, indices in range, an
// instance's asset in range and its map invertible. Messages name objects[i]. Programs
// that build a scene piece by piece (the Python module) check each object as it is added.
template <class T>
void validate_object(const Object<T>& object, size_t i, size_t materials, size_t assets = 0) {
  // Paths are made only for a value that is refused (detail::path_text).
  validate_object_at(
      object, [i] { return at("objects", i); }, materials, assets, false);
}

// Object i of the scene (validate_geometry).
template <class T>
void validate_object(const Scene<T>& scene, size_t i) {
  validate_object(scene.objects[i], i, scene.materials.size(), scene.assets.size());
}

// The assets' objects: as the scene's, less planes and instances. Paths name
// assets.NAME[i] (or assets[k] for an asset without a name).
template <class T>
void validate_assets(const Scene<T>& scene) {
  for (size_t k = 0; k < scene.assets.size(); ++k) {
    const Asset<T>& a = scene.assets[k];
    std::string name = a.name.empty() ? at("assets", k) : "assets." + a.name;
    if (a.objects.empty()) refuse(name, "holds no objects");
    for (size_t i = 0; i < a.objects.size(); ++i)
      validate_object_at(
          a.objects[i], [&] { return at(name, i); }, scene.materials.size(), scene.assets.size(),
          true);
  }
}

// materials[i], in a scene of `textures` textures: color channels in [0, 1]; ka, kd, ks
// and shininess >= 0; glaze in [0, 1]; a texture index in range.
template <class T>
void validate_material(const Material<T>& m, size_t i, size_t textures) {
  std::string base = at("materials", i);
  for (int c = 0; c < 3; ++c)
    require_range(base + ".color[" + std::to_string(c) + "]", m.color[c], T(0), T(1));
  require_range(base + ".ka", m.ka, T(0), T(INFINITY));
  require_range(base + ".kd", m.kd, T(0), T(INFINITY));
  require_range(base + ".ks", m.ks, T(0), T(INFINITY));
  require_range(base + ".shininess", m.shininess, T(0), T(INFINITY));
  require_range(base + ".glaze", m.glaze, T(0), T(1));
  require_range(base + ".transmission", m.transmission, T(0), T(1) - m.glaze);
  require_range(base + ".ior", m.ior, T(0), T(INFINITY), true);
  for (int c = 0; c < 3; ++c)
    require_range(base + ".absorption[" + std::to_string(c) + "]", m.absorption[c], T(0),
                  T(INFINITY));
  if (m.texture < -1 || m.texture >= static_cast<int>(textures))
    refuse(base + ".texture", "no texture with index " + std::to_string(m.texture) + " (" +
                                  std::to_string(textures) + " defined)");
}

}  // namespace detail

using detail::validate_material;
using detail::validate_object;

// The environment, where it has a texture: its index in range, a finite rotation, an
// intensity >= 0 whose product with every texel stays finite.
template <class T>
void validate_environment(const Scene<T>& scene) {
  const Environment<T>& e = scene.environment;
  if (e.texture < -1 || e.texture >= static_cast<int>(scene.textures.size()))
    detail::refuse("image.environment.texture",
                   "no texture with index " + std::to_string(e.texture) + " (" +
                       std::to_string(scene.textures.size()) + " defined)");
  if (!e.enabled()) return;
  if (!std::isfinite(e.rotate_degrees))
    detail::refuse("image.environment.rotate_degrees",
                   "must be finite, got " + detail::format_number(e.rotate_degrees));
  detail::require_range("image.environment.intensity", e.intensity, T(0), T(INFINITY));
  detail::require_finite("image.environment.up", e.up);
  if (!(glm::dot(e.up, e.up) > T(0)) || !std::isfinite(glm::dot(e.up, e.up)))
    detail::refuse("image.environment.up",
                   "must be a non-zero vector of finite length, got " + detail::format_vec(e.up));
  T brightest = T(0);
  for (T v : scene.textures[static_cast<size_t>(e.texture)].texels)
    brightest = v > brightest ? v : brightest;
  if (!std::isfinite(brightest * e.intensity))
    detail::refuse("image.environment.intensity", "intensity x the brightest texel overflows: " +
                                                      detail::format_number(e.intensity) + " x " +
                                                      detail::format_number(brightest));
}

// Objects are checked in chunks of this many, on every thread (validate_geometry).
inline constexpr size_t kValidateChunk = 4096;

// Geometry and materials: finite geometry, radii > 0, non-zero plane normals, mesh,
// material and texture indices in range, unit vertex normals, finite uvs, texels in [0, 1];
// material and background colors in [0, 1]; ka, kd, ks and shininess >= 0; glaze in [0, 1].
// `after_chunk(chunk, begin, end)` runs on each chunk of kValidateChunk objects that
// passed, on the thread that checked it, while its objects are still in the caches:
// pack_scene counts the primitives there instead of reading a million objects again.
template <class T, class AfterChunk>
void validate_geometry(const Scene<T>& scene, const AfterChunk& after_chunk) {
  using detail::at;
  using detail::refuse;
  for (int c = 0; c < 3; ++c)
    detail::require_range("image.background[" + std::to_string(c) + "]", scene.background[c], T(0),
                          T(1));
  for (size_t i = 0; i < scene.materials.size(); ++i) {
    const Material<T>& m = scene.materials[i];
    detail::validate_material(m, i, scene.textures.size());
    if (m.texture >= 0 && scene.textures[static_cast<size_t>(m.texture)].hdr)
      refuse(at("materials", i) + ".texture",
             "is a high-dynamic-range image (" +
                 scene.textures[static_cast<size_t>(m.texture)].name +
                 "); a material's texture holds colors in [0, 1]");
  }
  validate_environment(scene);
  detail::validate_assets(scene);
  long long texels = 0;
  for (size_t i = 0; i < scene.textures.size(); ++i)
    texels += detail::validate_texture(at("textures", i), scene.textures[i]);
  // The device code indexes all texels with an int (device/texture.h).
  if (texels > 0x7fffffffll)
    refuse("textures", "hold " + std::to_string(texels) + " values in all, more than 2^31 - 1");
  // Objects in chunks on every thread (a scene of a million spheres is a few hundred
  // MB of objects to read); each chunk stops at its first bad object, and the error
  // of the lowest such chunk is the one reported, so the message does not depend on
  // the thread count.
  constexpr size_t kChunk = kValidateChunk;
  const size_t n_chunks = block_count(scene.objects.size(), kChunk);
  std::vector<std::exception_ptr> errors(n_chunks);
  std::atomic<size_t> first_bad{n_chunks};
  parallel_for_blocks(scene.objects.size(), kChunk, [&](size_t chunk, size_t begin, size_t end) {
    if (first_bad.load(std::memory_order_relaxed) < chunk) return;  // an earlier one failed
    try {
      for (size_t i = begin; i < end; ++i) detail::validate_object(scene, i);
      after_chunk(chunk, begin, end);
    } catch (...) {
      errors[chunk] = std::current_exception();
      size_t seen = first_bad.load();
      while (chunk < seen && !first_bad.compare_exchange_weak(seen, chunk)) {
      }
    }
  });
  const size_t bad = first_bad.load();
  if (bad < n_chunks) std::rethrow_exception(errors[bad]);
}
template <class T>
void validate_geometry(const Scene<T>& scene) {
  validate_geometry(scene, [](size_t, size_t, size_t) {});
}

// Lights: finite positions, intensities and colors >= 0, and a finite product of the two;
// a rect's edges finite and spanning an area, a sphere's radius > 0, an area light's
// samples per side in [1, kMaxLightSamples].
template <class T>
void validate_lights(const std::vector<Light<T>>& lights) {
  using detail::at;
  using detail::refuse;
  for (size_t i = 0; i < lights.size(); ++i) {
    std::string base = at("lights", i);
    const Light<T>& l = lights[i];
    const char* where = l.shape == LightShape::Rect     ? ".corner"
                        : l.shape == LightShape::Sphere ? ".center"
                                                        : ".position";
    detail::require_finite(base + where, l.position);
    if (l.shape == LightShape::Rect) {
      detail::require_finite(base + ".edge1", l.edge1);
      detail::require_finite(base + ".edge2", l.edge2);
      glm::vec<3, T> area = glm::cross(l.edge1, l.edge2);
      if (!(glm::dot(area, area) > T(0)) || !std::isfinite(glm::dot(area, area)))
        refuse(base + ".edge2",
               "must span an area with edge1 (not zero, not parallel to it), got " +
                   detail::format_vec(l.edge1) + " and " + detail::format_vec(l.edge2));
    } else if (l.shape == LightShape::Sphere) {
      detail::require_range(base + ".radius", l.radius, T(0), T(INFINITY), true);
    } else if (l.shape != LightShape::Point) {
      refuse(base + ".type", "unknown light shape " + std::to_string(static_cast<int>(l.shape)));
    }
    if (l.shape != LightShape::Point)
      detail::require_count((base + ".samples").c_str(), l.samples, kMaxLightSamples);
    detail::require_range(base + ".intensity", l.intensity, T(0), T(INFINITY));
    for (int c = 0; c < 3; ++c)
      detail::require_range(base + ".color[" + std::to_string(c) + "]", l.color[c], T(0),
                            T(INFINITY));
    // The renderer uses intensity x color; each factor finite does not make the product.
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(l.intensity * l.color[c]))
        refuse(base + ".intensity", "intensity x color[" + std::to_string(c) + "] overflows " +
                                        (std::is_same<T, float>::value ? "float" : "double") +
                                        ": " + detail::format_number(l.intensity) + " x " +
                                        detail::format_number(l.color[c]));
  }
}

// The whole scene: validate_geometry and validate_lights.
template <class T>
void validate(const Scene<T>& scene) {
  validate_geometry(scene);
  validate_lights(scene.lights);
}

// Options: spp in [1, Limits::max_spp], max_depth in [1, Limits::max_depth], only
// known term bits; adaptive sampling, when on, with more samples than spp and a finite
// threshold >= 0.
inline void validate(const RenderOptions& options) {
  using detail::refuse;
  detail::require_count("render.spp", options.spp, Limits::max_spp);
  detail::require_count("render.max_depth", options.max_depth, Limits::max_depth);
  if ((options.terms & ~unsigned(kAllTerms)) != 0u)
    refuse("render.terms", "unknown term bits " + std::to_string(options.terms));
  if (options.adaptive_spp != 0 &&
      (options.adaptive_spp <= options.spp || options.adaptive_spp > Limits::max_spp))
    refuse("render.adaptive.spp", "must be more than render.spp (" + std::to_string(options.spp) +
                                      ") and at most " + std::to_string(Limits::max_spp) +
                                      ", got " + std::to_string(options.adaptive_spp));
  if (!(options.adaptive_threshold >= 0.0) || !(options.adaptive_threshold < 1e30))
    refuse("render.adaptive.threshold", "must be a finite number >= 0");
}

}  // namespace twinray
