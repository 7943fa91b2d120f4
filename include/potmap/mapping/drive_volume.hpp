#pragma once
// A 3D drive's map as the files robotics tools load, from one pass over its volume: the map is
// evaluated on the device in blocks of 16^3 voxels (map/voxel_blocks.hpp) only where it holds
// kernels, never over the drive's bounding box (2.4 km x 0.8 km x 130 m for a city drive), while
// a second thread turns each finished batch of blocks into
//  - an OctoMap (.bt) of every known voxel at its most likely state (io/octomap_binary.hpp:
//    octovis, octomap_server and OcTree::readBinary load it), unknown voxels left out as
//    OctoMap leaves space no beam crossed (io/known_cells.hpp decides, from the variance);
//  - the occupied voxels (p > 0.5) as a binary little-endian PLY point cloud with their
//    probability and logit variance (x y z probability variance, float; CloudCompare, MeshLab,
//    PCL);
//  - a height band about the sensor's path seen from above (each place takes the height of the
//    nearest point of the path, so a road that climbs keeps its band): per column the band's
//    largest probability and the variance there, for pictures and a ROS map.
// Files are written whole or not at all (a temporary file renamed into place).

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "potmap/export.h"
#include "potmap/io/known_cells.hpp"
#include "potmap/map/kernel_map.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct DriveVolumeOptions {
  /// Voxel edge, metres (default 0.4: the drive map's kernels are 1 m apart, so finer voxels
  /// show the same surfaces, while each halving costs 8 times the evaluation and the files).
  double voxel = 0.4;
  /// The band, metres about the path's height (defaults -1.0 to +0.5: from about 0.8 m above
  /// the road to a van's roof for a LIDAR on a car's roof at 1.8 m). Lower, the band meets the
  /// road itself: 1 m kernels blur the road's surface upward by about half a metre.
  double band_low = -1.0, band_high = 0.5;
  KnownRule known;           ///< which voxels are known (default: io/known_cells.hpp's)
  std::string octomap_path;  ///< the .bt to write (empty: none)
  std::string cloud_path;    ///< the .ply of occupied voxels to write (empty: none)
  /// Called with the share of blocks done (0 to 1) after each batch, on the calling thread.
  std::function<void(double fraction)> progress;
};

/// The band seen from above: nx x ny cells of `res` metres from the lower-left corner `origin`,
/// row-major (x fastest); prob < 0 where no voxel of the band is known.
struct HeightBandRaster {
  double origin[2] = {0, 0};
  double res = 0;
  std::size_t nx = 0, ny = 0;
  std::vector<float> prob, var;
};

struct DriveVolume {
  double voxel = 0;        ///< the voxel edge used, metres
  std::size_t blocks = 0;  ///< blocks of 16^3 voxels evaluated: those holding kernels
  std::size_t occupied = 0, free = 0, unknown = 0;  ///< voxels
  std::uint64_t octomap_nodes = 0, octomap_leaves = 0;
  HeightBandRaster band;  ///< at the voxel edge
};

/// The map's probability at n points (3n coordinates, metres) of a 3D map, evaluated a column
/// of 64 m at a time with the kernels within reach of it: one evaluator over a whole drive's
/// map and points spread along kilometres would gather, for each chunk of points, every kernel
/// of the chunk's wide box. Throws ArgumentError for a 2D map.
std::vector<float> probability_by_columns(Context& ctx, const KernelMap& map,
                                          const std::vector<double>& points);

/// Evaluates `map` (3D) over the blocks that hold its kernels and writes the files named in
/// `options`; `path` holds the sensor's positions in order (x y z each, metres; at least one).
/// Throws ArgumentError for a 2D or empty map, a bad option or an empty path, potmap::Error
/// when a file cannot be written (nothing is left half-written).
DriveVolume export_drive_volume(Context& ctx, const KernelMap& map, const std::vector<double>& path,
                                const DriveVolumeOptions& options = {});

}  // namespace potmap
POTMAP_CXX_API_END
