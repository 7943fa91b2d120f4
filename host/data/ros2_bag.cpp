// ROS 2 bags: not yet read (placeholder until the sqlite3 reader lands).
#include "data/bag_source.hpp"
#include "potmap/error.hpp"

namespace potmap::data {

std::unique_ptr<BagSource> open_ros2_bag(const std::string& path) {
  throw InputError(path + ": ROS 2 bags are not read yet");
}

}  // namespace potmap::data
