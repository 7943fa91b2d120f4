// 3D drives read as SLAM tools and KITTI lay them out: the real ../shared drives indexed and a
// keyframe moved into the world by its pose; every malformed-input class an InputError naming
// the file, the line and the value.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "potmap/data/drive.hpp"
#include "potmap/error.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

using test::expect_input_error;
using test::write_file;

const char* kIdentity = "1 0 0 0 0 1 0 0 0 0 1 0\n";

// An ascii PCD of n points on a line in the sensor frame.
std::string ascii_pcd(int n) {
  std::string s =
      "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\n"
      "COUNT 1 1 1 1\nWIDTH " +
      std::to_string(n) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + std::to_string(n) +
      "\nDATA ascii\n";
  for (int i = 0; i < n; ++i) s += std::to_string(1 + i) + " 0 0.5 7\n";
  return s;
}

// A small drive: `frames` keyframes and the given poses text (times.txt when `times` is set).
std::string small_drive(const std::string& name, int frames, const std::string& poses,
                        const std::string& times = "") {
  const std::string dir = test::temp_dir(name);
  std::filesystem::create_directories(dir + "/Scans");
  for (int i = 0; i < frames; ++i) {
    char f[32];
    std::snprintf(f, sizeof f, "Scans/%06d.pcd", i);
    write_file(dir, f, ascii_pcd(3));
  }
  write_file(dir, "odom_poses.txt", poses);
  if (!times.empty()) write_file(dir, "times.txt", times);
  return dir;
}

}  // namespace

TEST(DriveReader, IndexesTheRiversideDriveAsItIs) {
  const std::string dir = test::shared_data("drives3d/riverside-a");
  ASSERT_TRUE(is_drive(dir));
  const Drive d = open_drive(dir);
  EXPECT_EQ(d.layout, "slam");
  ASSERT_EQ(d.size(), 281u);
  EXPECT_EQ(d.poses.size(), 281u);
  EXPECT_TRUE(d.has_times);
  EXPECT_NEAR(d.times.back() - d.times.front(), 214.2, 0.1);
  // Keyframe 10 in the world: every point is its sensor-frame point moved by pose 10, so the
  // sensor sits at the pose's translation and the points lie within the Ouster's reach of it.
  const Scan s = read_keyframe(d, 10);
  EXPECT_EQ(s.dim, 3);
  EXPECT_GT(s.num_hits(), 5000u);
  const auto o = s.origin();
  EXPECT_DOUBLE_EQ(o[0], d.poses[10][3]);
  EXPECT_DOUBLE_EQ(o[1], d.poses[10][7]);
  EXPECT_DOUBLE_EQ(o[2], d.poses[10][11]);
  EXPECT_DOUBLE_EQ(s.timestamp, d.times[10]);
  double far = 0;
  for (std::size_t i = 0; i < s.num_hits(); ++i)
    far = std::max(
        far, std::hypot(s.hits[3 * i] - o[0], s.hits[3 * i + 1] - o[1], s.hits[3 * i + 2] - o[2]));
  EXPECT_LT(far, 200.0);  // the OS1-64 returns past its rated 120 m (152 m here)
  EXPECT_GT(far, 20.0);
}

TEST(DriveReader, SummarisesBothSharedDrives) {
  const DriveSummary r = summarise_drive(open_drive(test::shared_data("drives3d/riverside-a")));
  EXPECT_EQ(r.keyframes, 281u);
  EXPECT_NEAR(r.path_length, 2415.6, 1.0);  // the data README's 2.4 km
  EXPECT_NEAR(r.largest_step, 63.5, 0.1);   // its one gap of 64 m
  EXPECT_GE(r.min_points, 5000u);
  EXPECT_LE(r.max_points, 15100u);
  EXPECT_GT(r.azimuth_span, 340.0);  // a spinning Ouster
  const DriveSummary h = summarise_drive(open_drive(test::shared_data("drives3d/hku-1")));
  EXPECT_EQ(h.keyframes, 314u);
  EXPECT_NEAR(h.path_length, 63.6, 0.5);
  EXPECT_LT(h.azimuth_span, 100.0);  // the Livox Avia's 70 x 77 degrees
  EXPECT_GT(h.azimuth_span, 60.0);
}

TEST(DriveReader, ReadsASmallDriveWithPosesAndTimes) {
  const std::string dir = small_drive(
      "drive_small", 2, std::string(kIdentity) + "0 -1 0 10 1 0 0 20 0 0 1 1\n", "100.5\n101.5\n");
  const Dataset ds = read_dataset(dir);
  ASSERT_EQ(ds.scans.size(), 2u);
  // Keyframe 1 turned 90 degrees about z and moved to (10, 20, 1): sensor point (1, 0, 0.5)
  // lands at (10, 21, 1.5).
  const Scan& s = ds.scans[1];
  EXPECT_NEAR(s.hits[0], 10.0, 1e-12);
  EXPECT_NEAR(s.hits[1], 21.0, 1e-12);
  EXPECT_NEAR(s.hits[2], 1.5, 1e-12);
  EXPECT_DOUBLE_EQ(s.timestamp, 101.5);
}

TEST(DriveReader, RefusesFewerPoseRowsThanKeyframes) {
  const std::string dir = small_drive("drive_short_poses", 3, std::string(kIdentity) + kIdentity);
  expect_input_error([&] { open_drive(dir); }, {"odom_poses.txt", "line 3",
                                                "2 rows for 3 keyframes", "keyframe 2 has no row"});
}

TEST(DriveReader, RefusesANaNPose) {
  const std::string dir =
      small_drive("drive_nan_pose", 2, std::string(kIdentity) + "1 0 0 nan 0 1 0 0 0 0 1 0\n");
  expect_input_error([&] { open_drive(dir); }, {"odom_poses.txt", "line 2", "number 4", "'nan'"});
}

TEST(DriveReader, RefusesAPoseWhoseRotationIsNone) {
  const std::string dir =
      small_drive("drive_scaled_pose", 2, std::string(kIdentity) + "2 0 0 0 0 1 0 0 0 0 1 0\n");
  expect_input_error([&] { open_drive(dir); }, {"odom_poses.txt", "line 2", "not a rotation"});
}

TEST(DriveReader, RefusesATruncatedKeyframe) {
  const std::string dir = small_drive("drive_truncated", 2, std::string(kIdentity) + kIdentity);
  // A binary PCD announcing 100 points and holding 10 of them.
  std::string pcd =
      "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 100\nHEIGHT 1\n"
      "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 100\nDATA binary\n";
  pcd += std::string(10 * 12, '\0');
  const std::string bad = write_file(dir, "Scans/000001.pcd", pcd);
  const Drive d = open_drive(dir);
  EXPECT_NO_THROW(read_keyframe(d, 0));
  expect_input_error([&] { read_keyframe(d, 1); }, {"000001.pcd"});
}

TEST(DriveReader, RefusesBadTimesAndUnknownFolders) {
  const std::string dir =
      small_drive("drive_bad_times", 2, std::string(kIdentity) + kIdentity, "5.0\n4.0\n");
  expect_input_error([&] { open_drive(dir); }, {"times.txt", "line 2", "4.0", "before"});
  const std::string empty = test::temp_dir("drive_none");
  EXPECT_FALSE(is_drive(empty));
  expect_input_error([&] { open_drive(empty); }, {empty, "not a drive folder"});
}

TEST(DriveReader, ReadsAKittiSequenceInTheBenchmarksLayout) {
  // dataset/sequences/07/{velodyne/*.bin, calib.txt} and dataset/poses/07.txt two folders up,
  // with a pose more than the frames downloaded (the benchmark's poses cover the whole
  // sequence).
  const std::string root = test::temp_dir("kitti_layout");
  const std::string seq = root + "/dataset/sequences/07";
  std::filesystem::create_directories(seq + "/velodyne");
  const float pts[8] = {1, 0, 0, 0.5f, 0, 2, 0, 0.5f};  // x y z reflectance, sensor frame
  for (const char* f : {"/velodyne/000000.bin", "/velodyne/000001.bin"})
    write_file(seq, f, std::string(reinterpret_cast<const char*>(pts), sizeof pts));
  write_file(seq, "calib.txt", "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nTr: 1 0 0 0 0 1 0 0 0 0 1 0\n");
  std::filesystem::create_directories(root + "/dataset/poses");
  write_file(root + "/dataset/poses", "07.txt",
             std::string(kIdentity) + "1 0 0 5 0 1 0 0 0 0 1 0\n" + kIdentity);
  const Drive d = open_drive(seq);
  EXPECT_EQ(d.layout, "kitti");
  ASSERT_EQ(d.size(), 2u);
  EXPECT_NE(d.poses_file.find("poses/07.txt"), std::string::npos) << d.poses_file;
  const Scan k = read_keyframe(d, 1);
  ASSERT_EQ(k.dim, 3);
  ASSERT_EQ(k.num_hits(), 2u);
  EXPECT_NEAR(k.hits[0], 6.0, 1e-6);  // (1, 0, 0) moved 5 m along x
  EXPECT_NEAR(k.hits[4], 2.0, 1e-6);
  EXPECT_NEAR(k.origin()[0], 5.0, 1e-12);
  // Without poses: an error naming both places looked in.
  std::filesystem::remove(root + "/dataset/poses/07.txt");
  expect_input_error([&] { open_drive(seq); }, {"without poses", "poses.txt", "07.txt"});
}
