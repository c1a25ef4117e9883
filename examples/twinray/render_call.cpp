// render_scene(): the one translation unit of `twinray` that instantiates the renderer
// (the device code for every Features variant, in float and double); every subcommand
// that renders calls it instead of twinray::render, so it is compiled once.
#include "cli_common.hpp"

#include <twinray/backend/render.hpp>

namespace twinray_cli {

template <class T>
twinray::Image<T> render_scene(const twinray::io::SceneFile<T>& file, twinray::RenderInfo* info) {
  return twinray::render(file.scene, file.camera, file.options, info);
}

template twinray::Image<float> render_scene<float>(const twinray::io::SceneFile<float>&,
                                                   twinray::RenderInfo*);
template twinray::Image<double> render_scene<double>(const twinray::io::SceneFile<double>&,
                                                     twinray::RenderInfo*);

}  // namespace twinray_cli
