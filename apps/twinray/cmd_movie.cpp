// `twinray movie SCENE -o OUT.mp4 [options]`: render the scene's animation to an H.264
// MP4 through the ffmpeg program (docs/command-line.md, docs/movies.md).
//
// Every frame is kept as a PNG in a frames folder beside the output (OUT.frames/ for
// OUT.mp4) while the movie is made, and piped to ffmpeg as raw RGB. A run that stops
// (Ctrl-C, a crash, a full disk) leaves those frames; the same command run again takes
// them instead of rendering them anew, as long as the scene and every option that
// changes the pixels are the same (the folder's key file says which). The MP4 is
// encoded into the frames folder and renamed into place when ffmpeg succeeded: OUT.mp4
// is complete or absent. The frames folder goes once the movie is done, unless
// --keep-frames.
//
// In an MPI job (docs/distributed.md) every rank renders frames that rank 0 hands out
// one at a time (cluster.hpp); rank 0 alone keeps the folder and feeds the encoder,
// from the folder and in frame order, so the MP4 is the one-process MP4.
#include <dirent.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <vector>

#include <stb_image.h>
#include <twinray/scene/validate.hpp>
#include <twinray/io/animation_json.hpp>
#include <twinray/io/atomic_file.hpp>
#include "ffmpeg_pipe.hpp"
#include <twinray/io/png.hpp>

#include "cli_common.hpp"
#include "cluster.hpp"
#include "command.hpp"

namespace twinray_cli {
namespace {

struct MovieArgs {
  std::string scene;
  std::string output;
  SharedOptions shared;
  int frames = 0;  // 0: the animation's
  double fps = 0;  // 0: the animation's
  int from = -1;   // -1: 0
  int to = -1;     // -1: the last frame
  bool keep_frames = false;
};

// ---- Ctrl-C: finish the frame being rendered, keep the frames, stop ffmpeg ----
std::atomic<bool> g_interrupted{false};
extern "C" void on_interrupt(int) {
  g_interrupted.store(true);
  std::signal(SIGINT, SIG_DFL);  // a second Ctrl-C ends twinray at once
  std::signal(SIGTERM, SIG_DFL);
}

// ---- files ----
bool is_directory(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode);
}

bool exists(const std::string& path) {
  struct stat st {};
  return ::lstat(path.c_str(), &st) == 0;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string frame_name(long long k) {
  char name[32];
  std::snprintf(name, sizeof name, "frame_%06lld.png", k);
  return name;
}

// The frames folder of one movie.
class FrameStore {
 public:
  static constexpr const char* kKeyFile = "twinray-frames.key";

  FrameStore(std::string dir, std::string key) : dir_(std::move(dir)), key_(std::move(key)) {}

  // Creates the folder, or checks that it holds frames of the same settings; frames of
  // other settings are removed.
  void open(Progress& progress) {
    if (exists(dir_) && !is_directory(dir_))
      throw twinray::Error(twinray::ErrorKind::RuntimeFailure,
                           dir_ +
                               ": exists and is not a folder; twinray keeps the movie's "
                               "frames there, so move it away");
    if (!is_directory(dir_) && ::mkdir(dir_.c_str(), 0755) != 0)
      throw twinray::Error(twinray::ErrorKind::RuntimeFailure,
                           dir_ + ": cannot create the frames folder: " + std::strerror(errno));
    std::string key_path = dir_ + "/" + kKeyFile;
    std::string old_key = exists(key_path) ? read_file(key_path) : "";
    // Temporary files are another process's work in progress unless that process is
    // gone (io/atomic_file.hpp); only those left behind are removed.
    std::vector<std::string> frames, leftovers;
    for (const std::string& name : own_files()) {
      if (!twinray::io::is_temporary(name)) {
        if (name.rfind("frame_", 0) == 0) frames.push_back(name);
      } else if (twinray::io::is_abandoned_temporary(name)) {
        leftovers.push_back(name);
      }
    }
    remove(leftovers);
    if (old_key != key_ + "\n") {
      if (!frames.empty())
        progress.note(dir_ + ": " + std::to_string(frames.size()) +
                      " frames of another scene or other settings; rendering anew");
      remove(frames);
      std::string nl = key_ + "\n";
      twinray::io::write_file_atomically(key_path, nl.data(), nl.size());
    }
  }

  // Frame k as width x height RGB bytes, if a complete file of that size is there.
  bool load(long long k, int width, int height, std::vector<unsigned char>& rgb) const {
    std::string bytes = read_file(dir_ + "/" + frame_name(k));
    if (bytes.empty()) return false;
    int w = 0, h = 0, n = 0;
    unsigned char* data =
        stbi_load_from_memory(reinterpret_cast<const unsigned char*>(bytes.data()),
                              static_cast<int>(bytes.size()), &w, &h, &n, 3);
    if (!data) return false;
    bool ok = w == width && h == height;
    if (ok) rgb.assign(data, data + static_cast<size_t>(w) * h * 3);
    stbi_image_free(data);
    return ok;
  }

  // Whether frame k is there as a PNG of width x height (only its header is read; the
  // encoder decodes it in full).
  bool has(long long k, int width, int height) const {
    int w = 0, h = 0, n = 0;
    return stbi_info((dir_ + "/" + frame_name(k)).c_str(), &w, &h, &n) && w == width && h == height;
  }

  void save(long long k, const std::string& png) const {
    twinray::io::write_file_atomically(dir_ + "/" + frame_name(k), png.data(), png.size());
  }

  // The MP4 while ffmpeg writes it: a temporary of this process, renamed into place.
  std::string encoding_path() const { return dir_ + "/" + kEncoding + encoding_suffix_; }

  // Removes the frames and the key, and the folder when nothing else is left in it
  // (another process's temporary files stay).
  void discard() {
    std::vector<std::string> done;
    for (const std::string& name : own_files())
      if (!twinray::io::is_temporary(name)) done.push_back(name);
    remove(done);
    ::rmdir(dir_.c_str());
  }

  const std::string& dir() const { return dir_; }

 private:
  static constexpr const char* kEncoding = "encoding.mp4";

  std::vector<std::string> own_files() const {
    std::vector<std::string> names;
    DIR* d = ::opendir(dir_.c_str());
    if (!d) return names;
    while (dirent* e = ::readdir(d)) {
      std::string name = e->d_name;
      if (name.rfind("frame_", 0) == 0 || name.rfind(kKeyFile, 0) == 0 ||
          name.rfind(kEncoding, 0) == 0)
        names.push_back(name);
    }
    ::closedir(d);
    return names;
  }

  void remove(const std::vector<std::string>& names) const {
    for (const std::string& name : names) ::unlink((dir_ + "/" + name).c_str());
  }

  std::string dir_, key_;
  std::string encoding_suffix_ = twinray::io::temporary_suffix();
};

std::string format_seconds(double s) {
  if (!(s >= 0) || s > 1e7) return "?";
  long long t = static_cast<long long>(s + 0.5);
  char buf[32];
  if (t >= 3600)
    std::snprintf(buf, sizeof buf, "%lld:%02lld:%02lld", t / 3600, t / 60 % 60, t % 60);
  else
    std::snprintf(buf, sizeof buf, "%lld:%02lld", t / 60, t % 60);
  return buf;
}

// OUT.mp4 -> OUT.frames
std::string frames_folder(const std::string& output) {
  size_t slash = output.find_last_of('/');
  size_t dot = output.find_last_of('.');
  std::string stem = dot == std::string::npos || (slash != std::string::npos && dot < slash)
                         ? output
                         : output.substr(0, dot);
  return stem + ".frames";
}

void check_movie_output(const std::string& path) {
  if (path.empty()) usage_error("-o: the output path is empty");
  size_t slash = path.find_last_of('/');
  std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  std::string ext = name.size() >= 4 ? name.substr(name.size() - 4) : "";
  for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  if (ext != ".mp4" || name.size() == 4)
    usage_error("-o " + path + ": a movie is written as MP4; the output must end in .mp4");
  std::string folder =
      slash == std::string::npos ? "." : (slash == 0 ? "/" : path.substr(0, slash));
  if (!is_directory(folder))
    usage_error("-o " + path + ": the folder " + folder + " does not exist");
  if (is_directory(path)) usage_error("-o " + path + ": is a folder");
}

// Refuses a frame range outside the movie, and checks every frame's camera before the
// first frame renders.
template <class T>
void check_frames(const twinray::io::SceneFile<T>& f, const twinray::Animation<T>& anim,
                  long long frames, long long from, long long to) {
  const std::string range_note = "the movie has " + std::to_string(frames) + " frames (0 to " +
                                 std::to_string(frames - 1) + ")";
  if (from >= frames) usage_error("--from " + std::to_string(from) + ": " + range_note);
  if (to >= frames)
    usage_error("--to " + std::to_string(to) + ": " + range_note + "; --frames N makes it longer");
  if (from > to)
    usage_error("--from " + std::to_string(from) + " --to " + std::to_string(to) +
                ": the first frame is after the last");
  if (!anim.camera) return;
  twinray::Animation<T> camera_only = anim;
  camera_only.paths.clear();
  for (long long k = from; k <= to; ++k) {
    twinray::Camera<T> c = f.camera;
    twinray::Scene<T> none;
    twinray::animate_into(none, f.camera, camera_only, k, none, c);
    try {
      twinray::validate(c);
    } catch (const twinray::Error& e) {
      usage_error(f.path + ": animation.camera: at frame " + std::to_string(k) + ": " + e.what());
    }
  }
}

template <class T>
int make_movie(const MovieArgs& a, const std::string& text, const std::string& ffmpeg) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  twinray::io::SceneFile<T> f;
  twinray::Animation<T> anim;
  long long frames = 0, from = 0, to = 0;
  double fps = 0;
  // Every rank reads the scene and checks the frames; the ranks must agree on all of it.
  cluster::agree(
      [&] {
        f = prepare_scene<T>(a.scene, text, a.shared);
        if (f.animation.is_null())
          usage_error(f.path +
                      " has no animation (no \"animation\" key), so there is no movie to "
                      "make; docs/scene-format.md describes the key");
        anim = twinray::io::parse_animation(f);
        frames = a.frames > 0 ? a.frames : anim.frames;
        fps = a.fps > 0 ? a.fps : anim.fps;
        from = a.from >= 0 ? a.from : 0;
        to = a.to >= 0 ? a.to : frames - 1;
        check_frames(f, anim, frames, from, to);
        char shape[96];
        std::snprintf(shape, sizeof shape, "-%lld-%lld-%lld-%.17g", frames, from, to, fps);
        return pixels_key(f, a.shared.precision) + shape;
      },
      "the scene, the frames or the options that decide the pixels");

  const bool speaks = cluster::rank() == 0;
  const int width = f.camera.width, height = f.camera.height;
  const long long count = to - from + 1;
  Progress progress(a.output, count, speaks && Progress::wanted(a.shared.quiet));
  std::unique_ptr<FrameStore> store;
  std::unique_ptr<twinray::io::FfmpegEncoder> encoder;
  // Rank 0 keeps the frames folder and feeds the encoder; a Ctrl-C there finishes the
  // frames under way and keeps them.
  g_interrupted.store(false);
  auto old_int = std::signal(SIGINT, speaks ? on_interrupt : SIG_DFL);
  auto old_term = std::signal(SIGTERM, speaks ? on_interrupt : SIG_DFL);
  struct RestoreSignals {
    void (*i)(int);
    void (*t)(int);
    ~RestoreSignals() {
      std::signal(SIGINT, i);
      std::signal(SIGTERM, t);
    }
  } restore{old_int, old_term};
  std::vector<long long> missing;
  std::vector<char> on_disk(static_cast<size_t>(count), 0);
  if (speaks) {
    store =
        std::make_unique<FrameStore>(frames_folder(a.output), pixels_key(f, a.shared.precision));
    store->open(progress);
    for (long long k = from; k <= to; ++k) {
      if (store->has(k, width, height))
        on_disk[static_cast<size_t>(k - from)] = 1;
      else
        missing.push_back(k);
    }
    encoder = std::make_unique<twinray::io::FfmpegEncoder>(ffmpeg, store->encoding_path(), width,
                                                           height, fps);
  }

  twinray::io::SceneFile<T> frame = f;
  frame.options.log = [&progress](const std::string& line) { progress.note(line); };
  SceneRenderer<T> renderer;
  const bool moves_objects = twinray::moves_objects(anim);
  const bool moves_only_instances = twinray::moves_only_instances(anim, f.scene);
  twinray::RenderInfo info;
  // Renders frame k (on any rank) to the PNG bytes the frames folder keeps.
  auto render_frame = [&](long long k) {
    twinray::animate_into(f.scene, f.camera, anim, k, frame.scene, frame.camera);
    // One backend for the whole movie: the scene is packed again only for the frames
    // of an animation that moves objects, and where it moves only instances, only the
    // top-level BVH is built again (the assets are packed once per movie).
    twinray::Image<T> image =
        renderer.render(frame, &info, moves_objects ? k : 0, {}, moves_only_instances);
    std::vector<unsigned char> png = twinray::io::encode_png(image);
    return std::string(png.begin(), png.end());
  };

  // The encoder takes the frames in order from the frames folder: those kept from an
  // earlier run, and the new ones once they are there, from whichever rank. Nothing
  // waits in memory, however far ahead of the encoder the ranks get.
  long long next = from, rendered = 0;
  std::vector<unsigned char> rgb;
  const auto start = Clock::now();
  auto encode_ready = [&] {
    for (; next <= to && on_disk[static_cast<size_t>(next - from)]; ++next) {
      if (!store->load(next, width, height, rgb))
        throw twinray::Error(twinray::ErrorKind::RuntimeFailure,
                             store->dir() + "/" + frame_name(next) +
                                 ": cannot read the frame back; remove it and run again");
      encoder->write_frame(rgb.data(), width, height);
      long long done = next - from + 1;
      double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
      double rate = elapsed > 0 ? static_cast<double>(done) / elapsed : 0;
      std::ostringstream label;
      label << a.output << std::fixed << std::setprecision(1) << "  " << rate << " frames/s, "
            << format_seconds(rate > 0 ? static_cast<double>(count - done) / rate : -1) << " left";
      progress.set_label(label.str());
      progress.set(done);
    }
  };
  if (speaks) encode_ready();
  cluster::WorkSummary summary = cluster::share_work(
      missing, render_frame,
      [&](long long k, std::string&& png) {
        store->save(k, png);
        on_disk[static_cast<size_t>(k - from)] = 1;
        ++rendered;
        encode_ready();
      },
      &g_interrupted);
  if (!speaks) return kExitOk;
  const double render_s = std::chrono::duration<double>(Clock::now() - start).count();
  const long long kept = count - static_cast<long long>(missing.size());
  if (summary.interrupted) {
    encoder->abort();
    progress.finish();
    std::cerr << "twinray: interrupted; " << (kept + rendered) << " of " << count
              << " frames are kept in " << store->dir()
              << "/; run the same command again to continue from there\n";
    return 130;
  }
  encode_ready();
  progress.set_label("encoding " + a.output);
  encoder->finish();
  // The movie is complete: make it durable, then put it in place.
  int fd = ::open(store->encoding_path().c_str(), O_RDONLY);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
  if (::rename(store->encoding_path().c_str(), a.output.c_str()) != 0)
    throw twinray::Error(twinray::ErrorKind::RuntimeFailure,
                         a.output + ": cannot write: " + std::strerror(errno));
  if (!a.keep_frames) store->discard();
  progress.finish();
  double total_s = std::chrono::duration<double>(Clock::now() - t0).count();
  std::ostringstream s;
  s << std::fixed << std::setprecision(1);
  s << a.output << ": " << count << " frames";
  if (from != 0 || to != frames - 1) s << " (" << from << " to " << to << ")";
  s << ", " << width << "x" << height;
  if ((width | height) & 1)
    s << " (stored as " << twinray::io::even_up(width) << "x" << twinray::io::even_up(height)
      << ")";
  char rate[32];
  std::snprintf(rate, sizeof rate, "%g", fps);
  s << " at " << rate << " fps, H.264, " << frame.options.spp << " spp, " << a.shared.precision;
  if (rendered > 0)
    s << ", backend " << twinray::to_string(info.backend) << " (" << info.device << "), "
      << rendered << " rendered at " << std::setprecision(2)
      << static_cast<double>(rendered) / render_s << " frames/s" << std::setprecision(1);
  const std::string ranks = cluster::ranks_note(summary, "frames");
  if (!ranks.empty()) s << ", " << ranks;
  if (kept > 0) s << ", " << kept << " kept from " << store->dir() << "/";
  s << ", total " << total_s << " s";
  std::cout << s.str() << std::endl;
  return kExitOk;
}

int run_movie(const MovieArgs& a) {
  // Rank 0 refuses what the command line gets wrong, and a missing ffmpeg, before any
  // work, then reads the scene for every rank.
  std::string ffmpeg;
  const std::string text = cluster::share_from_rank0([&] {
    check_movie_output(a.output);
    if (a.shared.frame >= 0) usage_error("--frame: movie renders a range; use --from and --to");
    try {
      ffmpeg = twinray::io::find_ffmpeg();
    } catch (const twinray::Error& e) {
      // Said as it is: no "backend" prefix, which main() gives to unavailable backends.
      std::cerr << "twinray: " << e.what() << "\n";
      throw QuietExit{exit_status(e.kind())};
    }
    return scene_arg_text(a.scene);
  });
  return with_precision(a.shared,
                        [&](auto zero) { return make_movie<decltype(zero)>(a, text, ffmpeg); });
}

const Command kMovie(
    "movie", "render the scene's animation to an H.264 MP4 (needs the ffmpeg program)",
    [](CLI::App& app) {
      auto a = std::make_shared<MovieArgs>();
      app.add_option("SCENE", a->scene, "scene file with an \"animation\" (docs/scene-format.md)")
          ->required();
      app.add_option("-o,--output", a->output,
                     "output movie (.mp4); frames are kept in OUT.frames/ until it is done")
          ->required();
      add_shared_options(app, a->shared);
      app.add_option("--frames", a->frames, "frames in the movie (default: the animation's)")
          ->check(CLI::Range(1, 10000000));
      app.add_option("--fps", a->fps, "frames per second (default: the animation's)")
          ->check(CLI::Range(0.001, 1000.0));
      app.add_option("--from", a->from, "first frame to render (default 0)")
          ->check(CLI::Range(0, 10000000));
      app.add_option("--to", a->to, "last frame to render, inclusive (default: the last)")
          ->check(CLI::Range(0, 10000000));
      app.add_flag("--keep-frames", a->keep_frames,
                   "keep the frames folder (PNG per frame) after the movie is done");
      return [a] { return run_movie(*a); };
    },
    20, /*across_ranks=*/true);

}  // namespace
}  // namespace twinray_cli
