// `twinray render SCENE -o OUT [options]`: render one image (docs/command-line.md).
//
// In an MPI job (docs/distributed.md) the frame is split into tiles of kTile x kTile
// pixels that rank 0 hands out one at a time; the image equals the one-process image
// bit for bit.
#include <algorithm>
#include <chrono>
#include <cstring>
#include <iostream>
#include <memory>
#include <vector>

#include "cli_common.hpp"
#include "cluster.hpp"
#include "command.hpp"

namespace twinray_cli {
namespace {

constexpr int kTile = 256;

struct RenderArgs {
  std::string scene;
  std::string output;
  SharedOptions shared;
};

// The tiles of a frame rendered across ranks, row by row.
std::vector<twinray::PixelRect> tiles_of(int width, int height) {
  std::vector<twinray::PixelRect> tiles;
  for (int y = 0; y < height; y += kTile)
    for (int x = 0; x < width; x += kTile)
      tiles.push_back({x, y, std::min(kTile, width - x), std::min(kTile, height - y)});
  return tiles;
}

int run_render(const RenderArgs& a) {
  auto t0 = std::chrono::steady_clock::now();
  // Rank 0 refuses what the command line gets wrong before any work, then reads the
  // scene for every rank.
  const std::string text = cluster::share_from_rank0([&] {
    check_output_path(a.output, !a.shared.aov.empty());
    return scene_arg_text(a.scene);
  });
  return with_precision(a.shared, [&](auto zero) {
    using T = decltype(zero);
    twinray::io::SceneFile<T> f;
    cluster::agree(
        [&] {
          f = prepare_scene<T>(a.scene, text, a.shared);
          return pixels_key(f, a.shared.precision) + a.shared.aov;
        },
        "the scene or the options that decide the pixels");
    const int width = f.camera.width, height = f.camera.height;
    const bool speaks = cluster::rank() == 0;
    std::string what = a.shared.aov.empty() ? "shaded" : a.shared.aov + " AOV";
    const std::vector<twinray::PixelRect> tiles =
        cluster::distributed() ? tiles_of(width, height) : std::vector<twinray::PixelRect>{};
    // A bar of tiles across ranks; one process shows the time it has been rendering.
    Progress progress("rendering " + std::to_string(width) + "x" + std::to_string(height),
                      static_cast<long long>(tiles.size()),
                      speaks && Progress::wanted(a.shared.quiet));
    f.options.log = [&progress](const std::string& line) { progress.note(line); };
    twinray::RenderInfo info;
    SceneRenderer<T> renderer;
    twinray::Image<T> image;
    std::string ranks;
    if (!cluster::distributed()) {
      image = renderer.render(f, &info);
    } else {
      // Tiles handed out one at a time; each is bit-identical to the same pixels of a
      // whole-frame render (backend/backend.hpp), and travels as its raw values.
      std::vector<long long> items(tiles.size());
      for (size_t i = 0; i < items.size(); ++i) items[i] = static_cast<long long>(i);
      if (speaks) image = twinray::Image<T>(width, height);
      auto r0 = std::chrono::steady_clock::now();
      long long done = 0;
      bool first_tile = true;
      cluster::WorkSummary summary = cluster::share_work(
          items,
          [&](long long i) {
            // The closing summary names the backend and the program build of the
            // first tile.
            twinray::RenderInfo tile_info;
            twinray::Image<T> tile =
                renderer.render(f, &tile_info, 0, tiles[static_cast<size_t>(i)]);
            if (first_tile) info = tile_info, first_tile = false;
            return std::string(reinterpret_cast<const char*>(tile.rgb.data()),
                               tile.rgb.size() * sizeof(T));
          },
          [&](long long i, std::string&& bytes) {
            const twinray::PixelRect& r = tiles[static_cast<size_t>(i)];
            const size_t row = static_cast<size_t>(r.width) * 3;
            if (bytes.size() != row * static_cast<size_t>(r.height) * sizeof(T))
              throw twinray::Error(twinray::ErrorKind::RuntimeFailure,
                                   "a tile came back with " + std::to_string(bytes.size()) +
                                       " bytes; the ranks disagree on the frame");
            for (int y = 0; y < r.height; ++y)
              std::memcpy(image.pixel(r.x, r.y + y), bytes.data() + y * row * sizeof(T),
                          row * sizeof(T));
            progress.set(++done);
          },
          nullptr);
      if (!speaks) return kExitOk;
      info.render_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - r0).count();
      ranks = cluster::ranks_note(summary, "tiles");
    }
    progress.set_label("writing " + a.output);
    write_image(a.output, image);
    progress.finish();
    double total_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    int spp = f.options.output == twinray::Output::Shaded ? f.options.spp : 1;
    std::string line =
        summary_line(a.output, width, height, spp, a.shared.precision, what, info, total_ms);
    std::cout << line << (ranks.empty() ? "" : ", " + ranks) << std::endl;
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
    10, /*across_ranks=*/true);

}  // namespace
}  // namespace twinray_cli
