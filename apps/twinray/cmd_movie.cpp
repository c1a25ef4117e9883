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

#include <stb_image.h>
#include <twinray/scene/validate.hpp>
#include <twinray/io/animation_json.hpp>
#include <twinray/io/atomic_file.hpp>
#include "ffmpeg_pipe.hpp"
#include <twinray/io/png.hpp>

#include "cli_common.hpp"
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

// ---- the key of a frames folder: everything that decides the pixels of frame K ----
class Hasher {
 public:
  void bytes(const void* data, size_t n) {
    const unsigned char* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < n; ++i) h_ = (h_ ^ p[i]) * 1099511628211ull;
  }
  template <class V>
  void value(const V& v) {
    static_assert(std::is_trivially_copyable<V>::value, "plain data only");
    bytes(&v, sizeof v);
  }
  void text(const std::string& s) {
    value(s.size());
    bytes(s.data(), s.size());
  }
  std::string hex() const {
    std::ostringstream os;
    os << std::hex << std::setw(16) << std::setfill('0') << h_;
    return os.str();
  }

 private:
  unsigned long long h_ = 1469598103934665603ull;  // FNV-1a, 64 bits
};

template <class T>
std::string frames_key(const twinray::io::SceneFile<T>& f, const std::string& precision) {
  Hasher h;
  h.text("twinray movie frames v1");
  h.text(precision);
  const twinray::Camera<T>& c = f.camera;
  h.value(c.projection), h.value(c.position), h.value(c.look_at), h.value(c.up);
  h.value(c.focal_length.has_value()), h.value(c.focal_length.value_or(T(0)));
  h.value(c.viewplane_height), h.value(c.width), h.value(c.height);
  const twinray::RenderOptions& o = f.options;
  h.value(o.spp), h.value(o.max_depth), h.value(o.shadows), h.value(o.glaze), h.value(o.terms);
  h.value(o.sampler), h.value(o.seed), h.value(o.adaptive_spp), h.value(o.adaptive_threshold);
  h.value(o.output);
  h.value(f.scene.background);
  for (const auto& m : f.scene.materials)
    h.value(m.color), h.value(m.ka), h.value(m.kd), h.value(m.ks), h.value(m.shininess),
        h.value(m.glaze);
  for (const auto& l : f.scene.lights) h.value(l.position), h.value(l.intensity), h.value(l.color);
  for (const auto& object : f.scene.objects) {
    h.value(object.index());
    std::visit(
        [&](const auto& o) {
          using O = std::decay_t<decltype(o)>;
          h.value(o.material);
          if constexpr (std::is_same<O, twinray::Sphere<T>>::value) {
            h.value(o.center), h.value(o.radius);
          } else if constexpr (std::is_same<O, twinray::Plane<T>>::value) {
            h.value(o.point), h.value(o.normal);
          } else if constexpr (std::is_same<O, twinray::Triangle<T>>::value) {
            h.value(o.vertices);
          } else {
            h.bytes(o.vertices.data(), o.vertices.size() * sizeof(o.vertices[0]));
            h.bytes(o.triangles.data(), o.triangles.size() * sizeof(o.triangles[0]));
          }
        },
        object);
  }
  h.text(f.animation.dump());
  return h.hex();
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
    std::vector<std::string> ours = own_files();
    if (old_key != key_ + "\n") {
      int frames = 0;
      for (const std::string& name : ours)
        if (name.rfind("frame_", 0) == 0 && name.find(".tmp-") == std::string::npos) ++frames;
      if (frames > 0)
        progress.note(dir_ + ": " + std::to_string(frames) +
                      " frames of another scene or other settings; rendering anew");
      remove(ours);
      std::string nl = key_ + "\n";
      twinray::io::write_file_atomically(key_path, nl.data(), nl.size());
    } else {
      // Only what an interrupted write left behind.
      std::vector<std::string> partial;
      for (const std::string& name : ours)
        if (name.find(".tmp-") != std::string::npos || name == kEncoding) partial.push_back(name);
      remove(partial);
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

  void save(long long k, const std::vector<unsigned char>& png) const {
    twinray::io::write_file_atomically(dir_ + "/" + frame_name(k), png);
  }

  std::string encoding_path() const { return dir_ + "/" + kEncoding; }

  // Removes the folder (only twinray's own files; a folder with others stays).
  void discard() {
    remove(own_files());
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

template <class T>
int make_movie(const MovieArgs& a, const std::string& ffmpeg) {
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  twinray::io::SceneFile<T> f = prepare_scene<T>(a.scene, a.shared);
  if (f.animation.is_null())
    usage_error(f.path +
                " has no animation (no \"animation\" key), so there is no movie to "
                "make; docs/scene-format.md describes the key");
  twinray::Animation<T> anim = twinray::io::parse_animation(f);
  const long long frames = a.frames > 0 ? a.frames : anim.frames;
  const double fps = a.fps > 0 ? a.fps : anim.fps;
  const long long from = a.from >= 0 ? a.from : 0;
  const long long to = a.to >= 0 ? a.to : frames - 1;
  const std::string range_note = "the movie has " + std::to_string(frames) + " frames (0 to " +
                                 std::to_string(frames - 1) + ")";
  if (from >= frames) usage_error("--from " + std::to_string(from) + ": " + range_note);
  if (to >= frames)
    usage_error("--to " + std::to_string(to) + ": " + range_note + "; --frames N makes it longer");
  if (from > to)
    usage_error("--from " + std::to_string(from) + " --to " + std::to_string(to) +
                ": the first frame is after the last");
  // Every frame's camera is checked before the first one renders.
  for (long long k = from; k <= to; ++k) {
    twinray::Camera<T> c = f.camera;
    twinray::Scene<T> none;
    if (anim.camera) {
      twinray::Animation<T> camera_only = anim;
      camera_only.paths.clear();
      twinray::animate_into(none, f.camera, camera_only, k, none, c);
    }
    try {
      twinray::validate(c);
    } catch (const twinray::Error& e) {
      usage_error(f.path + ": animation.camera: at frame " + std::to_string(k) + ": " + e.what());
    }
    if (!anim.camera) break;
  }

  const int width = f.camera.width, height = f.camera.height;
  const long long count = to - from + 1;
  Progress progress(a.output, count, Progress::wanted(a.shared.quiet));
  FrameStore store(frames_folder(a.output), frames_key(f, a.shared.precision));
  store.open(progress);

  g_interrupted.store(false);
  auto old_int = std::signal(SIGINT, on_interrupt);
  auto old_term = std::signal(SIGTERM, on_interrupt);
  struct RestoreSignals {
    void (*i)(int);
    void (*t)(int);
    ~RestoreSignals() {
      std::signal(SIGINT, i);
      std::signal(SIGTERM, t);
    }
  } restore{old_int, old_term};

  twinray::io::FfmpegEncoder encoder(ffmpeg, store.encoding_path(), width, height, fps);
  twinray::io::SceneFile<T> frame = f;
  frame.options.log = [&progress](const std::string& line) { progress.note(line); };
  SceneRenderer<T> renderer;
  const bool moves_objects = twinray::moves_objects(anim);
  twinray::RenderInfo info;
  std::string device;
  long long kept = 0, rendered = 0;
  double render_s = 0;
  std::vector<unsigned char> rgb;
  const auto start = Clock::now();
  for (long long k = from; k <= to; ++k) {
    if (g_interrupted.load()) break;
    if (!store.load(k, width, height, rgb)) {
      twinray::animate_into(f.scene, f.camera, anim, k, frame.scene, frame.camera);
      auto r0 = Clock::now();
      // One backend for the whole movie: the scene is packed again only for the
      // frames of an animation that moves objects.
      twinray::Image<T> image = renderer.render(frame, &info, moves_objects ? k : 0);
      render_s += std::chrono::duration<double>(Clock::now() - r0).count();
      device = std::string(twinray::to_string(info.backend)) + " (" + info.device + ")";
      rgb = twinray::io::to_rgb8(image);
      std::vector<unsigned char> png = twinray::io::encode_png(image);
      store.save(k, png);
      ++rendered;
    } else {
      ++kept;
    }
    encoder.write_frame(rgb.data(), width, height);
    long long done = k - from + 1;
    double elapsed = std::chrono::duration<double>(Clock::now() - start).count();
    double rate = elapsed > 0 ? static_cast<double>(done) / elapsed : 0;
    std::ostringstream label;
    label << a.output << std::fixed << std::setprecision(1) << "  " << rate << " frames/s, "
          << format_seconds(rate > 0 ? static_cast<double>(count - done) / rate : -1) << " left";
    progress.set_label(label.str());
    progress.set(done);
  }
  if (g_interrupted.load()) {
    encoder.abort();
    progress.finish();
    std::cerr << "twinray: interrupted; " << (kept + rendered) << " of " << count
              << " frames are kept in " << store.dir()
              << "/; run the same command again to continue from there\n";
    return 130;
  }
  progress.set_label("encoding " + a.output);
  encoder.finish();
  // The movie is complete: make it durable, then put it in place.
  int fd = ::open(store.encoding_path().c_str(), O_RDONLY);
  if (fd >= 0) {
    ::fsync(fd);
    ::close(fd);
  }
  if (::rename(store.encoding_path().c_str(), a.output.c_str()) != 0)
    throw twinray::Error(twinray::ErrorKind::RuntimeFailure,
                         a.output + ": cannot write: " + std::strerror(errno));
  if (!a.keep_frames) store.discard();
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
    s << ", backend " << device << ", " << rendered << " rendered at " << std::setprecision(2)
      << static_cast<double>(rendered) / render_s << " frames/s" << std::setprecision(1);
  if (kept > 0) s << ", " << kept << " kept from " << store.dir() << "/";
  s << ", total " << total_s << " s";
  std::cout << s.str() << std::endl;
  return kExitOk;
}

int run_movie(const MovieArgs& a) {
  // Everything the command line can get wrong, and a missing ffmpeg, are refused
  // before any work.
  check_movie_output(a.output);
  if (a.shared.frame >= 0) usage_error("--frame: movie renders a range; use --from and --to");
  std::string ffmpeg;
  try {
    ffmpeg = twinray::io::find_ffmpeg();
  } catch (const twinray::Error& e) {
    std::cerr << "twinray: " << e.what() << "\n";
    return exit_status(e.kind());
  }
  return with_precision(a.shared, [&](auto zero) { return make_movie<decltype(zero)>(a, ffmpeg); });
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
    20);

}  // namespace
}  // namespace twinray_cli
