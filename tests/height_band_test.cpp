// Height bands: the levels, the reduction rule, the device's band maximum against the exact
// reference and against the CPU reduction of the device's own levels, and bad arguments.
#include "potmap/map/height_band.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

// Kernels over 20 x 20 m and 0 to 3 m high, widths over a factor of 10: a band sees several
// kernels at different heights in most columns.
KernelMap band_map(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(0, 20), z(0, 3), lg(std::log(0.5), std::log(5.0)),
      w(-6, 6), lv(std::log(1e-3), std::log(10.0));
  KernelMap map;
  map.dim = 3;
  for (int k = 0; k < 400; ++k) {
    const double p[3] = {xy(rng), xy(rng), z(rng)};
    map.push_back(p, std::exp(lg(rng)), w(rng), std::exp(lv(rng)));
  }
  map.has_bias = true;
  map.bias_mean = -0.5;
  map.bias_var = 0.5;
  return map;
}

// 2D columns over the map, 0.25 m cells, not a whole number of device tiles on either axis.
GridSpec columns() {
  GridSpec g;
  g.dim = 3;
  g.resolution = 0.25;
  g.origin[0] = -0.3;
  g.origin[1] = 0.1;
  g.count[0] = 83;
  g.count[1] = 77;
  return g;
}

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

}  // namespace

TEST(HeightBand, LevelsIncludeBothEndsAndStepAtMostTheAskedOne) {
  const std::vector<double> z = height_band_levels(-1.0, 1.5, 0.1);
  ASSERT_EQ(z.size(), 26u);
  EXPECT_DOUBLE_EQ(z.front(), -1.0);
  EXPECT_DOUBLE_EQ(z.back(), 1.5);
  EXPECT_NEAR(z[1] - z[0], 0.1, 1e-12);
  const std::vector<double> z2 = height_band_levels(0.0, 1.0, 0.3);  // 4 gaps of 0.25
  ASSERT_EQ(z2.size(), 5u);
  EXPECT_DOUBLE_EQ(z2[1], 0.25);
  EXPECT_EQ(height_band_levels(0.7, 0.7, 0.1), std::vector<double>{0.7});
  EXPECT_THROW(height_band_levels(1.0, 0.0, 0.1), ArgumentError);
  EXPECT_THROW(height_band_levels(0.0, 1.0, 0.0), ArgumentError);
  EXPECT_THROW(height_band_levels(0.0, NAN, 0.1), ArgumentError);
  EXPECT_THROW(height_band_levels(0.0, 1000.0, 0.01), ArgumentError);  // 100001 levels
}

TEST(HeightBand, DefaultStepIsTheNarrowestKernelsDeviation) {
  KernelMap m;
  m.dim = 3;
  const double p[3] = {0, 0, 0};
  m.push_back(p, 2.0, 1.0, 1.0);
  m.push_back(p, 8.0, 1.0, 1.0);
  EXPECT_DOUBLE_EQ(default_band_step(m), 0.25);  // 1 / sqrt(2 * 8)
  EXPECT_DOUBLE_EQ(default_band_step(KernelMap{}), 0.1);
}

TEST(HeightBand, RuleKeepsTheFirstMaximumAndNaN) {
  const float prob[] = {0.2f, 0.7f, 0.1f,   // level 0
                        0.7f, 0.7f, kNaN,   // level 1
                        0.9f, 0.7f, 0.9f};  // level 2
  const float var[] = {1, 2, 3, 4, 5, 6, 7, 8, 9};
  const float mean[] = {-1, -2, -3, -4, -5, -6, -7, -8, -9};
  float p[3], v[3], m[3];
  reduce_band_max(prob, var, mean, 3, 3, p, v, m);
  EXPECT_EQ(p[0], 0.9f);
  EXPECT_EQ(v[0], 7.0f);
  EXPECT_EQ(m[0], -7.0f);
  EXPECT_EQ(p[1], 0.7f);  // a tie keeps the lowest level
  EXPECT_EQ(v[1], 2.0f);
  EXPECT_TRUE(std::isnan(p[2]));  // a NaN level makes the column NaN, whatever comes after
  EXPECT_EQ(v[2], 6.0f);
  reduce_band_max(prob, var, nullptr, 0, 3, p, v, nullptr);
  EXPECT_TRUE(std::isnan(p[0]));
}

TEST(HeightBand, DeviceMatchesTheExactReference) {
  const KernelMap map = band_map(21);
  const GridSpec g = columns();
  const std::vector<double> levels = height_band_levels(0.2, 2.6, 0.2);
  ASSERT_EQ(levels.size(), 13u);  // two blocks of 8 levels, the second padded
  MapEvaluator ev(test::context(), map);
  const std::size_t n = g.count[0] * g.count[1];
  std::vector<float> mean(n), var(n), prob(n);
  ev.evaluate_band_max(g, levels, mean.data(), var.data(), prob.data());
  EXPECT_GT(ev.last_pairs(), 0u);
  const MapValuesExact band = evaluate_band_exact(map, g, levels);
  // Each level: exact values, to find the levels whose probability ties the maximum.
  std::vector<MapValuesExact> level(levels.size());
  for (std::size_t k = 0; k < levels.size(); ++k)
    level[k] = evaluate_band_exact(map, g, {levels[k]});
  double worst_p = 0;
  std::size_t spread = 0;  // columns whose levels differ by more than 0.05
  for (std::size_t c = 0; c < n; ++c) {
    ASSERT_TRUE(std::isfinite(prob[c])) << c;
    worst_p = std::max(worst_p, std::abs(prob[c] - band.prob[c]));
    // The variance and mean are those of a level at the maximum (to the device's accuracy).
    bool found = false;
    double lo = 1, hi = 0;
    for (std::size_t k = 0; k < levels.size(); ++k) {
      lo = std::min(lo, level[k].prob[c]);
      hi = std::max(hi, level[k].prob[c]);
      if (std::abs(level[k].prob[c] - band.prob[c]) > 2e-6) continue;
      found = found || (std::abs(var[c] - level[k].var[c]) <= 1e-5 * (1 + level[k].var[c]) &&
                        std::abs(mean[c] - level[k].mean[c]) <= 1e-5 * (1 + std::abs(mean[c])));
    }
    ASSERT_TRUE(found) << "column " << c << ": var " << var[c] << ", exact " << band.var[c];
    spread += hi - lo > 0.05;
  }
  EXPECT_LT(worst_p, 1e-6);
  EXPECT_GT(spread, n / 4) << "the band should differ from its levels in many columns";
}

TEST(HeightBand, DeviceReductionMatchesTheCpuReductionOfItsLevels) {
  const KernelMap map = band_map(22);
  const GridSpec g = columns();
  const std::vector<double> levels = height_band_levels(0.0, 3.0, 0.25);
  MapEvaluator ev(test::context(), map);
  const std::size_t n = g.count[0] * g.count[1], nz = levels.size();
  std::vector<float> mean(n), var(n), prob(n);
  ev.evaluate_band_max(g, levels, mean.data(), var.data(), prob.data());
  // The device's levels one at a time, stacked, reduced on the CPU.
  std::vector<float> lm(n * nz), lv(n * nz), lp(n * nz);
  for (std::size_t k = 0; k < nz; ++k)
    ev.evaluate_band_max(g, {levels[k]}, &lm[k * n], &lv[k * n], &lp[k * n]);
  std::vector<float> rm(n), rv(n), rp(n);
  reduce_band_max(lp.data(), lv.data(), lm.data(), nz, n, rp.data(), rv.data(), rm.data());
  std::size_t clear = 0;
  for (std::size_t c = 0; c < n; ++c) {
    ASSERT_NEAR(prob[c], rp[c], 1e-6) << c;
    // Where the best level is clear, it is the same level: the same variance and mean.
    float second = -1;
    for (std::size_t k = 0; k < nz; ++k)
      if (lp[k * n + c] < rp[c]) second = std::max(second, lp[k * n + c]);
    if (rp[c] - second < 1e-5) continue;
    ++clear;
    ASSERT_NEAR(var[c], rv[c], 1e-5 * (1 + rv[c])) << c;
    ASSERT_NEAR(mean[c], rm[c], 1e-5 * (1 + std::abs(rm[c]))) << c;
  }
  EXPECT_GT(clear, n * 9 / 10);
}

TEST(HeightBand, SmallLaunchesGiveTheSameValues) {
  const KernelMap map = band_map(23);
  const GridSpec g = columns();
  const std::vector<double> levels = height_band_levels(0.0, 2.0, 0.1);  // 21 levels
  MapEvaluator whole(test::context(), map);
  EvalOptions small;
  small.cells_per_launch = 1;  // one row of blocks (every level) a launch
  MapEvaluator pieces(test::context(), map, small);
  const std::size_t n = g.count[0] * g.count[1];
  std::vector<float> va(n), pa(n), vb(n), pb(n);
  whole.evaluate_band_max(g, levels, nullptr, va.data(), pa.data());
  pieces.evaluate_band_max(g, levels, nullptr, vb.data(), pb.data());
  for (std::size_t c = 0; c < n; ++c) {
    ASSERT_EQ(pa[c], pb[c]) << c;
    ASSERT_EQ(va[c], vb[c]) << c;
  }
}

TEST(HeightBand, BadArgumentsAreNamed) {
  KernelMap flat;
  flat.dim = 2;
  const double p[2] = {0, 0};
  flat.push_back(p, 1.0, 1.0, 1.0);
  MapEvaluator ev2(test::context(), flat);
  GridSpec g = columns();
  float out[1];
  EXPECT_THROW(ev2.evaluate_band_max(g, {0.0}, nullptr, nullptr, out), ArgumentError);
  const KernelMap map = band_map(24);
  MapEvaluator ev(test::context(), map);
  EXPECT_THROW(ev.evaluate_band_max(g, {0.0, NAN}, nullptr, nullptr, out), ArgumentError);
  g.count[0] = 0;
  EXPECT_NO_THROW(ev.evaluate_band_max(g, {0.0}, nullptr, nullptr, nullptr));  // nothing to do
  EXPECT_NO_THROW(ev.evaluate_band_max(columns(), {}, nullptr, nullptr, nullptr));
}
