// `twinray view SCENE [options]`: the scene in a window, rendered live with either
// backend (view_controls.hpp lists the keys). The window is SDL2's; a twinray built
// without SDL2 (Debian libsdl2-dev) has the subcommand but says it has no viewer.
#include <iostream>
#include <memory>

#include "cli_common.hpp"
#include "command.hpp"
#ifdef TWINRAY_WITH_SDL2
#include "view_window.hpp"
#endif

namespace twinray_cli {
namespace {

struct ViewArgs {
  std::string scene;
  SharedOptions shared;
  std::string screenshots = ".";
  double target_ms = 40.0;
};

int run_view(const ViewArgs& a) {
#ifdef TWINRAY_WITH_SDL2
  return with_precision(a.shared, [&](auto zero) {
    using T = decltype(zero);
    twinray::io::SceneFile<T> f = prepare_scene<T>(a.scene, a.shared);
    view::WindowOptions options;
    options.scene_name = a.scene;
    options.screenshot_dir = a.screenshots;
    options.target_ms = a.target_ms;
    return view::run_window(f, options);
  });
#else
  (void)a;
  std::cerr << "twinray: this twinray was built without SDL2, so it has no viewer; install "
               "libsdl2-dev (Debian) and build it again\n";
  return kExitBackendUnavailable;
#endif
}

const Command kView(
    "view",
    "interactive window: o orthographic/perspective, 1 2 3 terms, s shadows, g glaze, "
    "b backend, arrows orbit, + - spp, space play, p save PNG, q quit",
    [](CLI::App& app) {
      auto a = std::make_shared<ViewArgs>();
      app.add_option("SCENE", a->scene, "scene file (.json), or demo")->required();
      add_shared_options(app, a->shared);
      app.add_option("--screenshots", a->screenshots,
                     "folder where p saves twinray-view-NNN.png (default: the current one)")
          ->check(CLI::ExistingDirectory);
      app.add_option("--preview-ms", a->target_ms,
                     "aim of the reduced-resolution first image after a change, in ms")
          ->check(CLI::Range(1.0, 10000.0))
          ->capture_default_str();
      return [a] { return run_view(*a); };
    },
    30);

}  // namespace
}  // namespace twinray_cli
