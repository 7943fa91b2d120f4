#pragma once
// What `potmap mapping DRIVE` writes beside the map, from one pass over the map's volume: the
// map is evaluated voxel by voxel only in the blocks (8 m cubes) that hold kernels, never over
// the drive's bounding box (2.4 km x 0.8 km x 130 m for riverside-a), and unknown voxels
// (io/known_cells.hpp) are left out as OctoMap leaves space no beam crossed.
//  - PREFIX.bt: an OctoMap of every known voxel (occupied and free, the maximum likelihood),
//    which OctoMap's own tools (octovis, octomap_server) load;
//  - PREFIX_occupied.ply: the occupied voxels (p > 0.5) as points with their probability and
//    logit variance (binary little-endian PLY: x y z float, probability variance float), which
//    CloudCompare, MeshLab and PCL open;
//  - a height band about the sensor's height (each place takes the height of the nearest
//    keyframe, so a drive that climbs keeps its band on the road): the band's largest
//    probability (and the variance there) as PREFIX_band_prob.png and PREFIX_band_var.png,
//    with never-observed space grey, a colour bar and a scale, and as a ROS map
//    PREFIX_band.yaml + .pgm (occupied where any voxel of the band is, free where the band is
//    known and free, unknown elsewhere).
#include <nlohmann/json.hpp>

#include <cstddef>
#include <string>
#include <vector>

#include "potmap/io/known_cells.hpp"
#include "potmap/map/kernel_map.hpp"
#include "potmap/runtime/context.hpp"

namespace potmap::cli {

struct DriveOutputOptions {
  /// The band, metres about the sensor's height (defaults -1.0 to +0.5: from about 0.8 m above
  /// the road to a van's roof for a LIDAR on a car's roof at 1.8 m). Lower, the band meets the
  /// road itself: 1 m kernels blur the road's surface upward by about half a metre, and the
  /// road is seen densest under each keyframe, which shows as stripes across it.
  double band_low = -1.0, band_high = 0.5;
  /// Voxel edge of the OctoMap, the point cloud and the band, metres (default 0.4: the map's
  /// kernels are 1 m apart, so finer voxels show the same surfaces, while each halving costs
  /// 8 times the evaluation and the OctoMap's memory: on riverside-a's first 30 keyframes
  /// 0.2 m took 20 s and 260 MB more, 0.4 m 4.5 s and nothing above the mapping's peak).
  double voxel = 0.4;
  /// ROS map resolution, metres (0, default: the voxel edge).
  double ros_res = 0;
  /// Picture resolution, metres a pixel (0, default: the coarsest multiple of the voxel edge
  /// that fits picture_pixels along the longer side).
  double picture_res = 0;
  std::size_t picture_pixels = 1200;  ///< along the longer side (as 2D mapping's pictures)
  KnownRule known;
};

struct DriveOutputs {
  std::vector<std::string> files;
  std::string summary;  ///< lines for the command's summary
  nlohmann::json json;
};

/// The map's probability at n points (3n coordinates), evaluated a column of 32 m at a time
/// with the kernels within reach of it: one evaluator over a whole drive's map and points
/// spread along 2.4 km would gather, for each chunk of points, every kernel of the chunk's
/// wide box (gigabytes).
std::vector<float> probability_by_columns(Context& ctx, const KernelMap& map,
                                          const std::vector<double>& points);

/// Writes the files above for `map` (3D); `positions` holds the keyframes' sensor positions
/// (x y z each). Throws ArgumentError for a 2D map or bad options.
DriveOutputs write_drive_outputs(Context& ctx, const KernelMap& map,
                                 const std::vector<double>& positions, const std::string& prefix,
                                 const DriveOutputOptions& options = {});

}  // namespace potmap::cli
