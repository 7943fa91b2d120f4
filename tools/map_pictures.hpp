#pragma once
// The pictures of a finished map (probability, variance, kernels), shared by `potmap map`,
// `potmap mapping` and the demo.
#include <string>
#include <vector>

#include "potmap/map/kernel_map.hpp"
#include "potmap/runtime/context.hpp"

namespace potmap::cli {

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

}  // namespace potmap::cli
