#pragma once
// One LIDAR sweep (SPEC section 1) and the dataset readers that produce sweeps.
//
// Points are stored in the world frame (metres). A 2D scan has dim == 2 and a pose (x, y, yaw);
// a 3D scan has dim == 3 and a rigid transform. Beams that returned nothing are kept as unit
// directions so that free space can be sampled along them up to max_range.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "potmap/data/bag_options.hpp"
#include "potmap/data/labelled_points.hpp"
#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct Scan {
  int dim = 2;           ///< 2 or 3
  double timestamp = 0;  ///< seconds (reader-specific epoch; scan index when the source has none)
  double max_range = 0;  ///< metres; a beam at or beyond it is a no-return
  /// Sensor pose, world frame. 2D: x, y (metres) and yaw (radians) in pose2d; 3D: pose3d is a
  /// 3 x 4 row-major [R | t] mapping sensor coordinates to world coordinates.
  std::array<double, 3> pose2d{0, 0, 0};
  std::array<double, 12> pose3d{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  std::vector<double> hits;       ///< end points of returned beams, world frame, dim per point
  std::vector<double> no_return;  ///< unit directions (world frame) of beams with no return
  std::size_t num_hits() const { return dim ? hits.size() / dim : 0; }
  std::size_t num_no_return() const { return dim ? no_return.size() / dim : 0; }
  std::size_t num_beams() const { return num_hits() + num_no_return(); }
  /// Sensor position in the world frame (dim coordinates).
  std::array<double, 3> origin() const;
};

/// What a reader saw besides the scans.
struct ReadStats {
  std::size_t lines_skipped = 0;   ///< lines of other types (CARMEN ODOM, PARAM, ...)
  std::size_t points_dropped = 0;  ///< NaN or Inf points dropped at the door
  /// Scans timed by their index because the log's stamps do not advance from most scans to the
  /// next (a CARMEN log whose stamps were printed with too few digits); 0: the log's stamps.
  std::size_t stamps_replaced = 0;
};

struct Dataset {
  std::vector<Scan> scans;
  ReadStats stats;
};

/// CARMEN log (plain or gzip, detected by the magic bytes). A log is read from one kind of
/// laser line, the first it has of:
/// - the front laser with its pose: FLASER `n r_1..r_n x y theta odom_x odom_y odom_theta
///   [timestamp host logger_timestamp]` (without the timestamp, the scan's index is its
///   timestamp) and ROBOTLASER1 `type start fov res max_range accuracy remission_mode n r.. m
///   rem.. laser_x laser_y laser_theta robot_x robot_y robot_theta` followed by `tv rv
///   forward_safety_dist side_safety_dist turn_axis timestamp host logger_timestamp` (CARMEN's
///   logger), by `timestamp host logger_timestamp`, by the five velocity fields only, or by
///   nothing (the last two: the scan's index is its timestamp). ROBOTLASER1 beams span its field
///   of view from its start angle around the laser pose, with its maximum range;
/// - else the rear laser: RLASER, FLASER's layout, the beams centred on the heading plus pi
///   (pose2d's yaw is the rear laser's heading). A log with FLASER lines has its RLASER lines
///   skipped;
/// - else RAWLASERn `type start fov res max_range accuracy remission_mode n r.. m rem.. timestamp
///   host logger_timestamp`, the lowest n in the log (1: CARMEN's front laser): the pose is the
///   ODOM lines' (`ODOM x y theta tv rv accel timestamp host logger_timestamp`) linearly
///   interpolated at the laser's timestamp, the heading the shorter way round; a laser line up
///   to 0.5 s outside the ODOM lines' time span takes the nearest ODOM pose, further out (or in
///   a log with no ODOM line) it is an InputError naming the line and its time;
/// - else CARMEN's old laser lines LASER or LASERn (lowest n) `n r_1..r_n [timestamp host
///   logger_timestamp]` with FLASER's geometry, each at the pose of the latest ODOM line
///   before it (`ODOM x y theta ...`; none before it is an InputError naming the line).
/// Laser offsets on the robot (PARAM lines) are not applied: the logged or odometry pose is the
/// sensor's. Distances are metres and angles radians, as CARMEN writes them. Lines of other
/// types and laser lines of the kinds not read are counted in stats.lines_skipped; a file with
/// no laser line is an InputError naming it, its first line (non-printable bytes as '?') and
/// what is read. A range >= max_range is a no-return; `flaser_max_range` (metres, default 0 =
/// automatic: the largest range seen in the file, so readings at the device's limit count as
/// no-returns) sets it for FLASER, RLASER and LASER lines; `flaser_fov` (radians, default pi) is
/// their field of view, centred on the heading (n odd: both ends included; n even: 1 degree
/// steps for 180 beams over 180 degrees, the last beam one step short of +fov/2). Throws
/// InputError naming file, line and value for a truncated line, wrong field count, non-numeric
/// value, NaN pose or negative range. A log whose stamps do not advance from most scans to the
/// next (printed with too few digits: CSAIL's) has its scans timed by their index
/// (stats.stamps_replaced).
Dataset read_carmen(const std::string& path, double flaser_max_range = 0,
                    double flaser_fov = 3.14159265358979323846);

/// KITTI Velodyne frame: N x 4 float32 (x, y, z, reflectance), plain or gzip. The sensor is at
/// the origin unless a pose is given. max_range in metres (default 120, the HDL-64E).
/// Throws InputError (file, byte offset, size) when the size is not a multiple of 16 bytes.
Scan read_kitti_bin(const std::string& path, double max_range = 120);

/// nuScenes LIDAR_TOP frame: N x 5 float32 (x, y, z, intensity, ring), sensor at the origin.
/// max_range in metres (default 110: the frames hold returns past 100 m).
Scan read_nuscenes_bin(const std::string& path, double max_range = 110);

/// KITTI odometry: poses.txt (one 3 x 4 row-major camera pose per line) and calib.txt (line
/// `Tr: ...` velodyne to camera). Returns, per frame, the velodyne-to-world pose
/// Tr^-1 * P_i * Tr as 3 x 4 row-major, so a frame's points map into the first camera's frame
/// expressed in velodyne axes.
std::vector<std::array<double, 12>> read_kitti_poses(const std::string& poses_path,
                                                     const std::string& calib_path);

/// Point-cloud frame: PCD (ascii, binary or binary_compressed) or PLY (ascii or binary), by its
/// name's extension, parsed by PCL's io module. Fields x, y, z (float32 or float64; others are
/// ignored) are the hits; NaN or Inf points (an organised cloud's missing returns) are dropped
/// and counted in `dropped` when given. A PCD VIEWPOINT (PLY camera) is the sensor's pose in the
/// cloud's frame and becomes pose3d; the points stay as stored. max_range in metres (default
/// 120, as KITTI frames: a cloud does not say its sensor's range). Throws InputError naming the
/// file and what is wrong for an unreadable header, a missing or non-float x/y/z field, an empty
/// cloud, a truncated body (byte offset and sizes), or a cloud with no finite point.
Scan read_point_cloud(const std::string& path, double max_range = 120,
                      std::size_t* dropped = nullptr);

/// A sequence of point-cloud frames by its poses file: one line per frame, `FRAME r00 r01 r02 tx
/// r10 r11 r12 ty r20 r21 r22 tz` (the frame's .pcd or .ply path, relative to the poses file's
/// folder unless absolute, then its sensor-to-world 3 x 4 row-major [R | t], KITTI's order);
/// blank lines and lines starting with '#' are skipped. Each frame is read by read_point_cloud
/// and moved into the world by its pose; timestamps are the frame indices. Throws InputError
/// naming the poses file and line for a short or non-numeric pose, a missing frame, or no frame.
Dataset read_point_cloud_sequence(const std::string& poses_path, double max_range = 120);

/// True when the first non-comment line of a text file starts with a .pcd or .ply name (a
/// point-cloud poses file rather than KITTI's poses.txt, whose lines are 12 numbers).
bool is_point_cloud_poses(const std::string& path);

/// Moves a 3D scan's points from the sensor frame into the world by `pose` (3 x 4 row-major).
void apply_pose(Scan& scan, const std::array<double, 12>& pose);

/// Groups labelled points (BHM labelled-sample CSV, read by read_labelled_csv) into scans by
/// their scan index t. Only hits become beam end points; the sensor pose is unknown in this
/// format and set to the centroid of the scan's free points (or of its hits when none).
/// max_range (metres, default 20) is stored on every scan.
std::vector<Scan> scans_from_labelled(const LabelledPoints& points, double max_range = 20);

/// NumPy .npz with `X` (N x 3: t, x, y, or N x 4: t, x, y, z) and `Y` (N or N x 1 labels).
LabelledPoints read_npz_labelled(const std::string& path);

/// Reads any supported file by its name: *.log[.gz] and *.clf[.gz] CARMEN, *.bin KITTI (4 floats)
/// or nuScenes (5 floats, name containing "nuscenes"), a KITTI odometry sequence by its poses.txt
/// (velodyne/NNNNNN.bin and calib.txt beside it; frames moved into the world frame, max range
/// 120 m) or by its folder (the one holding poses.txt), *.pcd and *.ply point-cloud frames, a
/// point-cloud sequence by its poses file (*.txt whose lines start with a frame name, see
/// read_point_cloud_sequence) or by its folder (holding such a poses.txt), *.npz and *.csv
/// labelled samples, ROS 1 .bag files and ROS 2 bag folders (read_bag with `bag`'s topic, frame
/// and poses). A file of any other name is read as a CARMEN log; when it holds no laser line,
/// the InputError lists the extensions read. Throws InputError naming a folder that holds no
/// poses.txt.
Dataset read_dataset(const std::string& path, const BagOptions& bag = {});

}  // namespace potmap
POTMAP_CXX_API_END
