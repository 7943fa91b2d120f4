#pragma once
// The ROS 2 message types potmap maps from, decoded from their CDR bodies into bag_source.hpp's
// structs. Apart from the bag reader so that a fuzzer can feed it message bodies directly.
#include <cstddef>
#include <cstdint>
#include <string>

#include "data/bag_source.hpp"

namespace potmap::data {

enum class Ros2Type {
  other,
  laser_scan,             ///< sensor_msgs/msg/LaserScan
  multi_echo_laser_scan,  ///< sensor_msgs/msg/MultiEchoLaserScan
  point_cloud2,           ///< sensor_msgs/msg/PointCloud2
  tf,                     ///< tf2_msgs/msg/TFMessage
  odometry,               ///< nav_msgs/msg/Odometry
  pose_stamped,           ///< geometry_msgs/msg/PoseStamped
};

/// The type of a rosbag2 topic's `type` ("sensor_msgs/msg/LaserScan"); other for the rest.
Ros2Type ros2_type(const std::string& type);
/// ROS 1's spelling of a ROS 2 type name: "sensor_msgs/msg/LaserScan" -> "sensor_msgs/LaserScan".
std::string ros1_type_name(const std::string& ros2_type_name);

/// Decodes one message of `type` and hands it to the handler of its kind (transform once per
/// TFMessage entry, static when `topic` is /tf_static). Types of `other` are skipped. Throws
/// InputError naming `where`, the field and its byte offset when the body does not decode.
void decode_ros2_message(Ros2Type type, const std::uint8_t* data, std::size_t size,
                         const std::string& where, const std::string& topic, std::uint64_t key,
                         const BagHandlers& handlers);

/// The full PointCloud2 of one message.
CloudMsg decode_ros2_cloud(const std::uint8_t* data, std::size_t size, const std::string& where);

/// header.frame_id of a message of a type that starts with a std_msgs/Header ("" for TFMessage,
/// which has none, and for `other`).
std::string ros2_header_frame(Ros2Type type, const std::uint8_t* data, std::size_t size,
                              const std::string& where);

}  // namespace potmap::data
