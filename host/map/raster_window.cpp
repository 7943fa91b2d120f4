#include "map/raster_window.hpp"

#include "potmap/error.hpp"
#include "potmap/map/height_band.hpp"

namespace potmap {

std::vector<double> raster_levels(const RasterSpec& spec, const KernelMap& map) {
  if (!spec.has_band()) return {};
  spec.validate();
  if (map.dim != 3)
    throw ArgumentError("raster: a height band needs a 3D map; this map is " +
                        std::to_string(map.dim) + "D");
  const double step = spec.band_step > 0 ? spec.band_step : default_band_step(map);
  return height_band_levels(spec.band_lo, spec.band_hi, step);
}

namespace detail {

WindowEvaluator::WindowEvaluator(Context& ctx, const KernelMap& map, const RasterSpec& spec,
                                 const EvalOptions& options)
    : ev_(ctx, map, options), spec_(spec), dim_(map.dim), levels_(raster_levels(spec, map)) {}

void WindowEvaluator::rows(std::size_t x0, std::size_t nx, std::size_t j0, std::size_t ny,
                           float* var, float* prob) {
  GridSpec g;
  g.dim = dim_;
  g.resolution = spec_.resolution;
  g.origin[0] = spec_.xmin + double(x0) * spec_.resolution;
  g.origin[1] = spec_.ymin + double(j0) * spec_.resolution;
  g.origin[2] = spec_.z - 0.5 * spec_.resolution;  // one layer centred on z (3D maps)
  g.count[0] = nx;
  g.count[1] = ny;
  g.count[2] = 1;
  if (spec_.has_band())
    ev_.evaluate_band_max(g, levels_, nullptr, var, prob);
  else
    ev_.evaluate_grid(g, nullptr, var, prob);
}

}  // namespace detail

}  // namespace potmap
