// Point-cloud frames (PCD, PLY) written by PCL's own writers read back by potmap's reader, point
// for point; sequences by their poses file; every malformed-input class an InputError naming the
// file and what is wrong.
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

using test::expect_input_error;
using test::write_file;

pcl::PointCloud<pcl::PointXYZI> random_cloud(std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-60.f, 60.f);
  pcl::PointCloud<pcl::PointXYZI> c;
  for (std::size_t i = 0; i < n; ++i) {
    pcl::PointXYZI p;
    p.x = u(rng);
    p.y = u(rng);
    p.z = u(rng) / 20;
    p.intensity = static_cast<float>(i);
    c.push_back(p);
  }
  return c;
}

// rel: relative tolerance (0 for the binary formats, which keep float32 bits).
void expect_same_points(const Scan& s, const pcl::PointCloud<pcl::PointXYZI>& c, double rel) {
  ASSERT_EQ(s.dim, 3);
  ASSERT_EQ(s.num_hits(), c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    const float v[3] = {c[i].x, c[i].y, c[i].z};
    for (int d = 0; d < 3; ++d)
      ASSERT_NEAR(s.hits[3 * i + d], v[d], rel * std::abs(v[d])) << "point " << i << " axis " << d;
  }
}

}  // namespace

TEST(PointCloudReaders, PcdAsciiRoundTrip) {
  const std::string d = test::temp_dir("pcd_ascii");
  const auto c = random_cloud(500, 1);
  // PCL writes ASCII floats with 8 significant digits.
  ASSERT_EQ(pcl::io::savePCDFileASCII(d + "/f.pcd", c), 0);
  expect_same_points(read_point_cloud(d + "/f.pcd"), c, 1e-7);
}

TEST(PointCloudReaders, PcdBinaryAndCompressedRoundTrip) {
  const std::string d = test::temp_dir("pcd_binary");
  const auto c = random_cloud(1000, 2);
  ASSERT_EQ(pcl::io::savePCDFileBinary(d + "/b.pcd", c), 0);
  ASSERT_EQ(pcl::io::savePCDFileBinaryCompressed(d + "/z.pcd", c), 0);
  expect_same_points(read_point_cloud(d + "/b.pcd"), c, 0);
  expect_same_points(read_point_cloud(d + "/z.pcd"), c, 0);
  const Dataset ds = read_dataset(d + "/b.pcd");
  ASSERT_EQ(ds.scans.size(), 1u);
  expect_same_points(ds.scans[0], c, 0);
}

TEST(PointCloudReaders, PlyBinaryAndAsciiRoundTrip) {
  const std::string d = test::temp_dir("ply");
  const auto c = random_cloud(700, 3);
  ASSERT_EQ(pcl::io::savePLYFile(d + "/b.ply", c, true), 0);
  ASSERT_EQ(pcl::io::savePLYFile(d + "/a.ply", c, false), 0);
  expect_same_points(read_point_cloud(d + "/b.ply"), c, 0);
  expect_same_points(read_point_cloud(d + "/a.ply"), c, 1e-7);
}

TEST(PointCloudReaders, NanPointsAreDroppedAndCounted) {
  const std::string d = test::temp_dir("pcd_nan");
  auto c = random_cloud(10, 4);
  c[3].x = std::numeric_limits<float>::quiet_NaN();
  c[7].z = std::numeric_limits<float>::infinity();
  c.is_dense = false;
  ASSERT_EQ(pcl::io::savePCDFileBinary(d + "/n.pcd", c), 0);
  const Dataset ds = read_dataset(d + "/n.pcd");
  ASSERT_EQ(ds.scans.size(), 1u);
  EXPECT_EQ(ds.scans[0].num_hits(), 8u);
  EXPECT_EQ(ds.stats.points_dropped, 2u);
  EXPECT_EQ(ds.scans[0].hits[9], c[4].x);  // the fourth point kept is the cloud's fifth
}

TEST(PointCloudReaders, ViewpointIsTheSensorPose) {
  const std::string d = test::temp_dir("pcd_view");
  auto c = random_cloud(5, 5);
  c.sensor_origin_ = Eigen::Vector4f(1, 2, 3, 0);
  c.sensor_orientation_ = Eigen::Quaternionf(Eigen::AngleAxisf(0.5f, Eigen::Vector3f::UnitZ()));
  ASSERT_EQ(pcl::io::savePCDFileBinary(d + "/v.pcd", c), 0);
  const Scan s = read_point_cloud(d + "/v.pcd");
  const auto o = s.origin();
  EXPECT_NEAR(o[0], 1, 1e-6);
  EXPECT_NEAR(o[1], 2, 1e-6);
  EXPECT_NEAR(o[2], 3, 1e-6);
  EXPECT_NEAR(s.pose3d[0], std::cos(0.5), 1e-6);
  EXPECT_NEAR(s.pose3d[4], std::sin(0.5), 1e-6);
  expect_same_points(s, c, 0);  // the points stay in the cloud's frame
}

TEST(PointCloudReaders, SequenceByPosesFileOrFolder) {
  const std::string d = test::temp_dir("pc_seq");
  std::filesystem::create_directories(d + "/frames");
  const auto a = random_cloud(50, 6), b = random_cloud(60, 7);
  ASSERT_EQ(pcl::io::savePCDFileBinary(d + "/frames/0.pcd", a), 0);
  ASSERT_EQ(pcl::io::savePLYFile(d + "/frames/1.ply", b, true), 0);
  // Frame 1: a quarter turn about z and 10 m along x.
  write_file(d, "poses.txt",
             "# frame r00 r01 r02 tx r10 r11 r12 ty r20 r21 r22 tz\n"
             "frames/0.pcd 1 0 0 0 0 1 0 0 0 0 1 0\n\n"
             "frames/1.ply 0 -1 0 10 1 0 0 0 0 0 1 0\n");
  for (const std::string& path : {d, d + "/poses.txt"}) {
    const Dataset ds = read_dataset(path);
    ASSERT_EQ(ds.scans.size(), 2u) << path;
    expect_same_points(ds.scans[0], a, 0);
    ASSERT_EQ(ds.scans[1].num_hits(), b.size());
    for (std::size_t i = 0; i < b.size(); ++i) {
      EXPECT_NEAR(ds.scans[1].hits[3 * i], 10 - b[i].y, 1e-5);
      EXPECT_NEAR(ds.scans[1].hits[3 * i + 1], b[i].x, 1e-5);
      EXPECT_NEAR(ds.scans[1].hits[3 * i + 2], b[i].z, 1e-5);
    }
    EXPECT_NEAR(ds.scans[1].origin()[0], 10, 1e-12);
    EXPECT_EQ(ds.scans[1].timestamp, 1);
  }
}

TEST(PointCloudReadersMalformed, TruncatedBinaryPcdAndPly) {
  const std::string d = test::temp_dir("pc_trunc");
  const auto c = random_cloud(100, 8);
  for (const std::string name : {"t.pcd", "t.ply"}) {
    const std::string p = d + "/" + name;
    ASSERT_EQ(name == "t.pcd" ? pcl::io::savePCDFileBinary(p, c) : pcl::io::savePLYFile(p, c, true),
              0);
    const auto size = std::filesystem::file_size(p);
    std::filesystem::resize_file(p, size - 30);
    // PCD: the header is read alone, so the sizes are known. PLY: PCL's reader parses the body
    // with the header, so the error can only say what may be wrong, and the file's size.
    if (name == "t.pcd")
      expect_input_error([&] { read_point_cloud(p); },
                         {p, "truncated", "byte " + std::to_string(size - 30), "100 points"});
    else
      expect_input_error([&] { read_point_cloud(p); },
                         {p, "truncated", std::to_string(size - 30) + " bytes"});
  }
}

TEST(PointCloudReadersMalformed, TruncatedAsciiPcd) {
  const std::string d = test::temp_dir("pc_trunc_ascii");
  const std::string p = write_file(d, "a.pcd",
                                   "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                                   "WIDTH 3\nHEIGHT 1\nPOINTS 3\nDATA ascii\n1 2 3\n4 5 6\n");
  expect_input_error([&] { read_point_cloud(p); }, {p, "truncated", "header's 3"});
}

TEST(PointCloudReadersMalformed, EmptyCloud) {
  const std::string d = test::temp_dir("pc_empty");
  const std::string p = write_file(d, "e.pcd",
                                   "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                                   "WIDTH 0\nHEIGHT 1\nPOINTS 0\nDATA ascii\n");
  expect_input_error([&] { read_point_cloud(p); }, {p, "no points"});
}

TEST(PointCloudReadersMalformed, AllPointsNan) {
  const std::string d = test::temp_dir("pc_allnan");
  const std::string p =
      write_file(d, "n.pcd",
                 "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                 "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\nnan nan nan\n1 nan 2\n");
  expect_input_error([&] { read_point_cloud(p); }, {p, "all 2 points", "NaN"});
}

TEST(PointCloudReadersMalformed, WrongFieldLayout) {
  const std::string d = test::temp_dir("pc_fields");
  const std::string no_z =
      write_file(d, "noz.pcd",
                 "VERSION .7\nFIELDS x y intensity\nSIZE 4 4 4\nTYPE F F F\n"
                 "COUNT 1 1 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n");
  expect_input_error([&] { read_point_cloud(no_z); }, {no_z, "no field 'z'", "x y intensity"});
  const std::string ints =
      write_file(d, "int.pcd",
                 "VERSION .7\nFIELDS x y z\nSIZE 1 4 4\nTYPE U F F\n"
                 "COUNT 1 1 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n");
  expect_input_error([&] { read_point_cloud(ints); }, {ints, "'x'", "uint8"});
  // fuzz_point_cloud's first find: PCL's header reader throws std::out_of_range on this (and
  // other inconsistent headers corrupt its heap), so potmap checks the header first.
  const std::string thrower = write_file(
      d, "thrower.pcd", "DATAION\".7\001\nFIELDS x y z inteVnsiEt" + std::string(32, '\xcd'));
  expect_input_error([&] { read_point_cloud(thrower); }, {thrower, "not a PCD header keyword"});
  const std::string mismatch =
      write_file(d, "mismatch.pcd",
                 "VERSION .7\nFIELDS x y z intensity\nSIZE 4 4 4\nTYPE F F F\n"
                 "WIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n");
  expect_input_error([&] { read_point_cloud(mismatch); },
                     {mismatch, "4 FIELDS, 3 SIZE, 3 TYPE", "must match"});
  const std::string junk = write_file(d, "junk.ply", "not a ply file\n");
  expect_input_error([&] { read_point_cloud(junk); }, {junk, "not a readable PLY file"});
}

// fuzz_point_cloud's second find: PCL sizes its buffer from the header's count before reading
// the body, so a header claiming 5 x 10^18 points exhausted memory inside PCL.
TEST(PointCloudReadersMalformed, PointCountBeyondTheFile) {
  const std::string d = test::temp_dir("pc_huge_count");
  const std::string pcd =
      write_file(d, "huge.pcd",
                 "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                 "WIDTH 1\nHEIGHT 1\nPOINTS 4999999999999999999\nDATA binary\n" +
                     std::string(12, '\0'));
  expect_input_error([&] { read_point_cloud(pcd); },
                     {pcd, "4999999999999999999 points", "more than any encoding holds"});
  const std::string ply = write_file(d, "huge.ply",
                                     "ply\nformat binary_little_endian 1.0\nelement vertex "
                                     "4999999999999999999\nproperty float x\nproperty float y\n"
                                     "property float z\nend_header\n" +
                                         std::string(12, '\0'));
  expect_input_error([&] { read_point_cloud(ply); }, {ply, "4999999999999999999 points"});
  const std::string bad =
      write_file(d, "bad.pcd",
                 "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                 "WIDTH 1\nHEIGHT 1\nPOINTS 99999999999999999999999\nDATA binary\n");
  expect_input_error([&] { read_point_cloud(bad); }, {bad, "line 8", "is not a count"});
}

TEST(PointCloudReadersMalformed, PosesFileLines) {
  const std::string d = test::temp_dir("pc_poses_bad");
  ASSERT_EQ(pcl::io::savePCDFileBinary(d + "/0.pcd", random_cloud(5, 9)), 0);
  const std::string short_pose =
      write_file(d, "short.txt", "0.pcd 1 0 0 0 0 1 0 0 0 0 1 0\n0.pcd 1 0\n");
  expect_input_error([&] { read_dataset(short_pose); }, {short_pose, "line 2", "12 numbers"});
  const std::string nan_pose = write_file(d, "nan.txt", "0.pcd 1 0 0 nan 0 1 0 0 0 0 1 0\n");
  expect_input_error([&] { read_dataset(nan_pose); }, {nan_pose, "line 1", "'nan'"});
  const std::string missing = write_file(d, "missing.txt", "9.pcd 1 0 0 0 0 1 0 0 0 0 1 0\n");
  expect_input_error([&] { read_dataset(missing); }, {missing, "line 1", "9.pcd"});
  // A name the system refuses to look up (longer than NAME_MAX; found by fuzz_point_cloud_poses,
  // where the lookup threw the filesystem library's own exception).
  const std::string too_long =
      write_file(d, "long.txt", std::string(300, 'm') + ".pcd 1 0 0 0 0 1 0 0 0 0 1 0\n");
  expect_input_error([&] { read_dataset(too_long); }, {too_long, "line 1", "cannot look up"});
}
