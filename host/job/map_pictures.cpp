#include "potmap/job/map_pictures.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "legend_picture.hpp"
#include "potmap/error.hpp"
#include "potmap/io/known_cells.hpp"
#include "potmap/map/raster.hpp"

namespace potmap::job {

double picture_resolution(const KernelMap& map, double margin, std::size_t long_side) {
  double lo[3], hi[3];
  map.bounds(lo, hi);
  const double extent = std::max(hi[0] - lo[0], hi[1] - lo[1]) + 2 * margin;
  return extent / double(std::max<std::size_t>(long_side, 1));
}

namespace {

// The map's probability and logit variance at the cell centres of the window, rows from the
// lowest y, the probability -1 where the map has not observed the cell (KnownRule's default:
// the exports' own rule). A row band at a time, so the points never all sit in memory.
void known_grid(Context& ctx, const KernelMap& map, const RasterSpec& spec, std::size_t nx,
                std::size_t ny, std::vector<float>& prob, std::vector<float>& var) {
  KnownEvaluator ev(&ctx, map);
  prob.assign(nx * ny, -1.0f);
  var.assign(nx * ny, 0.0f);
  const std::size_t band =
      std::max<std::size_t>(1, (std::size_t(1) << 20) / std::max<std::size_t>(nx, 1));
  std::vector<double> pts;
  for (std::size_t j0 = 0; j0 < ny; j0 += band) {
    const std::size_t j1 = std::min(ny, j0 + band);
    pts.clear();
    for (std::size_t j = j0; j < j1; ++j)
      for (std::size_t i = 0; i < nx; ++i) {
        pts.push_back(spec.xmin + (double(i) + 0.5) * spec.resolution);
        pts.push_back(spec.ymin + (double(j) + 0.5) * spec.resolution);
        if (map.dim == 3) pts.push_back(spec.z);
      }
    const KnownValues kv = ev.values(pts);
    for (std::size_t c = 0; c < kv.known.size(); ++c) {
      const std::size_t at = j0 * nx + c;
      if (kv.known[c]) prob[at] = float(kv.prob[c]);
      var[at] = float(kv.var[c]);
    }
  }
}

}  // namespace

MapPictures write_map_pictures(Context& ctx, const KernelMap& map, const std::string& prefix,
                               double resolution, double margin, double z) {
  if (map.empty()) throw ArgumentError("pictures: the map " + prefix + " has no kernels");
  if (!(resolution > 0) || !std::isfinite(resolution))
    throw ArgumentError("pictures: resolution must be positive, got " + std::to_string(resolution));
  double lo[3], hi[3];
  map.bounds(lo, hi);
  RasterSpec spec;
  spec.xmin = lo[0] - margin;
  spec.xmax = hi[0] + margin;
  spec.ymin = lo[1] - margin;
  spec.ymax = hi[1] + margin;
  spec.resolution = resolution;
  spec.z = z;
  const auto nx = std::size_t(std::ceil((spec.xmax - spec.xmin) / resolution));
  const auto ny = std::size_t(std::ceil((spec.ymax - spec.ymin) / resolution));
  std::vector<float> prob, var;
  known_grid(ctx, map, spec, nx, ny, prob, var);
  std::string where;
  if (map.dim == 3) {
    char at[64];
    std::snprintf(at, sizeof at, " AT Z %.2f M", z);
    where = at;
  }
  MapPictures p;
  p.files = {prefix + "_prob.png", prefix + "_var.png"};
  const LegendPictures lp = write_legend_pictures(
      prob, var, nx, ny, 1, resolution, p.files[0], p.files[1],
      "OCCUPANCY PROBABILITY P(OCCUPIED)" + where, "LOGIT VARIANCE: HOW UNSURE THE MAP IS" + where);
  const std::string kp = prefix + "_kernels.png";
  const KernelPictureSummary ks = write_kernel_legend_picture(ctx, map, spec, kp);
  p.files.push_back(kp);
  p.width = lp.width;
  p.height = lp.height;
  p.resolution = resolution;
  p.min_length = ks.min_length;
  p.max_length = ks.max_length;
  return p;
}

}  // namespace potmap::job
