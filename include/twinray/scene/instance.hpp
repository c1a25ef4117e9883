// Assets and instances: an asset is a list of objects packed once, with a BVH of its
// own, and not rendered by itself; an Instance<T> places it in the world through an
// affine map (any invertible one: rotation, non-uniform scale, mirroring). Rays enter
// the asset through the inverse map (device/instance.h), so a thousand instances cost
// one asset's memory and a few hundred bytes each.
//
//   twinray::Asset<float> tree{"tree", {twinray::Object<float>(trunk), ...}};
//   int id = scene.add_asset(tree);
//   scene.add_instance(id, twinray::Transform::scale_rotate_translate(...).m);
//
// One level: an asset holds spheres, triangles and meshes, never instances (as in
// OSPRay), and no planes (an unbounded plane has no box to place).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <glm/mat4x4.hpp>

namespace twinray {

template <class T>
struct Instance {
  int asset = 0;             // index into Scene<T>::assets
  glm::dmat4 to_world{1.0};  // the asset's space to the world (glm: m[column][row])
  int material = -1;         // replaces the asset's materials; -1 keeps them
  uint32_t mask = 0xffffffffu;
};

}  // namespace twinray
