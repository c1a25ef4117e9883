// Packing for tests that call the device code directly: the packed scene and the
// packed frame of one render, side by side.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <twinray/backend/render.hpp>
#include <twinray/pack/pack.hpp>

namespace test_support {

template <class T>
struct Packed {
  twinray::PackedScene<T> scene;
  twinray::PackedFrame<T> frame;
  typename twinray::device::Code<T>::SceneRef ref() const { return frame.ref(scene); }
  const typename twinray::device::Code<T>::Params& params() const { return frame.params; }
};

template <class T>
Packed<T> pack(const twinray::Scene<T>& scene, const twinray::Camera<T>& camera,
               const twinray::RenderOptions& options = {},
               twinray::BvhPolicy bvh = twinray::BvhPolicy::Auto) {
  Packed<T> p;
  p.scene = twinray::pack_scene(scene, bvh);
  p.frame = twinray::pack_frame(p.scene.summary(), {camera, scene.lights, options, {}});
  return p;
}

}  // namespace test_support

namespace test_support {

// The same packed arrays (in the BVH's leaf order) with the BVH removed: spheres and
// triangles go back to the linear loops.
template <class T>
twinray::PackedScene<T> without_bvh(twinray::PackedScene<T> ps) {
  ps.bvh_nodes.clear();
  ps.bvh_prims.clear();
  ps.features &= ~unsigned(TR_F_BVH);
  return ps;
}

// Renders a packed scene on a backend (Cpu or OpenCL) through the backend interface.
template <class T>
twinray::Image<T> render_packed(const twinray::PackedScene<T>& ps, const twinray::Camera<T>& camera,
                                const std::vector<twinray::Light<T>>& lights,
                                twinray::RenderOptions options, twinray::Backend backend) {
  options.backend = backend;
  options.log = [](const std::string&) {};
  auto renderer = twinray::make_backend<T>(options);
  renderer->set_scene(std::make_shared<const twinray::PackedScene<T>>(ps));
  return renderer->render({camera, lights, options, {}});
}

}  // namespace test_support
