// SceneRenderer: the one translation unit of `twinray` that instantiates the renderer
// (the device code for every Features variant, in float and double); every subcommand
// renders through it, so that code is compiled once.
#include <chrono>

#include "cli_common.hpp"

#include <twinray/backend/render.hpp>

namespace twinray_cli {

template <class T>
struct SceneRenderer<T>::State {
  std::unique_ptr<twinray::RenderBackend<T>> backend;
  twinray::Backend requested = twinray::Backend::Auto;  // what `backend` was made for
  int device = -1;
  long long geometry = 0;
  bool packed = false;
  std::shared_ptr<twinray::PackedScene<T>> scene;  // what `backend` renders
};

template <class T>
SceneRenderer<T>::SceneRenderer() : state_(std::make_unique<State>()) {}

template <class T>
SceneRenderer<T>::~SceneRenderer() = default;

template <class T>
twinray::Image<T> SceneRenderer<T>::render(const twinray::io::SceneFile<T>& file,
                                           twinray::RenderInfo* info, long long geometry,
                                           twinray::PixelRect rect, bool instances_only) {
  State& s = *state_;
  if (!s.backend || s.requested != file.options.backend || s.device != file.options.device) {
    s.backend = twinray::make_backend<T>(file.options);
    s.requested = file.options.backend;
    s.device = file.options.device;
    s.packed = false;
  }
  double pack_ms = 0;
  if (!s.packed || geometry != s.geometry) {
    auto t0 = std::chrono::steady_clock::now();
    // Where only instances moved, the assets stay packed: only the top level is built.
    if (s.packed && instances_only && s.scene && twinray::update_instances(*s.scene, file.scene)) {
      s.backend->set_moved_instances(s.scene);
    } else {
      s.scene = std::make_shared<twinray::PackedScene<T>>(
          twinray::pack_scene(file.scene, s.backend->pack_options()));
      s.backend->set_scene(s.scene);
    }
    pack_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    s.packed = true;
    s.geometry = geometry;
  }
  twinray::Image<T> image =
      s.backend->render({file.camera, file.scene.lights, file.options, rect}, info);
  if (info) info->pack_ms = pack_ms;
  return image;
}

template class SceneRenderer<float>;
template class SceneRenderer<double>;

}  // namespace twinray_cli
