// `twinray render SCENE -o OUT [options]`: render one image (docs/command-line.md).
#include <chrono>
#include <iostream>
#include <memory>

#include "cli_common.hpp"
#include "command.hpp"

namespace twinray_cli {
namespace {

struct RenderArgs {
  std::string scene;
  std::string output;
  SharedOptions shared;
};

int run_render(const RenderArgs& a) {
  auto t0 = std::chrono::steady_clock::now();
  // Everything the command line can get wrong is refused before any work.
  check_output_path(a.output, !a.shared.aov.empty());
  return with_precision(a.shared, [&](auto zero) {
    using T = decltype(zero);
    twinray::io::SceneFile<T> f = prepare_scene<T>(a.scene, a.shared);
    const int width = f.camera.width, height = f.camera.height;
    std::string what = a.shared.aov.empty() ? "shaded" : a.shared.aov + " AOV";
    Progress progress("rendering " + std::to_string(width) + "x" + std::to_string(height), 0,
                      Progress::wanted(a.shared.quiet));
    f.options.log = [&progress](const std::string& line) { progress.note(line); };
    twinray::RenderInfo info;
    twinray::Image<T> image = SceneRenderer<T>().render(f, &info);
    progress.set_label("writing " + a.output);
    write_image(a.output, image);
    progress.finish();
    double total_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    int spp = f.options.output == twinray::Output::Shaded ? f.options.spp : 1;
    std::cout << summary_line(a.output, width, height, spp, a.shared.precision, what, info,
                              total_ms)
              << std::endl;
    return kExitOk;
  });
}

const Command kRender(
    "render", "render one image of a scene file (or `demo`) to .png, .pfm or .ppm",
    [](CLI::App& app) {
      auto a = std::make_shared<RenderArgs>();
      app.add_option("SCENE", a->scene, "scene file (.json, see docs/scene-format.md), or demo")
          ->required();
      app.add_option("-o,--output", a->output,
                     "output image: .png (8-bit), .pfm (32-bit float, exact), .ppm (8-bit)")
          ->required();
      add_shared_options(app, a->shared, kOptionFrame | kOptionAov);
      return [a] { return run_render(*a); };
    },
    10);

}  // namespace
}  // namespace twinray_cli
