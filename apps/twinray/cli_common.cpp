// The shared helpers of the `twinray` command (cli_common.hpp), compiled once for
// float and double.
#include "cli_common.hpp"
#include "cluster.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <sstream>

#include <sys/ioctl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <twinray/scene/validate.hpp>
#include <twinray/core/process.hpp>
#include <twinray/io/atomic_file.hpp>
#include <twinray/io/pfm.hpp>
#ifdef TWINRAY_WITH_OPENEXR
#include <twinray/io/exr.hpp>
#endif
#include <twinray/io/png.hpp>

#include <twinray/scene/demo_scene.hpp>

namespace twinray_cli {

using twinray::Error;
using twinray::ErrorKind;

int exit_status(ErrorKind kind) {
  switch (kind) {
    case ErrorKind::InvalidInput:
      return kExitBadInput;
    case ErrorKind::BackendUnavailable:
      return kExitBackendUnavailable;
    case ErrorKind::RuntimeFailure:
      break;
  }
  return kExitRuntimeFailure;
}

void usage_error(const std::string& message) {
  throw twinray::invalid_input(message);
}

// ---- options ----

namespace {
// A CLI11 check for --terms: a comma-separated subset of ambient, diffuse, specular.
CLI::Validator terms_validator() {
  return CLI::Validator(
      [](std::string& value) -> std::string {
        try {
          parse_terms(value);
        } catch (const Error& e) {
          return e.what();
        }
        return "";
      },
      "TERMS");
}
// A CLI11 check for the limit options: parse_amount's.
CLI::Validator amount_validator(const std::string& option, bool size) {
  return CLI::Validator(
      [option, size](std::string& value) -> std::string {
        try {
          parse_amount(value, option, size);
        } catch (const Error& e) {
          return e.what();
        }
        return "";
      },
      size ? "BYTES" : "N");
}
}  // namespace

void add_shared_options(CLI::App& app, SharedOptions& o, unsigned extras) {
  using twinray::Limits;
  app.add_option("--backend", o.backend,
                 "cpu, opencl, or auto (OpenCL when a device exists, else the CPU)")
      ->check(CLI::IsMember({"cpu", "opencl", "auto"}))
      ->capture_default_str();
  app.add_option("--device", o.device, "OpenCL device index, as `twinray info` lists them")
      ->check(CLI::Range(0, 1 << 20));
  app.add_option("--precision", o.precision, "scalar type of the whole render")
      ->check(CLI::IsMember({"float", "double"}))
      ->capture_default_str();
  app.add_option("--width", o.width, "image width in pixels (overrides the scene)")
      ->check(CLI::Range(1, Limits::max_image_side));
  app.add_option("--height", o.height, "image height in pixels (overrides the scene)")
      ->check(CLI::Range(1, Limits::max_image_side));
  app.add_option("--spp", o.spp, "samples per pixel (overrides the scene)")
      ->check(CLI::Range(1, Limits::max_spp));
  app.add_option("--max-depth", o.max_depth, "reflection depth; 1 = no reflected rays")
      ->check(CLI::Range(1, Limits::max_depth));
  app.add_option("--camera", o.camera, "projection: perspective or orthographic")
      ->check(CLI::IsMember({"perspective", "orthographic"}));
  app.add_flag("--no-shadows", o.no_shadows, "trace no shadow rays");
  app.add_flag("--no-glaze", o.no_glaze, "trace no reflected rays");
  app.add_option("--terms", o.terms,
                 "shading terms that are on, comma-separated: ambient,diffuse,specular")
      ->check(terms_validator());
  if (extras & kOptionFrame)
    app.add_option("--frame", o.frame, "render frame K of the scene's animation")
        ->check(CLI::Range(0, 1 << 30));
  app.add_option("--threads", o.threads, "CPU backend threads (default: all cores)")
      ->check(CLI::Range(1, 4096));
  if (extras & kOptionAov)
    app.add_option("--aov", o.aov,
                   "write, as PFM or EXR, instead of the shaded image: depth (primary hit "
                   "distance, inf for no hit), normal (geometric normal, 0 for no hit), "
                   "shading-normal (interpolated vertex normal where a mesh has them, else "
                   "the geometric one), uv (texture coordinates u, v, 0), object (object "
                   "index, -1 for no hit); or all: the shaded image and every AOV as named "
                   "channels of one .exr")
        ->check(CLI::IsMember({"depth", "normal", "shading-normal", "uv", "object", "all"}));
  app.add_flag("--quiet", o.quiet, "no progress bar");
  app.add_flag("--strict", o.strict,
               "a missing or unreadable .mtl or texture file, or an unknown usemtl name, is an "
               "error (exit status 2) instead of a warning");
  app.add_option("--max-triangles", o.max_triangles,
                 "the most triangles a scene may hold (default: as many as this machine's "
                 "memory holds, " +
                     std::to_string(twinray::io::memory_triangle_limit()) + ")")
      ->check(amount_validator("--max-triangles", false));
  app.add_option("--max-obj-size", o.max_obj_bytes,
                 "the largest .obj file read, in bytes or with K, M, G, T (default: this "
                 "machine's memory)")
      ->check(amount_validator("--max-obj-size", true));
  app.add_option("--sampler", o.sampler,
                 "sub-pixel sample positions: grid, stratified (jittered) or r2 "
                 "(low-discrepancy)")
      ->check(CLI::IsMember({"grid", "stratified", "r2"}));
  app.add_option("--seed", o.seed, "sampler seed (stratified jitter, r2 per-pixel shift)")
      ->check(CLI::Range(0, 2147483647));
  app.add_option("--adaptive", o.adaptive_spp,
                 "adaptive anti-aliasing: N samples in the pixels whose contrast is above "
                 "--adaptive-threshold after a first pass of --spp samples")
      ->check(CLI::Range(2, Limits::max_spp));
  app.add_option("--adaptive-threshold", o.adaptive_threshold,
                 "contrast (linear units) above which a pixel is refined; default 1/32")
      ->check(CLI::Range(0.0, 1e30));
}

twinray::Backend parse_backend(const std::string& name) {
  if (name == "cpu") return twinray::Backend::Cpu;
  if (name == "opencl") return twinray::Backend::OpenCL;
  if (name == "auto") return twinray::Backend::Auto;
  usage_error("--backend: must be cpu, opencl or auto, got \"" + name + "\"");
}

long long parse_amount(const std::string& text, const std::string& option, bool size) {
  auto refuse = [&](const std::string& why) -> long long {
    usage_error(option + ": " + why + ", got \"" + text + "\"");
  };
  size_t digits = 0;
  while (digits < text.size() &&
         (std::isdigit(static_cast<unsigned char>(text[digits])) || text[digits] == '.' ||
          ((text[digits] == 'e' || text[digits] == 'E') && digits > 0)))
    ++digits;
  std::string unit = text.substr(digits);
  double scale = 1.0;
  if (!unit.empty()) {
    const std::string units = "KMGT";
    const size_t power = units.find(static_cast<char>(std::toupper(unit[0])));
    if (!size || power == std::string::npos || !(unit.size() == 1 || unit.substr(1) == "iB"))
      return refuse(size ? "must be a number of bytes, optionally with K, M, G or T"
                         : "must be a whole number such as 50000000 or 5e7");
    scale = std::ldexp(1.0, 10 * static_cast<int>(power + 1));
  }
  double value = 0.0;
  size_t used = 0;
  try {
    value = std::stod(text.substr(0, digits), &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (digits == 0 || used != digits)
    return refuse(size ? "must be a number of bytes, optionally with K, M, G or T"
                       : "must be a whole number such as 50000000 or 5e7");
  value *= scale;
  if (!(value >= 1.0 && value < 9.2e18) || value != std::floor(value))
    return refuse("must be a whole number from 1 to 2^63");
  return static_cast<long long>(value);
}

twinray::io::SceneLimits scene_limits(const SharedOptions& o) {
  twinray::io::SceneLimits limits;
  limits.strict = o.strict;
  if (!o.max_triangles.empty()) {
    // Mesh indices are int: no limit passes 2^31 - 1 (io/obj_mesh.hpp).
    const long long n = parse_amount(o.max_triangles, "--max-triangles", false);
    if (n > (1ll << 31) - 1)
      usage_error(
          "--max-triangles: at most 2147483647 (2^31 - 1, mesh indices are 32-bit), "
          "got " +
          o.max_triangles);
    limits.max_total_triangles = n;
    limits.max_mesh_vertices = std::min(3 * n, (1ll << 31) - 1);
  }
  if (!o.max_obj_bytes.empty())
    limits.max_obj_file_bytes = parse_amount(o.max_obj_bytes, "--max-obj-size", true);
  return limits;
}

unsigned parse_terms(const std::string& list) {
  unsigned terms = 0;
  std::stringstream ss(list);
  std::string term;
  if (list.empty()) usage_error("--terms: give at least one of ambient, diffuse, specular");
  while (std::getline(ss, term, ',')) {
    unsigned bit = term == "ambient"    ? twinray::kAmbient
                   : term == "diffuse"  ? twinray::kDiffuse
                   : term == "specular" ? twinray::kSpecular
                                        : 0u;
    if (bit == 0)
      usage_error("--terms: unknown term \"" + term +
                  "\"; the terms are ambient, diffuse and specular, comma-separated");
    if (terms & bit) usage_error("--terms: \"" + term + "\" is given twice");
    terms |= bit;
  }
  if (list.back() == ',') usage_error("--terms: empty term after the last comma");
  return terms;
}

// ---- scenes ----

std::string scene_arg_text(const std::string& scene) {
  return scene == "demo" ? std::string() : twinray::io::read_scene_text(scene);
}

template <class T>
twinray::io::SceneFile<T> parse_scene_arg(const std::string& scene, const std::string& text,
                                          const twinray::io::SceneLimits& limits = {}) {
  if (scene == "demo") {
    twinray::demo::DemoSetup<T> d = twinray::demo::make_demo_scene<T>();
    twinray::io::SceneFile<T> f;
    f.scene = d.scene;
    f.camera = d.camera;
    f.material_names = {"green", "cyan", "dark_blue", "lime", "magenta"};
    f.path = "demo";
    return f;
  }
  return twinray::io::parse_scene<T>(text, scene, twinray::io::scene_folder(scene), limits);
}

template <class T>
twinray::io::SceneFile<T> load_scene_arg(const std::string& scene) {
  return parse_scene_arg<T>(scene, scene_arg_text(scene));
}

template <class T>
void apply_shared_options(twinray::io::SceneFile<T>& f, const SharedOptions& o) {
  twinray::RenderOptions& r = f.options;
  r.backend = parse_backend(o.backend);
  r.device = o.device;
  twinray::set_thread_count(o.threads);
  if (o.width > 0) f.camera.width = o.width;
  if (o.height > 0) f.camera.height = o.height;
  if (o.spp > 0) r.spp = o.spp;
  if (o.max_depth > 0) r.max_depth = o.max_depth;
  if (!o.camera.empty())
    f.camera.projection = o.camera == "orthographic" ? twinray::Projection::Orthographic
                                                     : twinray::Projection::Perspective;
  if (!o.sampler.empty()) twinray::parse_sampler(o.sampler, &r.sampler);
  if (o.seed >= 0) r.seed = o.seed;
  if (o.adaptive_spp > 0) r.adaptive_spp = o.adaptive_spp;
  if (o.adaptive_threshold >= 0) r.adaptive_threshold = o.adaptive_threshold;
  if (r.adaptive_spp > 0 && r.adaptive_spp <= r.spp)
    usage_error("--adaptive " + std::to_string(r.adaptive_spp) +
                ": must be more than the samples of the first pass (--spp or render.spp, " +
                std::to_string(r.spp) + ")");
  if (o.no_shadows) r.shadows = false;
  if (o.no_glaze) r.glaze = false;
  if (!o.terms.empty()) r.terms = parse_terms(o.terms);
  // --aov all renders each output in turn (cmd_render.cpp), starting from the shaded one.
  if (!o.aov.empty() && o.aov != "all")
    r.output = o.aov == "depth"            ? twinray::Output::Depth
               : o.aov == "normal"         ? twinray::Output::Normal
               : o.aov == "shading-normal" ? twinray::Output::ShadingNormal
               : o.aov == "uv"             ? twinray::Output::Uv
                                           : twinray::Output::ObjectIndex;
  if (o.frame >= 0) {
    if (f.animation.is_null())
      usage_error("--frame " + std::to_string(o.frame) + ": " + f.path +
                  " has no animation (no \"animation\" key)");
    twinray::io::apply_frame(f, o.frame);  // io/scene_json.hpp
  }
  long long pixels = static_cast<long long>(f.camera.width) * f.camera.height;
  if ((o.width > 0 || o.height > 0) && pixels > twinray::Limits::max_pixels)
    usage_error("--width/--height: " + std::to_string(f.camera.width) + " x " +
                std::to_string(f.camera.height) + " is more than the limit of " +
                std::to_string(twinray::Limits::max_pixels) + " pixels");
  try {
    twinray::validate(f.camera);
    twinray::validate(f.scene);
    twinray::validate(f.options);
  } catch (const Error& e) {
    throw twinray::invalid_input(f.path + ": " + e.what());
  }
}

template <class T>
twinray::io::SceneFile<T> prepare_scene(const std::string& scene, const std::string& text,
                                        const SharedOptions& o) {
  twinray::io::SceneFile<T> f = parse_scene_arg<T>(scene, text, scene_limits(o));
  for (const std::string& warning : f.warnings)
    std::fprintf(stderr, "twinray: warning: %s\n", warning.c_str());
  apply_shared_options(f, o);
  return f;
}

template <class T>
twinray::io::SceneFile<T> prepare_scene(const std::string& scene, const SharedOptions& o) {
  return prepare_scene<T>(scene, scene_arg_text(scene), o);
}

// ---- the key of what decides the pixels ----

namespace {
// FNV-1a over the bytes of plain values.
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

}  // namespace

template <class T>
std::string pixels_key(const twinray::io::SceneFile<T>& f, const std::string& precision) {
  Hasher h;
  h.text("twinray movie frames v3");
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
        h.value(m.glaze), h.value(m.texture), h.value(m.transmission), h.value(m.ior),
        h.value(m.absorption);
  auto array = [&](const auto& v) {
    h.value(v.size());
    h.bytes(v.data(), v.size() * sizeof(v[0]));
  };
  for (const auto& t : f.scene.textures)
    h.value(t.width), h.value(t.height), h.value(t.hdr), array(t.texels);
  const twinray::Environment<T>& env = f.scene.environment;
  h.value(env.texture), h.value(env.rotate_degrees), h.value(env.intensity), h.value(env.up);
  for (const auto& l : f.scene.lights)
    h.value(l.position), h.value(l.intensity), h.value(l.color), h.value(l.shape), h.value(l.edge1),
        h.value(l.edge2), h.value(l.radius), h.value(l.samples);
  auto object_key = [&](const twinray::Object<T>& object) {
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
          } else if constexpr (std::is_same<O, twinray::Instance<T>>::value) {
            h.value(o.asset), h.value(o.to_world);
          } else {
            array(o.vertices), array(o.triangles), array(o.normals), array(o.normal_triangles);
            array(o.uvs), array(o.uv_triangles), array(o.triangle_materials);
          }
        },
        object);
  };
  for (const auto& object : f.scene.objects) object_key(object);
  h.value(f.scene.assets.size());
  for (const auto& asset : f.scene.assets) {
    h.value(asset.objects.size());
    for (const auto& object : asset.objects) object_key(object);
  }
  h.text(f.animation.dump());
  return h.hex();
}

// ---- outputs ----

ImageFormat check_output_path(const std::string& path, OutputNeeds needs,
                              const std::string& option) {
  if (path.empty()) usage_error(option + ": the output path is empty");
  size_t slash = path.find_last_of('/');
  size_t dot = path.find_last_of('.');
  std::string ext = dot == std::string::npos || (slash != std::string::npos && dot < slash)
                        ? ""
                        : path.substr(dot);
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  ImageFormat format;
  if (ext == ".png")
    format = ImageFormat::Png;
  else if (ext == ".pfm")
    format = ImageFormat::Pfm;
  else if (ext == ".ppm")
    format = ImageFormat::Ppm;
  else if (ext == ".exr")
    format = ImageFormat::Exr;
  else
    usage_error(option + " " + path + ": unknown image format \"" + ext +
                "\"; the output's extension must be .png, .pfm, .ppm or .exr");
  if (needs == OutputNeeds::Float && format != ImageFormat::Pfm && format != ImageFormat::Exr)
    usage_error(option + " " + path +
                ": --aov writes 32-bit float values; the output must be .pfm or .exr");
  if (needs == OutputNeeds::Channels && format != ImageFormat::Exr)
    usage_error(option + " " + path +
                ": --aov all writes named channels into one file; the output must be .exr");
#ifndef TWINRAY_WITH_OPENEXR
  if (format == ImageFormat::Exr)
    usage_error(option + " " + path +
                ": this twinray was built without OpenEXR, so it cannot write .exr (install "
                "libopenexr-dev on Debian and rebuild), or write .pfm");
#endif
  std::string folder =
      slash == std::string::npos ? "." : (slash == 0 ? "/" : path.substr(0, slash));
  struct stat st {};
  if (::stat(folder.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
    usage_error(option + " " + path + ": the folder " + folder + " does not exist");
  return format;
}

template <class T>
void write_image(const std::string& path, const twinray::Image<T>& image) {
  switch (check_output_path(path, OutputNeeds::Any)) {
    case ImageFormat::Png:
      twinray::io::write_png(path, image);
      return;
    case ImageFormat::Pfm:
      twinray::io::write_pfm(path, image);
      return;
    case ImageFormat::Ppm: {
      // Binary PPM (P6), 8-bit, converted like PNG (clamp, scale by 255, round).
      std::string header =
          "P6\n" + std::to_string(image.width) + " " + std::to_string(image.height) + "\n255\n";
      std::vector<unsigned char> bytes(header.begin(), header.end());
      std::vector<unsigned char> rgb = twinray::io::to_rgb8(image);
      bytes.insert(bytes.end(), rgb.begin(), rgb.end());
      twinray::io::write_file_atomically(path, bytes);
      return;
    }
    case ImageFormat::Exr:
      write_exr_channels<T>(path, image.width, image.height,
                            {{"R", &image, 0}, {"G", &image, 1}, {"B", &image, 2}});
      return;
  }
}

template <class T>
void write_exr_channels(const std::string& path, int width, int height,
                        const std::vector<ExrChannelOf<T>>& channels) {
#ifdef TWINRAY_WITH_OPENEXR
  std::vector<twinray::io::ExrChannel> out;
  for (const ExrChannelOf<T>& c : channels) {
    if (c.image->width != width || c.image->height != height)
      throw twinray::Error(twinray::ErrorKind::RuntimeFailure,
                           path + ": channel " + c.name + " is not of the image's size");
    out.push_back({c.name, twinray::io::channel_of(*c.image, c.component)});
  }
  twinray::io::write_exr(path, width, height, out);
#else
  (void)width, (void)height, (void)channels;
  check_output_path(path, OutputNeeds::Any);  // refuses .exr, naming the missing package
#endif
}

// ---- progress ----

bool stderr_is_terminal() {
  return ::isatty(STDERR_FILENO) == 1;
}

Progress::Progress(std::string label, long long total, bool enabled)
    : label_(std::move(label)),
      total_(total),
      enabled_(enabled),
      start_(std::chrono::steady_clock::now()) {
  if (!enabled_) return;
  {
    // Drawn once now, so even work shorter than a redraw shows it.
    std::lock_guard<std::mutex> lock(mutex_);
    draw_locked();
  }
  thread_ = std::thread([this] { loop(); });
}

Progress::~Progress() {
  finish();
}

void Progress::set(long long done) {
  std::lock_guard<std::mutex> lock(mutex_);
  done_ = done;
}

void Progress::set_label(const std::string& label) {
  std::lock_guard<std::mutex> lock(mutex_);
  label_ = label;
}

void Progress::note(const std::string& line) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (enabled_ && !finished_) std::fputs("\r\033[K", stderr);
  std::fprintf(stderr, "%s%s\n", cluster::message_prefix().c_str(), line.c_str());
  if (enabled_ && !finished_) draw_locked();
  std::fflush(stderr);
}

void Progress::finish() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (finished_) return;
    finished_ = true;
    if (enabled_) {
      std::fputs("\r\033[K", stderr);
      std::fflush(stderr);
    }
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void Progress::loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!finished_) {
    draw_locked();
    wake_.wait_for(lock, std::chrono::milliseconds(100));
  }
}

void Progress::draw_locked() {
  int columns = 80;
  winsize ws{};
  if (::ioctl(STDERR_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col > 0) columns = ws.ws_col;
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  std::ostringstream tail;
  tail << std::fixed << std::setprecision(1);
  if (total_ > 0)
    tail << " " << std::min(done_, total_) << "/" << total_ << "  " << seconds << " s";
  else
    tail << "  " << seconds << " s";
  int bar = std::max(10, std::min(40, columns - static_cast<int>(label_.size()) -
                                          static_cast<int>(tail.str().size()) - 4));
  std::string cells(static_cast<size_t>(bar), ' ');
  if (total_ > 0) {
    int filled = static_cast<int>(static_cast<double>(bar) * std::min(done_, total_) / total_);
    std::fill(cells.begin(), cells.begin() + filled, '#');
  } else {
    // A block of four bouncing from end to end, one cell per redraw.
    int span = bar - 4, step = static_cast<int>(seconds * 10) % (2 * span);
    int at = step < span ? step : 2 * span - step;
    std::fill(cells.begin() + at, cells.begin() + at + 4, '#');
  }
  std::string line = label_ + " [" + cells + "]" + tail.str();
  if (static_cast<int>(line.size()) >= columns) line.resize(static_cast<size_t>(columns - 1));
  std::fputs(("\r\033[K" + line).c_str(), stderr);
  std::fflush(stderr);
}

std::string summary_line(const std::string& output, int width, int height, int spp,
                         const std::string& precision, const std::string& what,
                         const twinray::RenderInfo& info, double load_ms, double total_ms) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(1);
  s << output << ": " << what << ", " << width << "x" << height << ", " << spp << " spp, "
    << precision << ", backend " << twinray::to_string(info.backend) << " (" << info.device
    << "), load " << load_ms << " ms, pack " << info.pack_ms << " ms, render " << info.render_ms
    << " ms";
  if (info.backend == twinray::Backend::OpenCL)
    s << ", program " << (info.program_cached ? "cached " : "build ") << info.build_ms << " ms"
      << ", kernel " << info.kernel;
  s << ", total " << total_ms << " ms, peak "
    << static_cast<double>(twinray::peak_resident_bytes()) / (1 << 20) << " MiB";
  return s.str();
}

// ---- instantiations ----
#define TWINRAY_CLI_INSTANTIATE(T)                                                               \
  template twinray::io::SceneFile<T> load_scene_arg<T>(const std::string&);                      \
  template void apply_shared_options<T>(twinray::io::SceneFile<T>&, const SharedOptions&);       \
  template twinray::io::SceneFile<T> prepare_scene<T>(const std::string&, const SharedOptions&); \
  template twinray::io::SceneFile<T> prepare_scene<T>(const std::string&, const std::string&,    \
                                                      const SharedOptions&);                     \
  template std::string pixels_key<T>(const twinray::io::SceneFile<T>&, const std::string&);      \
  template void write_image<T>(const std::string&, const twinray::Image<T>&);                    \
  template void write_exr_channels<T>(const std::string&, int, int,                              \
                                      const std::vector<ExrChannelOf<T>>&);
TWINRAY_CLI_INSTANTIATE(float)
TWINRAY_CLI_INSTANTIATE(double)
#undef TWINRAY_CLI_INSTANTIATE

}  // namespace twinray_cli
