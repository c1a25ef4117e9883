// The SDL2 window of `twinray view` (view_window.hpp).
#include "view_window.hpp"

#include <SDL.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <condition_variable>
#include <cstdio>
#include <iostream>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include <sys/stat.h>

#include <twinray/io/animation_json.hpp>
#include <twinray/io/png.hpp>

#include "cli_common.hpp"
#include "view_controls.hpp"

namespace twinray_cli {
namespace view {
namespace {

Key key_from_sdl(SDL_Keycode sym) {
  switch (sym) {
    case SDLK_LEFT:
      return Key::Left;
    case SDLK_RIGHT:
      return Key::Right;
    case SDLK_UP:
      return Key::Up;
    case SDLK_DOWN:
      return Key::Down;
    case SDLK_KP_PLUS:
      return Key::MoreSamples;
    case SDLK_KP_MINUS:
      return Key::FewerSamples;
    case SDLK_ESCAPE:
      return Key::Quit;
    default:
      return sym > 0 && sym < 128 ? key_from_char(static_cast<char>(sym)) : Key::Other;
  }
}

// The renderer's thread: one job at a time, the latest one wins.
template <class T>
class RenderThread {
 public:
  struct Output {
    Result result;
    int width = 0, height = 0;
    std::vector<unsigned char> rgb;
    twinray::Image<T> image;  // full resolution only, for screenshots
  };

  RenderThread(const twinray::io::SceneFile<T>& base, const twinray::Animation<T>* animation,
               Uint32 wake_event)
      : base_(base), animation_(animation), frame_(base), wake_event_(wake_event) {
    thread_ = std::thread([this] { loop(); });
  }
  ~RenderThread() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    thread_.join();
  }

  void post(const Job& job) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_ = job;
    }
    wake_.notify_all();
  }

  std::optional<Output> take() {
    std::lock_guard<std::mutex> lock(mutex_);
    std::optional<Output> out = std::move(output_);
    output_.reset();
    return out;
  }

 private:
  void loop() {
    for (;;) {
      Job job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [this] { return stop_ || job_.has_value(); });
        if (stop_) return;
        job = *job_;
        job_.reset();
      }
      Output out = render(job);
      {
        std::lock_guard<std::mutex> lock(mutex_);
        output_ = std::move(out);
      }
      SDL_Event e{};
      e.type = wake_event_;
      SDL_PushEvent(&e);
    }
  }

  Output render(const Job& job) {
    Output out;
    out.result.generation = job.generation;
    out.result.divisor = job.divisor;
    try {
      apply_view(base_, animation_, job.state, frame_);
      frame_.camera.width = std::max(1, base_.camera.width / job.divisor);
      frame_.camera.height = std::max(1, base_.camera.height / job.divisor);
      frame_.options.log = [](const std::string& line) {
        std::cerr << "twinray: " << line << "\n";
      };
      twinray::RenderInfo info;
      auto t0 = std::chrono::steady_clock::now();
      const bool moves = animation_ && twinray::moves_objects(*animation_);
      const bool only_instances = moves && twinray::moves_only_instances(*animation_, base_.scene);
      twinray::Image<T> image =
          renderer_.render(frame_, &info, moves ? job.state.frame : 0, {}, only_instances);
      // The frame's cost, without an OpenCL program build (the first frames'), since
      // the preview size is chosen from it.
      out.result.ms = std::max(
          0.0,
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() -
              info.build_ms);
      out.result.backend = info.backend;
      out.width = image.width;
      out.height = image.height;
      out.rgb = twinray::io::to_rgb8(image);
      if (job.divisor == 1) out.image = std::move(image);
    } catch (const std::exception& e) {
      out.result.failed = true;
      out.result.error = e.what();
    }
    return out;
  }

  const twinray::io::SceneFile<T>& base_;
  const twinray::Animation<T>* animation_;
  twinray::io::SceneFile<T> frame_;
  SceneRenderer<T> renderer_;  // one backend, the scene packed once per geometry
  Uint32 wake_event_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::optional<Job> job_;
  std::optional<Output> output_;
  bool stop_ = false;
  std::thread thread_;
};

std::string next_screenshot_path(const std::string& dir) {
  for (int i = 1; i < 100000; ++i) {
    char name[64];
    std::snprintf(name, sizeof name, "/twinray-view-%03d.png", i);
    struct stat st {};
    std::string path = dir + name;
    if (::stat(path.c_str(), &st) != 0) return path;
  }
  return dir + "/twinray-view.png";
}

struct SdlSession {
  SDL_Window* window = nullptr;
  SDL_Renderer* renderer = nullptr;
  SDL_Texture* texture = nullptr;
  ~SdlSession() {
    if (texture) SDL_DestroyTexture(texture);
    if (renderer) SDL_DestroyRenderer(renderer);
    if (window) SDL_DestroyWindow(window);
    SDL_Quit();
  }
};

}  // namespace

template <class T>
int run_window(const twinray::io::SceneFile<T>& base, const WindowOptions& options) {
  std::optional<twinray::Animation<T>> animation;
  if (!base.animation.is_null()) animation = twinray::io::parse_animation(base);

  ViewState initial;
  initial.projection = base.camera.projection;
  initial.terms = base.options.terms;
  initial.shadows = base.options.shadows;
  initial.glaze = base.options.glaze;
  initial.spp = base.options.spp;
  initial.backend = base.options.backend;
  if (animation) {
    initial.frames = animation->frames;
    initial.fps = animation->fps;
  }
  ViewController controller(initial, options.target_ms);

  if (SDL_Init(SDL_INIT_VIDEO) != 0)
    throw twinray::Error(twinray::ErrorKind::BackendUnavailable,
                         std::string("cannot open a window: ") + SDL_GetError() +
                             " (the viewer needs a display; is DISPLAY set?)");
  SdlSession sdl;
  // Without a display SDL falls back to drivers that draw nowhere; a window nobody sees
  // would look like a hang. (SDL_VIDEODRIVER=offscreen still works when asked for.)
  const char* driver = SDL_GetCurrentVideoDriver();
  const char* asked = std::getenv("SDL_VIDEODRIVER");
  std::string name = driver ? driver : "";
  if ((!asked || !*asked) && (name.empty() || name == "offscreen" || name == "dummy"))
    throw twinray::Error(twinray::ErrorKind::BackendUnavailable,
                         "cannot open a window: no display (SDL found only the \"" + name +
                             "\" video driver); run twinray view in a desktop session, or "
                             "set DISPLAY");
  SDL_SetHint(SDL_HINT_RENDER_SCALE_QUALITY, "1");
  sdl.window = SDL_CreateWindow(
      controller.title(options.scene_name).c_str(), SDL_WINDOWPOS_CENTERED, SDL_WINDOWPOS_CENTERED,
      base.camera.width, base.camera.height, SDL_WINDOW_RESIZABLE | SDL_WINDOW_ALLOW_HIGHDPI);
  if (!sdl.window)
    throw twinray::Error(twinray::ErrorKind::BackendUnavailable,
                         std::string("cannot open a window: ") + SDL_GetError());
  sdl.renderer = SDL_CreateRenderer(sdl.window, -1, 0);
  if (!sdl.renderer) sdl.renderer = SDL_CreateRenderer(sdl.window, -1, SDL_RENDERER_SOFTWARE);
  if (!sdl.renderer)
    throw twinray::Error(twinray::ErrorKind::BackendUnavailable,
                         std::string("cannot draw in the window: ") + SDL_GetError());
  Uint32 wake_event = SDL_RegisterEvents(1);
  int texture_w = 0, texture_h = 0;

  auto present = [&] {
    SDL_SetRenderDrawColor(sdl.renderer, 0, 0, 0, 255);
    SDL_RenderClear(sdl.renderer);
    if (sdl.texture) SDL_RenderCopy(sdl.renderer, sdl.texture, nullptr, nullptr);
    SDL_RenderPresent(sdl.renderer);
  };

  std::fprintf(stderr,
               "twinray: view keys: o projection, 1 2 3 terms, s shadows, g glaze, b backend, "
               "arrows orbit, + - spp, space play, p save PNG, r reset, q quit\n");
  RenderThread<T> worker(base, animation ? &*animation : nullptr, wake_event);
  const auto start = std::chrono::steady_clock::now();
  bool busy = false;
  std::string title;
  twinray::Image<T> last_full;
  while (!controller.quit()) {
    double now = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!busy) {
      Job job;
      if (controller.next_job(now, job)) {
        worker.post(job);
        busy = true;
      }
    }
    std::string t = controller.title(options.scene_name);
    if (t != title) {
      SDL_SetWindowTitle(sdl.window, t.c_str());
      title = t;
    }
    SDL_Event e;
    int timeout = controller.state().playing && !busy ? 5 : 100;
    if (!SDL_WaitEventTimeout(&e, timeout)) continue;
    do {
      if (e.type == SDL_QUIT) {
        controller.press(Key::Quit);
      } else if (e.type == SDL_KEYDOWN) {
        controller.press(key_from_sdl(e.key.keysym.sym));
      } else if (e.type == wake_event) {
        std::optional<typename RenderThread<T>::Output> out = worker.take();
        busy = false;
        if (!out) continue;
        if (out->result.failed) {
          std::cerr << "twinray: " << out->result.error << "\n";
          controller.finish(out->result);
          continue;
        }
        controller.finish(out->result);
        if (out->width != texture_w || out->height != texture_h) {
          if (sdl.texture) SDL_DestroyTexture(sdl.texture);
          sdl.texture = SDL_CreateTexture(sdl.renderer, SDL_PIXELFORMAT_RGB24,
                                          SDL_TEXTUREACCESS_STREAMING, out->width, out->height);
          texture_w = out->width;
          texture_h = out->height;
        }
        if (sdl.texture) SDL_UpdateTexture(sdl.texture, nullptr, out->rgb.data(), out->width * 3);
        if (out->result.divisor == 1) last_full = std::move(out->image);
        present();
      } else if (e.type == SDL_WINDOWEVENT) {
        present();
      }
    } while (SDL_PollEvent(&e));
    if (controller.screenshot_due() && last_full.width > 0) {
      std::string path = next_screenshot_path(options.screenshot_dir);
      try {
        twinray::io::write_png(path, last_full);
        std::fprintf(stderr, "twinray: saved %s\n", path.c_str());
      } catch (const twinray::Error& err) {
        std::fprintf(stderr, "twinray: %s\n", err.what());
      }
      controller.screenshot_done();
    }
  }
  return kExitOk;
}

template int run_window<float>(const twinray::io::SceneFile<float>&, const WindowOptions&);
template int run_window<double>(const twinray::io::SceneFile<double>&, const WindowOptions&);

}  // namespace view
}  // namespace twinray_cli
