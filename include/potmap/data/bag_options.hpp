#pragma once
// How a ROS bag is read (potmap/data/bag.hpp): which topic, which frame, which poses.

#include <string>

#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct BagOptions {
  /// The topic to map. Empty (default): the sensor topic (LaserScan, MultiEchoLaserScan or
  /// PointCloud2) with the most messages, as a robot's main LIDAR usually is.
  std::string topic;
  /// The frame the map is built in. Empty (default): `map` when /tf links it to the sensor at
  /// the first message, else `odom` (what REP 105 names the world-fixed and odometry frames).
  std::string fixed_frame;
  /// A nav_msgs/Odometry or geometry_msgs/PoseStamped topic to take poses from instead of /tf.
  /// Its messages give the pose of their child_frame_id (Odometry) in their header frame; the
  /// sensor's offset from that child comes from /tf_static when it links them, else the pose is
  /// the sensor's own (PoseStamped always: it names no child). Empty (default): /tf.
  std::string pose_topic;
  /// Maximum range, metres. 0 (default): a LaserScan's own range_max; 120 for point clouds (a
  /// PointCloud2 does not say its sensor's; 120 m is an Ouster OS1-64's and an HDL-64E's).
  double max_range = 0;
  /// Point clouds: a new keyframe when the sensor has moved this far (metres, default 1) or
  /// turned this much (radians, default 0.26 = 15 degrees) since the last one, as LOAM-family
  /// SLAM tools keep theirs; the sweeps between add little beside them and cost a full update.
  /// 0 and 0: every sweep.
  double keyframe_distance = 1.0;
  double keyframe_angle = 0.26;
};

}  // namespace potmap
POTMAP_CXX_API_END
