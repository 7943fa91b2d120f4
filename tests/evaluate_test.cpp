#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

// Widths log-uniform over two orders of magnitude, so that reaches differ by a factor of 10.
KernelMap random_map(int dim, std::size_t m, double extent, std::uint32_t seed, bool bias = false) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(0, extent), lg(std::log(0.01), std::log(1.0)),
      w(-10, 10), lv(std::log(1e-6), std::log(1e4));
  KernelMap map;
  map.dim = dim;
  for (std::size_t k = 0; k < m; ++k) {
    double p[3] = {pos(rng), pos(rng), pos(rng) * 0.3};
    map.push_back(p, std::exp(lg(rng)), w(rng), std::exp(lv(rng)));
  }
  map.has_bias = bias;
  map.bias_mean = -0.3;
  map.bias_var = 2.0;
  return map;
}

std::vector<double> random_points(int dim, std::size_t n, double lo, double hi,
                                  std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(lo, hi);
  std::vector<double> p(dim * n);
  for (std::size_t i = 0; i < n; ++i)
    for (int d = 0; d < dim; ++d) p[i * dim + d] = u(rng) * (d == 2 ? 0.3 : 1.0);
  return p;
}

struct Worst {
  double dp = 0, dmean_rel = 0, dvar_rel = 0;
};

// Compares device values with the exact reference; mean and var relative to their scale.
Worst compare(const KernelMap& map, const std::vector<double>& pts, const MapValues& got) {
  const std::size_t n = pts.size() / map.dim;
  const MapValuesExact ref = evaluate_exact(map, pts.data(), n);
  Worst w;
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_TRUE(std::isfinite(got.prob[i])) << "point " << i;
    w.dp = std::max(w.dp, std::abs(got.prob[i] - ref.prob[i]));
    w.dmean_rel =
        std::max(w.dmean_rel, std::abs(got.mean[i] - ref.mean[i]) / (1 + std::abs(ref.mean[i])));
    w.dvar_rel = std::max(w.dvar_rel, std::abs(got.var[i] - ref.var[i]) / (1 + ref.var[i]));
  }
  return w;
}

}  // namespace

TEST(MapEval, Random2DMatchesExactReference) {
  KernelMap map = random_map(2, 3000, 100, 1);
  MapEvaluator ev(test::context(), map);
  const auto pts = random_points(2, 20000, -20, 120, 2);
  const Worst w = compare(map, pts, ev.evaluate(pts));
  EXPECT_LT(w.dp, 1e-6);
  EXPECT_LT(w.dmean_rel, 1e-5);
  EXPECT_LT(w.dvar_rel, 1e-5);
}

TEST(MapEval, Random3DWithBiasMatchesExactReference) {
  KernelMap map = random_map(3, 2000, 60, 3, true);
  MapEvaluator ev(test::context(), map);
  const auto pts = random_points(3, 8000, -10, 70, 4);
  const Worst w = compare(map, pts, ev.evaluate(pts));
  EXPECT_LT(w.dp, 1e-6);
  EXPECT_LT(w.dmean_rel, 1e-5);
  EXPECT_LT(w.dvar_rel, 1e-5);
}

TEST(MapEval, FarFrameKeepsPrecision) {
  // A map in UTM-like coordinates: float positions alone would be off by centimetres here.
  KernelMap map = random_map(2, 1500, 80, 5);
  for (std::size_t k = 0; k < map.size(); ++k) {
    map.position[2 * k] += 512345.0;
    map.position[2 * k + 1] += 5412345.0;
  }
  auto pts = random_points(2, 5000, 0, 80, 6);
  for (std::size_t i = 0; i < pts.size(); i += 2) {
    pts[i] += 512345.0;
    pts[i + 1] += 5412345.0;
  }
  MapEvaluator ev(test::context(), map);
  const Worst w = compare(map, pts, ev.evaluate(pts));
  EXPECT_LT(w.dp, 1e-6);
  EXPECT_LT(w.dmean_rel, 1e-5);
}

TEST(MapEval, WideKernelsFarAwayAreNotLost) {
  // One very wide kernel 25 m from a cluster of narrow ones: its reach (42 m) covers the
  // queries, which lie far outside the narrow kernels' cells.
  KernelMap map;
  map.dim = 2;
  const double wide[2] = {-25, 0};
  map.push_back(wide, 0.01, 5.0, 1.0);
  for (int i = 0; i < 200; ++i) {
    const double p[2] = {40.0 + (i % 20), double(i / 20)};
    map.push_back(p, 2.0, -3.0, 0.5);
  }
  MapEvaluator ev(test::context(), map);
  std::vector<double> pts;
  for (int i = 0; i < 100; ++i) {
    pts.push_back(i * 0.1);
    pts.push_back(0.05 * i);
  }
  const Worst w = compare(map, pts, ev.evaluate(pts));
  EXPECT_LT(w.dp, 1e-6);
  EXPECT_LT(w.dmean_rel, 1e-6);
}

TEST(MapEval, EmptyQueryIsANoOp) {
  KernelMap map = random_map(2, 10, 10, 7);
  MapEvaluator ev(test::context(), map);
  EXPECT_NO_THROW(ev.evaluate(nullptr, 0, nullptr, nullptr, nullptr));
  const MapValues v = ev.evaluate(std::vector<double>{});
  EXPECT_TRUE(v.prob.empty());
}

TEST(MapEval, EmptyMapGivesPriorEverywhere) {
  KernelMap map;
  map.dim = 2;
  MapEvaluator ev(test::context(), map);
  const MapValues v = ev.evaluate(std::vector<double>{1, 2, 3, 4});
  ASSERT_EQ(v.prob.size(), 2u);
  EXPECT_EQ(v.mean[0], 0.f);
  EXPECT_FLOAT_EQ(v.prob[1], 0.5f);
}

TEST(MapEval, NonFinitePointsGiveNaNAndDoNotDisturbOthers) {
  KernelMap map = random_map(2, 100, 20, 8);
  MapEvaluator ev(test::context(), map);
  std::vector<double> pts = {5, 5, NAN, 1, 10, 10, 3, INFINITY};
  const MapValues v = ev.evaluate(pts);
  EXPECT_TRUE(std::isnan(v.prob[1]));
  EXPECT_TRUE(std::isnan(v.prob[3]));
  const MapValuesExact ref = evaluate_exact(map, pts.data(), 1);
  EXPECT_NEAR(v.prob[0], ref.prob[0], 1e-6);
}

TEST(MapEval, WrongCoordinateCountIsAnError) {
  KernelMap map = random_map(3, 10, 10, 9);
  MapEvaluator ev(test::context(), map);
  EXPECT_THROW(ev.evaluate(std::vector<double>{1, 2, 3, 4}), ArgumentError);
}

TEST(MapEval, InvalidMapIsRejected) {
  KernelMap map = random_map(2, 10, 10, 10);
  map.gamma[3] = -1;
  EXPECT_THROW(MapEvaluator(test::context(), map), ArgumentError);
}

TEST(MapEval, GridMatchesPointEvaluation) {
  KernelMap map = random_map(2, 800, 50, 11);
  MapEvaluator ev(test::context(), map);
  const double lo[3] = {-3.3, -1.7, 0}, hi[3] = {52.1, 49.9, 0};
  const GridSpec g = GridSpec::covering(2, lo, hi, 0.37);
  const MapValues v = ev.evaluate_grid(g);
  const MapValuesExact ref = evaluate_exact(map, g);
  ASSERT_EQ(v.prob.size(), ref.prob.size());
  double dp = 0;
  for (std::size_t i = 0; i < v.prob.size(); ++i)
    dp = std::max(dp, std::abs(v.prob[i] - ref.prob[i]));
  EXPECT_LT(dp, 1e-6);
}

TEST(MapEval, Grid3DMatchesReference) {
  KernelMap map = random_map(3, 500, 30, 12);
  MapEvaluator ev(test::context(), map);
  const double lo[3] = {0, 0, 0}, hi[3] = {30, 30, 9};
  const GridSpec g = GridSpec::covering(3, lo, hi, 0.75);
  const MapValues v = ev.evaluate_grid(g);
  const MapValuesExact ref = evaluate_exact(map, g);
  double dp = 0;
  for (std::size_t i = 0; i < v.prob.size(); ++i)
    dp = std::max(dp, std::abs(v.prob[i] - ref.prob[i]));
  EXPECT_LT(dp, 1e-6);
}

TEST(MapEval, SmallLaunchesGiveTheSameValues) {
  // Many launches (bounded memory) must not change a single value.
  KernelMap map = random_map(2, 600, 40, 13);
  MapEvaluator whole(test::context(), map);
  EvalOptions small;
  small.points_per_launch = 777;
  small.cells_per_launch = 64 * 64 * 2;
  MapEvaluator pieces(test::context(), map, small);
  const double lo[3] = {0, 0, 0}, hi[3] = {40, 40, 0};
  const GridSpec g = GridSpec::covering(2, lo, hi, 0.2);
  const MapValues a = whole.evaluate_grid(g), b = pieces.evaluate_grid(g);
  ASSERT_EQ(a.prob.size(), b.prob.size());
  for (std::size_t i = 0; i < a.prob.size(); i += 37) ASSERT_EQ(a.prob[i], b.prob[i]) << i;
  const auto pts = random_points(2, 5000, 0, 40, 14);
  const MapValues c = pieces.evaluate(pts);
  const MapValuesExact ref = evaluate_exact(map, pts.data(), 5000);
  for (std::size_t i = 0; i < 5000; ++i) ASSERT_NEAR(c.prob[i], ref.prob[i], 1e-6) << i;
}

TEST(MapEval, GridDimensionMismatchIsAnError) {
  KernelMap map = random_map(2, 10, 10, 15);
  MapEvaluator ev(test::context(), map);
  const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
  EXPECT_THROW(ev.evaluate_grid(GridSpec::covering(3, lo, hi, 0.5)), ArgumentError);
  EXPECT_THROW(GridSpec::covering(2, lo, hi, -1.0), ArgumentError);
}

TEST(MapEval, Grid3DInSmallLaunchesMatchesPoints) {
  KernelMap map = random_map(3, 300, 20, 16);
  EvalOptions small;
  small.cells_per_launch = 1;  // one row block per launch: exercises the 3D scatter
  MapEvaluator ev(test::context(), map, small);
  const double lo[3] = {0, 0, 0}, hi[3] = {20, 13, 11};
  const GridSpec g = GridSpec::covering(3, lo, hi, 0.5);
  const MapValues v = ev.evaluate_grid(g);
  const MapValuesExact ref = evaluate_exact(map, g);
  ASSERT_EQ(v.prob.size(), ref.prob.size());
  for (std::size_t i = 0; i < v.prob.size(); ++i) ASSERT_NEAR(v.prob[i], ref.prob[i], 1e-6) << i;
}

TEST(MapEval, CutoffTauIsHonoured) {
  // The device sums every kernel with gamma d^2 <= tau and may add some beyond it (those whose
  // cut-off reaches the chunk or block of cells): its mean lies between the strict-cut sum and
  // that sum plus the magnitude of all terms beyond the cut.
  KernelMap map = random_map(2, 400, 30, 17);
  EvalOptions o;
  o.tau = 0.5;
  MapEvaluator ev(test::context(), map, o);
  const auto pts = random_points(2, 3000, 0, 30, 18);
  const MapValues v = ev.evaluate(pts);
  const MapValuesExact full = evaluate_exact(map, pts.data(), 3000);
  double differs = 0;
  for (std::size_t i = 0; i < 3000; ++i) {
    double cut = 0, beyond = 0;
    for (std::size_t k = 0; k < map.size(); ++k) {
      const double dx = pts[2 * i] - map.position[2 * k],
                   dy = pts[2 * i + 1] - map.position[2 * k + 1];
      const double a = map.gamma[k] * (dx * dx + dy * dy);
      (a <= o.tau ? cut : beyond) +=
          a <= o.tau ? map.w_mean[k] * std::exp(-a) : std::abs(map.w_mean[k]) * std::exp(-a);
    }
    ASSERT_LE(std::abs(v.mean[i] - cut), beyond + 1e-4 * (1 + std::abs(cut))) << i;
    differs = std::max(differs, std::abs(v.mean[i] - full.mean[i]));
  }
  EXPECT_GT(differs, 1e-2);  // the cut really dropped something
}

TEST(MapEval, AMapLearnedWithACutoffIsEvaluatedAtIt) {
  // KernelMap::cutoff_tau below the evaluator's own tau: the same values as asking for it.
  KernelMap map = random_map(2, 400, 30, 17);
  EvalOptions o;
  o.tau = 0.5;
  const auto pts = random_points(2, 3000, 0, 30, 18);
  const MapValues want = MapEvaluator(test::context(), map, o).evaluate(pts);
  const MapValues full = MapEvaluator(test::context(), map).evaluate(pts);
  map.cutoff_tau = 0.5;
  const MapValues got = MapEvaluator(test::context(), map).evaluate(pts);
  EXPECT_EQ(got.mean, want.mean);
  EXPECT_EQ(got.var, want.var);
  EXPECT_NE(got.mean, full.mean);
  // Above the evaluator's tau it changes nothing.
  map.cutoff_tau = 40;
  EXPECT_EQ(MapEvaluator(test::context(), map).evaluate(pts).mean, full.mean);
  map.cutoff_tau = 0;
  EXPECT_THROW(MapEvaluator(test::context(), map), ArgumentError);
}
