#pragma once
// Occupancy maps as ROS map_server / nav2 load them: `map.yaml` beside a binary PGM image.
//
// The YAML holds image (the PGM's file name, relative to the YAML), mode, resolution (metres
// per pixel), origin (x, y, yaw of the lower-left pixel's lower-left corner, metres and
// radians), negate (0), occupied_thresh and free_thresh. With negate 0 a loader reads a pixel
// v as occupancy (255 - v) / 255.
//
// Which cells are unknown is decided from the variance (known_cells.hpp: no kernel reaches the
// cell, or the kernels there still hold their prior variance). Known cells in trinary mode: p >
// occupied_thresh is occupied (pixel 0), p < free_thresh free (254), anything between unknown
// (205), which is what the loader reads back from those values. In scale mode a known cell is the
// grey level round(255 (1 - p)); a PGM has no alpha channel, so unknown cells are written at p =
// 0.5 (128), which the loader reads as an uncertain cost.

#include <cstddef>
#include <cstdint>
#include <string>

#include "potmap/export.h"
#include "potmap/io/known_cells.hpp"
#include "potmap/map/kernel_map.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

enum class RosMapMode { trinary, scale };

struct RosMapOptions {
  /// Metres per pixel (default 0.05, the usual resolution of ROS 2D navigation maps).
  double resolution = 0.05;
  /// Window in metres. All four zero (default): the known cells' bounds widened by `margin`
  /// (the kernels' bounds when no cell is known): a persistent RePOT map's tiles reach well
  /// beyond where the scans went, and a robot needs only what was seen.
  double xmin = 0, xmax = 0, ymin = 0, ymax = 0;
  /// Metres added around those bounds when no window is given (default 1: one kernel reach of
  /// the joint BHM's kernels).
  double margin = 1.0;
  /// Height of the horizontal slice of a 3D map, metres (default 0).
  double z = 0;
  /// Probability above which a cell is occupied (default 0.65, map_server's).
  double occupied_thresh = 0.65;
  /// Probability below which a cell is free (default 0.196, map_server's).
  double free_thresh = 0.196;
  RosMapMode mode = RosMapMode::trinary;
  /// Which cells are unknown (known_cells.hpp; defaults there).
  KnownRule known;
  /// Largest image, pixels along either side (default 20000); a larger window is refused
  /// rather than allocating gigabytes.
  std::size_t max_pixels = 20000;
};

/// Pixel value of one cell, as write_ros_map writes it (see the rule above).
std::uint8_t ros_map_pixel(double prob, bool known, const RosMapOptions& options);

struct RosMapSummary {
  std::string yaml, pgm;  ///< the files written
  std::size_t width = 0, height = 0;
  double origin[2] = {0, 0};  ///< lower-left corner of the lower-left pixel, metres
  std::size_t occupied = 0, free = 0, unknown = 0;  ///< cells of each kind
};

/// Writes `yaml_path` and the PGM beside it (the YAML's name with .pgm) for the map's
/// probability on the window (slice at options.z in 3D). `ctx` null: the exact CPU sum (slow
/// for large maps). Both files are written to temporaries and renamed. Throws ArgumentError for
/// bad thresholds (0 <= free_thresh < occupied_thresh <= 1), resolution or window; potmap::Error
/// naming the file when it cannot be written.
RosMapSummary write_ros_map(Context* ctx, const KernelMap& map, const std::string& yaml_path,
                            const RosMapOptions& options = {});

/// The same files for cells already evaluated: `prob` and `known` of nx x ny cells in row-major
/// order from the lower-left cell at `origin` (metres), options.resolution metres each (a 3D
/// map's height band, say). The thresholds are write_ros_map's; the cells written are the known
/// ones' bounds widened by options.margin (all of them when options name a window); options.z
/// is not used. Throws ArgumentError for sizes that disagree.
RosMapSummary write_ros_cells(const std::vector<double>& prob,
                              const std::vector<std::uint8_t>& known, std::size_t nx,
                              std::size_t ny, const double origin[2], const std::string& yaml_path,
                              const RosMapOptions& options);

}  // namespace potmap
POTMAP_CXX_API_END
