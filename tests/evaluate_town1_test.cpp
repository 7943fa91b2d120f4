// The evaluator on the real Town 1 map learned by the paper's authors (92,372 kernels).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "potmap/data/labelled_points.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/map/evaluate.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

const KernelMap& town1() {
  static const KernelMap map = read_map(test::shared_data("carla/town1_abhm_map.csv"));
  return map;
}

}  // namespace

TEST(MapEvalTown1, TestPointsWithinOneMillionthOfExact) {
  const LabelledPoints test = read_labelled_csv(test::shared_data("carla/town1_test2k.csv"));
  ASSERT_EQ(test.size(), 2000u);
  MapEvaluator ev(test::context(), town1());
  const MapValues got = ev.evaluate(test.position);
  // The exact sums over 92,372 kernels are the slow part: small inputs check the first 200.
  const std::size_t n = test::sized<std::size_t>(test.size(), 200);
  const MapValuesExact ref = evaluate_exact(town1(), test.position.data(), n);
  double dp = 0, dm = 0, dv = 0;
  for (std::size_t i = 0; i < n; ++i) {
    dp = std::max(dp, std::abs(got.prob[i] - ref.prob[i]));
    dm = std::max(dm, std::abs(got.mean[i] - ref.mean[i]) / (1 + std::abs(ref.mean[i])));
    dv = std::max(dv, std::abs(got.var[i] - ref.var[i]) / (1 + ref.var[i]));
  }
  EXPECT_LT(dp, 1e-6);
  EXPECT_LT(dm, 1e-5);
  EXPECT_LT(dv, 1e-5);
  RecordProperty("max_abs_dp", std::to_string(dp));
}

TEST(MapEvalTown1, GridWithinOneMillionthOfExactOnASample) {
  // A 0.25 m grid over a 100 m x 60 m window with the busiest streets; the exact sum is taken on
  // every 97th cell (997th with small inputs; the dense reference over all cells would take
  // minutes).
  MapEvaluator ev(test::context(), town1());
  const double lo[3] = {-150, 150, 0}, hi[3] = {-50, 210, 0};
  const GridSpec g = GridSpec::covering(2, lo, hi, 0.25);
  const MapValues got = ev.evaluate_grid(g);
  std::vector<double> pts;
  std::vector<std::size_t> cell;
  for (std::size_t i = 0; i < g.cells(); i += test::sized<std::size_t>(97, 997)) {
    cell.push_back(i);
    pts.push_back(g.origin[0] + (i % g.count[0] + 0.5) * g.resolution);
    pts.push_back(g.origin[1] + (i / g.count[0] + 0.5) * g.resolution);
  }
  const MapValuesExact ref = evaluate_exact(town1(), pts.data(), cell.size());
  double dp = 0;
  for (std::size_t j = 0; j < cell.size(); ++j)
    dp = std::max(dp, std::abs(got.prob[cell[j]] - ref.prob[j]));
  EXPECT_LT(dp, 1e-6);
}
