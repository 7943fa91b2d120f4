#include "potmap/data/simulator.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>

#include "potmap/error.hpp"
#include "test_support.hpp"

using namespace potmap;

TEST(Simulator, DeterministicBySeed) {
  const Town t = Town::builtin("town1", 3);
  SimOptions o;
  o.scans = 5;
  const Simulation a = simulate(t, o), b = simulate(Town::builtin("town1", 3), o);
  EXPECT_EQ(a.scans[4].hits, b.scans[4].hits);
  o.seed = 9;
  const Simulation c = simulate(t, o);
  EXPECT_NE(a.route, c.route);
}

TEST(Simulator, BuiltinTownsDiffer) {
  const Town a = Town::builtin("town1"), b = Town::builtin("town2"), c = Town::builtin("town3");
  EXPECT_NE(a.obstacles().size(), b.obstacles().size());
  EXPECT_NE(b.obstacles().size(), c.obstacles().size());
  EXPECT_NE(a.width(), c.width());
  EXPECT_THROW(Town::builtin("town9"), Error);
}

// The ray caster and the occupancy query are separate code paths: a hit must sit on a surface,
// free just before it and occupied just behind it.
TEST(Simulator, HitsLieOnObstacleSurfaces) {
  const Town t = Town::builtin("town3", 1);
  SimOptions o;
  o.scans = 20;
  o.spacing = 3;
  const Simulation s = simulate(t, o);
  std::size_t checked = 0, inside_behind = 0;
  for (const Scan& sc : s.scans) {
    EXPECT_EQ(sc.num_beams(), 360u);
    for (std::size_t i = 0; i < sc.num_hits(); i += 7) {
      const double hx = sc.hits[2 * i], hy = sc.hits[2 * i + 1];
      const double dx = hx - sc.pose2d[0], dy = hy - sc.pose2d[1], r = std::hypot(dx, dy);
      EXPECT_LE(r, 20 + 1e-9);
      EXPECT_FALSE(t.occupied(hx - 0.02 * dx / r, hy - 0.02 * dy / r));
      // A ray grazing a pole or a corner leaves the obstacle within 2 cm: allow a few of those.
      inside_behind += t.occupied(hx + 0.02 * dx / r, hy + 0.02 * dy / r);
      ++checked;
    }
  }
  EXPECT_GT(checked, 100u);
  EXPECT_GE(inside_behind, checked * 98 / 100);
}

TEST(Simulator, ThreeDHasRingsAndGround) {
  const Town t = Town::builtin("town2");
  SimOptions o;
  o.scans = 2;
  o.three_d = true;
  o.channels = 16;
  const Simulation s = simulate(t, o);
  ASSERT_EQ(s.scans[0].dim, 3);
  EXPECT_EQ(s.scans[0].num_beams(), 16u * 360);
  std::size_t ground = 0;
  for (std::size_t i = 0; i < s.scans[0].num_hits(); ++i) {
    const double z = s.scans[0].hits[3 * i + 2];
    EXPECT_GT(z, -1e-6);
    if (std::fabs(z) < 1e-6) ++ground;
    // Just beyond a hit along its beam is inside something (an obstacle or the ground).
    const auto o3 = s.scans[0].origin();
    const double* h = &s.scans[0].hits[3 * i];
    const double d[3] = {h[0] - o3[0], h[1] - o3[1], h[2] - o3[2]};
    const double r = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    EXPECT_TRUE(t.occupied(h[0] + 0.02 * d[0] / r, h[1] + 0.02 * d[1] / r, h[2] + 0.02 * d[2] / r));
    EXPECT_FALSE(
        t.occupied(h[0] - 0.02 * d[0] / r, h[1] - 0.02 * d[1] / r, h[2] - 0.02 * d[2] / r));
  }
  EXPECT_GT(ground, 0u);  // lower rings reach the road within 20 m
}

TEST(Simulator, MovingVehiclesChangeTheScene) {
  const Town t = Town::builtin("town1");
  SimOptions o;
  o.scans = 30;
  const Simulation still = simulate(t, o);
  o.moving_vehicles = 10;
  const Simulation busy = simulate(t, o);
  EXPECT_EQ(still.route, busy.route);
  std::size_t differ = 0;
  for (std::size_t n = 0; n < 30; ++n) differ += still.scans[n].hits != busy.scans[n].hits;
  EXPECT_GT(differ, 0u);
  // Dynamic ground truth: 2 cm beyond every hit lies inside the town or a vehicle of that scan,
  // and some hits are on vehicles alone.
  ASSERT_EQ(busy.moving.size(), 30u);
  std::size_t hits = 0, inside = 0, on_vehicles = 0;
  for (std::size_t n = 0; n < 30; ++n) {
    const Scan& sc = busy.scans[n];
    const auto o3 = sc.origin();
    for (std::size_t i = 0; i < sc.num_hits(); ++i) {
      const double* h = &sc.hits[2 * i];
      const double dx = h[0] - o3[0], dy = h[1] - o3[1], r = std::hypot(dx, dy);
      const double x = h[0] + 0.02 * dx / r, y = h[1] + 0.02 * dy / r;
      ++hits;
      const bool with = t.occupied(x, y, &busy.moving[n]);
      inside += with;
      on_vehicles += with && !t.occupied(x, y);
    }
  }
  EXPECT_GT(inside, hits * 98 / 100);
  EXPECT_GT(on_vehicles, 0u);
}

TEST(Simulator, ThousandScans) {
  // Speed is measured in bench/data_bench.cpp, not here.
  const Town t = Town::builtin("town1");
  SimOptions o;
  o.scans = 1000;
  const Simulation s = simulate(t, o);
  EXPECT_EQ(s.scans.size(), 1000u);
  EXPECT_EQ(s.route.size(), 2000u);
}

TEST(Simulator, TwoDDatasetRoundTripsThroughTheCarmenReader) {
  const Town t = Town::builtin("town1", 2);
  SimOptions o;
  o.scans = 12;
  const Simulation s = simulate(t, o);
  const std::string dir = potmap::test::temp_dir("sim_roundtrip2d");
  const std::string log = write_simulation(s, o, dir);
  const Dataset back = read_carmen(log);
  ASSERT_EQ(back.scans.size(), 12u);
  for (std::size_t n = 0; n < 12; ++n) {
    ASSERT_EQ(back.scans[n].num_hits(), s.scans[n].num_hits());
    EXPECT_EQ(back.scans[n].num_no_return(), s.scans[n].num_no_return());
    EXPECT_DOUBLE_EQ(back.scans[n].max_range, 20);
    for (std::size_t i = 0; i < back.scans[n].hits.size(); ++i)
      ASSERT_NEAR(back.scans[n].hits[i], s.scans[n].hits[i], 1e-3);
  }
}

TEST(Simulator, ThreeDDatasetRoundTripsThroughTheKittiReaders) {
  const Town t = Town::builtin("town3", 2);
  SimOptions o;
  o.scans = 3;
  o.three_d = true;
  const Simulation s = simulate(t, o);
  const std::string dir = potmap::test::temp_dir("sim_roundtrip3d");
  const std::string poses = write_simulation(s, o, dir);
  const auto T = read_kitti_poses(poses, dir + "/calib.txt");
  ASSERT_EQ(T.size(), 3u);
  Scan f = read_kitti_bin(dir + "/velodyne/000002.bin", 20);
  apply_pose(f, T[2]);
  ASSERT_EQ(f.num_hits(), s.scans[2].num_hits());
  for (std::size_t i = 0; i < f.hits.size(); ++i) ASSERT_NEAR(f.hits[i], s.scans[2].hits[i], 1e-3);
}
