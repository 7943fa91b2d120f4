#pragma once
// ROS bags as robots record them: ROS 1 .bag files (plain, bz2 or lz4 chunks) and ROS 2 bag
// folders (metadata.yaml and sqlite3 .db3 files). One topic is mapped: sensor_msgs/LaserScan or
// MultiEchoLaserScan (first echo) as 2D scans, sensor_msgs/PointCloud2 as 3D keyframes. Each
// message's sensor pose is the chain from a fixed frame to the message's frame_id in /tf and
// /tf_static, interpolated at the message's header stamp (tf2's BufferCore does the chain and
// the interpolation), or a nav_msgs/Odometry or geometry_msgs/PoseStamped topic.

#include <cstddef>
#include <string>
#include <vector>

#include "potmap/data/bag_options.hpp"
#include "potmap/data/drive.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct BagTopicSummary {
  std::string name, type;  ///< type in ROS 1 spelling: "sensor_msgs/LaserScan"
  std::size_t count = 0;   ///< messages
  std::string frame_id;    ///< of its first message ("" when its type has no header)
};

/// What `potmap data info BAG` prints: the storage's topics and what would be mapped.
struct BagSummary {
  std::string format;       ///< "ROS 1 bag" or "ROS 2 bag (sqlite3)"
  std::string compression;  ///< "none", "lz4", "bz2", "zstd (file)", "zstd (message)"
  std::vector<BagTopicSummary> topics;
  double start = 0, duration = 0;   ///< seconds (storage times)
  std::string topic;                ///< the topic that would be mapped
  std::string type;                 ///< its type
  int dim = 0;                      ///< 2 (scans) or 3 (clouds)
  std::string pose_source;          ///< "/tf" or the pose topic
  std::vector<std::string> frames;  ///< every frame named in /tf and /tf_static and the topics
};

/// Whether `path` is a ROS 1 .bag file or a ROS 2 bag (its folder, its metadata.yaml or a .db3).
bool is_bag(const std::string& path);

/// Lists a bag's topics and picks the topic `options` would map. Throws InputError naming the
/// bag when it holds no LaserScan, MultiEchoLaserScan or PointCloud2 topic (listing what it
/// holds), or when options.topic is not one of them, or options.pose_topic is not an Odometry or
/// PoseStamped topic.
BagSummary summarise_bag(const std::string& path, const BagOptions& options = {});

/// Every message of the chosen topic with a pose, as scans in the fixed frame: 2D scans for a
/// laser topic (ranges at or past max_range, or infinite, are no-returns; below range_min or NaN
/// are dropped and counted in stats.points_dropped), 3D keyframes for a cloud topic. Messages
/// whose pose cannot be found (before the first transform, a broken chain) are left out and
/// counted in stats.lines_skipped. Throws InputError when none has a pose, naming the frames
/// /tf holds and the ones asked for.
Dataset read_bag(const std::string& path, const BagOptions& options = {});

/// A cloud topic as a Drive (layout "rosbag"): its keyframes' poses and times, read one at a
/// time by read_keyframe.
Drive open_bag_drive(const std::string& path, const BagOptions& options = {});

}  // namespace potmap
POTMAP_CXX_API_END
