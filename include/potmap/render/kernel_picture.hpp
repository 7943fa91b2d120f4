#pragma once
// A picture of the kernels themselves (the paper's Fig. 3 and 9): the map's occupancy
// probability in light greys underneath (never-observed space a darker grey), every kernel drawn
// as a dot at its position coloured by its width. Widths are shown as the length scale
// 1/sqrt(gamma) (metres) on a log axis, so narrow kernels hugging walls and wide ones filling
// open space read apart at a glance.

#include <cstdint>
#include <string>
#include <vector>
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
  /// grey probability and never-observed space underneath (needs a device); default true
  bool background = true;
};

/// What was drawn.
struct KernelPictureSummary {
  std::size_t width = 0, height = 0;      ///< pixels
  std::size_t kernels_drawn = 0;          ///< kernels inside the window (3D: all heights)
  double min_length = 0, max_length = 0;  ///< colour scale used, metres
};

/// The picture's pixels in memory (`rgb`: width x height x 3 bytes, rows top first), as
/// write_kernel_picture draws them, for a caller that captions them. Throws as it does.
KernelPictureSummary render_kernel_picture(Context* ctx, const KernelMap& map,
                                           const RasterSpec& spec, std::vector<std::uint8_t>& rgb,
                                           const KernelPictureOptions& options = {});

/// The background's colour at probability p (0 to 1) where the map is known
/// (io/known_cells.hpp's default rule): free white to occupied dark brown, never the neutral
/// grey of kKernelPictureUnknown.
Rgb kernel_picture_grey(double p);

/// The background where nothing was observed: the grey of the probability pictures' unknown
/// space (experiment::kUnknownGrey).
constexpr Rgb kKernelPictureUnknown{150, 150, 150};

/// Writes the picture of `map` over the window of `spec` (resolution = metres per pixel) to
/// `path` (PNG, atomically). `ctx` may be null when options.background is false. Throws
/// ArgumentError for a bad spec, potmap::Error naming the file on a write failure.
KernelPictureSummary write_kernel_picture(Context* ctx, const KernelMap& map,
                                          const RasterSpec& spec, const std::string& path,
                                          const KernelPictureOptions& options = {});

}  // namespace potmap
POTMAP_CXX_API_END
