#pragma once
// Sensor poses for a bag's messages, found while the bag streams by: each message waits until
// the transforms after its stamp have arrived (interpolation needs both sides), then its pose is
// looked up, so only a few seconds of /tf are ever held, however long the drive.

#include <Eigen/Geometry>
#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "data/bag_source.hpp"

namespace potmap::data {

struct PoseQuery {
  std::size_t id = 0;  ///< the caller's
  double stamp = 0;    ///< seconds
  std::string frame;   ///< the message's frame_id
};

class BagPoses {
 public:
  /// fixed_frame "": map when linked at the first message, else odom. pose_topic "": /tf.
  BagPoses(std::string fixed_frame, std::string pose_topic);
  ~BagPoses();
  /// Feed every transform the bag holds on /tf, /tf_static and the pose topic, in bag order.
  void add(const std::string& topic, const TransformMsg& t);
  void wait(PoseQuery q) { pending_.push_back(std::move(q)); }
  using Found = std::function<void(const PoseQuery&, const Eigen::Isometry3d& sensor_to_fixed)>;
  using Lost = std::function<void(const PoseQuery&, const std::string& why)>;
  /// Answers the waiting queries that can be answered now; at_end: all of them.
  void settle(bool at_end, const Found& found, const Lost& lost);
  /// The fixed frame chosen ("" until the first answer).
  const std::string& fixed_frame() const { return fixed_; }
  /// The frames seen so far, sorted (for errors and `data info`).
  std::vector<std::string> frames() const;

 private:
  bool answer(const PoseQuery& q, bool at_end, const Found& found, const Lost& lost);
  bool answer_from_topic(const PoseQuery& q, bool at_end, const Found& found, const Lost& lost);
  struct Tf;
  std::unique_ptr<Tf> tf_;
  std::string fixed_, asked_fixed_, pose_topic_;
  std::deque<PoseQuery> pending_;
  double latest_ = -1e300;  ///< the newest stamp fed (seconds)
  struct Sample {
    double stamp;
    Eigen::Isometry3d pose;
  };
  std::vector<Sample> samples_;  ///< the pose topic's, in stamp order
  std::string sample_child_;     ///< the pose topic's child frame ("" for PoseStamped)
};

}  // namespace potmap::data
