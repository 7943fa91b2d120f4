#pragma once
// Which files a ROS 2 bag path names and how they are compressed: its metadata.yaml (read with
// yaml-cpp), or the .db3 files of a folder without one, or one .db3 file.
#include <string>
#include <vector>

namespace potmap::data {

enum class Ros2Compression { none, zstd_file, zstd_message };

struct Ros2BagLayout {
  std::vector<std::string> files;  ///< .db3 (or, zstd_file, .db3.zstd) paths in the bag's order
  Ros2Compression compression = Ros2Compression::none;
};

/// The bag at `path`: a folder holding metadata.yaml and .db3 files (or only .db3 files), its
/// metadata.yaml, or a single .db3 file. Throws InputError naming the path: nothing of a bag
/// there, MCAP storage, an unknown storage or compression, a listed file that is missing.
Ros2BagLayout find_ros2_bag(const std::string& path);

/// BagInfo::compression's words for it.
const char* compression_name(Ros2Compression c);

}  // namespace potmap::data
