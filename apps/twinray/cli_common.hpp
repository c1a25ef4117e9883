// What the subcommands of `twinray` share (docs/command-line.md): the render options of render /
// movie / view, loading SCENE (a scene file or `demo`) with those options applied,
// rendering, writing images atomically, the progress bar and the exit statuses.
//
// A subcommand that renders does, in its Run:
//   return twinray_cli::with_precision(opts, [&](auto zero) {
//     using T = decltype(zero);
//     twinray::io::SceneFile<T> f = twinray_cli::prepare_scene<T>(scene, opts);
//     twinray::Image<T> image = twinray_cli::SceneRenderer<T>().render(f, &info);
//     ...
//   });
// Everything here is compiled once (cli_common.cpp, render_call.cpp) for float and
// double, so a cmd_*.cpp stays quick to compile.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <twinray/core/error.hpp>
#include <twinray/core/image.hpp>
#include <twinray/core/options.hpp>
#include <twinray/io/scene_json.hpp>
#include <twinray/pack/pack.hpp>

namespace twinray_cli {

// ---- exit statuses (docs/command-line.md) ----
enum ExitStatus {
  kExitOk = 0,
  kExitRuntimeFailure = 1,
  kExitBadInput = 2,  // bad command line or bad scene
  kExitBackendUnavailable = 3,
};
int exit_status(twinray::ErrorKind kind);

// A bad command line: exit status 2, the message names the option.
[[noreturn]] void usage_error(const std::string& message);

// ---- the options shared by render / movie / view ----
struct SharedOptions {
  std::string backend = "auto";  // cpu | opencl | auto
  int device = -1;               // OpenCL device index; -1 = the first
  std::string precision = "float";
  int width = 0, height = 0;  // 0: the scene's
  int spp = 0;                // 0: the scene's
  int max_depth = 0;          // 0: the scene's
  std::string camera;         // "", perspective, orthographic
  bool no_shadows = false;
  bool no_glaze = false;
  std::string terms;  // "": the scene's; else comma-separated ambient,diffuse,specular
  int frame = -1;     // --frame K; -1: not given
  int threads = 0;    // 0: all cores
  std::string aov;    // "", depth, normal, shading-normal, uv, object
  bool quiet = false;
  bool strict = false;             // a missing .mtl or texture file is an error, not a warning
  std::string max_triangles;       // --max-triangles N; "": follow the machine's memory
  std::string max_obj_bytes;       // --max-obj-size BYTES; "": follow the machine's memory
  std::string sampler;             // "": the scene's; else grid, stratified, r2
  int seed = -1;                   // -1: the scene's
  int adaptive_spp = 0;            // --adaptive N; 0: the scene's
  double adaptive_threshold = -1;  // -1: the scene's
};

// Which of the options that only some subcommands take to add.
enum SharedOptionExtras : unsigned {
  kOptionFrame = 1u,  // --frame K
  kOptionAov = 2u,    // --aov depth|normal|object
};

void add_shared_options(CLI::App& app, SharedOptions& options, unsigned extras = 0);

twinray::Backend parse_backend(const std::string& name);
// A count or a size as the limit options take it: digits, or a decimal with an exponent
// (5e7), and for sizes a binary suffix K, M, G or T (with or without "iB"); throws
// InvalidInput naming `option` unless it is a whole number in [1, 2^63).
long long parse_amount(const std::string& text, const std::string& option, bool size);
// The scene loader's limits: the machine's memory's, or the options'.
twinray::io::SceneLimits scene_limits(const SharedOptions& options);
// "ambient,diffuse" -> kAmbient | kDiffuse; throws InvalidInput naming --terms.
unsigned parse_terms(const std::string& list);

// ---- scenes ----
// SCENE as given on the command line: a scene file, or `demo` for the seed's demo scene
// (include/twinray/scene/demo_scene.hpp; a file named demo is read as ./demo).
template <class T>
twinray::io::SceneFile<T> load_scene_arg(const std::string& scene);

// Applies the command-line overrides to a loaded scene and checks the result.
template <class T>
void apply_shared_options(twinray::io::SceneFile<T>& file, const SharedOptions& options);

// load_scene_arg + apply_shared_options.
template <class T>
twinray::io::SceneFile<T> prepare_scene(const std::string& scene, const SharedOptions& options);

// The same in two steps, for a file read in one place and parsed in several (the ranks
// of an MPI job): the text of SCENE ("" for `demo`), then the scene prepared from it.
std::string scene_arg_text(const std::string& scene);
template <class T>
twinray::io::SceneFile<T> prepare_scene(const std::string& scene, const std::string& text,
                                        const SharedOptions& options);

// A 64-bit hash (16 hex digits) of everything that decides the pixels of the prepared
// scene file's frames in `precision`: camera, options, materials, lights, geometry and
// the animation. It names a movie's frames folder and is what the ranks of an MPI job
// compare before they render.
template <class T>
std::string pixels_key(const twinray::io::SceneFile<T>& file, const std::string& precision);

// Calls f(T{}) with T the --precision type and returns its result.
template <class F>
int with_precision(const SharedOptions& options, F&& f) {
  if (options.precision == "double") return f(double{});
  return f(float{});
}

// Renders prepared scene files through one backend (backend/backend.hpp), made at the
// first render from that file's options (backend, device, log) and kept. The scene is
// packed and uploaded again only when `geometry` differs from the previous render's:
// frames that move only the camera or the lights reuse it. render_call.cpp is the one
// translation unit that instantiates the renderer.
template <class T>
class SceneRenderer {
 public:
  SceneRenderer();
  ~SceneRenderer();
  SceneRenderer(const SceneRenderer&) = delete;
  SceneRenderer& operator=(const SceneRenderer&) = delete;

  // Renders `rect` of the file's frame (default: all of it). The scene is packed again
  // where `geometry` differs from the last call's; with instances_only (only instances
  // moved since), only its top-level BVH is built again.
  twinray::Image<T> render(const twinray::io::SceneFile<T>& file, twinray::RenderInfo* info,
                           long long geometry = 0, twinray::PixelRect rect = {},
                           bool instances_only = false);

 private:
  struct State;
  std::unique_ptr<State> state_;
};
extern template class SceneRenderer<float>;
extern template class SceneRenderer<double>;

// ---- output images ----
enum class ImageFormat { Png, Pfm, Ppm, Exr };

// What an output must hold: any image, 32-bit floats (--aov: .pfm or .exr), or named
// channels (--aov all: .exr).
enum class OutputNeeds { Any, Float, Channels };

// The format of an output path from its extension, checked before any rendering:
// .png, .pfm, .ppm or .exr (.exr only in a build with OpenEXR), as `needs` allows, in a
// folder that exists. `option` names the option in messages (e.g. "-o").
ImageFormat check_output_path(const std::string& path, OutputNeeds needs,
                              const std::string& option = "-o");

// One channel of an EXR: component `component` (0, 1, 2) of `image`.
template <class T>
struct ExrChannelOf {
  std::string name;
  const twinray::Image<T>* image;
  int component;
};

// Writes the channels, all of width x height, as 32-bit floats into one .exr,
// atomically (io/exr.hpp).
template <class T>
void write_exr_channels(const std::string& path, int width, int height,
                        const std::vector<ExrChannelOf<T>>& channels);

// Writes atomically (temporary file + rename): complete or absent.
template <class T>
void write_image(const std::string& path, const twinray::Image<T>& image);

// ---- progress and notes on stderr ----
bool stderr_is_terminal();

// A progress bar on stderr, drawn only when enabled (use Progress::wanted(quiet):
// stderr is a terminal and --quiet was not given). total > 0: a bar of done / total;
// total == 0: an activity bar with the elapsed time, for work that reports no
// fraction. Redrawn by its own thread ten times a second; cleared by finish().
class Progress {
 public:
  Progress(std::string label, long long total, bool enabled);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  static bool wanted(bool quiet) { return !quiet && stderr_is_terminal(); }

  void set(long long done);
  void set_label(const std::string& label);
  // Prints one line on stderr (prefixed "twinray: "), above the bar.
  void note(const std::string& line);
  void finish();

 private:
  void draw_locked();
  void loop();

  std::string label_;
  long long total_ = 0, done_ = 0;
  bool enabled_ = false, finished_ = false;
  std::chrono::steady_clock::time_point start_;
  std::mutex mutex_;
  std::condition_variable wake_;
  std::thread thread_;
};

// The one summary line of a render (docs/command-line.md): output, size, spp, precision, backend,
// device, times (load: reading the scene and its files), the process's peak memory.
std::string summary_line(const std::string& output, int width, int height, int spp,
                         const std::string& precision, const std::string& what,
                         const twinray::RenderInfo& info, double load_ms, double total_ms);

}  // namespace twinray_cli
