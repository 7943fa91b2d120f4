// ROS 2 bags written by tests/data/write_ros2_bag.py (Python's sqlite3 and a CDR encoder of its
// own, not potmap's code) read back through open_ros2_bag: every decoded field equals what the
// script wrote, as its expected.json says.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "data/bag_source.hpp"
#include "data/ros2_messages.hpp"
#include "test_support.hpp"

// A namespace of its own: the unity build compiles this file in one batch with others.
namespace potmap::data::ros2_bag_test {
namespace {

using nlohmann::json;

// The bag of `scenario` in a fresh folder; its expected.json beside it (good scenarios).
std::string write_bag(const std::string& scenario) {
  const std::string dir = test::temp_dir("ros2_bag_" + scenario);
  const std::string cmd = "/usr/bin/python3 " +
                          test::quoted(test::source_dir() + "/tests/data/write_ros2_bag.py") + " " +
                          test::quoted(dir) + " " + scenario;
  EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
  return dir;
}

json expected(const std::string& dir, const std::string& scenario) {
  std::ifstream in(dir + "/" + scenario + ".json");
  return json::parse(in);
}

struct Read {
  std::vector<LaserScanMsg> scans;
  std::vector<CloudMsg> clouds;
  std::vector<std::uint64_t> cloud_keys;
  std::vector<TransformMsg> transforms;
  std::vector<std::string> order;  // the topic of each handler call
};

Read read_all(BagSource& bag, const std::vector<std::string>& topics, bool header_only = false) {
  Read r;
  BagHandlers h;
  h.clouds_header_only = header_only;
  h.scan = [&](const std::string& topic, std::uint64_t, const LaserScanMsg& m) {
    r.scans.push_back(m);
    r.order.push_back(topic);
  };
  h.cloud = [&](const std::string& topic, std::uint64_t key, const CloudMsg& m) {
    r.clouds.push_back(m);
    r.cloud_keys.push_back(key);
    r.order.push_back(topic);
  };
  h.transform = [&](const std::string& topic, const TransformMsg& m) {
    r.transforms.push_back(m);
    r.order.push_back(topic);
  };
  bag.read(topics, h);
  return r;
}

std::vector<std::string> all_topics(const BagInfo& info) {
  std::vector<std::string> names;
  for (const BagTopic& t : info.topics) names.push_back(t.name);
  return names;
}

void expect_info(const BagInfo& info, const json& e, const std::string& compression) {
  EXPECT_EQ(info.format, "ROS 2 bag (sqlite3)");
  EXPECT_EQ(info.compression, compression);
  EXPECT_NEAR(info.start, e["start"].get<double>(), 1e-6);
  EXPECT_NEAR(info.end, e["end"].get<double>(), 1e-6);
  ASSERT_EQ(info.topics.size(), e["topics"].size());
  for (std::size_t i = 0; i < info.topics.size(); ++i) {
    const json& t = e["topics"][i];
    EXPECT_EQ(info.topics[i].name, t["name"]);
    EXPECT_EQ(info.topics[i].type, t["type"]);
    EXPECT_EQ(info.topics[i].count, t["count"].get<std::size_t>()) << t["name"];
    EXPECT_EQ(info.topics[i].frame_id, t["frame"]) << t["name"];
  }
}

void expect_scans(const std::vector<LaserScanMsg>& scans, const json& e) {
  ASSERT_EQ(scans.size(), e.size());
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const LaserScanMsg& s = scans[i];
    const json& x = e[i];
    EXPECT_NEAR(s.stamp, x["stamp"].get<double>(), 1e-9) << i;
    EXPECT_EQ(s.frame_id, x["frame"]);
    EXPECT_EQ(s.angle_min, x["angle_min"].get<double>());
    EXPECT_EQ(s.angle_increment, x["angle_increment"].get<double>());
    EXPECT_EQ(s.range_min, x["range_min"].get<double>());
    EXPECT_EQ(s.range_max, x["range_max"].get<double>());
    ASSERT_EQ(s.ranges.size(), x["ranges"].size());
    for (std::size_t k = 0; k < s.ranges.size(); ++k) {
      if (x["ranges"][k].is_null())
        EXPECT_TRUE(std::isnan(s.ranges[k])) << i << " " << k;
      else
        EXPECT_EQ(s.ranges[k], x["ranges"][k].get<float>()) << i << " " << k;
    }
  }
}

void expect_transforms(const std::vector<TransformMsg>& ts, const json& e) {
  ASSERT_EQ(ts.size(), e.size());
  for (std::size_t i = 0; i < ts.size(); ++i) {
    const json& x = e[i];
    EXPECT_NEAR(ts[i].stamp, x["stamp"].get<double>(), 1e-9) << i;
    EXPECT_EQ(ts[i].parent, x["parent"]) << i;
    EXPECT_EQ(ts[i].child, x["child"]) << i;
    EXPECT_EQ(ts[i].is_static, x["static"].get<bool>()) << i;
    for (int k = 0; k < 3; ++k) EXPECT_EQ(ts[i].t[k], x["t"][k].get<double>()) << i;
    for (int k = 0; k < 4; ++k) EXPECT_EQ(ts[i].q[k], x["q"][k].get<double>()) << i;
  }
}

void expect_cloud(const CloudMsg& c, const json& x) {
  EXPECT_NEAR(c.stamp, x["stamp"].get<double>(), 1e-9);
  EXPECT_EQ(c.frame_id, x["frame"]);
  EXPECT_EQ(c.xyz, x["xyz"].get<std::vector<float>>());
  EXPECT_EQ(c.dropped, x["dropped"].get<std::size_t>());
}

// The scan_tf bag's whole content, however it is stored. Returns the bag's parent folder.
std::string expect_scan_tf_bag(const std::string& scenario, const std::string& compression) {
  const std::string dir = write_bag(scenario);
  const json e = expected(dir, scenario);
  const auto bag = open_ros2_bag(e["bag"]);
  expect_info(bag->info(), e, compression);
  const Read r = read_all(*bag, all_topics(bag->info()));
  EXPECT_EQ(r.order, e["order"].get<std::vector<std::string>>());
  expect_scans(r.scans, e["scans"]);
  expect_transforms(r.transforms, e["transforms"]);
  return dir;
}

TEST(Ros2Bag, LaserScanAndTfRoundTripAcrossTwoFiles) {
  expect_scan_tf_bag("scan_tf", "none");
}

TEST(Ros2Bag, OpensByMetadataYamlOrOneDb3File) {
  const std::string dir = write_bag("scan_tf");
  const auto by_yaml = open_ros2_bag(dir + "/scan_tf/metadata.yaml");
  EXPECT_EQ(by_yaml->info().topics.size(), 4u);
  // One file of a split bag alone: its own messages, topics listed by its own table.
  const auto one = open_ros2_bag(dir + "/scan_tf/scan_tf_1.db3");
  const Read r = read_all(*one, {"/scan", "/tf"});
  EXPECT_EQ(r.scans.size(), 2u);
  EXPECT_EQ(r.transforms.size(), 2u);
  // Only the topics asked for.
  const Read only_tf = read_all(*by_yaml, {"/tf_static"});
  EXPECT_TRUE(only_tf.scans.empty());
  ASSERT_EQ(only_tf.transforms.size(), 1u);
  EXPECT_TRUE(only_tf.transforms[0].is_static);
}

TEST(Ros2Bag, PointCloud2LayoutsAndReadCloudByKey) {
  const std::string dir = write_bag("cloud");
  const json e = expected(dir, "cloud");
  const auto bag = open_ros2_bag(e["bag"]);
  expect_info(bag->info(), e, "none");
  const Read r = read_all(*bag, {"/points"});
  ASSERT_EQ(r.clouds.size(), 3u);  // float32, float64 with a field between, big-endian
  for (std::size_t i = 0; i < 3; ++i) {
    SCOPED_TRACE(i);
    expect_cloud(r.clouds[i], e["clouds"][i]);
    expect_cloud(bag->read_cloud("/points", r.cloud_keys[i]), e["clouds"][i]);
  }
  const Read headers = read_all(*bag, {"/points"}, true);
  ASSERT_EQ(headers.clouds.size(), 3u);
  EXPECT_TRUE(headers.clouds[1].xyz.empty());
  EXPECT_EQ(headers.clouds[1].frame_id, "velodyne");
  EXPECT_NEAR(headers.clouds[1].stamp, e["clouds"][1]["stamp"].get<double>(), 1e-9);
  EXPECT_EQ(headers.cloud_keys, r.cloud_keys);
  test::expect_input_error([&] { bag->read_cloud("/points", r.cloud_keys[0] + 1000); },
                           {"cloud_0.db3", "no message with id"});
  test::expect_input_error([&] { bag->read_cloud("/other", r.cloud_keys[0]); },
                           {"cloud_0.db3", "not a PointCloud2 of topic /other"});
}

TEST(Ros2Bag, MultiEchoOdometryAndPoseStamped) {
  const std::string dir = write_bag("misc");
  const json e = expected(dir, "misc");
  const auto bag = open_ros2_bag(e["bag"]);
  expect_info(bag->info(), e, "none");
  const Read r = read_all(*bag, all_topics(bag->info()));
  EXPECT_EQ(r.order, e["order"].get<std::vector<std::string>>());
  expect_scans(r.scans, e["scans"]);  // the first echo of each beam, NaN where none
  expect_transforms(r.transforms, e["transforms"]);
}

TEST(Ros2Bag, ZstdFileCompression) {
  expect_scan_tf_bag("zstd_file", "zstd (file)");
}

TEST(Ros2Bag, ZstdMessageCompression) {
  const std::string dir = expect_scan_tf_bag("zstd_message", "zstd (message)");
  // One file of it alone: its compression from the metadata.yaml beside it.
  const auto one = open_ros2_bag(dir + "/zstd_message/zstd_message_1.db3");
  EXPECT_EQ(one->info().compression, "zstd (message)");
  EXPECT_EQ(read_all(*one, {"/scan"}).scans.size(), 2u);
}

TEST(Ros2Bag, TruncatedMessageNamesFileTopicTimeAndOffset) {
  const std::string dir = write_bag("truncated");
  const auto bag = open_ros2_bag(dir + "/truncated");
  std::size_t scans = 0;
  BagHandlers h;
  h.scan = [&](const std::string&, std::uint64_t, const LaserScanMsg&) { ++scans; };
  test::expect_input_error([&] { bag->read({"/scan"}, h); },
                           {"truncated_0.db3", "topic /scan", "1700000000.500000000 s",
                            "field 'ranges' at byte", "of 200"});
  EXPECT_EQ(scans, 1u);  // the good message before it
}

TEST(Ros2Bag, NotABagMcapAndCorruptFilesAreInputErrors) {
  const std::string empty = test::temp_dir("ros2_bag_empty");
  test::expect_input_error([&] { open_ros2_bag(empty); },
                           {empty, "neither metadata.yaml nor .db3"});
  test::expect_input_error([&] { open_ros2_bag(empty + "/missing"); }, {"missing", "no such"});
  const std::string mcap = write_bag("mcap");
  test::expect_input_error([&] { open_ros2_bag(mcap + "/mcap"); },
                           {"mcap/metadata.yaml", "MCAP", "ros2 bag convert"});
  test::expect_input_error([&] { open_ros2_bag(mcap + "/mcap/mcap_0.mcap"); },
                           {"mcap_0.mcap", "MCAP"});
  const std::string corrupt = write_bag("corrupt");
  test::expect_input_error([&] { open_ros2_bag(corrupt + "/corrupt"); },
                           {"corrupt_0.db3", "not a readable rosbag2 sqlite3 file"});
  const std::string no_tables = write_bag("no_tables");
  test::expect_input_error([&] { open_ros2_bag(no_tables + "/no_tables/no_tables.db3"); },
                           {"no_tables.db3", "no table 'topics'"});
}

TEST(Ros2Bag, UnknownCompressionAndBadYamlAreInputErrors) {
  const std::string dir = write_bag("misc");
  const std::string yaml = dir + "/misc/metadata.yaml";
  std::string text = test::file_bytes(yaml);
  const std::string good = text;
  text.replace(text.find("compression_format: \"\""), 22, "compression_format: \"lz4\"");
  text.replace(text.find("compression_mode: \"\""), 20, "compression_mode: \"FILE\"");
  test::write_file(dir + "/misc", "metadata.yaml", text);
  test::expect_input_error([&] { open_ros2_bag(dir + "/misc"); },
                           {"metadata.yaml", "compression_format 'lz4'"});
  test::write_file(dir + "/misc", "metadata.yaml", "rosbag2_bagfile_information: [unclosed\n");
  test::expect_input_error([&] { open_ros2_bag(dir + "/misc"); }, {"metadata.yaml", "line "});
}

TEST(Ros2Bag, CdrDecoderRejectsOtherEncapsulations) {
  const std::uint8_t pl_cdr[] = {0, 3, 0, 0, 1, 0, 0, 0};
  BagHandlers h;
  test::expect_input_error(
      [&] { decode_ros2_message(Ros2Type::pose_stamped, pl_cdr, sizeof pl_cdr, "m", "/p", 0, h); },
      {"m: CDR encapsulation 0x00 0x03"});
  const std::uint8_t huge_sequence[] = {0, 1, 0, 0, 0xff, 0xff, 0xff, 0xff};
  test::expect_input_error(
      [&] { decode_ros2_message(Ros2Type::tf, huge_sequence, 8, "m", "/tf", 0, h); },
      {"field 'transforms' at byte 8", "4294967295 elements"});
}

}  // namespace
}  // namespace potmap::data::ros2_bag_test
