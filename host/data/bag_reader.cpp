// A bag's chosen topic as scans (2D) or keyframes (3D), whichever storage holds it: the topic is
// picked, the poses found while the bag streams by (bag_poses.cpp), and each message turned
// into a Scan in the fixed frame.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>

#include "data/bag_poses.hpp"
#include "data/bag_source.hpp"
#include "potmap/data/bag.hpp"
#include "potmap/error.hpp"

namespace potmap {

namespace fs = std::filesystem;

/// An open bag behind a Drive of layout "rosbag": its keyframes' storage keys.
struct BagFile {
  std::mutex lock;  ///< read_keyframe may be called from a prefetching thread
  std::unique_ptr<data::BagSource> source;
  std::string topic;
  std::vector<std::uint64_t> keys;
};

namespace {

bool has_suffix(const std::string& s, const std::string& e) {
  return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
}

bool starts_with_rosbag_magic(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char head[13] = {};
  in.read(head, 13);
  return in.gcount() == 13 && std::string(head, 13) == "#ROSBAG V2.0\n";
}

bool is_ros2_bag(const fs::path& p) {
  std::error_code ec;
  if (fs::is_directory(p, ec)) return fs::exists(p / "metadata.yaml", ec);
  const std::string name = p.filename().string();
  return name == "metadata.yaml" || has_suffix(name, ".db3") || has_suffix(name, ".db3.zstd");
}

std::unique_ptr<data::BagSource> open_source(const std::string& path) {
  if (is_ros2_bag(path)) return data::open_ros2_bag(path);
  return data::open_ros1_bag(path);
}

bool is_laser(const std::string& type) {
  return type == "sensor_msgs/LaserScan" || type == "sensor_msgs/MultiEchoLaserScan";
}
bool is_sensor(const std::string& type) {
  return is_laser(type) || type == "sensor_msgs/PointCloud2";
}
bool is_pose(const std::string& type) {
  return type == "nav_msgs/Odometry" || type == "geometry_msgs/PoseStamped";
}

std::string topic_list(const data::BagInfo& info) {
  std::string s;
  for (const auto& t : info.topics) s += (s.empty() ? "" : ", ") + t.name + " (" + t.type + ")";
  return s.empty() ? "no topics" : s;
}

const data::BagTopic& choose_topic(const data::BagInfo& info, const BagOptions& o,
                                   const std::string& path) {
  const data::BagTopic* best = nullptr;
  for (const auto& t : info.topics) {
    if (!o.topic.empty()) {
      if (t.name != o.topic) continue;
      if (!is_sensor(t.type))
        throw InputError(path + ": topic " + o.topic + " is " + t.type +
                         "; potmap maps sensor_msgs/LaserScan, MultiEchoLaserScan or PointCloud2");
      return t;
    }
    if (is_sensor(t.type) && (!best || t.count > best->count)) best = &t;
  }
  if (!o.topic.empty())
    throw InputError(path + ": no topic " + o.topic + " (the bag holds " + topic_list(info) + ")");
  if (!best)
    throw InputError(path + ": no sensor_msgs/LaserScan, MultiEchoLaserScan or PointCloud2 topic " +
                     "to map (the bag holds " + topic_list(info) + ")");
  if (!o.pose_topic.empty()) {
    const auto it = std::find_if(info.topics.begin(), info.topics.end(),
                                 [&](const data::BagTopic& t) { return t.name == o.pose_topic; });
    if (it == info.topics.end() || !is_pose(it->type))
      throw InputError(path + ": pose topic " + o.pose_topic +
                       (it == info.topics.end() ? " is not in the bag" : " is " + it->type) +
                       "; poses come from nav_msgs/Odometry or geometry_msgs/PoseStamped");
  }
  return *best;
}

std::vector<std::string> topics_to_read(const std::string& sensor, const BagOptions& o,
                                        const data::BagInfo& info) {
  std::vector<std::string> topics{sensor};
  for (const auto& t : info.topics) {
    const bool tf = t.type == "tf2_msgs/TFMessage";
    const bool is_static = t.name == "/tf_static" || t.name == "tf_static";
    // With a pose topic, /tf's dynamic links would give the same edge a second source.
    if (tf && (o.pose_topic.empty() || is_static)) topics.push_back(t.name);
  }
  if (!o.pose_topic.empty()) topics.push_back(o.pose_topic);
  return topics;
}

std::array<double, 12> to_rows(const Eigen::Isometry3d& m) {
  std::array<double, 12> r{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r[i * 4 + j] = m.linear()(i, j);
    r[i * 4 + 3] = m.translation()(i);
  }
  return r;
}

// A laser scan in the fixed frame, every beam through the full 3D pose and then onto the
// plane, so a laser mounted upside down or tilted slightly still lands its beams right.
Scan laser_to_scan(const data::LaserScanMsg& m, const Eigen::Isometry3d& pose, double max_range,
                   std::size_t& dropped) {
  Scan s;
  s.dim = 2;
  s.timestamp = m.stamp;
  s.max_range = max_range > 0 ? max_range : m.range_max;
  const Eigen::Vector3d o = pose.translation();
  const Eigen::Vector3d x = pose.linear().col(0);
  s.pose2d = {o.x(), o.y(), std::atan2(x.y(), x.x())};
  for (std::size_t k = 0; k < m.ranges.size(); ++k) {
    const double r = m.ranges[k];
    const double a = m.angle_min + m.angle_increment * static_cast<double>(k);
    const Eigen::Vector3d d = pose.linear() * Eigen::Vector3d(std::cos(a), std::sin(a), 0);
    if (std::isnan(r) || r < m.range_min) {
      ++dropped;
      continue;
    }
    if (r >= s.max_range) {  // +Inf included: REP 117's "nothing within range"
      const double n = std::hypot(d.x(), d.y());
      if (n < 1e-9) continue;
      s.no_return.push_back(d.x() / n);
      s.no_return.push_back(d.y() / n);
    } else {
      s.hits.push_back(o.x() + r * d.x());
      s.hits.push_back(o.y() + r * d.y());
    }
  }
  return s;
}

double rotation_angle(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle();
}

struct Posed {
  std::uint64_t key;
  double stamp;
  Eigen::Isometry3d pose;
};

struct Walk {
  std::vector<Posed> clouds;
  Dataset scans;
  std::string fixed_frame;
  std::vector<std::string> frames;
  std::string first_loss;
};

// One pass over the bag: the sensor topic's messages, each given its pose as soon as the
// transforms after its stamp are in. Clouds are only indexed (keyframes are read later).
Walk walk_bag(data::BagSource& src, const std::string& path, const data::BagTopic& topic,
              const BagOptions& o) {
  Walk w;
  data::BagPoses poses(o.fixed_frame, o.pose_topic);
  std::map<std::size_t, data::LaserScanMsg> lasers;
  std::map<std::size_t, std::uint64_t> keys;
  std::size_t next = 0;
  const auto found = [&](const data::PoseQuery& q, const Eigen::Isometry3d& pose) {
    auto it = lasers.find(q.id);
    if (it != lasers.end()) {
      w.scans.scans.push_back(
          laser_to_scan(it->second, pose, o.max_range, w.scans.stats.points_dropped));
      lasers.erase(it);
    } else {
      w.clouds.push_back({keys.at(q.id), q.stamp, pose});
      keys.erase(q.id);
    }
  };
  const auto lost = [&](const data::PoseQuery& q, const std::string& why) {
    if (w.first_loss.empty())
      w.first_loss = "the message at " + std::to_string(q.stamp) + " s: " + why;
    ++w.scans.stats.lines_skipped;
    lasers.erase(q.id);
    keys.erase(q.id);
  };
  data::BagHandlers h;
  h.clouds_header_only = true;
  h.scan = [&](const std::string&, std::uint64_t, const data::LaserScanMsg& m) {
    lasers.emplace(next, m);
    poses.wait({next++, m.stamp, m.frame_id});
    poses.settle(false, found, lost);
  };
  h.cloud = [&](const std::string&, std::uint64_t key, const data::CloudMsg& m) {
    keys.emplace(next, key);
    poses.wait({next++, m.stamp, m.frame_id});
    poses.settle(false, found, lost);
  };
  h.transform = [&](const std::string& t, const data::TransformMsg& m) {
    poses.add(t, m);
    poses.settle(false, found, lost);
  };
  src.read(topics_to_read(topic.name, o, src.info()), h);
  poses.settle(true, found, lost);
  w.fixed_frame = poses.fixed_frame();
  w.frames = poses.frames();
  if (w.scans.scans.empty() && w.clouds.empty()) {
    std::string frames;
    for (const auto& f : w.frames) frames += (frames.empty() ? "" : ", ") + f;
    throw InputError(path + ": no message on " + topic.name + " has a pose (" +
                     (w.first_loss.empty() ? "the topic is empty" : w.first_loss) +
                     "; /tf's frames: " + (frames.empty() ? "none" : frames) +
                     "); --fixed-frame or --pose-topic choose another source");
  }
  return w;
}

std::vector<std::size_t> keyframes(const std::vector<Posed>& clouds, const BagOptions& o) {
  std::vector<std::size_t> keep;
  for (std::size_t i = 0; i < clouds.size(); ++i) {
    if (!keep.empty()) {
      const Posed& last = clouds[keep.back()];
      const double moved = (clouds[i].pose.translation() - last.pose.translation()).norm();
      const double turned = rotation_angle(last.pose, clouds[i].pose);
      if (moved < o.keyframe_distance && turned < o.keyframe_angle) continue;
    }
    keep.push_back(i);
  }
  return keep;
}

void check_options(const BagOptions& o) {
  if (!(o.max_range >= 0) || !std::isfinite(o.max_range))
    throw ArgumentError("bag: max range must be 0 (automatic) or positive, got " +
                        std::to_string(o.max_range));
  if (!(o.keyframe_distance >= 0) || !(o.keyframe_angle >= 0))
    throw ArgumentError("bag: keyframe distance and angle must be 0 or positive");
}

}  // namespace

bool is_bag(const std::string& path) {
  const fs::path p(path);
  if (is_ros2_bag(p)) return true;
  std::error_code ec;
  return fs::is_regular_file(p, ec) && (has_suffix(path, ".bag") || starts_with_rosbag_magic(path));
}

BagSummary summarise_bag(const std::string& path, const BagOptions& options) {
  check_options(options);
  const auto src = open_source(path);
  const data::BagInfo& info = src->info();
  BagSummary s;
  s.format = info.format;
  s.compression = info.compression;
  s.start = info.start;
  s.duration = info.end - info.start;
  std::vector<std::string> frames;
  for (const auto& t : info.topics) {
    s.topics.push_back({t.name, t.type, t.count, t.frame_id});
    if (!t.frame_id.empty()) frames.push_back(t.frame_id);
  }
  const data::BagTopic& chosen = choose_topic(info, options, path);
  s.topic = chosen.name;
  s.type = chosen.type;
  s.dim = is_laser(chosen.type) ? 2 : 3;
  s.pose_source = options.pose_topic.empty() ? "/tf" : options.pose_topic;
  s.frames = frames;
  std::sort(s.frames.begin(), s.frames.end());
  s.frames.erase(std::unique(s.frames.begin(), s.frames.end()), s.frames.end());
  return s;
}

namespace {

// A cloud topic's keyframes over an open bag (read_bag's own, so a bag is opened, and its
// framing checked, once).
Drive bag_drive(std::unique_ptr<data::BagSource> source, const std::string& path,
                const BagOptions& options) {
  auto file = std::make_shared<BagFile>();
  file->source = std::move(source);
  const data::BagTopic& topic = choose_topic(file->source->info(), options, path);
  if (is_laser(topic.type))
    throw InputError(path + ": " + topic.name + " holds 2D laser scans (" + topic.type +
                     "), not a drive's point clouds");
  const Walk w = walk_bag(*file->source, path, topic, options);
  Drive d;
  d.path = path;
  d.layout = "rosbag";
  d.poses_file = (options.pose_topic.empty() ? "/tf (" + w.fixed_frame + ")" : options.pose_topic);
  d.max_range = options.max_range > 0 ? options.max_range : 120;
  d.has_times = true;
  file->topic = topic.name;
  for (std::size_t i : keyframes(w.clouds, options)) {
    const Posed& c = w.clouds[i];
    d.frames.push_back(topic.name + " @ " + std::to_string(c.stamp) + " s");
    d.poses.push_back(to_rows(c.pose));
    d.times.push_back(c.stamp);
    file->keys.push_back(c.key);
  }
  d.bag = std::move(file);
  return d;
}

}  // namespace

Drive open_bag_drive(const std::string& path, const BagOptions& options) {
  check_options(options);
  return bag_drive(open_source(path), path, options);
}

Dataset read_bag(const std::string& path, const BagOptions& options) {
  check_options(options);
  auto src = open_source(path);
  const data::BagTopic& topic = choose_topic(src->info(), options, path);
  if (!is_laser(topic.type)) return read_drive(bag_drive(std::move(src), path, options));
  Walk w = walk_bag(*src, path, topic, options);
  return std::move(w.scans);
}

Scan read_bag_keyframe(const Drive& drive, std::size_t i, std::size_t* dropped) {
  BagFile& f = *drive.bag;
  data::CloudMsg c;
  {
    std::lock_guard<std::mutex> hold(f.lock);
    c = f.source->read_cloud(f.topic, f.keys.at(i));
  }
  Scan s;
  s.dim = 3;
  s.hits.assign(c.xyz.begin(), c.xyz.end());
  if (dropped) *dropped = c.dropped;
  return s;
}

}  // namespace potmap
