// What `potmap data info DRIVE` says about a drive: keyframes, points, path, field of view.
#include <algorithm>
#include <cmath>

#include "potmap/data/drive.hpp"

namespace potmap {

namespace {

double quantile(std::vector<double>& v, double q) {
  if (v.empty()) return 0;
  const std::size_t k = std::min(v.size() - 1, std::size_t(q * double(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(k), v.end());
  return v[k];
}

// Azimuth span covered by the returns: 360 minus the widest empty gap of a 1-degree histogram.
double azimuth_span(const std::vector<std::uint8_t>& bins) {
  const int n = int(bins.size());
  int gap = 0, run = 0;
  for (int k = 0; k < 2 * n; ++k) {  // twice round, so a gap across 180 degrees counts whole
    run = bins[std::size_t(k % n)] ? 0 : run + 1;
    gap = std::max(gap, std::min(run, n));
  }
  return 360.0 * double(n - gap) / double(n);
}

void add_path(const Drive& d, DriveSummary& s) {
  std::vector<double> steps;
  for (std::size_t i = 0; i < d.size(); ++i) {
    const auto& p = d.poses[i];
    const double t[3] = {p[3], p[7], p[11]};
    for (int a = 0; a < 3; ++a) {
      s.lo[a] = i ? std::min(s.lo[a], t[a]) : t[a];
      s.hi[a] = i ? std::max(s.hi[a], t[a]) : t[a];
    }
    if (i == 0) continue;
    const auto& q = d.poses[i - 1];
    const double step = std::hypot(p[3] - q[3], p[7] - q[7], p[11] - q[11]);
    steps.push_back(step);
    s.path_length += step;
    s.largest_step = std::max(s.largest_step, step);
  }
  s.median_step = quantile(steps, 0.5);
  if (d.has_times && d.size() > 1) s.duration = d.times.back() - d.times.front();
}

}  // namespace

DriveSummary summarise_drive(const Drive& drive, std::size_t sample) {
  DriveSummary s;
  s.keyframes = drive.size();
  add_path(drive, s);
  const std::size_t n = drive.size();
  const std::size_t take = sample == 0 ? n : std::min(n, sample);
  std::vector<std::uint8_t> bins(360, 0);
  std::vector<double> ranges, elevations;
  s.min_points = ~std::size_t(0);
  for (std::size_t k = 0; k < take; ++k) {
    const std::size_t i = take == n ? k : k * (n - 1) / std::max<std::size_t>(1, take - 1);
    const Scan sc = read_keyframe(drive, i);
    const std::size_t pts = sc.num_hits();
    s.points += pts;
    s.min_points = std::min(s.min_points, pts);
    s.max_points = std::max(s.max_points, pts);
    // Back into the sensor frame: x_s = R^T (x_w - t).
    const auto& T = drive.poses[i];
    for (std::size_t j = 0; j < pts; ++j) {
      const double* w = &sc.hits[3 * j];
      const double d[3] = {w[0] - T[3], w[1] - T[7], w[2] - T[11]};
      double x[3];
      for (int c = 0; c < 3; ++c) x[c] = T[c] * d[0] + T[4 + c] * d[1] + T[8 + c] * d[2];
      const double r = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
      if (!(r > 0.05)) continue;
      const double az = std::atan2(x[1], x[0]) * 180 / M_PI;
      bins[std::size_t(std::clamp(int(std::floor(az + 180)), 0, 359))] = 1;
      if (j % 8) continue;  // a sample of the returns is enough for quantiles
      ranges.push_back(r);
      elevations.push_back(std::asin(std::clamp(x[2] / r, -1.0, 1.0)) * 180 / M_PI);
    }
  }
  s.sampled = take;
  if (take == 0) s.min_points = 0;
  if (take < n && take > 0) s.points = s.points * n / take;  // estimated from the sample
  s.azimuth_span = azimuth_span(bins);
  // The 0.1 and 99.9 % points: a few stray returns (the vehicle's own roof) do not widen it.
  s.elevation_min = quantile(elevations, 0.001);
  s.elevation_max = quantile(elevations, 0.999);
  s.range_median = quantile(ranges, 0.5);
  s.range_p99 = quantile(ranges, 0.99);
  return s;
}

}  // namespace potmap
