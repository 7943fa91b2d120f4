// LaserScan, MultiEchoLaserScan, PointCloud2, TFMessage, Odometry and PoseStamped out of their
// CDR bodies, field by field in the order of their ROS 2 .msg definitions. Fields after the last
// one potmap needs (intensities, is_dense, twist) are not read.
#include "data/ros2_messages.hpp"

#include <cmath>
#include <limits>
#include <utility>

#include "data/ros2_cdr.hpp"

namespace potmap::data {

namespace {

struct Header {
  double stamp = 0;
  std::string frame_id;
};

Header read_header(CdrReader& in) {
  Header h;
  h.stamp = in.stamp("header.stamp");
  h.frame_id = in.str("header.frame_id");
  return h;
}

// geometry_msgs/Point or Vector3, then Quaternion: the layout of both Pose and Transform.
void read_pose(CdrReader& in, TransformMsg& t) {
  for (double& v : t.t) v = in.f64("position");
  for (double& v : t.q) v = in.f64("orientation");
}

// LaserScan and MultiEchoLaserScan share everything up to their ranges.
LaserScanMsg read_scan_head(CdrReader& in) {
  LaserScanMsg s;
  Header h = read_header(in);
  s.stamp = h.stamp;
  s.frame_id = std::move(h.frame_id);
  s.angle_min = in.f32("angle_min");
  in.f32("angle_max");
  s.angle_increment = in.f32("angle_increment");
  in.f32("time_increment");
  in.f32("scan_time");
  s.range_min = in.f32("range_min");
  s.range_max = in.f32("range_max");
  return s;
}

LaserScanMsg read_laser_scan(CdrReader& in) {
  LaserScanMsg s = read_scan_head(in);
  s.ranges = in.f32_sequence("ranges");
  return s;
}

LaserScanMsg read_multi_echo(CdrReader& in) {
  LaserScanMsg s = read_scan_head(in);
  // Each sensor_msgs/LaserEcho is at least its 4-byte length.
  const std::uint32_t beams = in.sequence_length("ranges", 4);
  s.ranges.reserve(beams);
  for (std::uint32_t i = 0; i < beams; ++i) {
    const std::vector<float> echoes = in.f32_sequence("ranges[].echoes");
    s.ranges.push_back(echoes.empty() ? std::numeric_limits<float>::quiet_NaN() : echoes[0]);
  }
  return s;
}

CloudMsg read_cloud(CdrReader& in, bool header_only) {
  CloudMsg c;
  Header h = read_header(in);
  c.stamp = h.stamp;
  c.frame_id = std::move(h.frame_id);
  if (header_only) return c;
  PointCloud2View v;
  v.height = in.u32("height");
  v.width = in.u32("width");
  // A PointField is at least a string length, offset, datatype and count.
  const std::uint32_t fields = in.sequence_length("fields", 13);
  for (std::uint32_t i = 0; i < fields; ++i) {
    PointFieldDesc f;
    f.name = in.str("fields[].name");
    f.offset = in.u32("fields[].offset");
    f.datatype = in.u8("fields[].datatype");
    f.count = in.u32("fields[].count");
    v.fields.push_back(std::move(f));
  }
  v.is_bigendian = in.u8("is_bigendian") != 0;
  v.point_step = in.u32("point_step");
  v.row_step = in.u32("row_step");
  v.data = in.byte_sequence("data", v.size);
  decode_point_cloud2(v, in.where(), c);
  return c;
}

void read_tf(CdrReader& in, const std::string& topic, const BagHandlers& handlers) {
  // A TransformStamped is at least its header and child's strings and seven float64s.
  const std::uint32_t n = in.sequence_length("transforms", 8 + 4 + 4 + 7 * 8);
  for (std::uint32_t i = 0; i < n; ++i) {
    TransformMsg t;
    Header h = read_header(in);
    t.stamp = h.stamp;
    t.parent = std::move(h.frame_id);
    t.child = in.str("transforms[].child_frame_id");
    read_pose(in, t);
    t.is_static = topic == "/tf_static";
    if (handlers.transform) handlers.transform(topic, t);
  }
}

TransformMsg read_odometry(CdrReader& in) {
  TransformMsg t;
  Header h = read_header(in);
  t.stamp = h.stamp;
  t.parent = std::move(h.frame_id);
  t.child = in.str("child_frame_id");
  read_pose(in, t);
  return t;
}

TransformMsg read_pose_stamped(CdrReader& in) {
  TransformMsg t;
  Header h = read_header(in);
  t.stamp = h.stamp;
  t.parent = std::move(h.frame_id);
  read_pose(in, t);
  return t;
}

}  // namespace

Ros2Type ros2_type(const std::string& type) {
  static const std::pair<const char*, Ros2Type> known[] = {
      {"sensor_msgs/msg/LaserScan", Ros2Type::laser_scan},
      {"sensor_msgs/msg/MultiEchoLaserScan", Ros2Type::multi_echo_laser_scan},
      {"sensor_msgs/msg/PointCloud2", Ros2Type::point_cloud2},
      {"tf2_msgs/msg/TFMessage", Ros2Type::tf},
      {"nav_msgs/msg/Odometry", Ros2Type::odometry},
      {"geometry_msgs/msg/PoseStamped", Ros2Type::pose_stamped},
  };
  for (const auto& [name, t] : known)
    if (type == name) return t;
  return Ros2Type::other;
}

std::string ros1_type_name(const std::string& ros2_type_name) {
  const std::size_t at = ros2_type_name.find("/msg/");
  if (at == std::string::npos) return ros2_type_name;
  return ros2_type_name.substr(0, at) + "/" + ros2_type_name.substr(at + 5);
}

void decode_ros2_message(Ros2Type type, const std::uint8_t* data, std::size_t size,
                         const std::string& where, const std::string& topic, std::uint64_t key,
                         const BagHandlers& handlers) {
  if (type == Ros2Type::other) return;
  CdrReader in(data, size, where);
  switch (type) {
    case Ros2Type::laser_scan: {
      const LaserScanMsg s = read_laser_scan(in);
      if (handlers.scan) handlers.scan(topic, key, s);
      break;
    }
    case Ros2Type::multi_echo_laser_scan: {
      const LaserScanMsg s = read_multi_echo(in);
      if (handlers.scan) handlers.scan(topic, key, s);
      break;
    }
    case Ros2Type::point_cloud2: {
      const CloudMsg c = read_cloud(in, handlers.clouds_header_only);
      if (handlers.cloud) handlers.cloud(topic, key, c);
      break;
    }
    case Ros2Type::tf:
      read_tf(in, topic, handlers);
      break;
    case Ros2Type::odometry: {
      const TransformMsg t = read_odometry(in);
      if (handlers.transform) handlers.transform(topic, t);
      break;
    }
    case Ros2Type::pose_stamped: {
      const TransformMsg t = read_pose_stamped(in);
      if (handlers.transform) handlers.transform(topic, t);
      break;
    }
    case Ros2Type::other:
      break;
  }
}

CloudMsg decode_ros2_cloud(const std::uint8_t* data, std::size_t size, const std::string& where) {
  CdrReader in(data, size, where);
  return read_cloud(in, false);
}

std::string ros2_header_frame(Ros2Type type, const std::uint8_t* data, std::size_t size,
                              const std::string& where) {
  if (type == Ros2Type::other || type == Ros2Type::tf) return "";
  CdrReader in(data, size, where);
  return read_header(in).frame_id;
}

}  // namespace potmap::data
