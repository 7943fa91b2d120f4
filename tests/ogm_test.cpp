#include "potmap/experiments/ogm.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "potmap/error.hpp"

using namespace potmap;

namespace {
// Sensor at (0.25, 0.25), a wall of hits at x = 5.25 over 90 degrees ahead, no-return beams
// behind (max range 20 m).
Scan wall_scan() {
  Scan s;
  s.dim = 2;
  s.max_range = 20;
  s.pose2d = {0.25, 0.25, 0};
  for (int i = -40; i <= 40; ++i) {
    const double a = i * M_PI / 180;
    s.hits.push_back(0.25 + 5.0);
    s.hits.push_back(0.25 + 5.0 * std::tan(a));
  }
  for (int i = 0; i < 90; ++i) {
    const double a = M_PI / 2 + i * M_PI / 90;
    s.no_return.push_back(std::cos(a));
    s.no_return.push_back(std::sin(a));
  }
  return s;
}

double at(const OccupancyGrid& g, double x, double y) {
  const double p[2] = {x, y};
  double out = -1;
  g.probability(p, 1, &out);
  return out;
}
}  // namespace

TEST(Ogm, HitsOccupiedRaysFreeUnknownHalf) {
  OgmOptions o;
  o.resolution = 0.5;
  OccupancyGrid g(2, o);
  for (int k = 0; k < 3; ++k) g.insert(wall_scan());
  EXPECT_GT(at(g, 5.25, 0.25), 0.8);  // the wall
  // Three misses of OctoMap's default 0.4 each: 1 / (1 + (0.6 / 0.4)^3).
  const double free3 = 1 / (1 + std::pow(1.5, 3));
  EXPECT_NEAR(at(g, 2.75, 0.25), free3, 1e-4);    // in front of it
  EXPECT_EQ(at(g, 7.25, 0.25), 0.5);              // behind it: never seen
  EXPECT_NEAR(at(g, -10.25, 0.25), free3, 1e-4);  // along a no-return beam, within range
  EXPECT_EQ(at(g, -25.25, 0.25), 0.5);            // past the maximum range
  EXPECT_GT(g.leaf_count(), 0u);
}

TEST(Ogm, MaxRangeOptionCutsRays) {
  OgmOptions o;
  o.resolution = 0.5;
  o.max_range = 8;
  OccupancyGrid g(2, o);
  g.insert(wall_scan());
  EXPECT_LT(at(g, -6.25, 0.25), 0.5);
  EXPECT_EQ(at(g, -12.25, 0.25), 0.5);
}

TEST(Ogm, ThreeDimensions) {
  Scan s;
  s.dim = 3;
  s.max_range = 30;
  s.pose3d = {1, 0, 0, 0.1, 0, 1, 0, 0.1, 0, 0, 1, 1.1};
  s.hits = {10.1, 0.1, 1.1};
  OccupancyGrid g(3, {});
  g.insert(s);
  const double hit[3] = {10.1, 0.1, 1.1}, mid[3] = {5.1, 0.1, 1.1}, off[3] = {5.1, 5.1, 1.1};
  double p[3];
  g.probability(hit, 1, p);
  g.probability(mid, 1, p + 1);
  g.probability(off, 1, p + 2);
  EXPECT_GT(p[0], 0.5);
  EXPECT_LT(p[1], 0.5);
  EXPECT_EQ(p[2], 0.5);
}

TEST(Ogm, BadOptionsAndMismatchedScans) {
  OgmOptions o;
  o.resolution = 0;
  EXPECT_THROW(OccupancyGrid(2, o), ArgumentError);
  EXPECT_THROW(OccupancyGrid(4, {}), ArgumentError);
  OccupancyGrid g(3, {});
  EXPECT_THROW(g.insert(wall_scan()), ArgumentError);
}
