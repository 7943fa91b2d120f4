// Height bands on the CPU: the levels, the default step, the reduction and the exact reference
// (include/potmap/map/height_band.hpp).
#include "potmap/map/height_band.hpp"

#include <algorithm>
#include <limits>
#include <string>

#include "io/text_io.hpp"
#include "potmap/error.hpp"

namespace potmap {

namespace {

constexpr std::size_t kMaxLevels = 4096;

// The shortest text that reads back as the same double.
std::string num(double v) {
  return detail::format_double(v);
}

}  // namespace

std::vector<double> height_band_levels(double z_lo, double z_hi, double step) {
  if (!std::isfinite(z_lo) || !std::isfinite(z_hi))
    throw ArgumentError("height band: " + num(z_lo) + ".." + num(z_hi) + " is not finite");
  if (z_lo > z_hi)
    throw ArgumentError("height band: bottom " + num(z_lo) + " m is above top " + num(z_hi) + " m");
  if (!(step > 0) || !std::isfinite(step))
    throw ArgumentError("height band: step must be a positive number of metres, got " + num(step));
  const double gaps = std::ceil((z_hi - z_lo) / step - 1e-9);
  if (gaps + 1 > double(kMaxLevels))
    throw ArgumentError("height band: " + num(z_lo) + ".." + num(z_hi) + " m every " + num(step) +
                        " m is " + num(gaps + 1) + " levels; at most " +
                        std::to_string(kMaxLevels));
  const std::size_t n = static_cast<std::size_t>(std::max(gaps, 0.0)) + 1;
  std::vector<double> z(n);
  for (std::size_t k = 0; k < n; ++k)
    z[k] = n == 1 ? z_lo : z_lo + (z_hi - z_lo) * double(k) / double(n - 1);
  return z;
}

double default_band_step(const KernelMap& map) {
  double gmax = 0;
  for (double g : map.gamma) gmax = std::max(gmax, g);
  return gmax > 0 ? 1.0 / std::sqrt(2.0 * gmax) : 0.1;
}

void reduce_band_max(const float* prob, const float* var, const float* mean, std::size_t levels,
                     std::size_t cells, float* out_prob, float* out_var, float* out_mean) {
  constexpr float nan = std::numeric_limits<float>::quiet_NaN();
  for (std::size_t c = 0; c < cells; ++c) {
    float bp = nan, bv = nan, bm = nan;
    if (levels > 0) {
      bp = prob[c];
      bv = var[c];
      bm = mean ? mean[c] : nan;
    }
    for (std::size_t k = 1; k < levels; ++k) {
      const std::size_t at = k * cells + c;
      keep_band_max(prob[at], var[at], mean ? mean[at] : nan, bp, bv, &bm);
    }
    out_prob[c] = bp;
    out_var[c] = bv;
    if (out_mean) out_mean[c] = bm;
  }
}

MapValuesExact evaluate_band_exact(const KernelMap& map, const GridSpec& columns,
                                   const std::vector<double>& levels) {
  if (map.dim != 3 || columns.dim != 3)
    throw ArgumentError("evaluate_band_exact: the map and the grid must be 3D");
  const std::size_t nx = columns.count[0], ny = columns.count[1], n = nx * ny;
  MapValuesExact band;
  band.prob.assign(n, std::numeric_limits<double>::quiet_NaN());
  band.var = band.prob;
  band.mean = band.prob;
  std::vector<double> pts(3 * n);
  for (std::size_t k = 0; k < levels.size(); ++k) {
    for (std::size_t j = 0; j < ny; ++j)
      for (std::size_t i = 0; i < nx; ++i) {
        double* p = &pts[3 * (j * nx + i)];
        p[0] = columns.origin[0] + (double(i) + 0.5) * columns.resolution;
        p[1] = columns.origin[1] + (double(j) + 0.5) * columns.resolution;
        p[2] = levels[k];
      }
    const MapValuesExact v = evaluate_exact(map, pts.data(), n);
    for (std::size_t c = 0; c < n; ++c) {
      if (k == 0) {
        band.prob[c] = v.prob[c];
        band.var[c] = v.var[c];
        band.mean[c] = v.mean[c];
      } else {
        keep_band_max(v.prob[c], v.var[c], v.mean[c], band.prob[c], band.var[c], &band.mean[c]);
      }
    }
  }
  return band;
}

}  // namespace potmap
