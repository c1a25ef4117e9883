// load_scene(): a twinray scene file (JSON, specified in docs/scene-format.md) as the
// core's Scene<T>, Camera<T> and RenderOptions.
//
//   twinray::io::SceneFile<float> f = twinray::io::load_scene<float>("scene.json");
//   twinray::Image<float> image = twinray::render(f.scene, f.camera, f.options);
//
// Strict: every key is known, every value has the right type, length and range, and
// every name and index resolves, or the load throws twinray::Error(InvalidInput) with
// the message `FILE: JSON.PATH: problem`, e.g.
//   scene.json: objects[3].radius: must be > 0, got -1
// Limits (SceneLimits) hold before anything large is allocated: the file size before
// it is read, the nesting depth and the number of JSON values while it is parsed, the
// image size, and the object, vertex and triangle counts before the scene is built.
// docs/scene-format.md ("The checks the loader makes") lists every check.
//
// The JSON reading itself (strict parse, typed values, messages) is io/json_read.hpp;
// the `animation` key is read by io/animation_json.hpp, and parse_animation(file) and
// apply_frame() below play it.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include <twinray/core/error.hpp>
#include <twinray/core/options.hpp>
#include <twinray/scene/animation.hpp>
#include <twinray/scene/camera.hpp>
#include <twinray/scene/scene.hpp>
#include <twinray/scene/transform.hpp>
#include <twinray/scene/validate.hpp>
#include <twinray/io/animation_json.hpp>
#include <twinray/io/json_read.hpp>
#include <twinray/io/obj_mesh.hpp>
#include <twinray/io/obj_model.hpp>
#include <twinray/io/texture_image.hpp>
#include <twinray/scene/mesh_normals.hpp>

namespace twinray {
namespace io {

// The scene format version this loader reads (the file's "twinray" key).
constexpr int kSceneFormatVersion = 1;

// The loader's limits. max_nesting and max_json_values (JsonLimits, io/json_read.hpp)
// hold while the JSON text is parsed.
struct SceneLimits : JsonLimits {
  long long max_file_bytes = 64ll << 20;  // the JSON text
  long long max_objects = 1ll << 20;      // entries of `objects`
  long long max_materials = 1ll << 16;    // named and inline materials
  long long max_lights = 1ll << 16;       // entries of `lights`
  // These three follow the machine's memory (io/obj_mesh.hpp, memory_triangle_limit).
  long long max_mesh_vertices = memory_vertex_limit();      // per mesh, inline or OBJ
  long long max_total_triangles = memory_triangle_limit();  // of all meshes and triangles
  long long max_obj_file_bytes = memory_obj_file_limit();
  // Not a limit but a policy of the same loads: a missing or unreadable .mtl or
  // texture file, or an unknown `usemtl` name, is an error instead of a warning.
  bool strict = false;
};

// Everything a scene file holds.
template <class T>
struct SceneFile {
  Scene<T> scene;
  Camera<T> camera;
  RenderOptions options;  // spp, max_depth, shadows, glaze, terms from `render`
  // Name of each entry of scene.materials: the key in `materials`, or the JSON path of
  // an inline material (`objects[2].material`).
  std::vector<std::string> material_names;
  // The `animation` object as written (null when absent), already checked by the
  // loader; parse_animation(file) below turns it into an Animation<T>.
  nlohmann::ordered_json animation;
  std::string path;  // the file as named by the caller
  // What the load found missing and did without (`spot.obj:2: usemtl red: ...; the
  // default material is used`); the command prints them. Empty with limits.strict.
  std::vector<std::string> warnings;
};

namespace detail {

// Reads the sections of a scene file out of the parsed document, with JsonReader's
// typed values; every failure names the file and the JSON path.
template <class T>
class SceneReader : public JsonReader<T> {
  using Base = JsonReader<T>;

 public:
  using Base::boolean;
  using Base::check_keys;
  using Base::choice;
  using Base::fail;
  using Base::index_path;
  using Base::integer;
  using Base::key_path;
  using Base::number;
  using Base::optional;
  using Base::require;
  using Base::require_array;
  using Base::require_object;
  using Base::scalar;
  using Base::string;
  using Base::vector3;
  using typename Base::vec3;

  SceneReader(std::string file, std::string base_dir, const SceneLimits& limits)
      : Base(std::move(file)), base_dir_(std::move(base_dir)), limits_(limits) {}

  // A color: three numbers in [0, hi].
  vec3 color(const Json& v, const std::string& path, double hi = 1.0) const {
    return vector3(v, path, 0.0, hi);
  }

  // ---- the sections of a scene file ----

  void read(const Json& root, SceneFile<T>& out) {
    require_object(root, "");
    check_keys(root, "",
               {"twinray", "image", "camera", "render", "materials", "lights", "assets", "objects",
                "animation"});
    long long version = integer(require(root, "", "twinray"), "twinray", 0, 1 << 30);
    if (version != kSceneFormatVersion)
      fail("twinray", "unsupported format version " + std::to_string(version) +
                          " (this build reads version " + std::to_string(kSceneFormatVersion) +
                          ")");
    // The image size first: the largest allocation a render makes.
    read_image(require(root, "", "image"), out);
    read_camera(require(root, "", "camera"), out.camera);
    if (const Json* r = optional(root, "render")) read_render(*r, out.options);
    if (const Json* m = optional(root, "materials")) read_materials(*m, out);
    if (const Json* l = optional(root, "lights")) read_lights(*l, out.scene);
    count_obj_uses(root);
    if (const Json* a = optional(root, "assets")) read_assets(*a, out);
    if (const Json* o = optional(root, "objects")) read_objects(*o, out);
    if (const Json* a = optional(root, "animation")) {
      require_object(*a, "animation");
      out.animation = *a;
      read_animation(*this, *a, out.scene, out.camera);  // io/animation_json.hpp
    }
  }

  void read_image(const Json& image, SceneFile<T>& out) {
    require_object(image, "image");
    check_keys(image, "image", {"width", "height", "background", "environment"});
    out.camera.width = static_cast<int>(
        integer(require(image, "image", "width"), "image.width", 1, Limits::max_image_side));
    out.camera.height = static_cast<int>(
        integer(require(image, "image", "height"), "image.height", 1, Limits::max_image_side));
    long long pixels = static_cast<long long>(out.camera.width) * out.camera.height;
    if (pixels > Limits::max_pixels)
      fail("image", "width x height must be at most " + std::to_string(Limits::max_pixels) +
                        " pixels, got " + std::to_string(out.camera.width) + " x " +
                        std::to_string(out.camera.height));
    if (const Json* bg = optional(image, "background"))
      out.scene.background = color(*bg, "image.background");
    if (const Json* e = optional(image, "environment")) read_environment(*e, out.scene);
  }

  // An equirectangular image the rays that hit nothing see (scene/environment.hpp).
  void read_environment(const Json& e, Scene<T>& scene) {
    const std::string path = "image.environment";
    require_object(e, path);
    check_keys(e, path, {"file", "rotate_degrees", "intensity", "up"});
    std::string fpath = key_path(path, "file");
    std::string name = string(require(e, path, "file"), fpath);
    if (name.empty()) fail(fpath, "must name an image file (PNG, JPEG or Radiance HDR)");
    const std::string file = beside_scene(name);
    Environment<T> env;
    if (const Json* r = optional(e, "rotate_degrees"))
      env.rotate_degrees = scalar(*r, key_path(path, "rotate_degrees"));
    if (const Json* k = optional(e, "intensity"))
      env.intensity = scalar(*k, key_path(path, "intensity"), 0.0);
    if (const Json* u = optional(e, "up")) env.up = vector3(*u, key_path(path, "up"));
    Texture<T> texture;
    try {
      texture = load_environment<T>(file);
    } catch (const Error& err) {
      fail(fpath, err.what());
    }
    env.texture = scene.add_texture(texture);
    scene.environment = env;
  }

  void read_camera(const Json& camera, Camera<T>& c) {
    require_object(camera, "camera");
    check_keys(camera, "camera",
               {"projection", "position", "look_at", "up", "focal_length", "viewplane_height"});
    std::string projection = choice(require(camera, "camera", "projection"), "camera.projection",
                                    {"perspective", "orthographic"});
    c.projection = projection == "perspective" ? Projection::Perspective : Projection::Orthographic;
    c.position = vector3(require(camera, "camera", "position"), "camera.position");
    c.look_at = vector3(require(camera, "camera", "look_at"), "camera.look_at");
    c.up = vector3(require(camera, "camera", "up"), "camera.up");
    if (const Json* f = optional(camera, "focal_length"))
      c.focal_length = scalar(*f, "camera.focal_length", 0.0, INFINITY, true);
    if (const Json* h = optional(camera, "viewplane_height"))
      c.viewplane_height = scalar(*h, "camera.viewplane_height", 0.0, INFINITY, true);
    // The geometry checks (look_at != position, up not parallel to the view direction,
    // a basis that stays finite) are the core's, which name the same paths.
    try {
      validate(c);
    } catch (const Error& e) {
      throw invalid_input(this->file() + ": " + e.what());
    }
  }

  void read_render(const Json& render, RenderOptions& o) {
    require_object(render, "render");
    check_keys(render, "render",
               {"spp", "max_depth", "shadows", "glaze", "terms", "sampler", "seed", "adaptive"});
    if (const Json* v = optional(render, "spp"))
      o.spp = static_cast<int>(integer(*v, "render.spp", 1, Limits::max_spp));
    if (const Json* v = optional(render, "max_depth"))
      o.max_depth = static_cast<int>(integer(*v, "render.max_depth", 1, Limits::max_depth));
    if (const Json* v = optional(render, "shadows")) o.shadows = boolean(*v, "render.shadows");
    if (const Json* v = optional(render, "glaze")) o.glaze = boolean(*v, "render.glaze");
    if (const Json* v = optional(render, "terms")) {
      require_array(*v, "render.terms");
      unsigned terms = 0;
      for (size_t i = 0; i < v->size(); ++i) {
        std::string path = index_path("render.terms", i);
        std::string t = choice((*v)[i], path, {"ambient", "diffuse", "specular"});
        unsigned bit = t == "ambient" ? kAmbient : t == "diffuse" ? kDiffuse : kSpecular;
        if (terms & bit) fail(path, "\"" + t + "\" is listed twice");
        terms |= bit;
      }
      o.terms = terms;
    }
    read_sampling(render, o);
  }

  // Sub-pixel sampling (device/sampling.h, device/adaptive.h): "sampler" (grid,
  // stratified, r2), "seed", and "adaptive": {"spp": samples of a refined pixel, more
  // than render.spp; "threshold": contrast above which a pixel is refined, default 1/32}.
  void read_sampling(const Json& render, RenderOptions& o) {
    if (const Json* v = optional(render, "sampler"))
      parse_sampler(choice(*v, "render.sampler", {"grid", "stratified", "r2"}), &o.sampler);
    if (const Json* v = optional(render, "seed"))
      o.seed = static_cast<int>(integer(*v, "render.seed", 0, 2147483647));
    if (const Json* a = optional(render, "adaptive")) {
      require_object(*a, "render.adaptive");
      check_keys(*a, "render.adaptive", {"spp", "threshold"});
      const Json* n = optional(*a, "spp");
      if (!n) fail("render.adaptive.spp", "is required (samples of a refined pixel)");
      o.adaptive_spp = static_cast<int>(integer(*n, "render.adaptive.spp", 2, Limits::max_spp));
      if (o.adaptive_spp <= o.spp)
        fail("render.adaptive.spp", "must be more than render.spp (" + std::to_string(o.spp) + ")");
      if (const Json* t = optional(*a, "threshold"))
        o.adaptive_threshold = scalar(*t, "render.adaptive.threshold", 0.0);
    }
  }

  Material<T> read_material(const Json& m, const std::string& path) {
    require_object(m, path);
    check_keys(
        m, path,
        {"color", "ka", "kd", "ks", "shininess", "glaze", "transmission", "ior", "absorption"});
    Material<T> mat;
    if (const Json* v = optional(m, "color")) mat.color = color(*v, key_path(path, "color"));
    if (const Json* v = optional(m, "ka")) mat.ka = scalar(*v, key_path(path, "ka"), 0.0);
    if (const Json* v = optional(m, "kd")) mat.kd = scalar(*v, key_path(path, "kd"), 0.0);
    if (const Json* v = optional(m, "ks")) mat.ks = scalar(*v, key_path(path, "ks"), 0.0);
    if (const Json* v = optional(m, "shininess"))
      mat.shininess = scalar(*v, key_path(path, "shininess"), 0.0);
    if (const Json* v = optional(m, "glaze"))
      mat.glaze = scalar(*v, key_path(path, "glaze"), 0.0, 1.0);
    if (const Json* v = optional(m, "transmission"))
      mat.transmission = scalar(*v, key_path(path, "transmission"), 0.0, 1.0);
    if (mat.transmission > T(1) - mat.glaze)  // validate_material's test; both keys are given
      fail(key_path(path, "transmission"), "glaze + transmission must be at most 1, got " +
                                               show(*optional(m, "glaze")) + " + " +
                                               show(*optional(m, "transmission")));
    if (const Json* v = optional(m, "ior"))
      mat.ior = scalar(*v, key_path(path, "ior"), 0.0, INFINITY, true);
    if (const Json* v = optional(m, "absorption"))
      mat.absorption = vector3(*v, key_path(path, "absorption"), 0.0);
    return mat;
  }

  void read_materials(const Json& materials, SceneFile<T>& out) {
    require_object(materials, "materials");
    if (static_cast<long long>(materials.size()) > limits_.max_materials)
      fail("materials", "more than " + std::to_string(limits_.max_materials) + " materials");
    for (auto it = materials.begin(); it != materials.end(); ++it) {
      if (it.key().empty()) fail("materials", "a material name must not be empty");
      std::string path = key_path("materials", it.key());
      names_.emplace(it.key(), static_cast<int>(out.scene.materials.size()));
      out.scene.add_material(read_material(it.value(), path));
      out.material_names.push_back(it.key());
    }
  }

  void read_lights(const Json& lights, Scene<T>& scene) {
    require_array(lights, "lights");
    if (static_cast<long long>(lights.size()) > limits_.max_lights)
      fail("lights", std::to_string(lights.size()) + " lights, more than the limit of " +
                         std::to_string(limits_.max_lights));
    for (size_t i = 0; i < lights.size(); ++i) {
      std::string path = index_path("lights", i);
      const Json& l = lights[i];
      require_object(l, path);
      std::string type =
          choice(require(l, path, "type"), key_path(path, "type"), {"point", "rect", "sphere"});
      Light<T> light;
      if (type == "point") {
        check_keys(l, path, {"type", "position", "intensity", "color"});
        light.position = vector3(require(l, path, "position"), key_path(path, "position"));
      } else if (type == "rect") {
        check_keys(l, path, {"type", "corner", "edge1", "edge2", "intensity", "color", "samples"});
        light.shape = LightShape::Rect;
        light.position = vector3(require(l, path, "corner"), key_path(path, "corner"));
        light.edge1 = vector3(require(l, path, "edge1"), key_path(path, "edge1"));
        light.edge2 = vector3(require(l, path, "edge2"), key_path(path, "edge2"));
      } else {
        check_keys(l, path, {"type", "center", "radius", "intensity", "color", "samples"});
        light.shape = LightShape::Sphere;
        light.position = vector3(require(l, path, "center"), key_path(path, "center"));
        light.radius =
            scalar(require(l, path, "radius"), key_path(path, "radius"), 0.0, INFINITY, true);
      }
      if (type != "point") {
        light.samples = kDefaultLightSamples;
        if (const Json* n = optional(l, "samples"))
          light.samples =
              static_cast<int>(integer(*n, key_path(path, "samples"), 1, kMaxLightSamples));
      }
      light.intensity = scalar(require(l, path, "intensity"), key_path(path, "intensity"), 0.0);
      if (const Json* c = optional(l, "color"))
        light.color = color(*c, key_path(path, "color"), INFINITY);
      scene.add_light(light);
    }
  }

  // The index `name` stands for in `names` (a material's or an asset's); refused at
  // `path` with the names `section` defines (and a near miss) where it is not there.
  int named(const std::map<std::string, int>& names, const std::string& name,
            const std::string& path, const char* what, const char* section) {
    auto it = names.find(name);
    if (it != names.end()) return it->second;
    std::vector<std::string> defined;
    for (const auto& n : names) defined.push_back(n.first);
    fail(path, std::string("no ") + what + " named \"" + name + "\"" + suggestion(name, defined) +
                   (defined.empty() ? "; `" + std::string(section) + "` defines none"
                                    : "; defined: " + join(defined)));
  }

  // A material name, or an inline material object.
  int material_ref(const Json& object, const std::string& path, SceneFile<T>& out) {
    std::string mpath = key_path(path, "material");
    const Json& m = require(object, path, "material");
    if (m.is_object()) {
      if (static_cast<long long>(out.scene.materials.size()) >= limits_.max_materials)
        fail(mpath, "more than " + std::to_string(limits_.max_materials) + " materials");
      out.material_names.push_back(mpath);
      return out.scene.add_material(read_material(m, mpath));
    }
    if (!m.is_string())
      fail(mpath, "must be a material name or a material object, got " + kind_of(m));
    return named(names_, m.get<std::string>(), mpath, "material", "materials");
  }

  void count_triangles(long long n, const std::string& path) {
    total_triangles_ += n;
    if (total_triangles_ > limits_.max_total_triangles)
      fail(path, "the scene has more than " + std::to_string(limits_.max_total_triangles) +
                     " triangles in all (the limit)");
  }

  void read_objects(const Json& objects, SceneFile<T>& out) {
    require_array(objects, "objects");
    if (static_cast<long long>(objects.size()) > limits_.max_objects)
      fail("objects", std::to_string(objects.size()) + " objects, more than the limit of " +
                          std::to_string(limits_.max_objects));
    out.scene.objects.reserve(objects.size());
    for (size_t i = 0; i < objects.size(); ++i)
      out.scene.add(read_object(objects[i], index_path("objects", i), out, false));
  }

  // `assets`: {name: an object or a list of objects}, each packed once and placed by
  // instance objects (scene/instance.hpp).
  void read_assets(const Json& assets, SceneFile<T>& out) {
    require_object(assets, "assets");
    for (auto it = assets.begin(); it != assets.end(); ++it) {
      std::string path = key_path("assets", it.key());
      Asset<T> asset;
      asset.name = it.key();
      const Json& v = it.value();
      if (v.is_array()) {
        if (v.empty()) fail(path, "an asset holds at least one object, got an empty list");
        for (size_t i = 0; i < v.size(); ++i)
          asset.objects.push_back(read_object(v[i], index_path(path, i), out, true));
      } else if (v.is_object()) {
        asset.objects.push_back(read_object(v, path, out, true));
      } else {
        fail(path, "must be an object or a list of objects, got " + kind_of(v));
      }
      asset_names_.emplace(it.key(), out.scene.add_asset(asset));
    }
  }

  // One object at `path`, placed by its "transform" when it has one; in_asset: in an
  // asset's list, which takes no planes and no instances.
  Object<T> read_object(const Json& o, const std::string& path, SceneFile<T>& out, bool in_asset) {
    require_object(o, path);
    std::string type = choice(require(o, path, "type"), key_path(path, "type"),
                              {"sphere", "plane", "triangle", "mesh", "instance"});
    if (in_asset && (type == "plane" || type == "instance"))
      fail(key_path(path, "type"),
           type == "plane" ? "an asset holds spheres, triangles and meshes, not planes (a plane is "
                             "unbounded: an instance of it could not be placed)"
                           : "an asset holds no instances (instances are one level deep)");
    if (type == "sphere") {
      check_keys(o, path, {"type", "center", "radius", "material", "transform", "mask"});
      Sphere<T> s;
      s.center = vector3(require(o, path, "center"), key_path(path, "center"));
      s.radius = scalar(require(o, path, "radius"), key_path(path, "radius"), 0.0, INFINITY, true);
      s.material = material_ref(o, path, out);
      s.mask = read_mask(o, path);
      return placed_object(o, path, Object<T>(s));
    }
    if (type == "plane") {
      check_keys(o, path, {"type", "point", "normal", "material", "transform", "mask"});
      Plane<T> p;
      p.point = vector3(require(o, path, "point"), key_path(path, "point"));
      p.normal = vector3(require(o, path, "normal"), key_path(path, "normal"));
      T len = glm::length(p.normal);
      if (!(len > T(0)) || !std::isfinite(len))
        fail(key_path(path, "normal"),
             "must be a non-zero vector of finite length, got " + show(o["normal"]));
      p.material = material_ref(o, path, out);
      p.mask = read_mask(o, path);
      return placed_object(o, path, Object<T>(p));
    }
    if (type == "triangle") {
      check_keys(o, path, {"type", "vertices", "material", "transform", "mask"});
      std::string vpath = key_path(path, "vertices");
      const Json& v = require(o, path, "vertices");
      if (!v.is_array() || v.size() != 3)
        fail(vpath, "must be an array of 3 points, got " + kind_of(v));
      count_triangles(1, path);
      Triangle<T> t;
      for (size_t k = 0; k < 3; ++k) t.vertices[k] = vector3(v[k], index_path(vpath, k));
      t.material = material_ref(o, path, out);
      t.mask = read_mask(o, path);
      return placed_object(o, path, Object<T>(t));
    }
    if (type == "instance") return Object<T>(read_instance(o, path, out));
    return placed_object(o, path, Object<T>(read_mesh(o, path, out)));
  }

  // {"type": "instance", "asset": name, "transform": ..., "material": ..., "mask": ...}.
  Instance<T> read_instance(const Json& o, const std::string& path, SceneFile<T>& out) {
    check_keys(o, path, {"type", "asset", "transform", "material", "mask"});
    std::string apath = key_path(path, "asset");
    const Json& a = require(o, path, "asset");
    if (!a.is_string()) fail(apath, "must be the name of an asset, got " + kind_of(a));
    Instance<T> instance;
    instance.asset = named(asset_names_, a.get<std::string>(), apath, "asset", "assets");
    if (optional(o, "material")) instance.material = material_ref(o, path, out);
    instance.mask = read_mask(o, path);
    if (const Json* t = optional(o, "transform"))
      instance.to_world = read_transform(*t, key_path(path, "transform")).m;
    return instance;
  }

  // The object, placed by its "transform" when it has one (scene/transform.hpp).
  Object<T> placed_object(const Json& o, const std::string& path, Object<T> object) {
    if (const Json* t = optional(o, "transform")) {
      std::string tpath = key_path(path, "transform");
      Transform transform = read_transform(*t, tpath);
      try {
        place(object, transform);
      } catch (const Error& e) {
        fail(tpath, e.what());
      }
    }
    return object;
  }

  // {"translate": [x, y, z], "rotate": {"axis": [x, y, z], "degrees": a}, "scale": s or
  // [sx, sy, sz]} (each optional; applied as scale, rotate, translate), or {"matrix":
  // 4 rows of 4 numbers}.
  Transform read_transform(const Json& t, const std::string& path) const {
    require_object(t, path);
    check_keys(t, path, {"translate", "rotate", "scale", "matrix"});
    auto dvector = [&](const Json& v, const std::string& p) {
      if (!v.is_array() || v.size() != 3)
        fail(p, "must be an array of 3 numbers, got " + kind_of(v));
      return glm::dvec3(number(v[0], index_path(p, 0)), number(v[1], index_path(p, 1)),
                        number(v[2], index_path(p, 2)));
    };
    if (const Json* m = optional(t, "matrix")) {
      std::string mpath = key_path(path, "matrix");
      for (const char* key : {"translate", "rotate", "scale"})
        if (optional(t, key))
          fail(key_path(path, key),
               "a transform takes either \"matrix\" or \"translate\", "
               "\"rotate\" and \"scale\", not both");
      if (!m->is_array() || m->size() != 4)
        fail(mpath, "must be 4 rows of 4 numbers (row-major), got " + kind_of(*m));
      double rows[4][4];
      for (size_t r = 0; r < 4; ++r) {
        std::string rpath = index_path(mpath, r);
        const Json& row = (*m)[r];
        if (!row.is_array() || row.size() != 4)
          fail(rpath, "must be a row of 4 numbers, got " + kind_of(row));
        for (size_t c = 0; c < 4; ++c) rows[r][c] = number(row[c], index_path(rpath, c));
      }
      try {
        return Transform::from_rows(rows);
      } catch (const Error& e) {
        fail(mpath, e.what());
      }
    }
    glm::dvec3 scale(1.0), axis(0.0, 1.0, 0.0), translate(0.0);
    double degrees = 0.0;
    if (const Json* sc = optional(t, "scale")) {
      std::string spath = key_path(path, "scale");
      if (sc->is_number()) {
        double k = number(*sc, spath);
        scale = glm::dvec3(k);
      } else {
        scale = dvector(*sc, spath);
      }
      for (int k = 0; k < 3; ++k)
        if (scale[k] == 0.0)
          fail(spath, "must not be 0: a zero scale flattens the object (a singular transform)");
    }
    if (const Json* r = optional(t, "rotate")) {
      std::string rpath = key_path(path, "rotate");
      require_object(*r, rpath);
      check_keys(*r, rpath, {"axis", "degrees"});
      axis = dvector(require(*r, rpath, "axis"), key_path(rpath, "axis"));
      if (!(glm::length(axis) > 0.0))
        fail(key_path(rpath, "axis"), "must be a non-zero vector, got " + show((*r)["axis"]));
      degrees = number(require(*r, rpath, "degrees"), key_path(rpath, "degrees"));
    }
    if (const Json* tr = optional(t, "translate"))
      translate = dvector(*tr, key_path(path, "translate"));
    try {
      return Transform::scale_rotate_translate(scale, axis, degrees, translate);
    } catch (const Error& e) {
      fail(path, e.what());
    }
  }

  Mesh<T> read_mesh(const Json& o, const std::string& path, SceneFile<T>& out) {
    check_keys(o, path,
               {"type", "vertices", "triangles", "obj", "material", "transform", "normals",
                "crease_angle", "mask"});
    Mesh<T> mesh;
    const Json* obj = optional(o, "obj");
    if (obj) {
      for (const char* key : {"vertices", "triangles"})
        if (optional(o, key))
          fail(key_path(path, key),
               "a mesh takes either \"obj\" or \"vertices\" and "
               "\"triangles\", not both");
      read_obj_model(o, path, *obj, out, mesh);
    } else {
      read_inline_mesh(o, path, mesh);
      mesh.material = material_ref(o, path, out);
    }
    read_normals(o, path, mesh);
    mesh.mask = read_mask(o, path);
    return mesh;
  }

  // `mask`: the object's 32-bit ray-query mask, an integer in [0, 2^32 - 1]; all ones
  // where absent (docs/ray-queries.md).
  uint32_t read_mask(const Json& o, const std::string& path) {
    const Json* m = optional(o, "mask");
    if (!m) return 0xffffffffu;
    if (!m->is_number_unsigned() || m->get<unsigned long long>() > 0xffffffffull)
      fail(key_path(path, "mask"), "must be an integer in [0, 4294967295], got " + show(*m));
    return static_cast<uint32_t>(m->get<unsigned long long>());
  }

  // `normals`: "file" (the OBJ's vn where given, else flat), "flat" or "smooth" (with
  // `crease_angle`, degrees, default 60).
  void read_normals(const Json& o, const std::string& path, Mesh<T>& mesh) {
    std::string mode = "file";
    if (const Json* n = optional(o, "normals"))
      mode = choice(*n, key_path(path, "normals"), {"file", "flat", "smooth"});
    const Json* crease = optional(o, "crease_angle");
    if (crease && mode != "smooth")
      fail(key_path(path, "crease_angle"),
           "applies to \"normals\": \"smooth\" only (normals are \"" + mode + "\")");
    if (mode == "flat") flat_normals(mesh);
    if (mode == "smooth") {
      double degrees = 60.0;
      if (crease) {
        std::string cpath = key_path(path, "crease_angle");
        degrees = number(*crease, cpath);
        if (!(degrees >= 0.0 && degrees <= 180.0))
          fail(cpath, "must be in [0, 180] degrees, got " + show(*crease));
      }
      smooth_normals(mesh, degrees);
    }
  }

  // A mesh from an OBJ file, with its MTL materials and textures unless `material`
  // overrides them all. Faces without a usable `usemtl`, and a file without materials,
  // take the default material (Material<T>{}).
  void read_obj_model(const Json& o, const std::string& path, const Json& obj, SceneFile<T>& out,
                      Mesh<T>& mesh) {
    std::string opath = key_path(path, "obj");
    std::string name = string(obj, opath);
    if (name.empty()) fail(opath, "must name an .obj file");
    const std::string file = beside_scene(name);
    const bool overridden = optional(o, "material") != nullptr;
    // A file named again is not read again: its mesh (and, unless overridden, the
    // materials adopted from it) comes from the first read, moved out at its last use.
    const std::string key = obj_key(file, overridden);
    auto uses = obj_uses_.find(key);
    if (auto kept = obj_meshes_.find(key); kept != obj_meshes_.end()) {
      count_triangles(static_cast<long long>(kept->second.triangles.size()), opath);
      const bool last = uses == obj_uses_.end() || --uses->second <= 0;
      mesh = last ? std::move(kept->second) : kept->second;
      if (last) obj_meshes_.erase(kept);
      if (overridden) mesh.material = material_ref(o, path, out);
      return;
    }
    read_obj_file(o, path, file, name, overridden, out, mesh);
    if (uses != obj_uses_.end() && --uses->second > 0) {
      Mesh<T> kept = mesh;
      if (overridden) kept.material = -1;
      obj_meshes_.emplace(key, std::move(kept));
    }
  }

  void read_obj_file(const Json& o, const std::string& path, const std::string& file,
                     const std::string& name, bool overridden, SceneFile<T>& out, Mesh<T>& mesh) {
    const std::string opath = key_path(path, "obj");
    ObjModelOptions options;
    options.limits.max_file_bytes = limits_.max_obj_file_bytes;
    options.limits.max_vertices = limits_.max_mesh_vertices;
    options.limits.max_triangles = limits_.max_total_triangles - total_triangles_;
    options.strict = limits_.strict;
    // A `material` key overrides the file's materials: their files are not read.
    options.materials = !overridden;
    ObjModel<T> model;
    try {
      model = load_obj_model<T>(file, options);
    } catch (const Error& e) {
      fail(opath, e.what());
    }
    count_triangles(static_cast<long long>(model.mesh.triangles.size()), opath);
    if (overridden) {
      mesh = std::move(model.mesh);
      mesh.triangle_materials.clear();
      mesh.material = material_ref(o, path, out);
      return;
    }
    for (const std::string& w : model.warnings) out.warnings.push_back(w);
    if (static_cast<long long>(out.scene.materials.size() + model.materials.size()) + 1 >
        limits_.max_materials)
      fail(opath, "more than " + std::to_string(limits_.max_materials) + " materials");
    mesh = adopt_obj_model(std::move(model), out.scene, name, &out.material_names);
  }

  void read_inline_mesh(const Json& o, const std::string& path, Mesh<T>& mesh) {
    std::string vpath = key_path(path, "vertices"), tpath = key_path(path, "triangles");
    const Json& v = require(o, path, "vertices");
    const Json& t = require(o, path, "triangles");
    require_array(v, vpath);
    require_array(t, tpath);
    if (static_cast<long long>(v.size()) > limits_.max_mesh_vertices)
      fail(vpath, std::to_string(v.size()) + " vertices, more than the limit of " +
                      std::to_string(limits_.max_mesh_vertices));
    if (v.empty()) fail(vpath, "must hold at least 3 points, got none");
    if (t.empty()) fail(tpath, "must hold at least one index triple, got none");
    count_triangles(static_cast<long long>(t.size()), tpath);
    mesh.vertices.reserve(v.size());
    for (size_t k = 0; k < v.size(); ++k)
      mesh.vertices.push_back(vector3(v[k], index_path(vpath, k)));
    mesh.triangles.reserve(t.size());
    long long n = static_cast<long long>(v.size());
    for (size_t f = 0; f < t.size(); ++f) {
      std::string fpath = index_path(tpath, f);
      const Json& tri = t[f];
      if (!tri.is_array() || tri.size() != 3)
        fail(fpath, "must be an array of 3 vertex indices, got " + kind_of(tri));
      std::array<int, 3> indices{};
      for (size_t k = 0; k < 3; ++k) {
        std::string ipath = index_path(fpath, k);
        const Json& index = tri[k];
        if (index.is_number_integer() &&
            (index.is_number_unsigned() || index.get<long long>() >= 0) &&
            index.get<unsigned long long>() >= static_cast<unsigned long long>(n))
          fail(ipath, "vertex index " + show(index) + " out of range: the mesh has " +
                          std::to_string(n) + " vertices (indices 0 to " + std::to_string(n - 1) +
                          ")");
        indices[k] = static_cast<int>(integer(index, ipath, 0, n - 1));
      }
      mesh.triangles.push_back(indices);
    }
  }

 private:
  // A file the scene names (an OBJ, an environment image): an absolute path as it is,
  // else relative to the scene's folder.
  std::string beside_scene(const std::string& name) const {
    return name[0] == '/' || base_dir_.empty() ? name : base_dir_ + "/" + name;
  }

  // An OBJ file read with or without its materials, by the file it is (two spellings
  // of one path are one key).
  static std::string obj_key(const std::string& file, bool overridden) {
    std::error_code ec;
    std::filesystem::path canonical = std::filesystem::weakly_canonical(file, ec);
    return (ec ? file : canonical.string()) + (overridden ? "\n" : "\n+materials");
  }

  // How many objects and assets name each OBJ file, so that a file named more than once
  // is kept after its first read, and only until its last use. Entries that are not
  // well formed are skipped here; reading them reports the error.
  void count_obj_uses(const Json& root) {
    auto count = [&](const Json& o) {
      if (!o.is_object()) return;
      auto obj = o.find("obj");
      if (obj == o.end() || !obj->is_string() || obj->template get<std::string>().empty()) return;
      ++obj_uses_[obj_key(beside_scene(obj->template get<std::string>()), o.contains("material"))];
    };
    if (const Json* objects = optional(root, "objects"); objects && objects->is_array())
      for (const Json& o : *objects) count(o);
    if (const Json* assets = optional(root, "assets"); assets && assets->is_object())
      for (const auto& [name, a] : assets->items()) {
        if (a.is_array())
          for (const Json& o : a) count(o);
        else
          count(a);
      }
  }

  std::string base_dir_;
  const SceneLimits& limits_;
  std::map<std::string, int> names_;
  std::map<std::string, int> asset_names_;
  long long total_triangles_ = 0;
  std::map<std::string, int> obj_uses_;        // obj_key -> objects and assets naming it
  std::map<std::string, Mesh<T>> obj_meshes_;  // obj_key -> mesh of a file named again
};

inline std::string parent_folder(const std::string& path) {
  size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return "";
  return slash == 0 ? "/" : path.substr(0, slash);
}

}  // namespace detail

// Reads a scene from JSON text. `file` names it in messages; relative `obj` paths are
// resolved against `base_dir` (empty: the current folder).
template <class T>
SceneFile<T> parse_scene(const std::string& text, const std::string& file,
                         const std::string& base_dir = "", const SceneLimits& limits = {}) {
  if (static_cast<long long>(text.size()) > limits.max_file_bytes)
    throw invalid_input(file + ": " + std::to_string(text.size()) +
                        " bytes, more than the limit of " + std::to_string(limits.max_file_bytes));
  detail::Json root = detail::parse_json(text, file, limits);
  SceneFile<T> out;
  out.path = file;
  detail::SceneReader<T> reader(file, base_dir, limits);
  reader.read(root, out);
  // The core's own checks, as a last line: the loader's are a superset, so this only
  // fires if the two ever disagree.
  try {
    validate(out.scene);
    validate(out.options);
  } catch (const Error& e) {
    throw invalid_input(file + ": " + e.what());
  }
  return out;
}

// The text of a scene file, size-checked before it is read: what load_scene() parses.
// A program that reads the file in one place and parses it in several (the ranks of
// an MPI job) passes it on to parse_scene(text, path, scene_folder(path)).
inline std::string read_scene_text(const std::string& path, const SceneLimits& limits = {}) {
  return detail::read_small_file(path, limits.max_file_bytes, "a scene file");
}

// The folder that relative `obj` paths of the scene file `path` are resolved against.
inline std::string scene_folder(const std::string& path) {
  return detail::parent_folder(path);
}

// Reads a scene file (size-checked before it is read).
template <class T>
SceneFile<T> load_scene(const std::string& path, const SceneLimits& limits = {}) {
  return parse_scene<T>(read_scene_text(path, limits), path, scene_folder(path), limits);
}

// The file's animation; a file without an `animation` key gets InvalidInput.
template <class T>
Animation<T> parse_animation(const SceneFile<T>& file) {
  if (file.animation.is_null())
    throw invalid_input(file.path + ": has no animation (no \"animation\" key)");
  return parse_animation(file.animation, file.path, file.scene, file.camera);
}

// Replaces the file's scene and camera with those of frame `frame`, which must be one
// of the animation's frames (0 to frames - 1).
template <class T>
void apply_frame(SceneFile<T>& file, long long frame) {
  Animation<T> anim = parse_animation(file);
  if (frame < 0 || frame >= anim.frames)
    throw invalid_input(file.path + ": animation.frames: frame " + std::to_string(frame) +
                        " is not in the animation, which has " + std::to_string(anim.frames) +
                        " frames (0 to " + std::to_string(anim.frames - 1) + ")");
  Frame<T> f = animate(file.scene, file.camera, anim, frame);
  file.scene = std::move(f.scene);
  file.camera = f.camera;
}

}  // namespace io
}  // namespace twinray
