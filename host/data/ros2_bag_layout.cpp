// rosbag2's folder layout and metadata.yaml (rosbag2_bagfile_information, versions 1 to 9).
#include "data/ros2_bag_layout.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <system_error>

#include "potmap/error.hpp"

namespace potmap::data {

namespace fs = std::filesystem;

namespace {

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

[[noreturn]] void mcap_error(const std::string& where) {
  throw InputError(where +
                   ": ROS 2 bags stored as MCAP need an MCAP reader, which potmap does not "
                   "have (Debian packages no MCAP library); convert with `ros2 bag convert` "
                   "to sqlite3");
}

bool is_file(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

// A folder's .db3 (and .db3.zstd) files in name order, which is the order rosbag2 splits into
// (<name>_0.db3, <name>_1.db3, ...) up to ten files; longer names sort after shorter ones.
std::vector<std::string> db3_files_in(const fs::path& folder, bool& any_mcap) {
  std::vector<std::string> files;
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (ends_with(name, ".mcap")) any_mcap = true;
    if (ends_with(name, ".db3") || ends_with(name, ".db3.zstd")) files.push_back(it->path());
  }
  std::sort(files.begin(), files.end(), [](const std::string& a, const std::string& b) {
    return a.size() != b.size() ? a.size() < b.size() : a < b;
  });
  return files;
}

Ros2Compression compression_of(const YAML::Node& info, const std::string& where) {
  const std::string format =
      info["compression_format"] ? info["compression_format"].as<std::string>() : "";
  std::string mode = info["compression_mode"] ? info["compression_mode"].as<std::string>() : "";
  for (char& ch : mode) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
  if (format.empty() || mode.empty() || mode == "NONE") return Ros2Compression::none;
  if (format != "zstd")
    throw InputError(where + ": compression_format '" + format +
                     "' is not supported (rosbag2 compresses with zstd)");
  if (mode == "FILE") return Ros2Compression::zstd_file;
  if (mode == "MESSAGE") return Ros2Compression::zstd_message;
  throw InputError(where + ": compression_mode '" + mode + "' is not FILE, MESSAGE or NONE");
}

// The bag's files as metadata.yaml lists them. rosbag2 before metadata version 4 wrote them
// relative to the folder above the bag, later ones relative to the bag.
std::vector<std::string> listed_files(const YAML::Node& info, const fs::path& folder,
                                      const std::string& where) {
  std::vector<std::string> rel;
  if (info["relative_file_paths"]) {
    rel = info["relative_file_paths"].as<std::vector<std::string>>();
  } else if (info["files"]) {
    for (const YAML::Node& f : info["files"]) rel.push_back(f["path"].as<std::string>());
  }
  std::vector<std::string> files;
  for (const std::string& r : rel) {
    if (ends_with(r, ".mcap")) mcap_error(where);
    const fs::path in_bag = folder / r, above = folder.parent_path() / r;
    if (is_file(in_bag))
      files.push_back(in_bag.string());
    else if (is_file(above))
      files.push_back(above.string());
    else
      throw InputError(where + ": lists the file '" + r + "', which is not in " + folder.string());
  }
  return files;
}

Ros2BagLayout read_metadata(const fs::path& yaml_path) {
  const std::string where = yaml_path.string();
  Ros2BagLayout layout;
  try {
    const YAML::Node root = YAML::LoadFile(where);
    const YAML::Node info = root["rosbag2_bagfile_information"];
    if (!info || !info.IsMap())
      throw InputError(where + ": not a rosbag2 metadata.yaml (no rosbag2_bagfile_information)");
    const std::string storage =
        info["storage_identifier"] ? info["storage_identifier"].as<std::string>() : "sqlite3";
    if (storage == "mcap") mcap_error(where);
    if (storage != "sqlite3")
      throw InputError(where + ": storage_identifier '" + storage +
                       "' is not supported (sqlite3 only)");
    layout.compression = compression_of(info, where);
    const fs::path folder = yaml_path.parent_path();
    layout.files = listed_files(info, folder, where);
    if (layout.files.empty()) {
      bool any_mcap = false;
      layout.files = db3_files_in(folder, any_mcap);
    }
    if (layout.files.empty())
      throw InputError(where + ": lists no storage files and none are beside it");
  } catch (const YAML::Exception& e) {
    throw InputError(where + ": line " + std::to_string(e.mark.line + 1) +
                     ": not a readable rosbag2 metadata.yaml (" + e.msg + ")");
  }
  return layout;
}

}  // namespace

const char* compression_name(Ros2Compression c) {
  switch (c) {
    case Ros2Compression::zstd_file:
      return "zstd (file)";
    case Ros2Compression::zstd_message:
      return "zstd (message)";
    case Ros2Compression::none:
      break;
  }
  return "none";
}

Ros2BagLayout find_ros2_bag(const std::string& path) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (!fs::exists(st))
    throw InputError(path +
                     ": no such file or folder (a ROS 2 bag is a folder with "
                     "metadata.yaml and .db3 files)");
  if (fs::is_directory(st)) {
    const fs::path yaml = fs::path(path) / "metadata.yaml";
    if (is_file(yaml)) return read_metadata(yaml);
    bool any_mcap = false;
    Ros2BagLayout layout;
    layout.files = db3_files_in(path, any_mcap);
    if (layout.files.empty() && any_mcap) mcap_error(path);
    if (layout.files.empty())
      throw InputError(path +
                       ": not a ROS 2 bag: the folder holds neither metadata.yaml nor "
                       ".db3 files");
    // Without metadata.yaml only the files' names tell their compression.
    if (ends_with(layout.files.front(), ".zstd")) layout.compression = Ros2Compression::zstd_file;
    return layout;
  }
  if (ends_with(path, ".yaml")) return read_metadata(path);
  if (ends_with(path, ".mcap")) mcap_error(path);
  if (ends_with(path, ".db3")) {
    // One file of a bag recorded with MESSAGE compression still needs its metadata.yaml's word.
    const fs::path yaml = fs::path(path).parent_path() / "metadata.yaml";
    Ros2Compression c = Ros2Compression::none;
    if (is_file(yaml) && read_metadata(yaml).compression == Ros2Compression::zstd_message)
      c = Ros2Compression::zstd_message;
    return {{path}, c};
  }
  if (ends_with(path, ".db3.zstd")) return {{path}, Ros2Compression::zstd_file};
  throw InputError(path +
                   ": not a ROS 2 bag (expected a folder with metadata.yaml, the "
                   "metadata.yaml or a .db3 file)");
}

}  // namespace potmap::data
