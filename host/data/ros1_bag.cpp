// ROS 1 bags through Debian's librosbag_storage (and the ROS message headers that come with
// it): the library reads the chunked format, its indexes and bz2/lz4 chunks; this file only
// turns its messages into the storage-neutral structs of bag_source.hpp.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <string>

#include "data/bag_source.hpp"
#include "potmap/error.hpp"

#ifdef POTMAP_WITH_ROS1
#include <geometry_msgs/PoseStamped.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <rosbag/view.h>
#include <sensor_msgs/LaserScan.h>
#include <sensor_msgs/MultiEchoLaserScan.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_msgs/TFMessage.h>
#endif

namespace potmap::data {

void check_ros1_bag_framing(const std::string& path);

#ifndef POTMAP_WITH_ROS1

std::unique_ptr<BagSource> open_ros1_bag(const std::string& path) {
  throw InputError(path +
                   ": this potmap was built without ROS 1 bag support (scripts/setup.sh installs "
                   "librosbag-storage-dev, libtf2-dev and the message headers; rebuild after it)");
}

#else

namespace {

double seconds(const ros::Time& t) {
  return t.toSec();
}

// Each chunk header names its compression; the first one, found after the bag's 4 KiB header
// record, tells what a user asks (librosbag exposes only the mode it would write).
std::string first_chunk_compression(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string head(1 << 16, '\0');
  in.read(&head[0], static_cast<std::streamsize>(head.size()));
  head.resize(static_cast<std::size_t>(in.gcount()));
  const std::string key = "compression=";
  const std::size_t at = head.find(key);
  if (at == std::string::npos || at < 4) return "none";
  std::uint32_t len = 0;
  std::memcpy(&len, head.data() + at - 4, 4);
  if (len <= key.size() || at - 4 + 4 + len > head.size()) return "unknown";
  return head.substr(at + key.size(), len - key.size());
}

void to_transform(const geometry_msgs::TransformStamped& m, bool is_static, TransformMsg& t) {
  t.stamp = seconds(m.header.stamp);
  t.parent = m.header.frame_id;
  t.child = m.child_frame_id;
  t.t = {m.transform.translation.x, m.transform.translation.y, m.transform.translation.z};
  t.q = {m.transform.rotation.x, m.transform.rotation.y, m.transform.rotation.z,
         m.transform.rotation.w};
  t.is_static = is_static;
}

void to_transform(const std_msgs::Header& h, const std::string& child, const geometry_msgs::Pose& p,
                  TransformMsg& t) {
  t.stamp = seconds(h.stamp);
  t.parent = h.frame_id;
  t.child = child;
  t.t = {p.position.x, p.position.y, p.position.z};
  t.q = {p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w};
}

// LaserScan and MultiEchoLaserScan share their header and beam geometry.
template <class Scan>
LaserScanMsg scan_geometry(const Scan& m) {
  LaserScanMsg s;
  s.stamp = seconds(m.header.stamp);
  s.frame_id = m.header.frame_id;
  s.angle_min = m.angle_min;
  s.angle_increment = m.angle_increment;
  s.range_min = m.range_min;
  s.range_max = m.range_max;
  return s;
}

LaserScanMsg to_scan(const sensor_msgs::LaserScan& m) {
  LaserScanMsg s = scan_geometry(m);
  s.ranges = m.ranges;
  return s;
}

LaserScanMsg to_scan(const sensor_msgs::MultiEchoLaserScan& m) {
  LaserScanMsg s = scan_geometry(m);
  s.ranges.reserve(m.ranges.size());
  for (const auto& echo : m.ranges)
    s.ranges.push_back(echo.echoes.empty() ? std::nanf("") : echo.echoes.front());
  return s;
}

CloudMsg to_cloud(const sensor_msgs::PointCloud2& m, bool header_only, const std::string& where) {
  CloudMsg c;
  c.stamp = seconds(m.header.stamp);
  c.frame_id = m.header.frame_id;
  if (header_only) return c;
  PointCloud2View v;
  v.height = m.height;
  v.width = m.width;
  v.point_step = m.point_step;
  v.row_step = m.row_step;
  v.is_bigendian = m.is_bigendian;
  for (const auto& f : m.fields) v.fields.push_back({f.name, f.offset, f.datatype, f.count});
  v.data = m.data.data();
  v.size = m.data.size();
  decode_point_cloud2(v, where, c);
  return c;
}

// A message whose definition differs from the headers' (another MD5) does not instantiate.
template <class T>
boost::shared_ptr<T> message(const rosbag::MessageInstance& m, const std::string& path) {
  boost::shared_ptr<T> p = m.instantiate<T>();
  if (!p)
    throw InputError(path + ": " + m.getTopic() + " at " + std::to_string(m.getTime().toSec()) +
                     " s is a " + m.getDataType() + " of another definition (MD5 " + m.getMD5Sum() +
                     ") than ROS's " + ros::message_traits::md5sum<T>());
  return p;
}

std::string header_frame(const rosbag::MessageInstance& m, const std::string& path) {
  const std::string& type = m.getDataType();
  if (type == "sensor_msgs/LaserScan")
    return message<sensor_msgs::LaserScan>(m, path)->header.frame_id;
  if (type == "sensor_msgs/MultiEchoLaserScan")
    return message<sensor_msgs::MultiEchoLaserScan>(m, path)->header.frame_id;
  if (type == "sensor_msgs/PointCloud2")
    return message<sensor_msgs::PointCloud2>(m, path)->header.frame_id;
  if (type == "nav_msgs/Odometry") return message<nav_msgs::Odometry>(m, path)->header.frame_id;
  if (type == "geometry_msgs/PoseStamped")
    return message<geometry_msgs::PoseStamped>(m, path)->header.frame_id;
  return "";
}

class Ros1Bag final : public BagSource {
 public:
  explicit Ros1Bag(const std::string& path) : path_(path) {
    check_ros1_bag_framing(path);
    try {
      bag_.open(path, rosbag::bagmode::Read);
      index();
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {  // rosbag's, ROS's and boost's exceptions alike
      throw InputError(path + ": not a readable ROS 1 bag: " + e.what());
    }
  }
  const BagInfo& info() const override { return info_; }
  void read(const std::vector<std::string>& topics, const BagHandlers& h) override;
  CloudMsg read_cloud(const std::string& topic, std::uint64_t key) override;

 private:
  void index();
  void hand_over(const rosbag::MessageInstance& m, const BagHandlers& h);
  std::string path_;
  rosbag::Bag bag_;
  BagInfo info_;
};

void Ros1Bag::index() {
  info_.format = "ROS 1 bag";
  info_.compression = first_chunk_compression(path_);
  rosbag::View all(bag_);
  std::map<std::string, BagTopic> topics;
  for (const rosbag::ConnectionInfo* c : all.getConnections()) {
    BagTopic& t = topics[c->topic];
    t.name = c->topic;
    t.type = c->datatype;
  }
  for (auto& [name, t] : topics) {
    rosbag::View one(bag_, rosbag::TopicQuery(name));
    t.count = one.size();
    // The first message with a frame: a topic's messages share one in practice.
    for (const rosbag::MessageInstance& m : one) {
      t.frame_id = header_frame(m, path_);
      break;
    }
    info_.topics.push_back(t);
  }
  if (all.size() > 0) {
    info_.start = seconds(all.getBeginTime());
    info_.end = seconds(all.getEndTime());
  }
}

void Ros1Bag::hand_over(const rosbag::MessageInstance& m, const BagHandlers& h) {
  const std::string& type = m.getDataType();
  const std::string& topic = m.getTopic();
  const std::uint64_t key = m.getTime().toNSec();
  if (type == "sensor_msgs/LaserScan" && h.scan) {
    h.scan(topic, key, to_scan(*message<sensor_msgs::LaserScan>(m, path_)));
  } else if (type == "sensor_msgs/MultiEchoLaserScan" && h.scan) {
    h.scan(topic, key, to_scan(*message<sensor_msgs::MultiEchoLaserScan>(m, path_)));
  } else if (type == "sensor_msgs/PointCloud2" && h.cloud) {
    h.cloud(topic, key,
            to_cloud(*message<sensor_msgs::PointCloud2>(m, path_), h.clouds_header_only,
                     path_ + ": " + topic));
  } else if (type == "tf2_msgs/TFMessage" && h.transform) {
    const bool is_static = topic == "/tf_static" || topic == "tf_static";
    // Held here: a range-for over a temporary's member would outlive the message.
    const auto tf = message<tf2_msgs::TFMessage>(m, path_);
    for (const auto& e : tf->transforms) {
      TransformMsg t;
      to_transform(e, is_static, t);
      h.transform(topic, t);
    }
  } else if (type == "nav_msgs/Odometry" && h.transform) {
    const auto o = message<nav_msgs::Odometry>(m, path_);
    TransformMsg t;
    to_transform(o->header, o->child_frame_id, o->pose.pose, t);
    h.transform(topic, t);
  } else if (type == "geometry_msgs/PoseStamped" && h.transform) {
    const auto p = message<geometry_msgs::PoseStamped>(m, path_);
    TransformMsg t;
    to_transform(p->header, "", p->pose, t);
    h.transform(topic, t);
  }
}

void Ros1Bag::read(const std::vector<std::string>& topics, const BagHandlers& h) {
  try {
    rosbag::View view(bag_, rosbag::TopicQuery(topics));
    for (const rosbag::MessageInstance& m : view) hand_over(m, h);
  } catch (const rosbag::BagException& e) {
    throw InputError(path_ + ": " + e.what());
  } catch (const ros::Exception& e) {
    throw InputError(path_ + ": a message does not decode: " + e.what());
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(path_ + ": " + e.what());
  }
}

CloudMsg Ros1Bag::read_cloud(const std::string& topic, std::uint64_t key) {
  ros::Time t;
  t.fromNSec(key);
  try {
    rosbag::View view(bag_, rosbag::TopicQuery(topic), t, t);
    for (const rosbag::MessageInstance& m : view) {
      const auto c = message<sensor_msgs::PointCloud2>(m, path_);
      return to_cloud(*c, false, path_ + ": " + topic);
    }
  } catch (const rosbag::BagException& e) {
    throw InputError(path_ + ": " + e.what());
  } catch (const ros::Exception& e) {
    throw InputError(path_ + ": " + topic + " at " + std::to_string(t.toSec()) +
                     " s does not decode: " + e.what());
  }
  throw InputError(path_ + ": no PointCloud2 on " + topic + " at " + std::to_string(t.toSec()) +
                   " s");
}

}  // namespace

std::unique_ptr<BagSource> open_ros1_bag(const std::string& path) {
  return std::make_unique<Ros1Bag>(path);
}

#endif

}  // namespace potmap::data
