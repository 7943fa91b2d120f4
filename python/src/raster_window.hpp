#pragma once
// A raster window from Python's arguments, shared by the array, file and GeoTIFF rasters.

#include <pybind11/pybind11.h>

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "potmap/map/raster.hpp"

namespace potmap::python {

/// A height band (z_lo, z_hi) in metres, or None for the slice at z.
using Band = std::optional<std::pair<double, double>>;

/// The window (xmin, xmax, ymin, ymax) at `res` metres, the slice at `z` or the height band;
/// ValueError unless `bounds` has four values (the library checks the rest).
inline RasterSpec window(const std::vector<double>& bounds, double res, double z,
                         const Band& band = {}, double band_step = 0) {
  if (bounds.size() != 4)
    throw pybind11::value_error("bounds: expected (xmin, xmax, ymin, ymax), got " +
                                std::to_string(bounds.size()) + " values");
  RasterSpec s;
  s.xmin = bounds[0];
  s.xmax = bounds[1];
  s.ymin = bounds[2];
  s.ymax = bounds[3];
  s.resolution = res;
  s.z = z;
  if (band) {
    s.band_lo = band->first;
    s.band_hi = band->second;
  }
  s.band_step = band_step;
  return s;
}

}  // namespace potmap::python
