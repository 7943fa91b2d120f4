// Structural score: precision, recall, F1 and chamfer distance between the occupied cells of two
// rasters, from exact Euclidean distance transforms; and the rasters the experiments score.
#include "potmap/experiments/structure_score.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "potmap/error.hpp"
#include "potmap/experiments/ogm.hpp"

namespace potmap {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Lower envelope of the parabolas (q - p)^2 + f[p] over the p with finite f (Felzenszwalb and
// Huttenlocher, "Distance Transforms of Sampled Functions", 2012): d[q] = min_p (q - p)^2 + f[p],
// +inf when no f is finite. Points with infinite f are left out of the envelope rather than
// given a large finite value, so that no rounding of huge numbers enters the finite results.
// f and d are strided views of n values; v and z are scratch of n and n + 1.
void envelope_1d(const double* f, std::size_t fstride, double* d, std::size_t dstride,
                 std::size_t n, std::vector<std::size_t>& v, std::vector<double>& z) {
  std::size_t k = 0;
  bool any = false;
  for (std::size_t q = 0; q < n; ++q) {
    const double fq = f[q * fstride];
    if (!std::isfinite(fq)) continue;
    if (!any) {
      any = true;
      v[0] = q;
      z[0] = -kInf;
      z[1] = kInf;
      continue;
    }
    const double qq = double(q);
    // z[0] = -inf: the search stops at the first parabola at the latest.
    double s = 0;
    for (;; --k) {
      const double p = double(v[k]);
      s = ((fq + qq * qq) - (f[v[k] * fstride] + p * p)) / (2 * qq - 2 * p);
      if (s > z[k]) break;
    }
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = kInf;
  }
  if (!any) {
    for (std::size_t q = 0; q < n; ++q) d[q * dstride] = kInf;
    return;
  }
  std::size_t j = 0;
  for (std::size_t q = 0; q < n; ++q) {
    while (z[j + 1] < double(q)) ++j;
    const double dq = double(q) - double(v[j]);
    d[q * dstride] = dq * dq + f[v[j] * fstride];
  }
}

// Squared distance, in cells^2, from every cell to the nearest occupied one (+inf: none).
std::vector<double> squared_edt_cells(const std::uint8_t* occ, std::size_t w, std::size_t h) {
  std::vector<double> f(w * h), g(w * h);
  for (std::size_t i = 0; i < w * h; ++i) f[i] = occ[i] ? 0.0 : kInf;
  const std::size_t n = std::max(w, h);
  std::vector<std::size_t> v(n);
  std::vector<double> z(n + 1);
  for (std::size_t c = 0; c < w; ++c) envelope_1d(&f[c], w, &g[c], w, h, v, z);          // columns
  for (std::size_t r = 0; r < h; ++r) envelope_1d(&g[r * w], 1, &f[r * w], 1, w, v, z);  // rows
  return f;
}

void check_raster(const std::uint8_t* p, std::size_t w, std::size_t h, double cell_m,
                  const char* what) {
  if (!(cell_m > 0) || !std::isfinite(cell_m))
    throw ArgumentError(std::string(what) + ": cell size must be > 0 metres, got " +
                        std::to_string(cell_m));
  if (w > 0 && h > 0 && !p) throw ArgumentError(std::string(what) + ": null raster");
  if (h > 0 && w > std::numeric_limits<std::size_t>::max() / h)
    throw ArgumentError(std::string(what) + ": raster too large");
}

}  // namespace

std::vector<double> distance_to_occupied(const std::uint8_t* occupied, std::size_t width,
                                         std::size_t height, double cell_m) {
  check_raster(occupied, width, height, cell_m, "distance_to_occupied");
  if (width == 0 || height == 0) return {};
  std::vector<double> d = squared_edt_cells(occupied, width, height);
  for (double& x : d) x = std::isfinite(x) ? std::sqrt(x) * cell_m : kInf;
  return d;
}

StructureScore structure_score(const std::uint8_t* map, const std::uint8_t* reference,
                               std::size_t width, std::size_t height, double cell_m,
                               double tolerance_m) {
  check_raster(map, width, height, cell_m, "structure_score");
  check_raster(reference, width, height, cell_m, "structure_score");
  if (!(tolerance_m >= 0) || !std::isfinite(tolerance_m))
    throw ArgumentError("structure_score: tolerance must be >= 0 metres, got " +
                        std::to_string(tolerance_m));
  StructureScore s;
  const std::size_t n = width * height;
  if (n == 0) return s;
  for (std::size_t i = 0; i < n; ++i) {
    s.map_cells += map[i] != 0;
    s.reference_cells += reference[i] != 0;
  }
  if (s.map_cells == 0 && s.reference_cells == 0) return s;  // nothing to compare: all NaN
  if (s.map_cells == 0 || s.reference_cells == 0) {
    // One side has structure the other lacks entirely: the side that has cells scores 0, the
    // empty side's ratio is 0 / 0.
    if (s.map_cells > 0) s.precision = 0;
    if (s.reference_cells > 0) s.recall = 0;
    s.f1 = 0;
    return s;
  }
  // Within the tolerance, compared in cells^2 (exact for the integer squared distances), with a
  // relative slack so that a tolerance of exactly k cells includes distance k.
  const double t = tolerance_m / cell_m;
  const double t2 = t * t * (1 + 1e-12) + 1e-12;
  const std::vector<double> to_ref = squared_edt_cells(reference, width, height);
  const std::vector<double> to_map = squared_edt_cells(map, width, height);
  std::size_t near_ref = 0, near_map = 0;
  double sum_map = 0, sum_ref = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (map[i]) {
      near_ref += to_ref[i] <= t2;
      sum_map += std::sqrt(to_ref[i]);
    }
    if (reference[i]) {
      near_map += to_map[i] <= t2;
      sum_ref += std::sqrt(to_map[i]);
    }
  }
  s.precision = double(near_ref) / double(s.map_cells);
  s.recall = double(near_map) / double(s.reference_cells);
  s.f1 = s.precision + s.recall > 0 ? 2 * s.precision * s.recall / (s.precision + s.recall) : 0.0;
  s.chamfer_m =
      0.5 * cell_m * (sum_map / double(s.map_cells) + sum_ref / double(s.reference_cells));
  return s;
}

StructureScore structure_score(const std::vector<std::uint8_t>& map,
                               const std::vector<std::uint8_t>& reference, std::size_t width,
                               std::size_t height, double cell_m, double tolerance_m) {
  if (height > 0 && width > std::numeric_limits<std::size_t>::max() / height)
    throw ArgumentError("structure_score: raster too large");
  if (map.size() != width * height || reference.size() != width * height)
    throw ArgumentError("structure_score: rasters of " + std::to_string(map.size()) + " and " +
                        std::to_string(reference.size()) + " cells for " + std::to_string(width) +
                        " x " + std::to_string(height));
  return structure_score(map.data(), reference.data(), width, height, cell_m, tolerance_m);
}

}  // namespace potmap

namespace potmap::experiment {

namespace {
// p within this of 0.5 is "no evidence" (see occupied_cells): the device evaluator returns 0.5
// exactly (float) where the CPU's double sum of far kernel tails lands a hair either side.
constexpr double kNoEvidence = 1e-3;
}  // namespace

StructureGrid structure_grid(const double lo[3], const double hi[3], double cell_m,
                             double tolerance_m, std::size_t max_cells) {
  if (!(cell_m > 0) || !std::isfinite(cell_m))
    throw ArgumentError("structure_grid: cell size must be > 0 metres");
  if (!(tolerance_m >= 0) || !std::isfinite(tolerance_m))
    throw ArgumentError("structure_grid: tolerance must be >= 0 metres");
  if (max_cells == 0) throw ArgumentError("structure_grid: max_cells must be > 0");
  for (int k = 0; k < 2; ++k)
    if (!std::isfinite(lo[k]) || !std::isfinite(hi[k]) || !(hi[k] > lo[k]))
      throw ArgumentError("structure_grid: empty or non-finite window");
  for (std::size_t factor = 1;; ++factor) {
    StructureGrid g;
    g.cell_m = cell_m * double(factor);
    g.tolerance_m = tolerance_m * double(factor);
    const double fx0 = std::floor(lo[0] / g.cell_m), fx1 = std::ceil(hi[0] / g.cell_m);
    const double fy0 = std::floor(lo[1] / g.cell_m), fy1 = std::ceil(hi[1] / g.cell_m);
    const double wd = std::max(1.0, fx1 - fx0), hd = std::max(1.0, fy1 - fy0);
    if (wd * hd <= double(max_cells)) {
      g.ix0 = std::int64_t(fx0);
      g.iy0 = std::int64_t(fy0);
      g.width = std::size_t(wd);
      g.height = std::size_t(hd);
      return g;
    }
    // Jump close to the factor that fits rather than stepping one at a time.
    const double need = std::sqrt(wd * hd / double(max_cells)) * double(factor);
    if (need > double(factor) + 1) factor = std::size_t(need) - 1;
  }
}

std::vector<std::uint8_t> occupied_cells(const FittedMap& map, int dim, const StructureGrid& grid,
                                         double z) {
  if (!map.query) throw ArgumentError("occupied_cells: the map has no query");
  std::vector<std::uint8_t> occ(grid.cells(), 0);
  // Rows in chunks of about 2^20 points, so that the query's buffers stay small on big windows.
  const std::size_t rows = std::max<std::size_t>(1, (std::size_t(1) << 20) / grid.width);
  std::vector<double> pts, prob;
  for (std::size_t r0 = 0; r0 < grid.height; r0 += rows) {
    const std::size_t r1 = std::min(grid.height, r0 + rows), n = (r1 - r0) * grid.width;
    pts.resize(n * std::size_t(dim));
    prob.assign(n, NAN);
    for (std::size_t r = r0; r < r1; ++r)
      for (std::size_t c = 0; c < grid.width; ++c) {
        double* p = &pts[((r - r0) * grid.width + c) * std::size_t(dim)];
        p[0] = grid.x(c);
        p[1] = grid.y(r);
        if (dim == 3) p[2] = z;
      }
    map.query(pts.data(), n, prob.data(), nullptr);
    for (std::size_t i = 0; i < n; ++i)
      occ[r0 * grid.width + i] = prob[i] > 0.5 + kNoEvidence;  // NaN: false
  }
  return occ;
}

FittedMap structure_reference(const MapTask& task, const StructureGrid& grid) {
  if (task.dim != 2)
    throw ArgumentError("structure_reference: 2D tasks only, got dim " + std::to_string(task.dim));
  const auto t0 = std::chrono::steady_clock::now();
  OgmOptions o;
  o.resolution = grid.cell_m;
  auto ogm = std::make_shared<OccupancyGrid>(2, o);
  for (const Scan& s : task.train_scans) ogm->insert(s);
  FittedMap f;
  f.fit_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  f.info["cell_m"] = grid.cell_m;
  f.query = [ogm](const double* pts, std::size_t n, double* prob, double* var) {
    ogm->probability(pts, n, prob);
    if (var)
      for (std::size_t i = 0; i < n; ++i) var[i] = std::numeric_limits<double>::quiet_NaN();
  };
  return f;
}

StructureScore score_structure(const FittedMap& map, int dim, const StructureGrid& grid,
                               const std::vector<std::uint8_t>& reference) {
  const std::vector<std::uint8_t> occ = occupied_cells(map, dim, grid);
  return structure_score(occ, reference, grid.width, grid.height, grid.cell_m, grid.tolerance_m);
}

}  // namespace potmap::experiment
