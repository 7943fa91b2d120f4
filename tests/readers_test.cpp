// Readers: every real dataset in ../shared/data loads with the counts its README states, and
// every malformed-input class is an InputError naming file, position and value.
#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <fstream>

#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

using test::expect_input_error;
using test::write_file;

void expect_counts(const std::string& rel, std::size_t scans, std::size_t beams) {
  const Dataset ds = read_carmen(test::shared_data(rel));
  ASSERT_EQ(ds.scans.size(), scans) << rel;
  for (const Scan& s : ds.scans) ASSERT_EQ(s.num_beams(), beams) << rel;
  EXPECT_GT(ds.stats.lines_skipped, 0u) << rel;
}

std::string flaser(int n, const std::string& ranges, const std::string& pose) {
  return "FLASER " + std::to_string(n) + " " + ranges + " " + pose + " 0 0 0 12.5 host 12.5\n";
}

}  // namespace

TEST(Readers, IntelRadish) {
  expect_counts("radish/intel-corrected.log.gz", 910, 180);
}
TEST(Readers, AcesRadish) {
  expect_counts("radish/aces-corrected.log.gz", 440, 180);
}
TEST(Readers, CsailRadish) {
  expect_counts("radish/csail-corrected.log.gz", 406, 361);
}
TEST(Readers, FreiburgRadish) {
  expect_counts("radish/freiburg-079-corrected.log.gz", 4791, 360);
}

TEST(Readers, IntelHasHitsAndNoReturns) {
  const Dataset ds = read_carmen(test::shared_data("radish/intel-corrected.log.gz"));
  std::size_t hits = 0, none = 0;
  for (const Scan& s : ds.scans) hits += s.num_hits(), none += s.num_no_return();
  EXPECT_GT(hits, none);
  EXPECT_GT(none, 0u);
  EXPECT_NEAR(ds.scans[0].max_range, 81.9, 0.2);
}

TEST(Readers, KittiFrame) {
  const Scan s = read_kitti_bin(test::shared_data("lidar3d/kitti_000008.bin"));
  EXPECT_EQ(s.num_hits(), 17238u);
  EXPECT_EQ(s.dim, 3);
}

TEST(Readers, NuscenesFrame) {
  const Scan s =
      read_nuscenes_bin(test::shared_data("lidar3d/nuscenes_lidar_top_1532402927647951.bin"));
  EXPECT_EQ(s.num_hits(), 34688u);
}

TEST(Readers, FlaserGeometryAndPlainText) {
  const std::string d = test::temp_dir("readers_geom");
  // Two beams at -90 and 0 degrees (n = 2: one step of 90 degrees), robot at (1, 2) facing +y.
  const std::string p =
      write_file(d, "a.log", "ODOM 0 0 0\n" + flaser(2, "3 4", "1 2 1.5707963267948966"));
  const Dataset ds = read_carmen(p, 10);
  ASSERT_EQ(ds.scans.size(), 1u);
  EXPECT_EQ(ds.stats.lines_skipped, 1u);
  const Scan& s = ds.scans[0];
  ASSERT_EQ(s.num_hits(), 2u);
  EXPECT_NEAR(s.hits[0], 4, 1e-9);  // -90 deg from +y is +x
  EXPECT_NEAR(s.hits[1], 2, 1e-9);
  EXPECT_NEAR(s.hits[2], 1, 1e-9);
  EXPECT_NEAR(s.hits[3], 6, 1e-9);
  EXPECT_DOUBLE_EQ(s.timestamp, 12.5);
}

TEST(Readers, GzipMatchesPlain) {
  const std::string d = test::temp_dir("readers_gz");
  const std::string body = flaser(3, "1 2 9", "0 0 0") + flaser(3, "1 nan 2", "1 0 0");
  const std::string plain = write_file(d, "p.log", body);
  gzFile g = gzopen((d + "/z.log.gz").c_str(), "wb");
  gzwrite(g, body.data(), static_cast<unsigned>(body.size()));
  gzclose(g);
  const Dataset a = read_carmen(plain, 5), b = read_carmen(d + "/z.log.gz", 5);
  ASSERT_EQ(a.scans.size(), 2u);
  ASSERT_EQ(b.scans.size(), 2u);
  EXPECT_EQ(a.scans[0].hits, b.scans[0].hits);
  EXPECT_EQ(a.scans[0].num_no_return(), 1u);  // 9 >= 5
  EXPECT_EQ(a.stats.points_dropped, 1u);      // the NaN range
  EXPECT_EQ(b.stats.points_dropped, 1u);
}

TEST(Readers, RobotLaser) {
  const std::string d = test::temp_dir("readers_robot");
  // start -pi/2, fov pi, 3 beams, max range 8; laser pose (0, 0, 0).
  const std::string p =
      write_file(d, "r.log",
                 "ROBOTLASER1 0 -1.5707963267948966 3.141592653589793 1.57 8 0.01 0 "
                 "3 1 8 2 0 0 0 0 0 0 0 0 0 0 0 0 77.5 host 77.5\n");
  const Dataset ds = read_carmen(p);
  ASSERT_EQ(ds.scans.size(), 1u);
  EXPECT_EQ(ds.scans[0].num_hits(), 2u);
  EXPECT_EQ(ds.scans[0].num_no_return(), 1u);
  EXPECT_NEAR(ds.scans[0].hits[1], -1, 1e-9);
  EXPECT_NEAR(ds.scans[0].hits[3], 2, 1e-9);  // the +90 degree beam, 2 m along +y
  EXPECT_DOUBLE_EQ(ds.scans[0].timestamp, 77.5);
}

// Published logs whose FLASER lines end after the odometry pose: read, the scans numbered.
TEST(Readers, FlaserWithoutTimestamps) {
  const std::string d = test::temp_dir("readers_flaser_short");
  const std::string p = write_file(d, "s.log",
                                   "FLASER 3 1 2 3 0 0 0 0 0 0\n"
                                   "FLASER 3 1 2 3 1 0 0 1 0 0 55.5 host 55.5\n"
                                   "FLASER 3 1 2 3 2 0 0 2 0 0\n");
  const Dataset ds = read_carmen(p, 10);
  ASSERT_EQ(ds.scans.size(), 3u);
  EXPECT_EQ(ds.scans[0].timestamp, 0.0);
  EXPECT_EQ(ds.scans[1].timestamp, 55.5);
  EXPECT_EQ(ds.scans[2].timestamp, 2.0);
  EXPECT_EQ(ds.scans[2].pose2d[0], 2.0);
  EXPECT_EQ(ds.scans[2].num_hits(), 3u);
}

// A text log in another format is an error naming the file, what it found and what it reads.
TEST(ReadersMalformed, NoLaserLines) {
  const std::string d = test::temp_dir("mal_nolaser");
  const std::string p = write_file(d, "o.log", "# other format\nSONAR 3 1 2 3\nODOM 0 0 0\n");
  expect_input_error([&] { read_carmen(p); },
                     {p, "no laser line", "'SONAR 3 1 2 3'", "FLASER", "RLASER", "ROBOTLASER1",
                      "RAWLASER1-4", "LASER, LASER1-4", "ODOM"});
  const std::string e = write_file(d, "e.log", "");
  expect_input_error([&] { read_carmen(e); }, {e, "empty"});
}

// An unknown extension holding no laser line: the error also lists what read_dataset reads by
// extension, and quotes binary bytes as '?'.
TEST(ReadersMalformed, UnknownFileNamesFormats) {
  const std::string d = test::temp_dir("mal_unknown");
  const std::string p =
      write_file(d, "junk.xyz", std::string("\x01\x02junk\x7f\0\xff\nmore\n", 15));
  try {
    read_dataset(p);
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    const std::string m = e.what();
    for (const char* n : {"junk.xyz", "no laser line", "'?\?junk?\?\?'", "RAWLASER1-4", ".bin",
                          ".pcd", ".npz", ".csv", "poses.txt"})
      EXPECT_NE(m.find(n), std::string::npos) << m << " lacks " << n;
    for (char c : m) EXPECT_TRUE(c >= 0x20 && c < 0x7f) << "non-printable byte in " << m;
  }
  // A CARMEN name does not list the other formats.
  const std::string l = write_file(d, "x.log", "PARAM a b\n");
  try {
    read_dataset(l);
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).find(".pcd"), std::string::npos) << e.what();
  }
}

TEST(ReadersMalformed, TruncatedLine) {
  const std::string d = test::temp_dir("mal_trunc");
  const std::string p = write_file(d, "t.log", flaser(3, "1 2 3", "0 0 0") + "FLASER 180 1.0 2.0");
  expect_input_error([&] { read_carmen(p); }, {p, "line 2", "2.0"});
}

TEST(ReadersMalformed, WrongFieldCountBeamCount) {
  const std::string d = test::temp_dir("mal_count");
  const std::string p = write_file(d, "c.log", "FLASER 2.5 1 2 0 0 0 0 0 0 1 h 1\n");
  expect_input_error([&] { read_carmen(p); }, {p, "line 1", "2.5"});
}

TEST(ReadersMalformed, NonNumericRange) {
  const std::string d = test::temp_dir("mal_nonnum");
  const std::string p = write_file(d, "n.log", flaser(2, "1 abc", "0 0 0"));
  expect_input_error([&] { read_carmen(p); }, {p, "line 1", "abc"});
}

TEST(ReadersMalformed, NanPose) {
  const std::string d = test::temp_dir("mal_nanpose");
  const std::string p = write_file(d, "p.log", "PARAM x\n" + flaser(2, "1 2", "0 nan 0"));
  expect_input_error([&] { read_carmen(p); }, {p, "line 2", "nan"});
}

TEST(ReadersMalformed, NegativeRange) {
  const std::string d = test::temp_dir("mal_neg");
  const std::string p = write_file(d, "g.log", flaser(2, "1 -0.5", "0 0 0"));
  expect_input_error([&] { read_carmen(p); }, {p, "line 1", "-0.5"});
}

TEST(ReadersMalformed, BinSizeNotMultipleOf16) {
  const std::string d = test::temp_dir("mal_bin");
  const std::string p = write_file(d, "k.bin", std::string(16 * 3 + 5, '\0'));
  expect_input_error([&] { read_kitti_bin(p); }, {p, "byte 48", "53"});
}

TEST(ReadersMalformed, CorruptGzip) {
  const std::string d = test::temp_dir("mal_gz");
  const std::string p = write_file(d, "x.log.gz", std::string("\x1f\x8b\x08\x00garbage", 11));
  expect_input_error([&] { read_carmen(p); }, {p, "byte"});
}

TEST(ReadersMalformed, KittiPoseLine) {
  const std::string d = test::temp_dir("mal_pose");
  const std::string calib =
      write_file(d, "calib.txt", "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nTr: 1 0 0 0 0 1 0 0 0 0 1 0\n");
  const std::string poses =
      write_file(d, "poses.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 inf 0 0 1 0\n");
  expect_input_error([&] { read_kitti_poses(poses, calib); }, {poses, "line 2", "inf"});
}

TEST(Readers, KittiPosesComposeWithCalib) {
  const std::string d = test::temp_dir("kitti_pose");
  // Tr swaps axes as KITTI's does (velo x forward -> cam z forward); the camera moves 2 m along z.
  const std::string calib = write_file(d, "calib.txt", "Tr: 0 -1 0 0 0 0 -1 0 1 0 0 0\n");
  const std::string poses = write_file(d, "poses.txt", "1 0 0 0 0 1 0 0 0 0 1 2\n");
  const auto T = read_kitti_poses(poses, calib);
  ASSERT_EQ(T.size(), 1u);
  // In velodyne axes that is 2 m forward (x).
  EXPECT_NEAR(T[0][3], 2, 1e-12);
  EXPECT_NEAR(T[0][7], 0, 1e-12);
  EXPECT_NEAR(T[0][11], 0, 1e-12);
  Scan s;
  s.dim = 3;
  s.hits = {1, 0, 0};
  apply_pose(s, T[0]);
  EXPECT_NEAR(s.hits[0], 3, 1e-12);
}

TEST(Readers, ScansFromLabelledGroupsByT) {
  LabelledPoints lp;
  lp.dim = 2;
  lp.position = {1, 1, 2, 2, 0, 0, 5, 5};
  lp.label = {1, 0, 1, 0};
  lp.scan = {0, 0, 3, 3};
  const auto scans = scans_from_labelled(lp);
  ASSERT_EQ(scans.size(), 2u);
  EXPECT_EQ(scans[0].num_hits(), 1u);
  EXPECT_DOUBLE_EQ(scans[1].timestamp, 3);
  EXPECT_DOUBLE_EQ(scans[1].pose2d[0], 5);
}

TEST(Readers, FlaserFieldOfViewWhenTold) {
  const std::string d = test::temp_dir("readers_fov");
  // Three beams over 90 degrees: -45, 0, +45 around a heading of 0.
  const std::string p = write_file(d, "f.log", flaser(3, "2 2 2", "0 0 0"));
  const Dataset ds = read_carmen(p, 10, M_PI / 2);
  ASSERT_EQ(ds.scans[0].num_hits(), 3u);
  EXPECT_NEAR(ds.scans[0].hits[0], std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(ds.scans[0].hits[1], -std::sqrt(2.0), 1e-9);
  EXPECT_NEAR(ds.scans[0].hits[5], std::sqrt(2.0), 1e-9);
}

namespace {

// Expects hit k of a 2D scan at (x, y).
void expect_hit(const Scan& s, std::size_t k, double x, double y) {
  ASSERT_LT(k, s.num_hits());
  EXPECT_NEAR(s.hits[2 * k], x, 1e-9) << "hit " << k;
  EXPECT_NEAR(s.hits[2 * k + 1], y, 1e-9) << "hit " << k;
}

std::string rawlaser(int n, const std::string& start_fov, int beams, const std::string& ranges,
                     const std::string& t) {
  return "RAWLASER" + std::to_string(n) + " 0 " + start_fov + " 0.01 8 0.01 0 " +
         std::to_string(beams) + " " + ranges + " 0 " + t + " host " + t + "\n";
}

}  // namespace

// The rear laser looks backwards: three beams over 180 degrees centred on the heading plus pi.
TEST(Readers, RlaserOnlyLooksBackwards) {
  const std::string d = test::temp_dir("readers_rlaser");
  const std::string p =
      write_file(d, "r.log", "ODOM 0 0 0 0 0 0 1 h 1\nRLASER 3 1 2 3 1 2 0 1 2 0 3.5 host 3.5\n");
  const Dataset ds = read_carmen(p, 10);
  ASSERT_EQ(ds.scans.size(), 1u);
  const Scan& s = ds.scans[0];
  EXPECT_DOUBLE_EQ(s.timestamp, 3.5);
  EXPECT_NEAR(std::cos(s.pose2d[2]), -1, 1e-12);  // the sensor's heading: pi
  ASSERT_EQ(s.num_hits(), 3u);
  expect_hit(s, 0, 1, 3);   // heading pi - 90 degrees: +y
  expect_hit(s, 1, -1, 2);  // straight back: -x
  expect_hit(s, 2, 1, -1);  // heading pi + 90 degrees: -y
}

// A log with both lasers is read from the front one; the rear lines are skipped and counted.
TEST(Readers, FlaserAndRlaserReadsFront) {
  const std::string d = test::temp_dir("readers_front_rear");
  const std::string p =
      write_file(d, "fr.log",
                 "RLASER 3 1 2 3 0 0 0 0 0 0 1 h 1\n" + flaser(3, "1 2 3", "5 0 0") +
                     "RLASER 3 1 2 3 0 0 0 0 0 0 2 h 2\n");
  const Dataset ds = read_carmen(p, 10);
  ASSERT_EQ(ds.scans.size(), 1u);
  EXPECT_EQ(ds.scans[0].pose2d[0], 5.0);
  EXPECT_EQ(ds.stats.lines_skipped, 2u);
  expect_hit(ds.scans[0], 1, 7, 0);  // the middle beam straight ahead
}

// RAWLASER has no pose: the ODOM lines' pose interpolated at its time, the heading the shorter
// way across +-pi (3 and -3 radians meet at pi, not at 0). RAWLASER2 (a second laser) is skipped.
TEST(Readers, RawLaserInterpolatesOdometry) {
  const std::string d = test::temp_dir("readers_rawlaser");
  const std::string p = write_file(
      d, "raw.log",
      "ODOM 0 0 3 0 0 0 10 h 10\n" + rawlaser(2, "0 1", 1, "1", "10.5") +
          rawlaser(1, "0 1.5707963267948966", 2, "2 3", "11") + "ODOM 2 4 -3 0 0 0 12 h 12\n");
  const Dataset ds = read_carmen(p);
  ASSERT_EQ(ds.scans.size(), 1u);
  EXPECT_EQ(ds.stats.lines_skipped, 3u);
  const Scan& s = ds.scans[0];
  EXPECT_DOUBLE_EQ(s.timestamp, 11);
  EXPECT_DOUBLE_EQ(s.max_range, 8);
  EXPECT_NEAR(s.pose2d[0], 1, 1e-12);
  EXPECT_NEAR(s.pose2d[1], 2, 1e-12);
  const double heading = 3 + 0.5 * (2 * M_PI - 6);  // half way along the short arc: pi
  EXPECT_NEAR(std::cos(s.pose2d[2]), std::cos(heading), 1e-12);
  expect_hit(s, 0, 1 + 2 * std::cos(heading), 2 + 2 * std::sin(heading));  // (-1, 2)
  expect_hit(s, 1, 1 + 3 * std::cos(heading + M_PI / 2), 2 + 3 * std::sin(heading + M_PI / 2));
}

// Just outside the ODOM lines' time span the nearest pose is taken; further out, or with no
// ODOM line, it is an error naming the line and its time.
TEST(Readers, RawLaserOutsideOdometry) {
  const std::string d = test::temp_dir("readers_rawgap");
  const std::string odom = "ODOM 0 0 0 0 0 0 10 h 10\nODOM 2 0 0 0 0 0 12 h 12\n";
  const Dataset ds =
      read_carmen(write_file(d, "near.log", odom + rawlaser(1, "0 0", 1, "1", "12.3")));
  ASSERT_EQ(ds.scans.size(), 1u);
  expect_hit(ds.scans[0], 0, 3, 0);
  const std::string far = write_file(d, "far.log", odom + rawlaser(1, "0 0", 1, "1", "13"));
  expect_input_error([&] { read_carmen(far); }, {far, "line 3", "RAWLASER1", "13", "line 2"});
  const std::string none =
      write_file(d, "none.log", "PARAM a b\n" + rawlaser(3, "0 0", 1, "1", "5"));
  expect_input_error([&] { read_carmen(none); }, {none, "line 2", "RAWLASER3", "no ODOM"});
  const std::string bad =
      write_file(d, "bad.log", "ODOM 0 0 abc 0 0 0 1 h 1\n" + rawlaser(1, "0 0", 1, "1", "1"));
  expect_input_error([&] { read_carmen(bad); }, {bad, "line 1", "abc"});
  const std::string short_odom =
      write_file(d, "short.log", "ODOM 0 0 0\n" + rawlaser(1, "0 0", 1, "1", "1"));
  expect_input_error([&] { read_carmen(short_odom); }, {short_odom, "line 1", "ODOM needs"});
  const std::string bad_t = write_file(d, "badt.log", odom + rawlaser(1, "0 0", 1, "1", "x1"));
  expect_input_error([&] { read_carmen(bad_t); }, {bad_t, "line 3", "x1"});
}

// A log whose stamps do not advance from most scans to the next (printed with six significant
// digits, as CSAIL's: 1.13486e+09) carries no time: its scans are timed by their index. One
// whose stamps advance keeps them, a step back or two included.
TEST(Readers, StampsThatDoNotAdvanceBecomeIndices) {
  const std::string d = test::temp_dir("readers_stamps");
  auto flaser = [](const std::string& t) {
    return "FLASER 3 1 1 1 0 0 0 0 0 0 " + t + " host " + t + "\n";
  };
  std::string coarse, fine;
  for (int i = 0; i < 8; ++i) {
    coarse += flaser(i < 7 ? "1.13486e+09" : "1.13487e+09");
    fine += flaser(std::to_string(i == 4 ? 2.5 : 10.0 + i));
  }
  const Dataset c = read_carmen(write_file(d, "coarse.log", coarse));
  ASSERT_EQ(c.scans.size(), 8u);
  EXPECT_EQ(c.stats.stamps_replaced, 8u);
  for (std::size_t i = 0; i < 8; ++i) EXPECT_EQ(c.scans[i].timestamp, double(i));
  const Dataset f = read_carmen(write_file(d, "fine.log", fine));
  EXPECT_EQ(f.stats.stamps_replaced, 0u);
  EXPECT_EQ(f.scans[4].timestamp, 2.5);
  EXPECT_EQ(f.scans[7].timestamp, 17.0);
}

// ROBOTLASER1 as CARMEN writes it, and as converters write it: without the velocity fields,
// without anything after the poses, with the velocities but no timestamp.
TEST(Readers, RobotLaserVariants) {
  const std::string d = test::temp_dir("readers_robot_variants");
  const std::string head = "ROBOTLASER1 0 0 0 0 8 0.01 0 1 2 0 ";
  const std::string p = write_file(d, "v.log",
                                   head + "0 0 0 0 0 0 0 0 0 0 0 1.25 host 1.25\n" +  //
                                       head + "1 0 0 1 0 0 1.75 host 1.75\n" +        //
                                       head + "0 1 1.5707963267948966 0 1 0\n" +      //
                                       head + "3 3 0 3 3 0 0 0 0 0 0\n");
  const Dataset ds = read_carmen(p);
  ASSERT_EQ(ds.scans.size(), 4u);
  EXPECT_DOUBLE_EQ(ds.scans[0].timestamp, 1.25);
  EXPECT_DOUBLE_EQ(ds.scans[1].timestamp, 1.75);
  EXPECT_EQ(ds.stats.stamps_replaced, 0u);
  EXPECT_DOUBLE_EQ(ds.scans[2].timestamp, 2);
  EXPECT_DOUBLE_EQ(ds.scans[3].timestamp, 3);
  expect_hit(ds.scans[1], 0, 3, 0);
  expect_hit(ds.scans[2], 0, 0, 3);  // the laser pose faces +y
  expect_hit(ds.scans[3], 0, 5, 3);
  const std::string bad = write_file(d, "b.log", head + "0 0 0 0 0 0 1 2 3 4\n");
  expect_input_error([&] { read_carmen(bad); }, {bad, "line 1", "4 fields after the robot pose"});
}

// CARMEN's old LASER lines have no pose: each takes the latest ODOM line's before it, with
// FLASER's geometry (2 beams: -90 and 0 degrees); without a timestamp the scan's index is its
// time.
TEST(Readers, OldLaserWithOdometry) {
  const std::string d = test::temp_dir("readers_oldlaser");
  const std::string p = write_file(d, "old.log",
                                   "ODOM 1 2 1.5707963267948966 0 0 0 5 h 5\n"
                                   "LASER 2 3 4 6 h 6\n"
                                   "ODOM 2 2 0\n"
                                   "LASER 2 1 1\n");
  const Dataset ds = read_carmen(p, 10);
  ASSERT_EQ(ds.scans.size(), 2u);
  EXPECT_DOUBLE_EQ(ds.scans[0].timestamp, 6);
  EXPECT_DOUBLE_EQ(ds.scans[1].timestamp, 1);
  expect_hit(ds.scans[0], 0, 4, 2);
  expect_hit(ds.scans[0], 1, 1, 6);
  expect_hit(ds.scans[1], 0, 2, 1);
  expect_hit(ds.scans[1], 1, 3, 2);
  const std::string first = write_file(d, "first.log", "LASER4 2 1 1\nODOM 0 0 0\n");
  expect_input_error([&] { read_carmen(first); }, {first, "line 1", "LASER4", "no ODOM"});
  const std::string bad = write_file(d, "bad.log", "ODOM 0 0 0\nLASER 2 1 -1\n");
  expect_input_error([&] { read_carmen(bad); }, {bad, "line 2", "-1"});
}
