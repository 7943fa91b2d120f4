#pragma once
// A picture of the kernels themselves (the paper's Fig. 3 and 9): the map's occupancy
// probability in grey underneath, every kernel drawn as a dot at its position coloured by its
// width. Widths are shown as the length scale 1/sqrt(gamma) (metres) on a log axis, so narrow
// kernels hugging walls and wide ones filling open space read apart at a glance.

#include <string>
#include "potmap/export.h"

#include "potmap/map/kernel_map.hpp"
#include "potmap/map/raster.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct KernelPictureOptions {
  /// Length scale 1/sqrt(gamma) at the two ends of the colour map, metres. 0 (the default):
  /// the smallest and largest of the map.
  double min_length = 0, max_length = 0;
  Colormap colormap = Colormap::Viridis;  ///< narrow (dark) to wide (bright); default viridis
  int dot_radius = 1;                     ///< pixels; 0 draws single pixels (default 1)
  bool background = true;  ///< grey probability underneath (needs a device); default true
};

/// What was drawn.
struct KernelPictureSummary {
  std::size_t width = 0, height = 0;      ///< pixels
  std::size_t kernels_drawn = 0;          ///< kernels inside the window (3D: all heights)
  double min_length = 0, max_length = 0;  ///< colour scale used, metres
};

/// Writes the picture of `map` over the window of `spec` (resolution = metres per pixel) to
/// `path` (PNG, atomically). `ctx` may be null when options.background is false. Throws
/// ArgumentError for a bad spec, potmap::Error naming the file on a write failure.
KernelPictureSummary write_kernel_picture(Context* ctx, const KernelMap& map,
                                          const RasterSpec& spec, const std::string& path,
                                          const KernelPictureOptions& options = {});

}  // namespace potmap
POTMAP_CXX_API_END
