// Sensor poses from /tf through tf2's BufferCore (the chain and its interpolation are tf2's
// job, done as ROS does it), or from a pose topic interpolated here (one pose, no chain).
#include "data/bag_poses.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "potmap/error.hpp"

#ifdef POTMAP_WITH_ROS1
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#endif

namespace potmap::data {

namespace {

// How long a message waits for the transforms after its stamp before it is given up: longer
// than any tf publisher's gap in a healthy recording, short enough that a missing link does
// not hold the whole bag in memory.
constexpr double kPatience = 30;

std::string strip_slash(const std::string& f) {
  return !f.empty() && f.front() == '/' ? f.substr(1) : f;
}

Eigen::Isometry3d to_isometry(const std::array<double, 3>& t, const Eigen::Quaterniond& q) {
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.linear() = q.toRotationMatrix();
  m.translation() = Eigen::Vector3d(t[0], t[1], t[2]);
  return m;
}

Eigen::Quaterniond unit_rotation(const TransformMsg& t, const std::string& topic) {
  Eigen::Quaterniond q(t.q[3], t.q[0], t.q[1], t.q[2]);
  const double n = q.norm();
  if (!(n > 0.5 && n < 1.5) || !std::isfinite(n))
    throw InputError(topic + ": the transform " + t.parent + " -> " + t.child + " at " +
                     std::to_string(t.stamp) + " s has a rotation quaternion of norm " +
                     std::to_string(n) + ", not a rotation");
  q.normalize();
  return q;
}

}  // namespace

#ifdef POTMAP_WITH_ROS1

struct BagPoses::Tf {
  // A cache longer than the patience, so that a waiting message's transforms are still held.
  tf2::BufferCore buffer{ros::Duration(2 * kPatience)};
  std::map<std::string, double> last;  ///< child -> newest stamp fed (tf2 drops repeats loudly)
  std::set<std::string> frames;
};

BagPoses::BagPoses(std::string fixed_frame, std::string pose_topic)
    : tf_(std::make_unique<Tf>()),
      asked_fixed_(strip_slash(fixed_frame)),
      pose_topic_(std::move(pose_topic)) {}

BagPoses::~BagPoses() = default;

void BagPoses::add(const std::string& topic, const TransformMsg& t) {
  const Eigen::Quaterniond q = unit_rotation(t, topic);
  if (!pose_topic_.empty() && topic == pose_topic_) {
    sample_child_ = strip_slash(t.child);
    if (samples_.empty() || t.stamp > samples_.back().stamp)
      samples_.push_back({t.stamp, to_isometry(t.t, q)});
    if (!t.parent.empty()) fixed_ = strip_slash(t.parent);
    latest_ = std::max(latest_, t.stamp);
    return;
  }
  const std::string parent = strip_slash(t.parent), child = strip_slash(t.child);
  tf_->frames.insert(parent);
  tf_->frames.insert(child);
  if (!t.is_static) {
    auto it = tf_->last.find(child);
    if (it != tf_->last.end() && t.stamp <= it->second) return;
    tf_->last[child] = t.stamp;
    latest_ = std::max(latest_, t.stamp);
  }
  geometry_msgs::TransformStamped m;
  m.header.stamp = ros::Time().fromSec(std::max(t.stamp, 0.0));
  m.header.frame_id = parent;
  m.child_frame_id = child;
  m.transform.translation.x = t.t[0];
  m.transform.translation.y = t.t[1];
  m.transform.translation.z = t.t[2];
  m.transform.rotation.x = q.x();
  m.transform.rotation.y = q.y();
  m.transform.rotation.z = q.z();
  m.transform.rotation.w = q.w();
  tf_->buffer.setTransform(m, "bag", t.is_static);
}

std::vector<std::string> BagPoses::frames() const {
  std::vector<std::string> out(tf_->frames.begin(), tf_->frames.end());
  if (!sample_child_.empty()) out.push_back(sample_child_);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

bool BagPoses::answer_from_topic(const PoseQuery& q, bool at_end, const Found& found,
                                 const Lost& lost) {
  // A pose after the stamp, not only at it: by then the bag has also handed over whatever it
  // recorded at the stamp, /tf_static's sensor offset among it.
  const bool after = !samples_.empty() && samples_.back().stamp > q.stamp;
  if (!after && !at_end && latest_ - q.stamp < kPatience) return false;
  if (samples_.empty() || samples_.back().stamp < q.stamp) {
    lost(q, "no pose on " + pose_topic_ + " after the message's stamp");
    return true;
  }
  auto hi = std::lower_bound(samples_.begin(), samples_.end(), q.stamp,
                             [](const Sample& s, double t) { return s.stamp < t; });
  if (hi == samples_.begin() && hi->stamp > q.stamp) {
    lost(q, "before the first pose on " + pose_topic_);
    return true;
  }
  Eigen::Isometry3d pose = hi->pose;
  if (hi->stamp > q.stamp) {
    const Sample& lo = *(hi - 1);
    const double w = (q.stamp - lo.stamp) / (hi->stamp - lo.stamp);
    const Eigen::Quaterniond a(lo.pose.linear()), b(hi->pose.linear());
    pose.linear() = a.slerp(w, b).toRotationMatrix();
    pose.translation() = (1 - w) * lo.pose.translation() + w * hi->pose.translation();
  }
  // The sensor's offset from the tracked frame, when /tf_static links them.
  const std::string frame = strip_slash(q.frame);
  if (!sample_child_.empty() && sample_child_ != frame &&
      tf_->buffer.canTransform(sample_child_, frame, ros::Time(0))) {
    const auto m = tf_->buffer.lookupTransform(sample_child_, frame, ros::Time(0));
    const auto& r = m.transform.rotation;
    const auto& t = m.transform.translation;
    pose = pose * to_isometry({t.x, t.y, t.z}, Eigen::Quaterniond(r.w, r.x, r.y, r.z));
  }
  found(q, pose);
  return true;
}

bool BagPoses::answer(const PoseQuery& q, bool at_end, const Found& found, const Lost& lost) {
  if (!pose_topic_.empty()) return answer_from_topic(q, at_end, found, lost);
  const std::string frame = strip_slash(q.frame);
  const ros::Time stamp = ros::Time().fromSec(std::max(q.stamp, 0.0));
  if (fixed_.empty()) {
    // REP 105: `map` is the world-fixed frame when a localiser publishes it; else `odom`.
    const std::vector<std::string> tries = asked_fixed_.empty()
                                               ? std::vector<std::string>{"map", "odom"}
                                               : std::vector<std::string>{asked_fixed_};
    for (const std::string& f : tries)
      if (tf_->frames.count(f) && tf_->buffer.canTransform(f, frame, stamp)) {
        fixed_ = f;
        break;
      }
    if (fixed_.empty()) {
      if (!at_end && latest_ - q.stamp < kPatience) return false;
      lost(q, "/tf links none of " + tries.front() + (tries.size() > 1 ? " or " + tries[1] : "") +
                  " to " + frame);
      return true;
    }
  }
  std::string why;
  if (tf_->buffer.canTransform(fixed_, frame, stamp, &why)) {
    const auto m = tf_->buffer.lookupTransform(fixed_, frame, stamp);
    const auto& r = m.transform.rotation;
    const auto& t = m.transform.translation;
    found(q, to_isometry({t.x, t.y, t.z}, Eigen::Quaterniond(r.w, r.x, r.y, r.z)));
    return true;
  }
  if (!at_end && latest_ - q.stamp < kPatience) return false;
  lost(q, why.empty() ? "/tf has no chain " + fixed_ + " -> " + frame : why);
  return true;
}

void BagPoses::settle(bool at_end, const Found& found, const Lost& lost) {
  while (!pending_.empty()) {
    if (!answer(pending_.front(), at_end, found, lost)) break;
    pending_.pop_front();
  }
}

#else

struct BagPoses::Tf {};
BagPoses::BagPoses(std::string, std::string) {
  throw InputError("this potmap was built without tf2 (scripts/setup.sh installs libtf2-dev)");
}
BagPoses::~BagPoses() = default;
void BagPoses::add(const std::string&, const TransformMsg&) {}
std::vector<std::string> BagPoses::frames() const {
  return {};
}
void BagPoses::settle(bool, const Found&, const Lost&) {}
bool BagPoses::answer(const PoseQuery&, bool, const Found&, const Lost&) {
  return false;
}
bool BagPoses::answer_from_topic(const PoseQuery&, bool, const Found&, const Lost&) {
  return false;
}

#endif

}  // namespace potmap::data
