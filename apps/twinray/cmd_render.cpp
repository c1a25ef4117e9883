// `twinray render SCENE -o OUT [options]`: render one image (docs/command-line.md).
//
// In an MPI job (docs/distributed.md) the frame is split into tiles of kTile x kTile
// pixels that rank 0 hands out one at a time; the image equals the one-process image
// bit for bit.
//
// `--aov all` renders the shaded image and then each AOV, one render per output, and
// writes them as the named channels of one .exr (kAllChannels).
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

// `--aov all`: each output and its channels in the EXR, as (name, component) pairs.
// Depth and the object index fill all three components of their images; uv fills two.
struct OutputChannels {
  twinray::Output output;
  std::vector<std::pair<const char*, int>> channels;
};
const std::vector<OutputChannels> kAllChannels = {
    {twinray::Output::Shaded, {{"R", 0}, {"G", 1}, {"B", 2}}},
    {twinray::Output::Depth, {{"Z", 0}}},
    {twinray::Output::Normal, {{"N.X", 0}, {"N.Y", 1}, {"N.Z", 2}}},
    {twinray::Output::ShadingNormal, {{"Ns.X", 0}, {"Ns.Y", 1}, {"Ns.Z", 2}}},
    {twinray::Output::ObjectIndex, {{"object", 0}}},
    {twinray::Output::Uv, {{"uv.U", 0}, {"uv.V", 1}}},
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
    check_output_path(a.output, a.shared.aov.empty()    ? OutputNeeds::Any
                                : a.shared.aov == "all" ? OutputNeeds::Channels
                                                        : OutputNeeds::Float);
    return scene_arg_text(a.scene);
  });
  return with_precision(a.shared, [&](auto zero) {
    using T = decltype(zero);
    twinray::io::SceneFile<T> f;
    double load_ms = 0;
    cluster::agree(
        [&] {
          f = prepare_scene<T>(a.scene, text, a.shared);
          load_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                        .count();
          return pixels_key(f, a.shared.precision) + a.shared.aov;
        },
        "the scene or the options that decide the pixels");
    const int width = f.camera.width, height = f.camera.height;
    const bool speaks = cluster::rank() == 0;
    const bool all = a.shared.aov == "all";
    std::string what = a.shared.aov.empty() ? "shaded"
                       : all                ? "shaded and every AOV"
                                            : a.shared.aov + " AOV";
    const std::vector<twinray::PixelRect> tiles =
        cluster::distributed() ? tiles_of(width, height) : std::vector<twinray::PixelRect>{};
    const size_t passes = all ? kAllChannels.size() : 1;
    // A bar of tiles across ranks; one process shows the time it has been rendering.
    Progress progress("rendering " + std::to_string(width) + "x" + std::to_string(height),
                      static_cast<long long>(tiles.size() * passes),
                      speaks && Progress::wanted(a.shared.quiet));
    f.options.log = [&progress](const std::string& line) { progress.note(line); };
    twinray::RenderInfo info;
    SceneRenderer<T> renderer;
    std::string ranks;
    long long done = 0;
    double render_ms = 0;    // of every render
    bool have_info = false;  // the summary names the backend and build of the first render
    // One render of the frame with the scene's current options (f.options.output);
    // across ranks, the image only on rank 0.
    auto render_frame = [&]() {
      twinray::Image<T> image;
      if (!cluster::distributed()) {
        twinray::RenderInfo pass_info;
        image = renderer.render(f, &pass_info);
        if (!have_info) info = pass_info, have_info = true;
        render_ms += pass_info.render_ms;
        info.render_ms = render_ms;
      } else {
        // Tiles handed out one at a time; each is bit-identical to the same pixels of a
        // whole-frame render (backend/backend.hpp), and travels as its raw values.
        std::vector<long long> items(tiles.size());
        for (size_t i = 0; i < items.size(); ++i) items[i] = static_cast<long long>(i);
        if (speaks) image = twinray::Image<T>(width, height);
        auto r0 = std::chrono::steady_clock::now();
        cluster::WorkSummary summary = cluster::share_work(
            items,
            [&](long long i) {
              // The closing summary names the backend and the program build of the
              // first tile.
              twinray::RenderInfo tile_info;
              twinray::Image<T> tile =
                  renderer.render(f, &tile_info, 0, tiles[static_cast<size_t>(i)]);
              if (!have_info) info = tile_info, have_info = true;
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
        render_ms +=
            std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - r0)
                .count();
        info.render_ms = render_ms;
        ranks = cluster::ranks_note(summary, "tiles");
      }
      return image;
    };
    if (!all) {
      twinray::Image<T> image = render_frame();
      if (!speaks) return kExitOk;
      progress.set_label("writing " + a.output);
      write_image(a.output, image);
    } else {
      std::vector<twinray::Image<T>> images;
      for (const OutputChannels& pass : kAllChannels) {
        f.options.output = pass.output;
        images.push_back(render_frame());
      }
      f.options.output = twinray::Output::Shaded;  // the summary's spp
      if (!speaks) return kExitOk;
      std::vector<ExrChannelOf<T>> channels;
      for (size_t i = 0; i < kAllChannels.size(); ++i)
        for (const auto& [name, component] : kAllChannels[i].channels)
          channels.push_back({name, &images[i], component});
      progress.set_label("writing " + a.output);
      write_exr_channels(a.output, width, height, channels);
    }
    progress.finish();
    double total_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    int spp = f.options.output == twinray::Output::Shaded ? f.options.spp : 1;
    std::string line = summary_line(a.output, width, height, spp, a.shared.precision, what, info,
                                    load_ms, total_ms);
    std::cout << line << (ranks.empty() ? "" : ", " + ranks) << std::endl;
    return kExitOk;
  });
}

const Command kRender(
    "render", "render one image of a scene file (or `demo`) to .png, .pfm, .ppm or .exr",
    [](CLI::App& app) {
      auto a = std::make_shared<RenderArgs>();
      app.add_option("SCENE", a->scene, "scene file (.json, see docs/scene-format.md), or demo")
          ->required();
      app.add_option("-o,--output", a->output,
                     "output image: .png (8-bit), .pfm (32-bit float, exact), .ppm (8-bit), .exr "
                     "(32-bit float channels, exact; --aov all: every AOV in one file)")
          ->required();
      add_shared_options(app, a->shared, kOptionFrame | kOptionAov);
      return [a] { return run_render(*a); };
    },
    10, /*across_ranks=*/true);

}  // namespace
}  // namespace twinray_cli
