// ROS map export (io/ros_map.hpp), read back the way nav2's map loader reads a map.yaml.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "potmap/error.hpp"
#include "potmap/io/ros_map.hpp"
#include "potmap/map/evaluate.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

// What nav2's loader produces: an OccupancyGrid, row 0 at the bottom (the origin's row).
struct LoadedGrid {
  std::map<std::string, std::string> yaml;
  double resolution = 0, origin[3] = {0, 0, 0}, occupied_thresh = 0, free_thresh = 0;
  int negate = -1;
  std::string mode;
  std::size_t width = 0, height = 0;
  std::vector<std::uint8_t> pixels;  // as in the file, top row first
  std::vector<int> data;             // -1 unknown, 0 free, 100 occupied (trinary)
};

std::string trim(std::string s) {
  while (!s.empty() && (s.back() == ' ' || s.back() == '\r')) s.pop_back();
  std::size_t b = 0;
  while (b < s.size() && s[b] == ' ') ++b;
  return s.substr(b);
}

LoadedGrid load_like_nav2(const std::string& yaml_path) {
  LoadedGrid g;
  std::ifstream y(yaml_path);
  std::string line;
  while (std::getline(y, line)) {
    const auto c = line.find(':');
    if (c == std::string::npos) continue;
    g.yaml[trim(line.substr(0, c))] = trim(line.substr(c + 1));
  }
  for (const char* key :
       {"image", "mode", "resolution", "origin", "negate", "occupied_thresh", "free_thresh"})
    EXPECT_EQ(g.yaml.count(key), 1u) << "missing " << key;
  g.resolution = std::stod(g.yaml["resolution"]);
  g.occupied_thresh = std::stod(g.yaml["occupied_thresh"]);
  g.free_thresh = std::stod(g.yaml["free_thresh"]);
  g.negate = std::stoi(g.yaml["negate"]);
  g.mode = g.yaml["mode"];
  std::string o = g.yaml["origin"];
  EXPECT_EQ(o.front(), '[');
  EXPECT_EQ(o.back(), ']');
  std::istringstream os(o.substr(1, o.size() - 2));
  for (double& v : g.origin) {
    std::string part;
    std::getline(os, part, ',');
    v = std::stod(part);
  }
  // The image, relative to the YAML's folder.
  const std::string pgm_path =
      (std::filesystem::path(yaml_path).parent_path() / g.yaml["image"]).string();
  std::ifstream p(pgm_path, std::ios::binary);
  std::string magic;
  p >> magic;
  EXPECT_EQ(magic, "P5");
  auto next_number = [&p]() {
    p >> std::ws;
    while (p.peek() == '#') {
      std::string comment;
      std::getline(p, comment);
      p >> std::ws;
    }
    std::size_t v = 0;
    p >> v;
    return v;
  };
  g.width = next_number();
  g.height = next_number();
  EXPECT_EQ(next_number(), 255u);
  p.get();  // the single whitespace before the pixels
  g.pixels.resize(g.width * g.height);
  p.read(reinterpret_cast<char*>(g.pixels.data()), static_cast<std::streamsize>(g.pixels.size()));
  EXPECT_EQ(static_cast<std::size_t>(p.gcount()), g.pixels.size());
  g.data.assign(g.pixels.size(), -1);
  for (std::size_t row = 0; row < g.height; ++row)
    for (std::size_t x = 0; x < g.width; ++x) {
      const double v = g.pixels[x + g.width * row];
      const double occ = g.negate ? v / 255.0 : (255.0 - v) / 255.0;
      int value = -1;
      if (occ > g.occupied_thresh)
        value = 100;
      else if (occ < g.free_thresh)
        value = 0;
      else if (g.mode == "scale")
        value = static_cast<int>(99 * (occ - g.free_thresh) / (g.occupied_thresh - g.free_thresh));
      g.data[x + g.width * (g.height - row - 1)] = value;
    }
  return g;
}

// Occupied wall at (0, 0), free space at (4, 0), a kernel no sample reached (prior variance) at
// (0, 4), an undecided kernel at (4, 4); nothing near (6, 8).
KernelMap test_map() {
  KernelMap m;
  const double pts[4][2] = {{0, 0}, {4, 0}, {0, 4}, {4, 4}};
  m.push_back(pts[0], 4.0, 5.0, 0.1);
  m.push_back(pts[1], 4.0, -5.0, 0.1);
  m.push_back(pts[2], 4.0, 0.0, 10.0);
  m.push_back(pts[3], 4.0, 0.3, 0.1);
  return m;
}

RosMapOptions test_options() {
  RosMapOptions o;
  o.resolution = 0.1;
  o.xmin = -2;
  o.xmax = 6;
  o.ymin = -2;
  o.ymax = 8;
  return o;
}

// The class the documented rule gives at a point, computed here from the exact sums.
int expected_class(const KernelMap& map, double x, double y, const RosMapOptions& o) {
  const double pt[2] = {x, y};
  const MapValuesExact v = evaluate_exact(map, pt, 1);
  KernelMap unit = map;
  unit.w_mean.assign(map.size(), 0.0);
  unit.w_var.assign(map.size(), 1.0);
  const double support = evaluate_exact(unit, pt, 1).var[0];
  if (support < o.known.min_support || v.var[0] / support >= o.known.unknown_variance) return -1;
  if (v.prob[0] > o.occupied_thresh) return 100;
  if (v.prob[0] < o.free_thresh) return 0;
  return -1;
}

int cell_at(const LoadedGrid& g, double x, double y) {
  const auto i = static_cast<std::size_t>(std::floor((x - g.origin[0]) / g.resolution));
  const auto j = static_cast<std::size_t>(std::floor((y - g.origin[1]) / g.resolution));
  return g.data[i + g.width * j];
}

}  // namespace

TEST(RosMap, Nav2ReadsTheCellsTheOriginAndTheThresholds) {
  const std::string dir = test::temp_dir("ros_map");
  const KernelMap map = test_map();
  const RosMapOptions o = test_options();
  const RosMapSummary s = write_ros_map(nullptr, map, dir + "/map.yaml", o);
  const LoadedGrid g = load_like_nav2(dir + "/map.yaml");
  EXPECT_EQ(g.yaml.at("image"), "map.pgm");
  EXPECT_EQ(g.mode, "trinary");
  EXPECT_EQ(g.negate, 0);
  EXPECT_DOUBLE_EQ(g.resolution, 0.1);
  EXPECT_DOUBLE_EQ(g.occupied_thresh, 0.65);
  EXPECT_DOUBLE_EQ(g.free_thresh, 0.196);
  EXPECT_DOUBLE_EQ(g.origin[0], -2.0);
  EXPECT_DOUBLE_EQ(g.origin[1], -2.0);
  EXPECT_DOUBLE_EQ(g.origin[2], 0.0);
  ASSERT_EQ(g.width, 80u);
  ASSERT_EQ(g.height, 100u);
  EXPECT_EQ(s.width, g.width);
  EXPECT_EQ(s.height, g.height);

  EXPECT_EQ(cell_at(g, 0.05, 0.05), 100);  // the wall
  EXPECT_EQ(cell_at(g, 4.05, 0.05), 0);    // free space
  EXPECT_EQ(cell_at(g, 0.05, 4.05), -1);   // prior variance: never observed
  EXPECT_EQ(cell_at(g, 4.05, 4.05), -1);   // p between the thresholds
  EXPECT_EQ(cell_at(g, 5.95, 7.95), -1);   // no kernel reaches
  // Row 0 of the file is the top of the window (y near 8), as map_server expects.
  EXPECT_EQ(g.pixels[0], 205);

  std::size_t counts[3] = {0, 0, 0};
  for (std::size_t j = 0; j < g.height; ++j)
    for (std::size_t i = 0; i < g.width; ++i) {
      const double x = g.origin[0] + (i + 0.5) * g.resolution;
      const double y = g.origin[1] + (j + 0.5) * g.resolution;
      const int got = g.data[i + g.width * j];
      ASSERT_EQ(got, expected_class(map, x, y, o)) << "cell " << i << ", " << j;
      ++counts[got == -1 ? 0 : got == 0 ? 1 : 2];
    }
  EXPECT_EQ(s.unknown, counts[0]);
  EXPECT_EQ(s.free, counts[1]);
  EXPECT_EQ(s.occupied, counts[2]);
  EXPECT_GT(s.occupied, 10u);
  EXPECT_GT(s.free, 10u);
}

TEST(RosMap, DeviceAgreesWithTheExactSum) {
  const std::string dir = test::temp_dir("ros_map_device");
  const KernelMap map = test_map();
  const RosMapOptions o = test_options();
  write_ros_map(nullptr, map, dir + "/exact.yaml", o);
  write_ros_map(&test::context(), map, dir + "/device.yaml", o);
  const LoadedGrid a = load_like_nav2(dir + "/exact.yaml");
  const LoadedGrid b = load_like_nav2(dir + "/device.yaml");
  ASSERT_EQ(a.data.size(), b.data.size());
  std::size_t differ = 0;
  for (std::size_t c = 0; c < a.data.size(); ++c) differ += a.data[c] != b.data[c];
  // Only a cell within float rounding of a threshold may fall the other way.
  EXPECT_LE(differ, 2u);
}

TEST(RosMap, ScaleModeWritesTheProbabilityAndMarksUnknownUncertain) {
  const std::string dir = test::temp_dir("ros_map_scale");
  const KernelMap map = test_map();
  RosMapOptions o = test_options();
  o.mode = RosMapMode::scale;
  write_ros_map(nullptr, map, dir + "/map.yaml", o);
  const LoadedGrid g = load_like_nav2(dir + "/map.yaml");
  EXPECT_EQ(g.mode, "scale");
  const double wall[2] = {0.05, 0.05};
  const double p = evaluate_exact(map, wall, 1).prob[0];
  const std::size_t i = 20, j = 20;  // the cell of (0.05, 0.05)
  EXPECT_EQ(g.pixels[i + g.width * (g.height - 1 - j)], std::lround(255 * (1 - p)));
  EXPECT_EQ(g.pixels[g.width - 1], 128);  // top right: no support
}

TEST(RosMap, RefusesBadThresholdsAndEmptyWindows) {
  const std::string dir = test::temp_dir("ros_map_bad");
  RosMapOptions o = test_options();
  o.free_thresh = 0.7;
  o.occupied_thresh = 0.6;
  EXPECT_THROW(write_ros_map(nullptr, test_map(), dir + "/a.yaml", o), ArgumentError);
  o = test_options();
  o.xmax = o.xmin;
  EXPECT_THROW(write_ros_map(nullptr, test_map(), dir + "/b.yaml", o), ArgumentError);
  EXPECT_THROW(write_ros_map(nullptr, KernelMap{}, dir + "/c.yaml", RosMapOptions{}),
               ArgumentError);
  EXPECT_FALSE(std::filesystem::exists(dir + "/a.yaml"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/a.pgm"));
}

TEST(RosMap, WithoutAWindowTheImageCoversTheKnownCellsAndAMargin) {
  const std::string dir = test::temp_dir("ros_map_auto");
  KernelMap map = test_map();
  const double far[2] = {20, 20};
  map.push_back(far, 4.0, 0.0, 10.0);  // a tile no scan reached: stretches the kernel bounds
  RosMapOptions o;
  o.resolution = 0.1;
  const RosMapSummary s = write_ros_map(nullptr, map, dir + "/map.yaml", o);
  const LoadedGrid g = load_like_nav2(dir + "/map.yaml");
  // Known cells lie within 0.54 m (support 0.1 at gamma 4) of the wall, the free kernel and
  // the kernel at (4, 4): about [-0.6, 4.6] on both axes, widened by 1 m, and cut at the
  // kernels' bounds widened by 1 m on the low side.
  EXPECT_NEAR(g.origin[0], -1.0, 1e-9);
  EXPECT_NEAR(g.origin[1], -1.0, 1e-9);
  EXPECT_NEAR(g.origin[0] + g.width * g.resolution, 5.6, 0.11);
  EXPECT_NEAR(g.origin[1] + g.height * g.resolution, 5.6, 0.11);
  EXPECT_EQ(s.width, g.width);
  // The cells keep their places: the wall is still at (0, 0).
  EXPECT_EQ(cell_at(g, 0.05, 0.05), 100);
  EXPECT_EQ(cell_at(g, 4.05, 0.05), 0);
}
