#pragma once
// What `potmap mapping DRIVE` writes beside the map: the library's volume export
// (mapping/drive_volume.hpp: PREFIX.bt, an OctoMap of every known voxel; PREFIX_occupied.ply,
// the occupied voxels with their probability and logit variance; a height band about the
// sensor's path) and the band's pictures PREFIX_band_prob.png and PREFIX_band_var.png (never
// observed space grey, a colour bar and a scale) and ROS map PREFIX_band.yaml + .pgm (occupied
// where any voxel of the band is, free where the band is known and free, unknown elsewhere).
#include <nlohmann/json.hpp>

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "potmap/io/known_cells.hpp"
#include "potmap/map/kernel_map.hpp"
#include "potmap/runtime/context.hpp"

namespace potmap::job {

struct DriveOutputOptions {
  /// The band, metres about the sensor's height (defaults -1.0 to +0.5: from about 0.8 m above
  /// the road to a van's roof for a LIDAR on a car's roof at 1.8 m). Lower, the band meets the
  /// road itself: 1 m kernels blur the road's surface upward by about half a metre, and the
  /// road is seen densest under each keyframe, which shows as stripes across it.
  double band_low = -1.0, band_high = 0.5;
  /// Voxel edge of the OctoMap, the point cloud and the band, metres (DriveVolumeOptions's
  /// default and why).
  double voxel = 0.4;
  /// Picture resolution, metres a pixel (0, default: the coarsest multiple of the voxel edge
  /// that fits picture_pixels along the longer side).
  double picture_res = 0;
  std::size_t picture_pixels = 1200;  ///< along the longer side (as 2D mapping's pictures)
  KnownRule known;
  /// The share of the volume done (0 to 1), after each batch of blocks.
  std::function<void(double fraction)> progress;
};

struct DriveOutputs {
  std::vector<std::string> files;
  std::string summary;  ///< lines for the command's summary
  nlohmann::json json;
};

/// Writes the files above for `map` (3D); `positions` holds the keyframes' sensor positions
/// (x y z each). Throws ArgumentError for a 2D map or bad options.
DriveOutputs write_drive_outputs(Context& ctx, const KernelMap& map,
                                 const std::vector<double>& positions, const std::string& prefix,
                                 const DriveOutputOptions& options = {});

}  // namespace potmap::job
