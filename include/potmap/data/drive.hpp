#pragma once
// 3D drives: keyframes with poses, as SLAM tools save them and as KITTI's odometry benchmark
// lays them out (SPEC section 8). A Drive is the index of a recording (file names, poses, times);
// keyframes are read one at a time, so a mapper holds one keyframe's points, never the drive's.
//
// Layouts read as they are:
//  - LOAM-family SLAM output (SC-A-LOAM, FAST_LIO_SLAM, LIO-SAM's savers): a folder with
//    Scans/NNNNNN.pcd (one keyframe, sensor frame), odom_poses.txt (one KITTI-style 3 x 4 [R | t]
//    row per keyframe, sensor to the first keyframe's frame), times.txt optional (seconds, one
//    a line). optimized_poses.txt (a pose graph's loop-closed poses) is used instead of
//    odom_poses.txt when `DriveOptions::poses` says so.
//  - A KITTI odometry sequence: sequences/NN/{velodyne/NNNNNN.bin, calib.txt, times.txt} with
//    its poses in poses/NN.txt two folders up (the benchmark's layout), or poses.txt in the
//    sequence folder (as `potmap data simulate --3d` writes it). Poses are the left camera's;
//    calib.txt's Tr takes them to the Velodyne (read_kitti_poses).

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include <memory>

#include "potmap/data/bag_options.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct DriveOptions {
  /// Which poses of a SLAM folder: "odom" (default: odom_poses.txt, the odometry every such
  /// tool writes, as in the paper, where localisation comes from another system), "optimized"
  /// (optimized_poses.txt) or "auto" (optimized_poses.txt when present, else odom_poses.txt).
  std::string poses = "odom";
  /// The sensor's maximum range, metres (default 120: an Ouster OS1-64's and a Velodyne
  /// HDL-64E's rated range; a point cloud does not say its sensor's). Returns at or beyond it
  /// count as no-returns (free space up to it), as Scan::max_range says; mapping cuts far
  /// shorter (DriveMapperOptions::range_cut).
  double max_range = 120;
  /// ROS bags (potmap/data/bag.hpp): the topic, frame and poses to read; max_range above
  /// applies when bag.max_range is 0.
  BagOptions bag;
};

struct BagFile;  ///< an open bag behind a Drive of layout "rosbag" (opaque)

/// The index of a drive: one entry per keyframe, in order.
struct Drive {
  std::string path;                           ///< the folder as given
  std::string layout;                         ///< "slam", "kitti" or "rosbag"
  std::string poses_file;                     ///< the poses file read
  std::vector<std::string> frames;            ///< keyframe files
  std::vector<std::array<double, 12>> poses;  ///< sensor to world, 3 x 4 row-major [R | t]
  std::vector<double> times;                  ///< seconds; keyframe indices when no times.txt
  bool has_times = false;                     ///< whether times came from times.txt
  double max_range = 120;                     ///< metres (DriveOptions::max_range)
  std::shared_ptr<BagFile> bag;               ///< layout "rosbag": the open bag
  std::size_t size() const { return frames.size(); }
};

/// Whether `path` is a folder in one of the layouts above, or a ROS bag whose topic (chosen by
/// options.bag, potmap/data/bag.hpp) holds point clouds.
bool is_drive(const std::string& path, const DriveOptions& options = {});

/// Indexes a drive folder (either layout), or a ROS bag's point-cloud topic (open_bag_drive). Throws InputError naming the file, line and value
/// for: a poses file with fewer or more rows than keyframes, a row that is not 12 finite
/// numbers, a rotation that is not one (R^T R off the identity by more than 1e-3, or det < 0),
/// a times file of another length or with a non-numeric or decreasing time, a folder with no
/// keyframe; and naming the folder when it is in no known layout.
Drive open_drive(const std::string& path, const DriveOptions& options = {});

/// Keyframe i: its points read (a truncated or malformed file throws InputError naming it and
/// the byte or field) and moved into the world by its pose; the timestamp is times[i], the max
/// range the drive's. `dropped` (optional) receives the NaN or Inf points dropped.
Scan read_keyframe(const Drive& drive, std::size_t i, std::size_t* dropped = nullptr);

/// Every keyframe of [first, first + count) (count 0: to the end) as a Dataset.
Dataset read_drive(const Drive& drive, std::size_t first = 0, std::size_t count = 0);

/// What `potmap data info DRIVE` prints.
struct DriveSummary {
  std::size_t keyframes = 0;
  std::size_t points = 0;  ///< summed over keyframes
  std::size_t min_points = 0, max_points = 0;
  double path_length = 0;                       ///< metres, along the poses
  double largest_step = 0;                      ///< metres between consecutive keyframes
  double median_step = 0;                       ///< metres
  double duration = 0;                          ///< seconds (times.txt; 0 without it)
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};  ///< bounds of the sensor positions, metres
  /// Field of view of the keyframes, in the sensor frame: azimuth span covered (degrees, 360
  /// for a spinning LIDAR), elevation range (degrees), and the median and 99th percentile
  /// range of the returns (metres), over the keyframes sampled.
  double azimuth_span = 0, elevation_min = 0, elevation_max = 0;
  double range_median = 0, range_p99 = 0;
  std::size_t sampled = 0;  ///< keyframes read for the point counts and field of view
};

/// Reads every keyframe's header-level facts (point counts) and samples up to `sample`
/// keyframes, evenly spaced, for the field of view (0: all).
DriveSummary summarise_drive(const Drive& drive, std::size_t sample = 0);

/// KITTI-style pose rows: 12 numbers a line (3 x 4 [R | t], row-major), blank lines skipped.
/// Throws InputError naming the file, line and value for a short row, a non-numeric or
/// non-finite value, or more than 12 numbers.
std::vector<std::array<double, 12>> read_pose_rows(const std::string& path);

}  // namespace potmap
POTMAP_CXX_API_END
