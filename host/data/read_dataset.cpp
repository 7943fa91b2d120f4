// Picks a reader by file name.
#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "data/file_bytes.hpp"
#include "potmap/data/bag.hpp"
#include "potmap/data/drive.hpp"
#include "potmap/data/labelled_points.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"

namespace potmap {

Dataset read_velodyne_dataset(const std::string& path, std::size_t fields, double max_range);
Dataset read_carmen_log(const std::string& path, double flaser_max_range, double flaser_fov,
                        const std::string& hint);

namespace {
bool ends_with(const std::string& s, const std::string& e) {
  return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
}
}  // namespace

Dataset read_dataset(const std::string& path, const BagOptions& bag) {
  if (is_bag(path)) return read_bag(path, bag);
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    // A drive (SLAM keyframes or a KITTI sequence in the benchmark's layout).
    if (is_drive(path)) return read_drive(open_drive(path));
    // A folder in KITTI odometry layout (as `potmap data simulate --3d` writes it) is its
    // sequence; any other folder is refused by name rather than read as an empty log.
    const std::filesystem::path poses = std::filesystem::path(path) / "poses.txt";
    if (std::filesystem::exists(poses, ec)) return read_dataset(poses.string());
    throw InputError(path +
                     ": not a dataset folder (a SLAM keyframe folder holds Scans/NNNNNN.pcd and "
                     "odom_poses.txt; a KITTI sequence velodyne/NNNNNN.bin, calib.txt and its "
                     "poses; a point-cloud sequence folder a poses.txt naming its .pcd or .ply "
                     "frames)");
  }
  std::string lower = path;
  std::transform(lower.begin(), lower.end(), lower.begin(), ::tolower);
  std::string base = lower;
  if (ends_with(base, ".gz")) base.resize(base.size() - 3);
  if (ends_with(base, ".bin")) {
    const bool nus = lower.find("nuscenes") != std::string::npos;
    return read_velodyne_dataset(path, nus ? 5 : 4, nus ? 110 : 120);
  }
  if (ends_with(base, ".pcd") || ends_with(base, ".ply")) {
    Dataset ds;
    ds.scans.push_back(read_point_cloud(path, 120, &ds.stats.points_dropped));
    return ds;
  }
  // A poses file naming .pcd/.ply frames; KITTI's poses.txt holds numbers only.
  if (ends_with(base, ".txt") && is_point_cloud_poses(path)) return read_point_cloud_sequence(path);
  if (ends_with(base, "poses.txt")) {
    // A KITTI odometry sequence: velodyne/NNNNNN.bin frames beside poses.txt and calib.txt.
    const std::filesystem::path dir = std::filesystem::path(path).parent_path();
    const auto poses = read_kitti_poses(path, (dir / "calib.txt").string());
    Dataset ds;
    ds.scans.reserve(poses.size());
    for (std::size_t i = 0; i < poses.size(); ++i) {
      char name[32];
      std::snprintf(name, sizeof name, "%06zu.bin", i);
      const std::filesystem::path frame = dir / "velodyne" / name;
      const std::string where = path + ": line " + std::to_string(i + 1);
      if (!data::file_exists(frame.string(), where))
        throw InputError(where + " has no frame " + frame.string());
      Scan scan = read_kitti_bin(frame.string());
      apply_pose(scan, poses[i]);
      scan.timestamp = static_cast<double>(i);
      ds.scans.push_back(std::move(scan));
    }
    return ds;
  }
  if (ends_with(base, ".npz")) {
    LabelledPoints lp = read_npz_labelled(path);
    Dataset ds;
    ds.scans = scans_from_labelled(lp);
    return ds;
  }
  if (ends_with(base, ".csv")) {
    Dataset ds;
    ds.scans = scans_from_labelled(read_labelled_csv(path));
    return ds;
  }
  if (ends_with(base, ".log") || ends_with(base, ".clf")) return read_carmen(path);
  // Any other name is tried as a CARMEN log; when it holds no laser line, say what the other
  // extensions would have read.
  return read_carmen_log(
      path, 0, 3.14159265358979323846,
      "; by extension read_dataset reads .log and .clf (CARMEN), .bin (KITTI or nuScenes "
      "frames), .pcd and .ply (point clouds), poses.txt (KITTI sequence), a .txt naming .pcd/.ply "
      "frames (point-cloud sequence), .npz and .csv (labelled samples), each also gzipped, "
      ".bag (ROS 1), ROS 2 bag folders and dataset folders");
}

}  // namespace potmap
