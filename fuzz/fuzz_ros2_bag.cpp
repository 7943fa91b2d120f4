#include <cstdint>
#include <vector>

#include "data/bag_source.hpp"
#include "data/ros2_messages.hpp"
#include "potmap/error.hpp"

// One ROS 2 message body as a rosbag2 .db3 row holds it (CDR, encapsulation header first): the
// first byte picks the type (its low bits), whether clouds are read header-only (0x80) and the
// topic (0x40: /tf_static); the rest is the body, decoded as the bag reader decodes it.
extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace potmap::data;
  if (size < 1) return 0;
  static const Ros2Type types[] = {Ros2Type::laser_scan,   Ros2Type::multi_echo_laser_scan,
                                   Ros2Type::point_cloud2, Ros2Type::tf,
                                   Ros2Type::odometry,     Ros2Type::pose_stamped};
  const Ros2Type type = types[(data[0] & 0x3f) % 6];
  // A copy of exactly the body's size, so that a read past its end is one past an allocation.
  const std::vector<uint8_t> body(data + 1, data + size);
  BagHandlers h;
  h.clouds_header_only = (data[0] & 0x80) != 0;
  std::size_t points = 0;
  h.scan = [&](const std::string&, std::uint64_t, const LaserScanMsg& m) {
    points += m.ranges.size();
  };
  h.cloud = [&](const std::string&, std::uint64_t, const CloudMsg& m) { points += m.xyz.size(); };
  h.transform = [&](const std::string&, const TransformMsg& m) { points += m.child.size(); };
  const char* topic = (data[0] & 0x40) ? "/tf_static" : "/topic";
  try {
    decode_ros2_message(type, body.data(), body.size(), "fuzz", topic, 0, h);
  } catch (const potmap::Error&) {
  }
  try {
    ros2_header_frame(type, body.data(), body.size(), "fuzz");
  } catch (const potmap::Error&) {
  }
  return 0;
}
