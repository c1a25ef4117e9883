// Scene<T>: materials, an ordered list of objects, lights, textures, assets (placed by
// instance objects), a background color and an environment image.
// An object's index in `objects` is its identity everywhere (error messages name
// `objects[i]`, the object AOV writes i), matching the scene file's `objects` array.
#pragma once

#include <string>
#include <variant>
#include <vector>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include <twinray/scene/environment.hpp>
#include <twinray/scene/instance.hpp>
#include <twinray/scene/light.hpp>
#include <twinray/scene/material.hpp>
#include <twinray/scene/shapes.hpp>
#include <twinray/scene/texture.hpp>

namespace twinray {

template <class T>
using Object = std::variant<Sphere<T>, Triangle<T>, Plane<T>, Mesh<T>, Instance<T>>;

// Objects placed only by instances (scene/instance.hpp); their materials are the scene's.
template <class T>
struct Asset {
  std::string name;  // for messages
  std::vector<Object<T>> objects;
};

// A plain value type, built on one thread. render() only reads it, so any number of
// threads may render the same Scene at once as long as nobody modifies it meanwhile.
// Units: any consistent length unit ("world units") for every position and size.
template <class T>
struct Scene {
  std::vector<Material<T>> materials;
  std::vector<Object<T>> objects;
  std::vector<Light<T>> lights;
  std::vector<Texture<T>> textures;             // Material::texture indexes them
  std::vector<Asset<T>> assets;                 // Instance::asset indexes them
  glm::vec<3, T> background{T(0), T(0), T(0)};  // color of rays that hit nothing
  Environment<T> environment;                   // what they see instead, where it has a texture

  // Each returns the new element's index.
  int add_material(const Material<T>& m) { return push(materials, m); }
  int add(const Object<T>& object) { return push(objects, object); }
  int add_light(const Light<T>& light) { return push(lights, light); }
  int add_texture(const Texture<T>& texture) { return push(textures, texture); }
  int add_asset(const Asset<T>& asset) { return push(assets, asset); }
  // Places asset `asset` by `to_world`; returns the instance's object index.
  int add_instance(int asset, const glm::dmat4& to_world = glm::dmat4(1.0), int material = -1) {
    Instance<T> instance;
    instance.asset = asset;
    instance.to_world = to_world;
    instance.material = material;
    return add(instance);
  }

 private:
  template <class V, class E>
  static int push(V& v, const E& e) {
    v.push_back(e);
    return static_cast<int>(v.size()) - 1;
  }
};

}  // namespace twinray
