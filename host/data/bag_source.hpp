#pragma once
// What a recording's storage hands to the bag readers: the messages potmap maps from, decoded
// into plain structs, whichever storage held them (ROS 1 .bag through Debian's librosbag_storage,
// ROS 2 folders through SQLite). The choice of topic, the poses (tf chain or a pose topic) and
// the turn into scans happen once, above this (bag_dataset.cpp), for both.

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace potmap::data {

/// One topic of a bag, as `potmap data info` lists it.
struct BagTopic {
  std::string name;       ///< "/scan"
  std::string type;       ///< ROS 1 spelling: "sensor_msgs/LaserScan" (ROS 2's "/msg/" dropped)
  std::size_t count = 0;  ///< messages
  std::string frame_id;   ///< header.frame_id of its first message that has one ("" if none)
};

struct BagInfo {
  std::string format;            ///< "ROS 1 bag", "ROS 2 bag (sqlite3)"
  std::string compression;       ///< "none", "lz4", "bz2", "zstd (file)", "zstd (message)", mixes
  std::vector<BagTopic> topics;  ///< in name order
  double start = 0, end = 0;     ///< seconds (the storage's receive times), 0 when empty
};

/// sensor_msgs/LaserScan, and sensor_msgs/MultiEchoLaserScan by its first echo per beam.
struct LaserScanMsg {
  double stamp = 0;  ///< header.stamp, seconds
  std::string frame_id;
  double angle_min = 0, angle_increment = 0;  ///< radians
  double range_min = 0, range_max = 0;        ///< metres
  std::vector<float> ranges;                  ///< metres; NaN/Inf kept as stored
};

/// sensor_msgs/PointCloud2's x, y, z (float32 or float64 fields), in the message's frame.
struct CloudMsg {
  double stamp = 0;
  std::string frame_id;
  std::vector<float> xyz;   ///< finite points only, 3 floats each
  std::size_t dropped = 0;  ///< NaN/Inf or (0, 0, 0) points left out (missing returns)
};

/// A rigid transform from `parent` to `child` at `stamp`: tf2_msgs/TFMessage's entries (and
/// /tf_static's, static = true), nav_msgs/Odometry (header.frame_id -> child_frame_id) and
/// geometry_msgs/PoseStamped (header.frame_id -> "", the pose of whatever the topic tracks).
struct TransformMsg {
  double stamp = 0;
  std::string parent, child;
  std::array<double, 3> t{0, 0, 0};     ///< metres
  std::array<double, 4> q{0, 0, 0, 1};  ///< x, y, z, w
  bool is_static = false;
};

/// The decoded messages of a read, each with the topic it came on and a key that finds it again
/// (read_cloud) without reading the bag through: a 3D drive indexes its clouds once, then reads
/// one keyframe at a time.
struct BagHandlers {
  std::function<void(const std::string& topic, std::uint64_t key, const LaserScanMsg&)> scan;
  std::function<void(const std::string& topic, std::uint64_t key, const CloudMsg&)> cloud;
  /// Called for TFMessage (every entry), Odometry and PoseStamped.
  std::function<void(const std::string& topic, const TransformMsg&)> transform;
  /// Point clouds are only counted here, not decoded (the drive's first pass): `cloud` then
  /// receives an empty CloudMsg carrying only stamp and frame_id.
  bool clouds_header_only = false;
};

/// A bag opened for reading. Readers throw InputError naming the file and what is wrong (not a
/// bag, truncated, a message that does not decode, an unknown compression).
class BagSource {
 public:
  virtual ~BagSource() = default;
  virtual const BagInfo& info() const = 0;
  /// Decodes every message of `topics` of the types above, in the order of the storage's
  /// receive times, and hands it to the matching handler (messages of other types are skipped).
  virtual void read(const std::vector<std::string>& topics, const BagHandlers& handlers) = 0;
  /// The cloud that read() handed over with `key` on `topic`.
  virtual CloudMsg read_cloud(const std::string& topic, std::uint64_t key) = 0;
};

/// A ROS 1 .bag file (plain, bz2 or lz4 chunks), read by librosbag_storage.
std::unique_ptr<BagSource> open_ros1_bag(const std::string& path);
/// A ROS 2 bag: its folder (metadata.yaml and .db3 files), its metadata.yaml or one .db3 file.
std::unique_ptr<BagSource> open_ros2_bag(const std::string& path);

/// sensor_msgs/PointField datatypes, as both ROS versions number them.
enum class PointFieldType : std::uint8_t {
  int8 = 1,
  uint8 = 2,
  int16 = 3,
  uint16 = 4,
  int32 = 5,
  uint32 = 6,
  float32 = 7,
  float64 = 8
};
struct PointFieldDesc {
  std::string name;
  std::uint32_t offset = 0;
  std::uint8_t datatype = 0;
  std::uint32_t count = 1;
};
/// sensor_msgs/PointCloud2's body as both storages carry it.
struct PointCloud2View {
  std::uint32_t height = 0, width = 0, point_step = 0, row_step = 0;
  bool is_bigendian = false;
  std::vector<PointFieldDesc> fields;
  const std::uint8_t* data = nullptr;
  std::size_t size = 0;
};
/// Fills cloud.xyz and cloud.dropped from a PointCloud2 body. `where` names the message in
/// errors (file and topic): no x/y/z field, a non-float one, a field past point_step, a data
/// block shorter than height x row_step or a row shorter than width x point_step.
void decode_point_cloud2(const PointCloud2View& view, const std::string& where, CloudMsg& cloud);

}  // namespace potmap::data
