// Error metrics of `twinray report`, on the linear framebuffer (before any clamping or
// quantization; Mitchell 1996, "Consequences of stratified sampling in graphics"): RMSE over every channel of every
// pixel, PSNR for a peak of 1, the largest absolute error, and RMSE over the edge and
// the smooth pixels of the reference separately. Plus the least-squares slope of
// log RMSE against log samples, and the median of the run times.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include <twinray/core/image.hpp>

namespace twinray_cli {
namespace report {

struct Errors {
  double rmse = 0, psnr_db = 0, max_abs = 0, rmse_edge = 0, rmse_smooth = 0;
};

// A pixel is an edge pixel when one of its channels differs from the same channel of
// a 4-neighbour in the reference by more than this (linear units).
constexpr double kEdgeStep = 0.05;

inline std::vector<char> edge_mask(const twinray::Image<double>& ref) {
  std::vector<char> mask(static_cast<size_t>(ref.width) * ref.height, 0);
  for (int y = 0; y < ref.height; ++y)
    for (int x = 0; x < ref.width; ++x) {
      const double* p = ref.pixel(x, y);
      const int nx[4] = {x - 1, x + 1, x, x}, ny[4] = {y, y, y - 1, y + 1};
      for (int k = 0; k < 4; ++k) {
        if (nx[k] < 0 || ny[k] < 0 || nx[k] >= ref.width || ny[k] >= ref.height) continue;
        const double* q = ref.pixel(nx[k], ny[k]);
        for (int c = 0; c < 3; ++c)
          if (std::fabs(p[c] - q[c]) > kEdgeStep) mask[static_cast<size_t>(y) * ref.width + x] = 1;
      }
    }
  return mask;
}

template <class T>
Errors errors(const twinray::Image<T>& image, const twinray::Image<double>& ref,
              const std::vector<char>& mask) {
  double sum = 0, sum_edge = 0, sum_smooth = 0, max_abs = 0;
  size_t n_edge = 0, n_smooth = 0;
  for (size_t i = 0; i < ref.rgb.size(); ++i) {
    double d = static_cast<double>(image.rgb[i]) - ref.rgb[i];
    double d2 = d * d;
    sum += d2;
    max_abs = std::max(max_abs, std::fabs(d));
    if (mask[i / 3]) {
      sum_edge += d2;
      ++n_edge;
    } else {
      sum_smooth += d2;
      ++n_smooth;
    }
  }
  Errors e;
  double mse = sum / static_cast<double>(ref.rgb.size());
  e.rmse = std::sqrt(mse);
  e.psnr_db = mse > 0 ? 10 * std::log10(1 / mse) : std::numeric_limits<double>::infinity();
  e.max_abs = max_abs;
  e.rmse_edge = n_edge ? std::sqrt(sum_edge / static_cast<double>(n_edge)) : 0;
  e.rmse_smooth = n_smooth ? std::sqrt(sum_smooth / static_cast<double>(n_smooth)) : 0;
  return e;
}

// RMSE and largest absolute difference between two images of any precision.
template <class A, class B>
void difference(const twinray::Image<A>& a, const twinray::Image<B>& b, double* rmse,
                double* max_abs) {
  double sum = 0, mx = 0;
  for (size_t i = 0; i < a.rgb.size(); ++i) {
    double d = static_cast<double>(a.rgb[i]) - static_cast<double>(b.rgb[i]);
    sum += d * d;
    mx = std::max(mx, std::fabs(d));
  }
  *rmse = std::sqrt(sum / static_cast<double>(a.rgb.size()));
  *max_abs = mx;
}

// Framebuffer values whose bits differ.
template <class T>
size_t differing_values(const twinray::Image<T>& a, const twinray::Image<T>& b) {
  size_t n = 0;
  for (size_t i = 0; i < a.rgb.size(); ++i) n += std::memcmp(&a.rgb[i], &b.rgb[i], sizeof(T)) != 0;
  return n;
}

// Least-squares slope of log(y) against log(x); NaN with fewer than two points.
inline double log_log_slope(const std::vector<double>& x, const std::vector<double>& y) {
  size_t n = std::min(x.size(), y.size());
  if (n < 2) return std::numeric_limits<double>::quiet_NaN();
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (size_t i = 0; i < n; ++i) {
    double lx = std::log(x[i]), ly = std::log(y[i]);
    sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly;
  }
  double den = static_cast<double>(n) * sxx - sx * sx;
  return den != 0 ? (static_cast<double>(n) * sxy - sx * sy) / den
                  : std::numeric_limits<double>::quiet_NaN();
}

inline double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : (v[m - 1] + v[m]) / 2;
}

inline void mean_std(const std::vector<double>& v, double* mean, double* std_dev) {
  double s = 0, s2 = 0;
  for (double x : v) s += x;
  *mean = v.empty() ? 0 : s / static_cast<double>(v.size());
  for (double x : v) s2 += (x - *mean) * (x - *mean);
  *std_dev = v.size() > 1 ? std::sqrt(s2 / static_cast<double>(v.size() - 1)) : 0;
}

}  // namespace report
}  // namespace twinray_cli
