#pragma once
// The pictures of a finished map (probability, variance, kernels): the mapping job's for a 2D
// log (job/mapping_job.hpp), and `potmap map`'s and the demo's.
#include <string>
#include <vector>

#include "potmap/export.h"
#include "potmap/map/kernel_map.hpp"
#include "potmap/map/raster.hpp"
#include "potmap/render/kernel_picture.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap::job {

struct MapPictures {
  std::vector<std::string> files;  ///< PREFIX_prob.png, PREFIX_var.png, PREFIX_kernels.png
  std::size_t width = 0, height = 0;
  double resolution = 0;                  ///< metres per pixel used
  double min_length = 0, max_length = 0;  ///< kernel colour scale, metres
};

/// Metres per pixel that puts `long_side` pixels along the longer side of the map's kernel
/// bounds widened by `margin` metres (a readable picture whatever the map's size).
double picture_resolution(const KernelMap& map, double margin, std::size_t long_side);

/// Writes the three pictures of `map` over its kernel bounds widened by `margin` metres, at
/// `resolution` metres per pixel, slice at height z for 3D maps: PREFIX_prob.png (viridis) and
/// PREFIX_var.png (magma logit variance), never-observed space grey (KnownRule's default, as
/// the ROS map and OctoMap exports), each under its title and above its colour bar and a scale
/// bar in metres, and PREFIX_kernels.png with its legend (legend_picture.hpp). The map must not
/// be empty.
MapPictures write_map_pictures(Context& ctx, const KernelMap& map, const std::string& prefix,
                               double resolution, double margin = 5, double z = 0);

/// The kernels picture (render/kernel_picture.hpp: a dot at each kernel's centre, coloured by
/// its length scale on a log axis, over the map's probability in grey) under its title and above
/// its legend: the length-scale colour bar in metres, the grey bar of P(occupied), the dot of a
/// kernel and a scale bar. Writes `path` (PNG); throws as write_kernel_picture does.
KernelPictureSummary write_kernel_legend_picture(Context& ctx, const KernelMap& map,
                                                 const RasterSpec& spec, const std::string& path);

}  // namespace potmap::job
POTMAP_CXX_API_END
