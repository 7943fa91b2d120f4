// 3D drives: SLAM keyframe folders and KITTI odometry sequences, indexed, read a keyframe at a
// time.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "data/file_bytes.hpp"
#include "potmap/data/bag.hpp"
#include "potmap/data/drive.hpp"
#include "potmap/error.hpp"

namespace potmap {

Scan read_bag_keyframe(const Drive& drive, std::size_t i, std::size_t* dropped);

namespace fs = std::filesystem;

namespace {

bool path_exists(const fs::path& p) {
  std::error_code ec;
  return fs::exists(p, ec);
}

bool folder_exists(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), ::tolower);
  return s;
}

// Files of `dir` whose lower-case extension is `ext`, sorted by name (zero-padded indices).
std::vector<std::string> files_with(const fs::path& dir, const std::string& ext) {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file(ec) && lower(e.path().extension().string()) == ext)
      out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

// A pose's rotation must be one: a wrong column order or a scale in a hand-made file would
// otherwise bend every keyframe silently.
void check_rotation(const std::array<double, 12>& m, const std::string& where) {
  double worst = 0;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      double dot = 0;
      for (int r = 0; r < 3; ++r) dot += m[r * 4 + a] * m[r * 4 + b];
      worst = std::max(worst, std::abs(dot - (a == b ? 1.0 : 0.0)));
    }
  const double det = m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
                     m[2] * (m[4] * m[9] - m[5] * m[8]);
  if (worst > 1e-3 || det < 0) {
    char buf[160];
    std::snprintf(buf, sizeof buf,
                  ": the 3 x 3 part is not a rotation (R^T R off the identity by %.3g, det %.4g)",
                  worst, det);
    throw InputError(where + buf);
  }
}

std::vector<double> read_times(const std::string& path) {
  std::istringstream in(data::read_file_bytes(path));
  std::vector<double> out;
  std::string text;
  std::size_t line = 0;
  while (std::getline(in, text)) {
    ++line;
    std::istringstream ss(text);
    std::string tok;
    if (!(ss >> tok)) continue;
    char* e = nullptr;
    const double t = std::strtod(tok.c_str(), &e);
    const std::string where = path + ": line " + std::to_string(line);
    if (e == tok.c_str() || *e != '\0' || !std::isfinite(t))
      throw InputError(where + ": bad time: '" + tok + "'");
    if (!out.empty() && t < out.back())
      throw InputError(where + ": time " + tok + " before the previous line's");
    out.push_back(t);
  }
  return out;
}

void check_counts(const Drive& d, const std::string& what, std::size_t rows) {
  if (rows == d.frames.size()) return;
  throw InputError(what + ": line " + std::to_string(std::min(rows, d.frames.size()) + 1) + ": " +
                   std::to_string(rows) + " rows for " + std::to_string(d.frames.size()) +
                   " keyframes (" + (rows < d.frames.size() ? "keyframe " : "row ") +
                   std::to_string(std::min(rows, d.frames.size())) + " has no " +
                   (rows < d.frames.size() ? "row" : "keyframe") + ")");
}

Drive open_slam(const fs::path& dir, const DriveOptions& o) {
  Drive d;
  d.layout = "slam";
  const fs::path odom = dir / "odom_poses.txt", opt = dir / "optimized_poses.txt";
  if (o.poses == "odom")
    d.poses_file = odom.string();
  else if (o.poses == "optimized")
    d.poses_file = opt.string();
  else if (o.poses == "auto")
    d.poses_file = (path_exists(opt) ? opt : odom).string();
  else
    throw ArgumentError("drive poses: '" + o.poses + "' (expected odom, optimized or auto)");
  if (!path_exists(d.poses_file))
    throw InputError(dir.string() + ": no " + fs::path(d.poses_file).filename().string() +
                     " beside Scans/");
  d.frames = files_with(dir / "Scans", ".pcd");
  const auto ply = files_with(dir / "Scans", ".ply");
  d.frames.insert(d.frames.end(), ply.begin(), ply.end());
  std::sort(d.frames.begin(), d.frames.end());
  if (d.frames.empty()) throw InputError((dir / "Scans").string() + ": no .pcd or .ply keyframe");
  d.poses = read_pose_rows(d.poses_file);
  check_counts(d, d.poses_file, d.poses.size());
  return d;
}

// KITTI's own layout keeps poses in dataset/poses/NN.txt, beside dataset/sequences/NN.
fs::path kitti_poses(const fs::path& seq) {
  if (path_exists(seq / "poses.txt")) return seq / "poses.txt";
  const fs::path up =
      seq.parent_path().parent_path() / "poses" / (seq.filename().string() + ".txt");
  return up;
}

Drive open_kitti(const fs::path& seq) {
  Drive d;
  d.layout = "kitti";
  d.poses_file = kitti_poses(seq).string();
  if (!path_exists(d.poses_file))
    throw InputError(seq.string() + ": a KITTI sequence without poses (looked for " +
                     (seq / "poses.txt").string() + " and " + d.poses_file + ")");
  d.frames = files_with(seq / "velodyne", ".bin");
  if (d.frames.empty()) throw InputError((seq / "velodyne").string() + ": no .bin frame");
  d.poses = read_kitti_poses(d.poses_file, (seq / "calib.txt").string());
  // The benchmark's poses may run past the frames a download holds: fewer poses is an error,
  // more are the frames not downloaded.
  if (d.poses.size() > d.frames.size()) d.poses.resize(d.frames.size());
  check_counts(d, d.poses_file, d.poses.size());
  return d;
}

}  // namespace

std::vector<std::array<double, 12>> read_pose_rows(const std::string& path) {
  std::istringstream in(data::read_file_bytes(path));
  std::vector<std::array<double, 12>> out;
  std::string text;
  std::size_t line = 0;
  while (std::getline(in, text)) {
    ++line;
    if (text.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::string where = path + ": line " + std::to_string(line);
    std::istringstream ss(text);
    std::array<double, 12> m{};
    for (int k = 0; k < 12; ++k) {
      std::string tok;
      if (!(ss >> tok))
        throw InputError(where + ": expected 12 numbers (3 x 4 [R | t]), got " + std::to_string(k));
      char* e = nullptr;
      m[k] = std::strtod(tok.c_str(), &e);
      if (e == tok.c_str() || *e != '\0' || !std::isfinite(m[k]))
        throw InputError(where + ": number " + std::to_string(k + 1) + ": bad pose value: '" + tok +
                         "'");
    }
    std::string extra;
    if (ss >> extra) throw InputError(where + ": more than 12 numbers: '" + extra + "'");
    check_rotation(m, where);
    out.push_back(m);
  }
  return out;
}

bool is_drive(const std::string& path, const DriveOptions& options) {
  if (is_bag(path)) return summarise_bag(path, options.bag).dim == 3;
  const fs::path p(path);
  if (!folder_exists(p)) return false;
  if (folder_exists(p / "Scans") &&
      (path_exists(p / "odom_poses.txt") || path_exists(p / "optimized_poses.txt")))
    return true;
  return folder_exists(p / "velodyne") && path_exists(p / "calib.txt") &&
         path_exists(kitti_poses(p));
}

Drive open_drive(const std::string& path, const DriveOptions& options) {
  if (is_bag(path)) {
    BagOptions bag = options.bag;
    if (bag.max_range == 0) bag.max_range = options.max_range;
    return open_bag_drive(path, bag);
  }
  if (!(options.max_range > 0) || !std::isfinite(options.max_range))
    throw ArgumentError("drive: max range must be positive, got " +
                        std::to_string(options.max_range));
  const fs::path p(path);
  Drive d;
  if (folder_exists(p / "Scans"))
    d = open_slam(p, options);
  else if (folder_exists(p / "velodyne"))
    d = open_kitti(p);
  else
    throw InputError(path +
                     ": not a drive folder (a SLAM keyframe folder holds Scans/NNNNNN.pcd and "
                     "odom_poses.txt; a KITTI sequence velodyne/NNNNNN.bin, calib.txt and its "
                     "poses)");
  d.path = path;
  d.max_range = options.max_range;
  const fs::path times = p / "times.txt";
  if (path_exists(times)) {
    d.times = read_times(times.string());
    check_counts(d, times.string(), d.times.size());
    d.has_times = true;
  } else {
    d.times.resize(d.frames.size());
    for (std::size_t i = 0; i < d.times.size(); ++i) d.times[i] = double(i);
  }
  return d;
}

Scan read_keyframe(const Drive& drive, std::size_t i, std::size_t* dropped) {
  if (i >= drive.size())
    throw ArgumentError("keyframe " + std::to_string(i) + " of a drive of " +
                        std::to_string(drive.size()));
  std::size_t drop = 0;
  Scan s = drive.layout == "kitti"    ? read_kitti_bin(drive.frames[i], drive.max_range)
           : drive.layout == "rosbag" ? read_bag_keyframe(drive, i, &drop)
                                      : read_point_cloud(drive.frames[i], drive.max_range, &drop);
  s.max_range = drive.max_range;
  apply_pose(s, drive.poses[i]);
  s.timestamp = drive.times[i];
  if (dropped) *dropped = drop;
  return s;
}

Dataset read_drive(const Drive& drive, std::size_t first, std::size_t count) {
  Dataset ds;
  const std::size_t end = count ? std::min(drive.size(), first + count) : drive.size();
  for (std::size_t i = first; i < end; ++i) {
    std::size_t dropped = 0;
    ds.scans.push_back(read_keyframe(drive, i, &dropped));
    ds.stats.points_dropped += dropped;
  }
  return ds;
}

}  // namespace potmap
