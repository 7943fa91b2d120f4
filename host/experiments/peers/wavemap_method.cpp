// wavemap as a method of the experiments (wavemap_method.hpp): the field of view, the fit and
// the queries. wavemap itself is reached only through WavemapGrid (wavemap_grid.cpp).
#include "potmap/experiments/wavemap_method.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include "../grid_queries.hpp"
#include "potmap/error.hpp"

namespace potmap {

namespace {

constexpr double kRadian = 180.0 / 3.14159265358979323846;

// The widest gap between sorted azimuths (degrees), around the circle: what the sensor never
// looks at.
double widest_gap(std::vector<double>& az, double* gap_end) {
  std::sort(az.begin(), az.end());
  double gap = az.front() + 360 - az.back();
  *gap_end = az.front();
  for (std::size_t i = 1; i < az.size(); ++i)
    if (az[i] - az[i - 1] > gap) {
      gap = az[i] - az[i - 1];
      *gap_end = az[i];
    }
  return gap;
}

}  // namespace

WavemapProjection wavemap_projection(const std::vector<Scan>& scans, double azimuth_pitch_deg,
                                     double elevation_pitch_deg) {
  if (!(azimuth_pitch_deg > 0) || !(elevation_pitch_deg > 0))
    throw ArgumentError("wavemap_projection: pixel pitches must be > 0 degrees");
  std::vector<double> az;
  double el_lo = 90, el_hi = -90;
  auto add = [&](const Scan& s, const double v[3]) {
    const auto& m = s.pose3d;  // sensor direction R^T v
    double d[3];
    for (int j = 0; j < 3; ++j) d[j] = m[j] * v[0] + m[4 + j] * v[1] + m[8 + j] * v[2];
    const double h = std::hypot(d[0], d[1]);
    if (!(h > 0 || d[2] != 0) || !std::isfinite(h + d[2])) return;
    az.push_back(std::atan2(d[1], d[0]) * kRadian);
    el_lo = std::min(el_lo, std::atan2(d[2], h) * kRadian);
    el_hi = std::max(el_hi, std::atan2(d[2], h) * kRadian);
  };
  for (const Scan& s : scans) {
    if (s.dim != 3) throw ArgumentError("wavemap_projection: 3D scans are needed");
    const auto o = s.origin();
    for (std::size_t i = 0; i < s.num_hits(); ++i) {
      const double v[3] = {s.hits[3 * i] - o[0], s.hits[3 * i + 1] - o[1],
                           s.hits[3 * i + 2] - o[2]};
      add(s, v);
    }
    for (std::size_t i = 0; i < s.num_no_return(); ++i) add(s, &s.no_return[3 * i]);
  }
  if (az.empty()) throw ArgumentError("wavemap_projection: no beam");
  WavemapProjection p;
  double start = 0;
  const bool sector = widest_gap(az, &start) >= 10;
  double hi = start;
  for (double a : az) hi = std::max(hi, a < start ? a + 360 : a);
  // A sector from the end of the widest gap round to its start; one that crosses +-180 (wavemap's
  // azimuths run from -180 to 180) and a spinning sensor's take the whole circle.
  if (sector && hi <= 180) {
    p.azimuth_min = start - azimuth_pitch_deg / 2;
    p.azimuth_max = hi + azimuth_pitch_deg / 2;
  }
  p.elevation_min = el_lo - elevation_pitch_deg / 2;
  p.elevation_max = el_hi + elevation_pitch_deg / 2;
  p.azimuth_cells =
      std::max(1, int(std::lround((p.azimuth_max - p.azimuth_min) / azimuth_pitch_deg)));
  p.elevation_cells =
      std::max(1, int(std::lround((p.elevation_max - p.elevation_min) / elevation_pitch_deg)));
  return p;
}

namespace experiment {

Method wavemap_method(const WavemapSetup& setup) {
  char name[64];
  std::snprintf(name, sizeof name, "wavemap %g m", setup.options.cell);
  Method m;
  m.name = name;
  m.group = "wavemap";
  m.fit = [setup](Context*, const MapTask& task) {
    if (task.dim != 3) throw ArgumentError("wavemap: a 3D task is needed (a drive)");
    // The sensor's field of view, as a user writes it into wavemap's configuration: not timed.
    const WavemapProjection fov =
        wavemap_projection(task.train_scans, setup.azimuth_pitch_deg, setup.elevation_pitch_deg);
    const auto t0 = std::chrono::steady_clock::now();
    auto grid = std::make_shared<WavemapGrid>(setup.options, fov);
    for (const Scan& s : task.train_scans) grid->insert(s);
    grid->finish();
    FittedMap f;
    f.fit_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    f.info["cell_m"] = setup.options.cell;
    f.info["memory_mb"] = double(grid->memory_bytes()) / 1e6;
    f.info["cells"] = double(grid->cells());
    f.info["azimuth_cells"] = fov.azimuth_cells;
    f.info["elevation_cells"] = fov.elevation_cells;
    f.info["azimuth_span_deg"] = fov.azimuth_max - fov.azimuth_min;
    f.info["elevation_min_deg"] = fov.elevation_min;
    f.info["elevation_max_deg"] = fov.elevation_max;
    detail::set_grid_queries(f, grid);
    return f;
  };
  return m;
}

}  // namespace experiment
}  // namespace potmap
