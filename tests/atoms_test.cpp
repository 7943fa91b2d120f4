// Sectors and dictionary atoms (SPEC section 4, steps 1 and 8).
#include <gtest/gtest.h>

#include <cmath>

#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"
#include "potmap/pot/atoms.hpp"

namespace potmap {
namespace {

LabelledPoints ring(int dim, int n, double radius, const std::array<double, 3>& c) {
  LabelledPoints lp;
  lp.dim = dim;
  for (int i = 0; i < n; ++i) {
    const double a = (i + 0.5) * 2 * test::kPi / n;
    lp.position.push_back(c[0] + radius * std::cos(a));
    lp.position.push_back(c[1] + radius * std::sin(a));
    if (dim == 3) lp.position.push_back(c[2] + 0.1 * i);
    lp.label.push_back(i % 2);
    lp.scan.push_back(0);
  }
  return lp;
}

TEST(Sectors, AssignsByBearingFromTheHeadingAndCentresAndScales) {
  const std::array<double, 3> sensor{100, -50, 0};
  const LabelledPoints lp = ring(2, 40, 10, sensor);
  SectorOptions o;
  o.sectors = 4;
  o.max_range = 20;
  o.scale = 0.5;
  o.min_samples = 1;
  // Heading pi/2: sector 0 covers world bearings pi/2 to pi.
  const auto secs = cut_sectors(lp, sensor, test::kPi / 2, o);
  ASSERT_EQ(secs.size(), 4u);
  for (const Sector& s : secs) {
    EXPECT_EQ(s.num_hits() + s.num_free(), 10u);
    EXPECT_EQ(s.num_hits(), 5u);
    // Hits average to zero in the sector frame (centred on the hit centroid).
    double mx = 0, my = 0;
    for (std::size_t i = 0; i < s.num_hits(); ++i) {
      mx += s.hits[2 * i];
      my += s.hits[2 * i + 1];
    }
    EXPECT_NEAR(mx, 0, 1e-9);
    EXPECT_NEAR(my, 0, 1e-9);
    // The centre lies in the sector's quadrant.
    const double a = std::atan2(s.centre[1] - sensor[1], s.centre[0] - sensor[0]) - test::kPi / 2;
    const double wrapped = a - 2 * test::kPi * std::floor(a / (2 * test::kPi));
    EXPECT_EQ(static_cast<int>(wrapped / (test::kPi / 2)), s.index);
    // Scaled: a point 10 m from the sensor is at most 20 m from the centre, times 0.5.
    for (double v : s.free) EXPECT_LE(std::abs(v), 10.0 + 1e-9);
  }
}

TEST(Sectors, DropsPointsBeyondRangeAndSmallSectors) {
  const std::array<double, 3> sensor{0, 0, 0};
  LabelledPoints lp = ring(2, 8, 5, sensor);
  const LabelledPoints far = ring(2, 8, 50, sensor);
  lp.position.insert(lp.position.end(), far.position.begin(), far.position.end());
  lp.label.insert(lp.label.end(), far.label.begin(), far.label.end());
  lp.scan.insert(lp.scan.end(), far.scan.begin(), far.scan.end());
  SectorOptions o;
  o.sectors = 2;
  o.max_range = 20;
  o.min_samples = 4;
  auto secs = cut_sectors(lp, sensor, 0, o);
  ASSERT_EQ(secs.size(), 2u);
  EXPECT_EQ(secs[0].num_hits() + secs[0].num_free(), 4u);
  o.min_samples = 5;
  EXPECT_TRUE(cut_sectors(lp, sensor, 0, o).empty());
}

TEST(Sectors, FreeCentroidWhenNoHits) {
  const std::array<double, 3> sensor{0, 0, 0};
  LabelledPoints lp = ring(3, 12, 5, sensor);
  for (auto& y : lp.label) y = 0;
  SectorOptions o;
  o.sectors = 1;
  o.max_range = 20;
  const auto secs = cut_sectors(lp, sensor, 0, o);
  ASSERT_EQ(secs.size(), 1u);
  EXPECT_EQ(secs[0].num_hits(), 0u);
  EXPECT_NEAR(secs[0].centre[2], 0.55, 1e-12);  // mean of 0.1 i, i < 12
}

TEST(Sectors, RejectsBadOptions) {
  const LabelledPoints lp = ring(2, 8, 5, {0, 0, 0});
  SectorOptions o;
  o.max_range = 0;
  EXPECT_THROW(cut_sectors(lp, {0, 0, 0}, 0, o), ArgumentError);
  o.max_range = 10;
  o.sectors = 0;
  EXPECT_THROW(cut_sectors(lp, {0, 0, 0}, 0, o), ArgumentError);
  o.sectors = 3;
  o.scale = -1;
  EXPECT_THROW(cut_sectors(lp, {0, 0, 0}, 0, o), ArgumentError);
}

TEST(Dictionary, AtomsHoldTheKernelsOfTheirSectorInTheSectorFrame) {
  SimOptions so;
  so.scans = 3;
  so.spacing = 4;
  const Simulation sim = simulate(Town::builtin("town1"), so);
  // One kernel every 2 m over the route's surroundings, each weight tagging its index.
  KernelMap map;
  map.dim = 2;
  const auto o = sim.scans[0].origin();
  for (int i = -15; i <= 15; ++i)
    for (int j = -15; j <= 15; ++j) {
      const double p[2] = {o[0] + 2.0 * i, o[1] + 2.0 * j};
      map.push_back(p, 1.0, static_cast<double>(map.size()), 1.0);
    }
  Dictionary dict;
  DictionaryOptions opt;
  opt.source = "town1-sim";
  build_dictionary(sim.scans, map, opt, dict);
  ASSERT_FALSE(dict.empty());
  EXPECT_EQ(dict.dim, 2);
  EXPECT_DOUBLE_EQ(dict.max_range, 20);
  std::size_t kernels_scan0 = 0;
  for (const Atom& a : dict.atoms) {
    EXPECT_EQ(a.source, "town1-sim");
    const Sector& s = a.sector;
    for (std::size_t k = 0; k < a.kernels.size(); ++k) {
      // Back in the world frame the kernel is the map's kernel with that weight tag.
      const auto m = static_cast<std::size_t>(a.kernels.w_mean[k]);
      for (int d = 0; d < 2; ++d)
        EXPECT_NEAR(a.kernels.position[2 * k + d] / s.scale + s.centre[d], map.position[2 * m + d],
                    1e-9);
      const double dx = map.position[2 * m] - s.sensor[0],
                   dy = map.position[2 * m + 1] - s.sensor[1];
      EXPECT_LE(dx * dx + dy * dy, 400 + 1e-9);
    }
    if (a.scan_index == 0) kernels_scan0 += a.kernels.size();
  }
  // Scan 0's sectors cover the whole 20 m disc around its sensor (every sector has samples).
  std::size_t in_disc = 0;
  for (std::size_t m = 0; m < map.size(); ++m) {
    const double dx = map.position[2 * m] - o[0], dy = map.position[2 * m + 1] - o[1];
    in_disc += dx * dx + dy * dy <= 400;
  }
  EXPECT_EQ(kernels_scan0, in_disc);
}

TEST(Dictionary, RejectsMixedDimensionsAndScales) {
  SimOptions so;
  so.scans = 1;
  const Simulation sim = simulate(Town::builtin("town1"), so);
  KernelMap map3;
  map3.dim = 3;
  const double p[3] = {0, 0, 0};
  map3.push_back(p, 1, 1, 1);
  Dictionary dict;
  EXPECT_THROW(build_dictionary(sim.scans, map3, {}, dict), ArgumentError);
  KernelMap map2;
  map2.dim = 2;
  const auto o = sim.scans[0].origin();
  const double near[2] = {o[0] + 1, o[1] + 0.5};
  map2.push_back(near, 1, 1, 1);
  build_dictionary(sim.scans, map2, {}, dict);
  ASSERT_EQ(dict.size(), 1u);
  DictionaryOptions other;
  other.sectors.scale = 0.1;
  EXPECT_THROW(build_dictionary(sim.scans, map2, other, dict), ArgumentError);
}

}  // namespace
}  // namespace potmap
