// `twinray report [--quick] -o DIR`: error against run time (docs/command-line.md,
// docs/sampling.md).
//
// For each scene (the demo, and "edges": report_scenes.hpp) x precision x sampler x
// samples per pixel (uniform, and adaptive: device/adaptive.h) x backend, renders
// `runs` timed frames after a warm-up and measures the error of the image against a
// reference (double, CPU, many stratified samples; its own convergence is checked
// against a second reference with 4x fewer samples and another seed). Writes to DIR:
//   report.csv          one line per configuration (columns: see kCsvHeader)
//   report.md           the highlights and the whole table in Markdown
//   error_vs_time.png   log-log RMSE against render time, one curve per configuration
//   error_vs_spp.png    log-log RMSE against samples per pixel, with fitted slopes
//   report.gp, plot.dat the gnuplot script and data behind the two plots
// The plots are drawn by gnuplot (Debian gnuplot-nox, scripts/packages.txt).
//
// Backends give the same bits (the report checks it for every configuration), so the
// error of a configuration does not depend on the backend; only its time does.
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <twinray/io/atomic_file.hpp>
#include <twinray/version.hpp>

#include "cli_common.hpp"
#include "command.hpp"
#include "report_metrics.hpp"
#include "report_scenes.hpp"

namespace twinray_cli {
namespace {

using report::Errors;
using twinray::Backend;
using twinray::Image;
using twinray::RenderInfo;
using twinray::RenderOptions;
using twinray::Sampler;

struct ReportArgs {
  std::string dir;
  bool quick = false;
  int runs = 0;  // 0: the plan's
  int size = 0;  // 0: the plan's
  std::string backends = "cpu,opencl";
  int threads = 0;
  bool quiet = false;
};

struct AdaptiveConfig {
  int spp;  // refined pixels' samples
  double threshold;
};

// What a report renders. Uniform counts are powers of 4 (square grids for the grid and
// stratified samplers); adaptive runs start from first_spp samples.
struct Plan {
  int size;
  std::vector<int> spps;
  int first_spp;
  std::vector<AdaptiveConfig> adaptive;
  int runs;          // timed runs per configuration and backend (median)
  int seeds;         // seeds of the stochastic samplers (float, uniform, spp <= seed_max_spp)
  int seed_max_spp;  // above it, one seed
  int ref_spp;       // reference: double, CPU, stratified
  int check_spp;     // second reference, another seed: the first one's convergence check
};

Plan make_plan(bool quick) {
  if (quick) return {40, {1, 4, 16}, 4, {{16, 1.0 / 32}}, 1, 2, 16, 256, 64};
  Plan full;
  full.size = 64;
  full.spps = {1, 4, 16, 64, 256};
  full.first_spp = 4;
  full.adaptive = {
      {16, 1.0 / 32}, {64, 1.0 / 32}, {256, 1.0 / 32}, {64, 1.0 / 128}, {256, 1.0 / 128}};
  full.runs = 3;
  full.seeds = 4;
  full.seed_max_spp = 64;
  full.ref_spp = 4096;
  full.check_spp = 1024;
  return full;
}

constexpr int kRefSeed = 1000, kCheckSeed = 2000;
const Sampler kSamplers[] = {Sampler::Grid, Sampler::Stratified, Sampler::R2};

struct Row {
  std::string scene, backend, device, precision, sampler, mode;
  int width = 0, height = 0, spp = 0, adaptive_spp = 0;
  double threshold = 0;
  double samples_per_pixel = 0, refined_fraction = 0;
  int runs = 0;
  double ms_median = 0, ms_min = 0, ms_max = 0, transfer_ms = 0, build_ms = 0;
  bool cached = false;
  Errors err;
  int seeds = 1;
  double rmse_mean = 0, rmse_std = 0;
  double fvd_rmse = std::nan(""), fvd_max = std::nan("");
  long long differ_from_cpu = -1;  // -1: not compared
};

struct SceneSummary {
  std::string name;
  int ref_spp = 0, check_spp = 0;
  double ref_ms = 0, check_rmse = 0;
};

const char* kCsvHeader =
    "scene,width,height,backend,device,precision,sampler,mode,spp,adaptive_spp,threshold,"
    "samples_per_pixel,refined_fraction,runs,render_ms_median,render_ms_min,render_ms_max,"
    "transfer_ms_median,build_ms,program_cached,rmse,psnr_db,max_abs,rmse_edge,rmse_smooth,"
    "seeds,rmse_mean,rmse_std,float_vs_double_rmse,float_vs_double_max,values_differing_from_cpu";

std::string num(double v, int precision = 6) {
  if (std::isnan(v)) return "";
  std::ostringstream s;
  s << std::setprecision(precision) << v;
  return s.str();
}

std::string fixed(double v, int decimals) {
  if (std::isnan(v)) return "-";
  std::ostringstream s;
  s << std::fixed << std::setprecision(decimals) << v;
  return s.str();
}

std::string config_name(const Row& r) {
  std::string s = r.sampler + " " + std::to_string(r.spp);
  if (r.mode == "adaptive")
    s += "->" + std::to_string(r.adaptive_spp) + " t=1/" +
         std::to_string(static_cast<int>(std::lround(1 / r.threshold)));
  return s;
}

template <class T>
Image<T> render_once(const report::ReportScene<T>& rs, const RenderOptions& o, RenderInfo* info) {
  twinray::io::SceneFile<T> f;
  f.scene = rs.scene;
  f.camera = rs.camera;
  f.options = o;
  f.path = rs.name;
  return SceneRenderer<T>().render(f, info);
}

template <class T>
report::ReportScene<T> make_scene(const std::string& name, int size) {
  return name == "demo" ? report::demo_scene<T>(size) : report::edges_scene<T>(size);
}

class Reporter {
 public:
  Reporter(const ReportArgs& args, const Plan& plan, Progress& progress)
      : plan_(plan), progress_(progress) {
    std::stringstream ss(args.backends);
    for (std::string b; std::getline(ss, b, ',');) backends_.push_back(parse_backend(b));
  }

  void run_scene(const std::string& name) {
    SceneSummary summary;
    summary.name = name;
    // The reference and its check: double, CPU, stratified.
    report::ReportScene<double> ref_scene = make_scene<double>(name, plan_.size);
    RenderOptions o = base_options(ref_scene.max_depth, Backend::Cpu);
    o.sampler = Sampler::Stratified;
    o.spp = plan_.ref_spp;
    o.seed = kRefSeed;
    progress_.set_label(name + ": reference, " + std::to_string(o.spp) + " spp");
    RenderInfo info;
    ref_ = render_once(ref_scene, o, &info);
    summary.ref_ms = info.render_ms;
    summary.ref_spp = plan_.ref_spp;
    o.spp = plan_.check_spp;
    o.seed = kCheckSeed;
    progress_.set_label(name + ": reference check, " + std::to_string(o.spp) + " spp");
    Image<double> check = render_once(ref_scene, o, &info);
    double unused;
    report::difference(check, ref_, &summary.check_rmse, &unused);
    summary.check_spp = plan_.check_spp;
    mask_ = report::edge_mask(ref_);
    summaries_.push_back(summary);
    float_images_.clear();
    run_precision<float>(name);
    run_precision<double>(name);
  }

  const std::vector<Row>& rows() const { return rows_; }
  const std::vector<SceneSummary>& summaries() const { return summaries_; }
  const std::vector<Backend>& backends() const { return backends_; }
  const std::map<std::string, std::string>& devices() const { return devices_; }

 private:
  RenderOptions base_options(int max_depth, Backend b) const {
    RenderOptions o;
    o.backend = b;
    o.max_depth = max_depth;
    o.log = [](const std::string&) {};
    return o;
  }

  template <class T>
  void run_precision(const std::string& name) {
    const std::string precision = sizeof(T) == 8 ? "double" : "float";
    report::ReportScene<T> rs = make_scene<T>(name, plan_.size);
    // Warm-up per backend: builds (or loads) the OpenCL program and lets PoCL generate
    // the code of every kernel the timed runs launch; its build time is reported.
    for (Backend b : backends_) {
      RenderOptions o = base_options(rs.max_depth, b);
      progress_.set_label(name + " " + precision + " " + twinray::to_string(b) + ": warm-up");
      RenderInfo info;
      render_once(rs, o, &info);
      build_ms_[b] = info.build_ms;
      cached_[b] = info.program_cached;
      // A second frame: the OpenCL backend may render a first frame with a kernel that
      // compiles sooner than the later frames' (backend/opencl/backend.hpp).
      render_once(rs, o, &info);
      build_ms_[b] += info.build_ms;
      cached_[b] = cached_[b] && (info.build_ms == 0 || info.program_cached);
      devices_[twinray::to_string(b)] = info.device;
      o.spp = 1;
      o.adaptive_spp = 2;
      render_once(rs, o, &info);
    }
    for (Sampler sampler : kSamplers) {
      for (int spp : plan_.spps) run_config<T>(rs, precision, sampler, spp, 0, 0);
      for (const AdaptiveConfig& a : plan_.adaptive)
        run_config<T>(rs, precision, sampler, plan_.first_spp, a.spp, a.threshold);
    }
  }

  template <class T>
  void run_config(const report::ReportScene<T>& rs, const std::string& precision, Sampler sampler,
                  int spp, int adaptive_spp, double threshold) {
    RenderOptions o = base_options(rs.max_depth, Backend::Cpu);
    o.sampler = sampler;
    o.spp = spp;
    o.adaptive_spp = adaptive_spp;
    if (adaptive_spp > 0) o.adaptive_threshold = threshold;
    const long long pixels = static_cast<long long>(rs.camera.width) * rs.camera.height;
    Image<T> first_image;
    size_t first_row = rows_.size();
    for (Backend b : backends_) {
      o.backend = b;
      Row r;
      r.scene = rs.name;
      r.width = rs.camera.width;
      r.height = rs.camera.height;
      r.backend = twinray::to_string(b);
      r.device = devices_[r.backend];
      r.precision = precision;
      r.sampler = twinray::to_string(sampler);
      r.mode = adaptive_spp > 0 ? "adaptive" : "uniform";
      r.spp = spp;
      r.adaptive_spp = adaptive_spp;
      r.threshold = adaptive_spp > 0 ? threshold : 0;
      progress_.set_label(rs.name + " " + precision + " " + r.backend + " " + config_name(r));
      std::vector<double> ms, transfer;
      Image<T> image;
      RenderInfo info;
      const int runs = plan_.runs;
      for (int k = 0; k < runs; ++k) {
        info = RenderInfo();
        image = render_once(rs, o, &info);
        ms.push_back(info.render_ms);
        transfer.push_back(info.transfer_ms);
      }
      progress_.set(++done_);
      r.runs = runs;
      r.ms_median = report::median(ms);
      r.ms_min = *std::min_element(ms.begin(), ms.end());
      r.ms_max = *std::max_element(ms.begin(), ms.end());
      r.transfer_ms = report::median(transfer);
      r.build_ms = build_ms_[b];
      r.cached = cached_[b];
      r.samples_per_pixel =
          adaptive_spp > 0 ? static_cast<double>(info.samples) / static_cast<double>(pixels) : spp;
      r.refined_fraction =
          adaptive_spp > 0 ? static_cast<double>(info.refined_pixels) / static_cast<double>(pixels)
                           : 0;
      r.err = report::errors(image, ref_, mask_);
      if (b == backends_.front()) {
        first_image = image;
      } else {
        r.differ_from_cpu = static_cast<long long>(report::differing_values(first_image, image));
        rows_[first_row].differ_from_cpu = 0;
      }
      rows_.push_back(r);
    }
    // Seeds: the error of a stochastic sampler is a random variable; its mean and
    // standard deviation over seeds (seed 0 is the timed image). Backend-independent.
    std::vector<double> rmses = {rows_[first_row].err.rmse};
    int effective = adaptive_spp > 0 ? adaptive_spp : spp;
    if (sampler != Sampler::Grid && precision == "float" && effective <= plan_.seed_max_spp) {
      o.backend = Backend::Cpu;
      for (int seed = 1; seed < plan_.seeds; ++seed) {
        o.seed = seed;
        RenderInfo info;
        rmses.push_back(report::errors(render_once(rs, o, &info), ref_, mask_).rmse);
      }
    }
    double mean = 0, std_dev = 0;
    report::mean_std(rmses, &mean, &std_dev);
    // Float against double at the same sample positions (the samplers place them at
    // the same reals in both precisions): the error that float alone adds.
    std::string key = config_name(rows_[first_row]);
    double fvd = std::nan(""), fvd_max = std::nan("");
    if (precision == "float") {
      Image<double> copy(first_image.width, first_image.height);
      for (size_t i = 0; i < copy.rgb.size(); ++i) copy.rgb[i] = first_image.rgb[i];
      float_images_[key] = {copy, first_row};
    } else if (float_images_.count(key)) {
      report::difference(float_images_[key].first, first_image, &fvd, &fvd_max);
      for (size_t i = float_images_[key].second; i < float_images_[key].second + backends_.size();
           ++i)
        rows_[i].fvd_rmse = fvd, rows_[i].fvd_max = fvd_max;
    }
    for (size_t i = first_row; i < rows_.size(); ++i) {
      rows_[i].seeds = static_cast<int>(rmses.size());
      rows_[i].rmse_mean = mean;
      rows_[i].rmse_std = std_dev;
      if (precision == "double") rows_[i].fvd_rmse = fvd, rows_[i].fvd_max = fvd_max;
    }
  }

  const Plan& plan_;
  Progress& progress_;
  std::vector<Backend> backends_;
  std::map<Backend, double> build_ms_;
  std::map<Backend, bool> cached_;
  std::map<std::string, std::string> devices_;
  Image<double> ref_;
  std::vector<char> mask_;
  std::map<std::string, std::pair<Image<double>, size_t>> float_images_;
  std::vector<Row> rows_;
  std::vector<SceneSummary> summaries_;
  long long done_ = 0;
};

// ---- the files ----

void write_text(const std::string& path, const std::string& text) {
  twinray::io::write_file_atomically(path, text.data(), text.size());
}

std::string csv(const std::vector<Row>& rows) {
  std::ostringstream s;
  s << kCsvHeader << "\n";
  for (const Row& r : rows) {
    s << r.scene << "," << r.width << "," << r.height << "," << r.backend << ",\"" << r.device
      << "\"," << r.precision << "," << r.sampler << "," << r.mode << "," << r.spp << ","
      << r.adaptive_spp << "," << num(r.threshold) << "," << num(r.samples_per_pixel) << ","
      << num(r.refined_fraction) << "," << r.runs << "," << num(r.ms_median) << "," << num(r.ms_min)
      << "," << num(r.ms_max) << "," << num(r.transfer_ms) << "," << num(r.build_ms) << ","
      << (r.cached ? 1 : 0) << "," << num(r.err.rmse) << "," << num(r.err.psnr_db) << ","
      << num(r.err.max_abs) << "," << num(r.err.rmse_edge) << "," << num(r.err.rmse_smooth) << ","
      << r.seeds << "," << num(r.rmse_mean) << "," << num(r.rmse_std) << "," << num(r.fvd_rmse)
      << "," << num(r.fvd_max) << ","
      << (r.differ_from_cpu < 0 ? std::string() : std::to_string(r.differ_from_cpu)) << "\n";
  }
  return s.str();
}

const Row* find_row(const std::vector<Row>& rows, const std::string& scene,
                    const std::string& backend, const std::string& precision,
                    const std::string& sampler, const std::string& mode, int spp,
                    int adaptive_spp = 0) {
  for (const Row& r : rows)
    if (r.scene == scene && r.backend == backend && r.precision == precision &&
        r.sampler == sampler && r.mode == mode && r.spp == spp &&
        (mode == "uniform" || r.adaptive_spp == adaptive_spp))
      return &r;
  return nullptr;
}

// "Reaches the error": RMSE (mean over seeds) at most this much above the target, well
// inside the seed-to-seed spread of the stochastic samplers.
constexpr double kErrorTolerance = 0.02;

// The cheapest adaptive configuration of (scene, backend, precision, sampler) whose
// RMSE (mean over seeds) reaches `target`; nullptr if none does.
const Row* cheapest_adaptive_at(const std::vector<Row>& rows, const Row& like, double target) {
  const Row* best = nullptr;
  for (const Row& r : rows)
    if (r.mode == "adaptive" && r.scene == like.scene && r.backend == like.backend &&
        r.precision == like.precision && r.sampler == like.sampler &&
        r.rmse_mean <= target * (1 + kErrorTolerance) && (!best || r.ms_median < best->ms_median))
      best = &r;
  return best;
}

struct Slope {
  double all, edge, smooth;
};

Slope fitted_slope(const std::vector<Row>& rows, const std::string& scene,
                   const std::string& sampler, const std::string& backend) {
  std::vector<double> x, y, ye, ys;
  for (const Row& r : rows)
    if (r.scene == scene && r.sampler == sampler && r.mode == "uniform" && r.precision == "float" &&
        r.backend == backend) {
      x.push_back(r.spp);
      y.push_back(r.rmse_mean);
      ye.push_back(r.err.rmse_edge);
      ys.push_back(r.err.rmse_smooth);
    }
  return {report::log_log_slope(x, y), report::log_log_slope(x, ye), report::log_log_slope(x, ys)};
}

std::string markdown(const std::vector<Row>& rows, const std::vector<SceneSummary>& summaries,
                     const Plan& plan, bool quick, const std::vector<Backend>& backends,
                     const std::map<std::string, std::string>& devices, double load_before,
                     double load_after, double total_s) {
  std::ostringstream s;
  const std::string b0 = twinray::to_string(backends.front());
  s << "# twinray report" << (quick ? " (--quick)" : "") << "\n\n";
  s << "twinray " << TWINRAY_VERSION_STRING << "; images " << plan.size << "x" << plan.size
    << "; timings are the median of " << plan.runs
    << " run(s) after a warm-up, in ms per frame, "
       "OpenCL program build excluded (its own "
       "column) and host-device transfers included (also in their own column). ";
  for (Backend b : backends) {
    auto it = devices.find(twinray::to_string(b));
    s << "Backend " << twinray::to_string(b) << ": " << (it != devices.end() ? it->second : "?")
      << ". ";
  }
  s << "Load average (1 min) " << fixed(load_before, 2) << " before, " << fixed(load_after, 2)
    << " after; the report took " << fixed(total_s, 0) << " s.\n\n";
  s << "Errors are measured on the linear framebuffer against the reference, over every "
       "channel of every pixel. Edge pixels: a channel differs from a 4-neighbour's by more "
       "than "
    << report::kEdgeStep << " in the reference.\n\n";

  s << "## References\n\n| scene | reference | render s | check | RMSE(check, reference) | "
       "smallest RMSE reported | ratio | converged |\n|---|---|---|---|---|---|---|---|\n";
  for (const SceneSummary& sm : summaries) {
    double smallest = 1e300;
    for (const Row& r : rows)
      if (r.scene == sm.name) smallest = std::min(smallest, r.err.rmse);
    s << "| " << sm.name << " | double, CPU, stratified " << sm.ref_spp << " spp | "
      << fixed(sm.ref_ms / 1000, 1) << " | stratified " << sm.check_spp << " spp, other seed | "
      << num(sm.check_rmse, 3) << " | " << num(smallest, 3) << " | "
      << fixed(smallest / sm.check_rmse, 1) << " | "
      << (sm.check_rmse < smallest / 10 ? "yes" : "no (< 10x)") << " |\n";
  }
  s << "\nThe check image has 4x fewer samples than the reference, so RMSE(check, reference) "
       "bounds the reference's own error from above; \"converged\" asks it to be below a tenth "
       "of the smallest error in the table.\n\n";

  // Adaptive against 64 (or the largest) uniform spp.
  int target_spp = 0;
  for (int spp : plan.spps)
    if (spp <= 64) target_spp = spp;
  s << "## Adaptive sampling against " << target_spp << " uniform samples per pixel\n\n";
  s << "For each backend, precision and sampler: the RMSE of " << target_spp
    << " uniform spp, and the fastest adaptive configuration whose RMSE (mean over seeds) is "
       "at most that (within "
    << 100 * kErrorTolerance << "%). time saved = uniform ms / adaptive ms.\n\n";
  s << "| scene | backend | precision | sampler | uniform " << target_spp
    << " spp: RMSE, ms | adaptive config | samples/px | refined | RMSE | ms | time saved |\n"
       "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const SceneSummary& sm : summaries)
    for (Backend b : backends)
      for (const char* precision : {"float", "double"})
        for (Sampler smp : kSamplers) {
          const Row* u = find_row(rows, sm.name, twinray::to_string(b), precision,
                                  twinray::to_string(smp), "uniform", target_spp);
          if (!u) continue;
          const Row* a = cheapest_adaptive_at(rows, *u, u->rmse_mean);
          s << "| " << sm.name << " | " << u->backend << " | " << precision << " | " << u->sampler
            << " | " << num(u->rmse_mean, 3) << ", " << fixed(u->ms_median, 1) << " | ";
          if (a)
            s << config_name(*a) << " | " << fixed(a->samples_per_pixel, 1) << " | "
              << fixed(100 * a->refined_fraction, 1) << "% | " << num(a->rmse_mean, 3) << " | "
              << fixed(a->ms_median, 1) << " | **" << fixed(u->ms_median / a->ms_median, 2)
              << "x** |\n";
          else
            s << "none reaches it | | | | | |\n";
        }

  s << "\n## Float against double\n\n"
       "Same sample positions (the samplers place them at the same reals in both precisions): "
       "the RMSE between the float and the double image is the error float alone adds. Time: "
       "median over all configurations of (double ms / float ms).\n\n"
       "| scene | backend | float-vs-double RMSE (median, max over configs) | largest abs "
       "difference | double / float time |\n|---|---|---|---|---|\n";
  for (const SceneSummary& sm : summaries)
    for (Backend b : backends) {
      std::vector<double> fvd, fvd_max, ratio;
      for (const Row& r : rows)
        if (r.scene == sm.name && r.backend == twinray::to_string(b) && r.precision == "double") {
          if (!std::isnan(r.fvd_rmse)) fvd.push_back(r.fvd_rmse), fvd_max.push_back(r.fvd_max);
          const Row* f =
              find_row(rows, r.scene, r.backend, "float", r.sampler, r.mode, r.spp, r.adaptive_spp);
          if (f && f->ms_median > 0 && (r.mode == "uniform" || f->threshold == r.threshold))
            ratio.push_back(r.ms_median / f->ms_median);
        }
      s << "| " << sm.name << " | " << twinray::to_string(b) << " | " << num(report::median(fvd), 3)
        << ", " << num(fvd.empty() ? 0 : *std::max_element(fvd.begin(), fvd.end()), 3) << " | "
        << num(fvd_max.empty() ? 0 : *std::max_element(fvd_max.begin(), fvd_max.end()), 3) << " | "
        << fixed(report::median(ratio), 2) << " |\n";
    }

  s << "\n## Convergence: fitted slope of log RMSE against log spp\n\n"
       "Uniform sampling, float, least squares over spp = ";
  for (size_t i = 0; i < plan.spps.size(); ++i) s << (i ? ", " : "") << plan.spps[i];
  s << ". Expected (Mitchell 1996): -0.5 for a regular grid on edges, about -0.75 "
       "for stratified on edges, -1 for smooth regions.\n\n"
       "| scene | sampler | all pixels | edge pixels | smooth pixels |\n|---|---|---|---|---|\n";
  for (const SceneSummary& sm : summaries)
    for (Sampler smp : kSamplers) {
      Slope sl = fitted_slope(rows, sm.name, twinray::to_string(smp), b0);
      s << "| " << sm.name << " | " << twinray::to_string(smp) << " | " << fixed(sl.all, 2) << " | "
        << fixed(sl.edge, 2) << " | " << fixed(sl.smooth, 2) << " |\n";
    }

  s << "\n## Plots\n\n![RMSE against render time](error_vs_time.png)\n\n"
       "![RMSE against samples per pixel](error_vs_spp.png)\n\n";

  s << "## All configurations\n\n"
       "RMSE is the seed-0 image's; mean +- std over `seeds` seeds for the stochastic samplers. "
       "`=cpu`: framebuffer values whose bits differ from the CPU backend's image.\n\n"
       "| scene | backend | prec | config | samples/px | ms (median) | transfer ms | build ms | "
       "RMSE | mean +- std (seeds) | PSNR dB | max abs | RMSE edge | RMSE smooth | f-vs-d RMSE "
       "| =cpu |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Row& r : rows)
    s << "| " << r.scene << " | " << r.backend << " | " << r.precision << " | " << config_name(r)
      << " | " << fixed(r.samples_per_pixel, 1) << " | " << fixed(r.ms_median, 1) << " | "
      << fixed(r.transfer_ms, 2) << " | " << fixed(r.build_ms, 0) << (r.cached ? " (cached)" : "")
      << " | " << num(r.err.rmse, 3) << " | " << num(r.rmse_mean, 3) << " +- " << num(r.rmse_std, 2)
      << " (" << r.seeds << ") | " << fixed(r.err.psnr_db, 1) << " | " << num(r.err.max_abs, 3)
      << " | " << num(r.err.rmse_edge, 3) << " | " << num(r.err.rmse_smooth, 3) << " | "
      << num(r.fvd_rmse, 2) << " | "
      << (r.differ_from_cpu < 0 ? std::string("") : std::to_string(r.differ_from_cpu)) << " |\n";
  return s.str();
}

// gnuplot data: one block per curve (separated by two blank lines, gnuplot's `index`).
struct Curve {
  std::string title, style;
  std::vector<std::pair<double, double>> points;
  std::vector<double> y_std;
};

std::string gp_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("''") : std::string(1, c);
  return out + "'";
}

void write_plots(const std::string& dir, const std::vector<Row>& rows,
                 const std::vector<SceneSummary>& summaries, const std::vector<Backend>& backends,
                 const Plan& plan) {
  const char* colors[] = {"#1b9e77", "#d95f02", "#7570b3"};  // grid, stratified, r2
  std::ostringstream data, script;
  int block = 0;
  // Writes a curve's data block; its gnuplot index is the order of writing.
  auto add = [&](std::vector<std::pair<int, Curve>>& to, const Curve& c) {
    data << "# " << c.title << "\n";
    for (size_t i = 0; i < c.points.size(); ++i)
      data << std::setprecision(9) << c.points[i].first << " " << c.points[i].second << " "
           << (i < c.y_std.size() ? c.y_std[i] : 0.0) << "\n";
    data << "\n\n";
    to.push_back({block++, c});
  };
  // panels[plot][scene] = curves
  std::vector<std::vector<std::pair<int, Curve>>> time_panels, spp_panels;
  for (const SceneSummary& sm : summaries) {
    std::vector<std::pair<int, Curve>> tcurves, scurves;
    for (int si = 0; si < 3; ++si) {
      std::string sampler = twinray::to_string(kSamplers[si]);
      for (Backend b : backends)
        for (const char* precision : {"float", "double"})
          for (const char* mode : {"uniform", "adaptive"}) {
            Curve c;
            std::string backend = twinray::to_string(b);
            c.title =
                sampler + " " + backend + " " + precision + (mode[0] == 'a' ? " adaptive" : "");
            for (const Row& r : rows)
              if (r.scene == sm.name && r.sampler == sampler && r.backend == backend &&
                  r.precision == precision && r.mode == mode)
                c.points.push_back({r.ms_median, r.err.rmse});
            std::sort(c.points.begin(), c.points.end());
            std::ostringstream st;
            st << "linespoints lc rgb '" << colors[si] << "' dt " << (b == Backend::Cpu ? 1 : 2)
               << " pt " << (std::string(precision) == "float" ? 7 : 9) << " ps 0.8 lw "
               << (mode[0] == 'a' ? 3 : 1);
            c.style = st.str();
            if (!c.points.empty()) add(tcurves, c);
          }
      // RMSE against spp: backend-independent; first backend, float.
      for (const char* mode : {"uniform", "adaptive"}) {
        Curve c;
        std::vector<double> x, y;
        for (const Row& r : rows)
          if (r.scene == sm.name && r.sampler == sampler &&
              r.backend == twinray::to_string(backends.front()) && r.precision == "float" &&
              r.mode == mode) {
            c.points.push_back({r.samples_per_pixel, r.rmse_mean});
            c.y_std.push_back(r.rmse_std);
            x.push_back(r.samples_per_pixel);
            y.push_back(r.rmse_mean);
          }
        if (c.points.empty()) continue;
        if (mode[0] == 'u') {
          c.title = sampler + " uniform, slope " + fixed(report::log_log_slope(x, y), 2);
          c.style = "yerrorlines lc rgb '" + std::string(colors[si]) + "' pt 7 ps 0.8 lw 2";
        } else {
          c.title = sampler + " adaptive (first pass " + std::to_string(plan.first_spp) + ")";
          c.style = "points lc rgb '" + std::string(colors[si]) + "' pt 5 ps 1.2";
        }
        add(scurves, c);
      }
    }
    time_panels.push_back(tcurves);
    spp_panels.push_back(scurves);
  }

  const std::string dat = dir + "/plot.dat";
  auto plot_panel = [&](const std::vector<std::pair<int, Curve>>& curves, bool with_std) {
    script << "plot ";
    for (size_t i = 0; i < curves.size(); ++i)
      script << (i ? ", \\\n     " : "") << gp_quote(dat) << " index " << curves[i].first
             << " using 1:2"
             << (with_std && curves[i].second.style.rfind("yerror", 0) == 0 ? ":3" : "") << " with "
             << curves[i].second.style << " title " << gp_quote(curves[i].second.title);
    script << "\n";
  };
  const int n = static_cast<int>(summaries.size());
  script << "# twinray report plots; run: gnuplot report.gp\n"
            "set terminal pngcairo size "
         << 900 * n << ",760 noenhanced font ',10'\n"
         << "set logscale xy\nset grid\nset key bottom left font ',8' spacing 0.9\n"
         << "set output " << gp_quote(dir + "/error_vs_time.png.tmp") << "\n"
         << "set multiplot layout 1," << n
         << " title 'RMSE against render time (median ms per frame, program build excluded); "
            "color: sampler, solid: CPU, dashed: OpenCL, circle: float, diamond: double, thick: "
            "adaptive'\n";
  for (int i = 0; i < n; ++i) {
    script << "set title " << gp_quote(summaries[i].name) << "\n"
           << "set xlabel 'render time per frame (ms)'\nset ylabel 'RMSE against the reference "
              "(linear)'\n";
    plot_panel(time_panels[i], false);
  }
  script << "unset multiplot\nset output " << gp_quote(dir + "/error_vs_spp.png.tmp") << "\n"
         << "set multiplot layout 1," << n
         << " title 'RMSE against samples per pixel (float; mean and std over seeds), with "
            "least-squares slopes'\n";
  for (int i = 0; i < n; ++i) {
    // Guides: slopes -0.5 and -1 through the grid sampler's 1-spp error.
    double y1 = spp_panels[i].empty() || spp_panels[i][0].second.points.empty()
                    ? 0.1
                    : spp_panels[i][0].second.points[0].second;
    script << "set title " << gp_quote(summaries[i].name) << "\n"
           << "set xlabel 'samples per pixel (adaptive: mean)'\nset ylabel 'RMSE'\n";
    script << "plot ";
    script << std::setprecision(9) << y1 << "*x**-0.5 with lines lc rgb '#aaaaaa' dt 3 title "
           << "'slope -0.5', " << y1 << "*x**-1 with lines lc rgb '#666666' dt 3 title 'slope -1'";
    for (const auto& ic : spp_panels[i])
      script << ", \\\n     " << gp_quote(dat) << " index " << ic.first << " using 1:2"
             << (ic.second.style.rfind("yerror", 0) == 0 ? ":3" : "") << " with " << ic.second.style
             << " title " << gp_quote(ic.second.title);
    script << "\n";
  }
  script << "unset multiplot\n";
  write_text(dat, data.str());
  write_text(dir + "/report.gp", script.str());
}

int run_report(const ReportArgs& a) {
  auto t0 = std::chrono::steady_clock::now();
  if (a.dir.empty()) usage_error("-o: give the folder for the report");
  if (a.dir.find('\'') != std::string::npos) usage_error("-o: the folder's name has a quote");
  std::error_code ec;
  std::filesystem::create_directories(a.dir, ec);
  struct stat st {};
  if (::stat(a.dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
    usage_error("-o " + a.dir + ": cannot create the folder");
  Plan plan = make_plan(a.quick);
  if (a.runs > 0) plan.runs = a.runs;
  if (a.size > 0) plan.size = a.size;
  bool has_gnuplot = std::system("command -v gnuplot >/dev/null 2>&1") == 0;

  double load_before = 0, load_after = 0;
  ::getloadavg(&load_before, 1);
  const std::vector<std::string> scenes = {"demo", "edges"};
  long long total = 0;
  {
    std::stringstream ss(a.backends);
    for (std::string b; std::getline(ss, b, ',');) ++total;
  }
  total *=
      static_cast<long long>(scenes.size()) * 2 * 3 * (plan.spps.size() + plan.adaptive.size());
  Progress progress("report", total, Progress::wanted(a.quiet));
  Reporter reporter(a, plan, progress);
  for (const std::string& scene : scenes) reporter.run_scene(scene);
  ::getloadavg(&load_after, 1);
  progress.set_label("writing " + a.dir);
  double total_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  const std::string dir = std::filesystem::absolute(a.dir).lexically_normal().string();
  write_text(dir + "/report.csv", csv(reporter.rows()));
  write_text(dir + "/report.md",
             markdown(reporter.rows(), reporter.summaries(), plan, a.quick, reporter.backends(),
                      reporter.devices(), load_before, load_after, total_s));
  write_plots(dir, reporter.rows(), reporter.summaries(), reporter.backends(), plan);
  progress.finish();
  if (!has_gnuplot) {
    std::cerr << "twinray: report: gnuplot not found, so no plots (the table is in " << dir
              << "/report.md); install it (Debian: apt-get install gnuplot-nox) and run "
                 "`gnuplot "
              << dir << "/report.gp`\n";
    return kExitRuntimeFailure;
  }
  std::string command = "gnuplot " + dir + "/report.gp";
  if (std::system(command.c_str()) != 0 ||
      std::rename((dir + "/error_vs_time.png.tmp").c_str(), (dir + "/error_vs_time.png").c_str()) !=
          0 ||
      std::rename((dir + "/error_vs_spp.png.tmp").c_str(), (dir + "/error_vs_spp.png").c_str()) !=
          0) {
    std::remove((dir + "/error_vs_time.png.tmp").c_str());
    std::remove((dir + "/error_vs_spp.png.tmp").c_str());
    std::cerr << "twinray: report: gnuplot failed on " << dir << "/report.gp\n";
    return kExitRuntimeFailure;
  }
  std::cout << dir << ": report.csv, report.md, error_vs_time.png, error_vs_spp.png ("
            << reporter.rows().size() << " configurations, " << std::fixed << std::setprecision(0)
            << total_s << " s)" << std::endl;
  return kExitOk;
}

const Command kReport(
    "report",
    "error against run time: every backend x precision x sampler x samples per pixel "
    "(uniform and adaptive) on the demo and a scene of edges, as a table and plots",
    [](CLI::App& app) {
      auto a = std::make_shared<ReportArgs>();
      app.add_option("-o,--output", a->dir, "folder for report.csv, report.md and the plots")
          ->required();
      app.add_flag("--quick", a->quick,
                   "a small run (40x40 images, up to 16 spp, one run each) with the same columns");
      app.add_option("--runs", a->runs, "timed runs per configuration (median; default 3, quick 1)")
          ->check(CLI::Range(1, 1000));
      app.add_option("--size", a->size, "image width and height (default 64, quick 40)")
          ->check(CLI::Range(8, 4096));
      app.add_option("--backends", a->backends,
                     "comma-separated backends to time (the extra seeds render on the CPU)")
          ->capture_default_str();
      app.add_option("--threads", a->threads, "CPU backend threads (default: all cores)")
          ->check(CLI::Range(1, 4096));
      app.add_flag("--quiet", a->quiet, "no progress bar");
      return [a] { return run_report(*a); };
    },
    40);

}  // namespace
}  // namespace twinray_cli
