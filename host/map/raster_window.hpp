#pragma once
// The values of a raster window's cells, as rasterize() and the tiled job both evaluate them: the
// slice at RasterSpec::z, or the maximum over its height band (MapEvaluator::evaluate_band_max).

#include <cstddef>
#include <vector>

#include "potmap/map/evaluate.hpp"
#include "potmap/map/raster.hpp"

namespace potmap::detail {

class WindowEvaluator {
 public:
  /// Validates the spec against the map (a band needs a 3D map) and uploads the map.
  WindowEvaluator(Context& ctx, const KernelMap& map, const RasterSpec& spec,
                  const EvalOptions& options);
  /// Cells of columns [x0, x0 + nx) and rows [j0, j0 + ny), rows counted from the window's
  /// bottom (y up), x fastest; var and prob receive nx * ny floats (either may be null).
  void rows(std::size_t x0, std::size_t nx, std::size_t j0, std::size_t ny, float* var,
            float* prob);
  /// The band's heights (empty for a slice).
  const std::vector<double>& levels() const { return levels_; }

 private:
  MapEvaluator ev_;
  RasterSpec spec_;
  int dim_;
  std::vector<double> levels_;
};

}  // namespace potmap::detail
