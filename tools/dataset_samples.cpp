#include "dataset_samples.hpp"

#include <algorithm>
#include <cctype>

#include "potmap/data/labelled_points.hpp"
#include "potmap/error.hpp"
#include "potmap/experiments/experiment.hpp"

namespace potmap::cli {

void add_label_options(CLI::App* cmd, LabelArgs& a, const std::string& seed_flag) {
  cmd->add_option("--free-per-metre", a.labels.free_per_metre,
                  "Scans: free samples per metre of free beam")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--holdout", a.labels.holdout_fraction,
                  "Scans: fraction of every scan's beams held out of learning")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 0.9));
  cmd->add_option("--range-cut", a.range_cut,
                  "Scans: returns farther than this (metres) become no-returns, free space "
                  "sampled up to it (0: none; the experiments cut real logs at 20)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option(seed_flag, a.labels.seed, "Scans: seed of the free samples and the hold-out")
      ->capture_default_str();
  add_bag_options(cmd, a.bag);
}

void add_bag_options(CLI::App* cmd, BagOptions& o) {
  cmd->add_option("--topic", o.topic,
                  "ROS bags: the LaserScan, MultiEchoLaserScan or PointCloud2 topic to map "
                  "(default: the one with the most messages)");
  cmd->add_option("--fixed-frame", o.fixed_frame,
                  "ROS bags: the frame to map in (default: map when /tf links it to the "
                  "sensor, else odom)");
  cmd->add_option("--pose-topic", o.pose_topic,
                  "ROS bags: a nav_msgs/Odometry or geometry_msgs/PoseStamped topic to take "
                  "poses from instead of /tf");
  cmd->add_option("--keyframe-distance", o.keyframe_distance,
                  "ROS bags of point clouds: metres between keyframes (0 with --keyframe-angle "
                  "0: every sweep)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--keyframe-angle", o.keyframe_angle,
                  "ROS bags of point clouds: radians of turn that also start a keyframe")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
}

namespace {

bool ends_with_nocase(const std::string& s, const std::string& end) {
  if (s.size() < end.size()) return false;
  return std::equal(end.begin(), end.end(), s.end() - static_cast<long>(end.size()),
                    [](char a, char b) {
                      return std::tolower(static_cast<unsigned char>(a)) ==
                             std::tolower(static_cast<unsigned char>(b));
                    });
}

}  // namespace

bool is_labelled_file(const std::string& path) {
  return ends_with_nocase(path, ".csv") || ends_with_nocase(path, ".npz");
}

std::vector<Scan> read_scans(const std::string& path, double range_cut, const BagOptions& bag) {
  Dataset ds = read_dataset(path, bag);
  if (ds.scans.empty()) throw InputError(path + ": no scans");
  if (range_cut > 0)
    for (Scan& s : ds.scans) s = experiment::limit_range(s, range_cut);
  return std::move(ds.scans);
}

LabelledSplit read_samples(const std::string& path, const LabelArgs& a) {
  LabelledSplit out;
  if (is_labelled_file(path)) {
    out.train = ends_with_nocase(path, ".npz") ? read_npz_labelled(path) : read_labelled_csv(path);
    out.test.dim = out.train.dim;
    return out;
  }
  return label_scans(read_scans(path, a.range_cut, a.bag), a.labels);
}

}  // namespace potmap::cli
