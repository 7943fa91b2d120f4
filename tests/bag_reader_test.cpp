// Bags read as the same data read another way: ROS 1 bags written by ROS's own Python tools
// (tests/data/write_ros1_bag.py) and ROS 2 bags in rosbag2's layout (tests/data/write_ros2_bag.py):
// a CARMEN log's scans through /tf and through an odometry topic, synthetic sweeps through a /tf
// chain with a static sensor mount.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

#include <nlohmann/json.hpp>

#include "potmap/data/bag.hpp"
#include "test_support.hpp"

#ifdef POTMAP_WITH_ROS

namespace potmap::test {
namespace {

std::string write_bag(const std::string& args, const std::string& name) {
  const std::string dir = temp_dir("ros1_bag_" + name.substr(0, name.find('.')));
  const std::string out = dir + "/" + name;
  const std::string cmd = std::string(POTMAP_DEBIAN_PYTHON) + " " +
                          quoted(source_dir() + "/tests/data/write_ros1_bag.py") + " " + args +
                          " " + quoted(out);
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  return out;
}

std::string intel() {
  return shared_data("radish/intel-corrected.log.gz");
}

std::string carmen_bag(std::size_t scans, const std::string& compression) {
  return write_bag("carmen " + quoted(intel()) + " --scans " + std::to_string(scans) +
                       " --compression " + compression,
                   "intel_" + compression + ".bag");
}

// The bag's scans against the log's: stamps, laser poses (the /tf chain odom -> base_link ->
// laser), and every beam's end point or no-return direction.
void expect_same_scans(const Dataset& bag, std::size_t n) {
  ASSERT_EQ(bag.scans.size(), n);
  // FLASER names no maximum range: the log is read with the bag's (the script's choice).
  Dataset log = read_carmen(intel(), bag.scans.front().max_range);
  log.scans.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Scan& a = bag.scans[i];
    const Scan& b = log.scans[i];
    ASSERT_EQ(a.dim, 2);
    EXPECT_NEAR(a.timestamp, b.timestamp, 1e-6) << i;
    for (int k = 0; k < 2; ++k) EXPECT_NEAR(a.pose2d[k], b.pose2d[k], 1e-6) << i;
    // The same heading, as an angle (the log writes it past pi, /tf as a quaternion).
    EXPECT_NEAR(std::remainder(a.pose2d[2] - b.pose2d[2], 2 * kPi), 0, 1e-6) << i;
    ASSERT_EQ(a.hits.size(), b.hits.size()) << i;
    ASSERT_EQ(a.no_return.size(), b.no_return.size()) << i;
    // Ranges and angles travel as float32 in a LaserScan: 1e-4 m at 80 m.
    for (std::size_t k = 0; k < a.hits.size(); ++k) EXPECT_NEAR(a.hits[k], b.hits[k], 1e-4) << i;
    for (std::size_t k = 0; k < a.no_return.size(); ++k)
      EXPECT_NEAR(a.no_return[k], b.no_return[k], 1e-6) << i;
  }
}

TEST(Ros1Bag, LaserScansThroughTfAreTheCarmenLogsScans) {
  const std::size_t n = sized<std::size_t>(120, 20);
  for (const std::string c : {"none", "lz4", "bz2"}) {
    SCOPED_TRACE(c);
    expect_same_scans(read_bag(carmen_bag(n, c)), n);
  }
}

TEST(Ros1Bag, MultiEchoScansAreReadByTheirFirstEcho) {
  const std::size_t n = sized<std::size_t>(60, 10);
  const std::string bag = write_bag(
      "carmen " + quoted(intel()) + " --scans " + std::to_string(n) + " --multi-echo", "multi.bag");
  EXPECT_EQ(summarise_bag(bag).type, "sensor_msgs/MultiEchoLaserScan");
  expect_same_scans(read_bag(bag), n);
}

TEST(Ros2BagScans, LaserScansThroughTfAreTheCarmenLogsScans) {
  const std::size_t n = sized<std::size_t>(120, 20);
  for (const std::string c : {"", "file", "message"}) {
    SCOPED_TRACE(c.empty() ? "uncompressed" : "zstd " + c);
    const std::string dir = temp_dir("ros2_bag_carmen");
    const std::string cmd = std::string(POTMAP_DEBIAN_PYTHON) + " " +
                            quoted(source_dir() + "/tests/data/write_ros2_bag.py") + " " +
                            quoted(dir) + " carmen " + quoted(intel()) + " " + std::to_string(n) +
                            " " + c;
    ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
    EXPECT_EQ(summarise_bag(dir + "/carmen").format, "ROS 2 bag (sqlite3)");
    expect_same_scans(read_bag(dir + "/carmen"), n);
  }
}

TEST(Ros1Bag, AnOdometryTopicGivesTheSamePoses) {
  const std::size_t n = sized<std::size_t>(60, 10);
  BagOptions o;
  o.pose_topic = "/odom";
  expect_same_scans(read_bag(carmen_bag(n, "none"), o), n);
}

TEST(Ros1Bag, SummaryListsTopicsAndPicksTheLaser) {
  const BagSummary s = summarise_bag(carmen_bag(5, "lz4"));
  EXPECT_EQ(s.format, "ROS 1 bag");
  EXPECT_EQ(s.compression, "lz4");
  EXPECT_EQ(s.topic, "/scan");
  EXPECT_EQ(s.type, "sensor_msgs/LaserScan");
  EXPECT_EQ(s.dim, 2);
  ASSERT_EQ(s.topics.size(), 4u);  // /odom /scan /tf /tf_static, in name order
  EXPECT_EQ(s.topics[1].name, "/scan");
  EXPECT_EQ(s.topics[1].count, 5u);
  EXPECT_EQ(s.topics[1].frame_id, "laser");
  EXPECT_EQ(s.topics[2].count, 5u);
  EXPECT_GT(s.duration, 0);
}

// Sweep i's points, sensor frame, as the script makes them (NaN points left out).
std::vector<std::array<double, 3>> sweep(int i) {
  std::vector<std::array<double, 3>> pts;
  for (int k = 0; k < 460; ++k) {
    if (k % 7 == 3) continue;
    if (k < 360) {
      const double a = k * kPi / 180;
      pts.push_back({10 * std::cos(a), 10 * std::sin(a), -1.0 + 0.01 * (k % 50)});
    } else {
      pts.push_back({5.0, -2.5 + 0.05 * (k - 360), 0.1 * i});
    }
  }
  return pts;
}

TEST(Ros1Bag, PointCloudsBecomeKeyframesInTheFixedFrame) {
  const std::string bag = write_bag("clouds --clouds 6 --compression lz4", "clouds.bag");
  DriveOptions o;
  EXPECT_TRUE(is_drive(bag, o));
  const Drive d = open_drive(bag, o);
  EXPECT_EQ(d.layout, "rosbag");
  // 0.5 m a sweep and keyframes 1 m apart: every second sweep.
  ASSERT_EQ(d.size(), 3u);
  for (std::size_t f = 0; f < d.size(); ++f) {
    const int i = static_cast<int>(2 * f);
    const double yaw = 0.05 * i, c = std::cos(yaw), s = std::sin(yaw);
    EXPECT_NEAR(d.times[f], 1000 + 0.1 * i, 1e-6);
    std::size_t dropped = 0;
    const Scan k = read_keyframe(d, f, &dropped);
    EXPECT_EQ(dropped, 66u);  // every 7th of 460 points is NaN
    const auto pts = sweep(i);
    ASSERT_EQ(k.num_hits(), pts.size());
    for (std::size_t p = 0; p < pts.size(); ++p) {
      const double x = 0.5 * i + c * pts[p][0] - s * pts[p][1];
      const double y = s * pts[p][0] + c * pts[p][1];
      const double z = 1.5 + pts[p][2];
      EXPECT_NEAR(k.hits[3 * p], x, 1e-5);
      EXPECT_NEAR(k.hits[3 * p + 1], y, 1e-5);
      EXPECT_NEAR(k.hits[3 * p + 2], z, 1e-5);
    }
    const auto o3 = k.origin();
    EXPECT_NEAR(o3[0], 0.5 * i, 1e-9);
    EXPECT_NEAR(o3[2], 1.5, 1e-9);
  }
  BagOptions every;
  every.keyframe_distance = 0;
  every.keyframe_angle = 0;
  EXPECT_EQ(open_bag_drive(bag, every).size(), 6u);
}

TEST(Ros1Bag, BadChoicesAndBadFilesNameWhatIsWrong) {
  const std::string bag = carmen_bag(5, "none");
  BagOptions o;
  o.topic = "/velodyne_points";
  expect_input_error([&] { read_bag(bag, o); }, {bag, "no topic /velodyne_points", "/scan"});
  o.topic = "/tf";
  expect_input_error([&] { read_bag(bag, o); }, {"/tf is tf2_msgs/TFMessage"});
  o = {};
  o.fixed_frame = "map";
  expect_input_error([&] { read_bag(bag, o); }, {"no message on /scan has a pose", "odom"});
  o = {};
  o.pose_topic = "/scan";
  expect_input_error([&] { read_bag(bag, o); }, {"pose topic /scan is sensor_msgs/LaserScan"});
  expect_input_error([&] { open_bag_drive(bag); }, {"holds 2D laser scans"});
  // A bag cut short: the header survives, the index does not.
  const std::string body = file_bytes(bag);
  const std::string cut = write_file(temp_dir("ros1_bag_cut"), "cut.bag", body.substr(0, 6000));
  expect_input_error([&] { read_bag(cut); }, {cut});
  const std::string junk = write_file(temp_dir("ros1_bag_junk"), "junk.bag", "not a bag at all");
  expect_input_error([&] { read_bag(junk); }, {junk, "#ROSBAG V2.0"});
  // A record header claiming 2 GB: refused before librosbag would allocate it.
  std::string huge = body;
  const char claim[4] = {'\xff', '\xff', '\xff', '\x7f'};
  huge.replace(13, 4, claim, 4);
  const std::string big = write_file(temp_dir("ros1_bag_huge"), "huge.bag", huge);
  expect_input_error([&] { read_bag(big); },
                     {big, "a record header of 2147483647 bytes at byte 13"});
}

nlohmann::json map_with_cli(const std::string& input, const std::string& out, std::size_t scans) {
  ::setenv("XDG_CACHE_HOME", (std::string(POTMAP_BINARY_DIR) + "/user-cache").c_str(), 1);
  const CliResult r = run_cli("mapping " + quoted(input) + " --first 10 --max-scans " +
                                  std::to_string(scans) + " -q -o " + quoted(out) + " --json -",
                              "2>/dev/null");
  EXPECT_EQ(r.status, 0) << r.out;
  return nlohmann::json::parse(r.out);
}

// The whole log in a bag, mapped by the command, and the same scans written back as a CARMEN log
// with the ranges a LaserScan carries (float32): the same held-out samples, the same scores.
TEST(Ros1BagCli, MapsAsTheSameScansReadAsCarmen) {
  if (!cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string dir = temp_dir("ros1_bag_cli");
  const std::string log = dir + "/copy.log";
  const std::string bag =
      write_bag("carmen " + quoted(intel()) + " --carmen-copy " + quoted(log), "whole.bag");
  // 30 scans at every input size: fewer leave so few held-out points that one changed sample
  // moves the NLL past the margin.
  const std::size_t n = 30;
  const nlohmann::json a = map_with_cli(bag, dir + "/bag", n);
  const nlohmann::json b = map_with_cli(log, dir + "/log", n);
  EXPECT_EQ(a["scans"], b["scans"]);
  EXPECT_EQ(a["overall_kernels"], b["overall_kernels"]);
  // Beam angles travel as float32 too, so end points differ by micrometres, and a beam whose
  // length sits on a whole number of free-sample spacings may get one sample more or fewer: the
  // held-out sets differ by a point or two in thousands. The overall map (the joint BHM over
  // every scan) is what the run leaves; measured: 1 point of 6058, AUC 1e-4 and NLL 7e-4 apart.
  // (Each scan's own transported map reacts more to a changed sample: NLL up to 0.011 apart.)
  const nlohmann::json& x = a["overall"];
  const nlohmann::json& y = b["overall"];
  EXPECT_NEAR(x["points"].get<double>(), y["points"].get<double>(),
              1e-3 * y["points"].get<double>());
  EXPECT_NEAR(x["auc"].get<double>(), y["auc"].get<double>(), 1e-3);
  EXPECT_NEAR(x["nll"].get<double>(), y["nll"].get<double>(), 2e-3);
}

// A real drive's keyframes written as PointCloud2 + /tf, mapped by the command as its SLAM
// folder is. The poses pass through quaternions (the folder's rotations are orthonormal to
// 1e-4, tf's exactly), so points move by micrometres; measured on 12 keyframes: the same held-out
// count, AUC 1.5e-6 and NLL 1.6e-6 apart.
TEST(Ros1BagCli, ADriveInABagMapsAsItsSlamFolder) {
  if (!cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string folder = shared_data("drives3d/riverside-a");
  const std::size_t n = sized<std::size_t>(6, 3);
  const std::string bag = write_bag(
      "drive " + quoted(folder) + " --keyframes " + std::to_string(n) + " --compression lz4",
      "drive.bag");
  const std::string dir = temp_dir("ros1_bag_drive_maps");
  ::setenv("XDG_CACHE_HOME", (std::string(POTMAP_BINARY_DIR) + "/user-cache").c_str(), 1);
  nlohmann::json j[2];
  const std::string inputs[2] = {bag, folder};
  for (int k = 0; k < 2; ++k) {
    const CliResult r =
        run_cli("mapping " + quoted(inputs[k]) + " --max-scans " + std::to_string(n) +
                    " --keyframe-distance 0 --keyframe-angle 0 -q -o " +
                    quoted(dir + "/" + std::to_string(k)) + " --json -",
                "2>/dev/null");
    ASSERT_EQ(r.status, 0) << r.out;
    j[k] = nlohmann::json::parse(r.out);
  }
  EXPECT_EQ(j[0]["keyframes"], j[1]["keyframes"]);
  EXPECT_EQ(j[0]["scores"]["n"], j[1]["scores"]["n"]);
  EXPECT_NEAR(j[0]["scores"]["auc"].get<double>(), j[1]["scores"]["auc"].get<double>(), 1e-4);
  EXPECT_NEAR(j[0]["scores"]["nll"].get<double>(), j[1]["scores"]["nll"].get<double>(), 1e-4);
}

TEST(Ros1BagCli, DataInfoListsTopicsAndWhatWouldBeMapped) {
  if (!cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string bag = carmen_bag(8, "bz2");
  CliResult r = run_cli("data info " + quoted(bag));
  ASSERT_EQ(r.status, 0) << r.out;
  for (const char* needle :
       {"ROS 1 bag, compression bz2", "/scan  sensor_msgs/LaserScan  8 messages  frame laser",
        "/odom  nav_msgs/Odometry  8 messages", "mapped topic: /scan", "pose source: /tf",
        "scans: 8"})
    EXPECT_NE(r.out.find(needle), std::string::npos) << needle << " in\n" << r.out;
  const std::string clouds = write_bag("clouds --clouds 6", "info_clouds.bag");
  r = run_cli("data info " + quoted(clouds) + " --keyframe-distance 0 --keyframe-angle 0");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("keyframes: 6"), std::string::npos) << r.out;
  r = run_cli("data info " + quoted(bag) + " --topic /nope");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("no topic /nope"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace potmap::test

#endif
