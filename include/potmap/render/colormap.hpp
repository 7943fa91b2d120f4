#pragma once
// Perceptual colour maps for the pictures potmap writes (rasters, figures, kernel pictures).

#include <cstdint>
#include <string>

#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// Perceptual colour maps (lightness increases monotonically from 0 to 1).
enum class Colormap {
  Viridis,  ///< dark blue -> green -> yellow
  Magma,    ///< black -> purple -> orange -> pale yellow
};

/// An 8-bit colour.
struct Rgb {
  std::uint8_t r = 0, g = 0, b = 0;
};

/// Colour of t in [0, 1] (clamped; NaN gives mid-grey) under `map`: piecewise-linear between
/// tabulated anchor colours of the published map.
Rgb colormap(Colormap map, double t);
/// Parses "viridis" or "magma" (case-insensitive); throws ArgumentError naming the value.
Colormap parse_colormap(const std::string& name);

}  // namespace potmap
POTMAP_CXX_API_END
