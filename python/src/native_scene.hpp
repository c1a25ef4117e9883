// NativeScene: the C++ side of twinray.Scene. A scene is kept as the steps that made it
// (a scene file, materials, objects, OBJ files), with numbers in double as Python gives
// them, and is built as a Scene<T> for a tracer's precision by replaying those steps. A
// scene file or OBJ file is then read in T exactly as `twinray render` reads it, and an
// object is rounded to T before its transform is applied, as the scene loader does; so
// a scene built in code and the same scene written as JSON pack to the same bits.
#pragma once

#include <atomic>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include <twinray/io/obj_model.hpp>
#include <twinray/io/scene_json.hpp>
#include <twinray/scene/transform.hpp>
#include <twinray/scene/validate.hpp>

namespace twinray_python {

using twinray::Material;
using twinray::Object;
using twinray::Transform;

// An object rounded from double to T, field by field.
template <class T>
glm::vec<3, T> rounded(const glm::dvec3& v) {
  return glm::vec<3, T>(static_cast<T>(v.x), static_cast<T>(v.y), static_cast<T>(v.z));
}

template <class T>
Material<T> rounded(const Material<double>& m) {
  Material<T> out;
  out.color = rounded<T>(m.color);
  out.ka = static_cast<T>(m.ka);
  out.kd = static_cast<T>(m.kd);
  out.ks = static_cast<T>(m.ks);
  out.shininess = static_cast<T>(m.shininess);
  out.glaze = static_cast<T>(m.glaze);
  out.transmission = static_cast<T>(m.transmission);
  out.ior = static_cast<T>(m.ior);
  out.absorption = rounded<T>(m.absorption);
  out.texture = m.texture;
  return out;
}

// The objects Python adds: spheres, planes, triangles and meshes of vertices and index
// triples (no normals or uvs: those come with OBJ files).
template <class T>
Object<T> rounded(const Object<double>& object) {
  if (auto* s = std::get_if<twinray::Sphere<double>>(&object))
    return twinray::Sphere<T>{rounded<T>(s->center), static_cast<T>(s->radius), s->material,
                              s->mask};
  if (auto* p = std::get_if<twinray::Plane<double>>(&object))
    return twinray::Plane<T>{rounded<T>(p->point), rounded<T>(p->normal), p->material, p->mask};
  if (auto* t = std::get_if<twinray::Triangle<double>>(&object)) {
    twinray::Triangle<T> out;
    for (int k = 0; k < 3; ++k) out.vertices[k] = rounded<T>(t->vertices[k]);
    out.material = t->material;
    out.mask = t->mask;
    return out;
  }
  if (auto* in = std::get_if<twinray::Instance<double>>(&object)) {
    twinray::Instance<T> out;
    out.asset = in->asset;
    out.to_world = in->to_world;  // a map stays in double (scene/instance.hpp)
    out.material = in->material;
    out.mask = in->mask;
    return out;
  }
  const auto& m = std::get<twinray::Mesh<double>>(object);
  twinray::Mesh<T> out;
  out.vertices.resize(m.vertices.size());
  for (size_t i = 0; i < m.vertices.size(); ++i) out.vertices[i] = rounded<T>(m.vertices[i]);
  out.triangles = m.triangles;
  out.material = m.material;
  out.mask = m.mask;
  return out;
}

// asset: the asset the object goes into (Scene::assets), -1 for the scene's objects.
struct ObjectStep {
  Object<double> object;
  std::optional<Transform> transform;
  int asset = -1;
};

struct ObjFileStep {
  std::string path;
  int material = -1;  // overrides the file's materials; -1: the file's own
  std::optional<Transform> transform;
  uint32_t mask = 0xffffffffu;
  int asset = -1;
};

struct AssetStep {
  std::string name;
};

class NativeScene {
 public:
  // The scene file's objects, materials, camera, lights and options come first; objects
  // added later follow them. Only an empty scene loads a file.
  void load(const std::string& path) {
    if (!steps_.empty() || !path_.empty())
      throw twinray::invalid_input(
          "Scene.load: the scene already has objects; load a file into "
          "a new Scene");
    file_ = twinray::io::load_scene<double>(path);
    path_ = path;
    materials_ = file_.scene.materials.size();
    objects_ = file_.scene.objects.size();
    background_ = file_.scene.background;
    bump();
  }

  int add_material(const Material<double>& m) {
    twinray::validate_material(m, materials_, 0);
    steps_.emplace_back(m);
    bump();
    return static_cast<int>(materials_++);
  }

  // A new empty asset (scene/instance.hpp): objects added with its index go into it, and
  // instances place it. Returns its index.
  int add_asset(const std::string& name) {
    steps_.emplace_back(AssetStep{name});
    asset_names_.push_back(name);
    asset_sizes_.push_back(0);
    bump();
    return static_cast<int>(asset_names_.size()) - 1;
  }
  size_t asset_count() const { return asset_names_.size(); }

  // An object whose material is -1 takes the scene's default material (Material{}),
  // added with the first such object that is valid. With asset >= 0 the object goes
  // into that asset (no planes, no instances there) and its index there is returned;
  // else its object index. An instance keeps material -1: its asset's own.
  int add_object(Object<double> object, std::optional<Transform> transform, int asset = -1) {
    const bool instance = std::holds_alternative<twinray::Instance<double>>(object);
    int& material = std::visit([](auto& o) -> int& { return o.material; }, object);
    const bool new_default = !instance && material == -1 && default_material_ < 0;
    if (!instance && material == -1) material = new_default ? int(materials_) : default_material_;
    const size_t materials = materials_ + (new_default ? 1 : 0);
    std::string path = twinray::detail::at("objects", objects_);
    if (asset >= 0) {
      if (static_cast<size_t>(asset) >= asset_names_.size())
        throw twinray::invalid_input("asset: no asset with index " + std::to_string(asset) + " (" +
                                     std::to_string(asset_names_.size()) + " defined)");
      const std::string& name = asset_names_[static_cast<size_t>(asset)];
      path = twinray::detail::at(name.empty()
                                     ? twinray::detail::at("assets", static_cast<size_t>(asset))
                                     : "assets." + name,
                                 asset_sizes_[static_cast<size_t>(asset)]);
    }
    twinray::detail::validate_object_at(
        object, [&] { return path; }, materials, asset_names_.size(), asset >= 0);
    if (transform) {  // a transform a sphere cannot take, or a result out of range
      Object<double> placed = object;
      try {
        twinray::place(placed, *transform);
      } catch (const twinray::Error& e) {
        throw twinray::invalid_input(path + ".transform: " + e.what());
      }
      if (auto* in = std::get_if<twinray::Instance<double>>(&placed))
        twinray::detail::validate_instance_map([&] { return path; }, in->to_world);
    }
    if (new_default) {
      steps_.emplace_back(Material<double>{});
      default_material_ = static_cast<int>(materials_++);
    }
    steps_.emplace_back(ObjectStep{std::move(object), transform, asset});
    bump();
    if (asset >= 0) return static_cast<int>(asset_sizes_[static_cast<size_t>(asset)]++);
    return static_cast<int>(objects_++);
  }

  // Reads the file now, to check it and count its materials; it is read again in the
  // tracer's precision when a tracer packs the scene. Returns the loader's warnings.
  std::vector<std::string> add_obj(const std::string& path, int material,
                                   std::optional<Transform> transform, uint32_t mask, int* index,
                                   int asset = -1) {
    if (asset >= static_cast<int>(asset_names_.size()))
      throw twinray::invalid_input("asset: no asset with index " + std::to_string(asset) + " (" +
                                   std::to_string(asset_names_.size()) + " defined)");
    if (material < -1 || material >= static_cast<int>(materials_))
      throw twinray::invalid_input(twinray::detail::at("objects", objects_) +
                                   ".material: no material with index " + std::to_string(material) +
                                   " (" + std::to_string(materials_) + " defined)");
    twinray::io::ObjModelOptions options;
    options.materials = material < 0;
    twinray::io::ObjModel<double> model = twinray::io::load_obj_model<double>(path, options);
    std::vector<std::string> warnings = model.warnings;
    const size_t added = material < 0 ? twinray::io::adopted_material_count(model) : 0;
    ObjFileStep step{path, material, transform, mask, asset};
    steps_.emplace_back(step);
    materials_ += added;
    *index = asset >= 0 ? static_cast<int>(asset_sizes_[static_cast<size_t>(asset)]++)
                        : static_cast<int>(objects_++);
    bump();
    return warnings;
  }

  void set_background(const glm::dvec3& color) {
    for (int c = 0; c < 3; ++c)
      twinray::detail::require_range("background[" + std::to_string(c) + "]", color[c], 0.0, 1.0);
    background_ = color;
    bump();
  }
  glm::dvec3 background() const { return background_; }

  // An environment image (PNG, JPEG or Radiance HDR), read now to check it and again in
  // the tracer's precision; an empty path removes the environment.
  void set_environment(const std::string& path, double rotate_degrees, double intensity,
                       const glm::dvec3& up) {
    EnvironmentStep step{path, rotate_degrees, intensity, up};
    if (!path.empty()) {
      twinray::Scene<double> check;
      check.environment = step.placed(check, twinray::io::load_environment<double>(path));
      twinray::validate_environment(check);
    }
    environment_ = step;
    bump();
  }
  // The environment set here, or the file's (path empty where there is none).
  std::string environment_file() const {
    if (environment_) return environment_->path;
    const auto& e = file_.scene.environment;
    return e.enabled() ? file_.scene.textures[static_cast<size_t>(e.texture)].name : "";
  }

  // The scene file as read in double: its camera, lights and render options.
  const twinray::io::SceneFile<double>& file() const { return file_; }
  size_t material_count() const { return materials_; }
  size_t object_count() const { return objects_; }
  // Changes on every edit of what a tracer packs (not the camera or the lights, which
  // Python keeps and passes with each render); unique across scenes.
  long long version() const { return version_; }

  // The scene in T, built by replaying the steps.
  template <class T>
  twinray::Scene<T> build() const {
    twinray::Scene<T> scene;
    if (!path_.empty()) scene = twinray::io::load_scene<T>(path_).scene;
    scene.lights.clear();  // Python passes the lights with each render
    scene.background = rounded<T>(background_);
    if (environment_)
      scene.environment =
          environment_->path.empty()
              ? twinray::Environment<T>{}
              : environment_->placed(scene, twinray::io::load_environment<T>(environment_->path));
    for (const Step& step : steps_) {
      if (auto* m = std::get_if<Material<double>>(&step)) {
        scene.add_material(rounded<T>(*m));
      } else if (auto* o = std::get_if<ObjectStep>(&step)) {
        Object<T> object = rounded<T>(o->object);
        if (o->transform) twinray::place(object, *o->transform);
        add_to(scene, o->asset, std::move(object));
      } else if (auto* a = std::get_if<AssetStep>(&step)) {
        twinray::Asset<T> asset;
        asset.name = a->name;
        scene.add_asset(asset);
      } else {
        const auto& f = std::get<ObjFileStep>(step);
        twinray::io::ObjModelOptions options;
        options.materials = f.material < 0;
        auto model = twinray::io::load_obj_model<T>(f.path, options);
        twinray::Mesh<T> mesh;
        if (f.material >= 0) {
          mesh = std::move(model.mesh);
          mesh.triangle_materials.clear();
          mesh.material = f.material;
        } else {
          mesh = twinray::io::adopt_obj_model(std::move(model), scene, f.path);
        }
        mesh.mask = f.mask;
        Object<T> object(std::move(mesh));
        if (f.transform) twinray::place(object, *f.transform);
        add_to(scene, f.asset, std::move(object));
      }
    }
    return scene;
  }

 private:
  using Step = std::variant<Material<double>, ObjectStep, ObjFileStep, AssetStep>;

  template <class T>
  static void add_to(twinray::Scene<T>& scene, int asset, Object<T> object) {
    if (asset < 0)
      scene.add(std::move(object));
    else
      scene.assets[static_cast<size_t>(asset)].objects.push_back(std::move(object));
  }

  struct EnvironmentStep {
    std::string path;
    double rotate_degrees = 0, intensity = 1;
    glm::dvec3 up{0.0, 1.0, 0.0};

    // The environment of `texture`, added to the scene.
    template <class T>
    twinray::Environment<T> placed(twinray::Scene<T>& scene, twinray::Texture<T> texture) const {
      twinray::Environment<T> e;
      e.texture = scene.add_texture(std::move(texture));
      e.rotate_degrees = static_cast<T>(rotate_degrees);
      e.intensity = static_cast<T>(intensity);
      e.up = glm::vec<3, T>(up);
      return e;
    }
  };

  void bump() {
    static std::atomic<long long> next{1};
    version_ = next++;
  }

  std::string path_;  // the scene file loaded, or empty
  twinray::io::SceneFile<double> file_;
  std::vector<Step> steps_;
  std::vector<std::string> asset_names_;
  std::vector<size_t> asset_sizes_;  // objects in each asset so far
  size_t materials_ = 0, objects_ = 0;
  int default_material_ = -1;
  glm::dvec3 background_{0.0, 0.0, 0.0};
  std::optional<EnvironmentStep> environment_;  // set by set_environment
  long long version_ = 0;
};

}  // namespace twinray_python
