// The experiments' look-ahead: each scan's held-out samples on the map before that scan.
#include "potmap/experiments/lookahead.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "potmap/data/simulator.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/map/evaluate.hpp"
#include "test_support.hpp"

using namespace potmap;
using namespace potmap::experiment;

namespace {

std::vector<Scan> street(std::size_t n) {
  SimOptions o;
  o.scans = n;
  o.spacing = 4;
  return simulate(Town::builtin("town1", 0), o).scans;
}

LabelledPoints points(int dim, const std::vector<std::vector<double>>& xs,
                      const std::vector<std::int64_t>& scans) {
  LabelledPoints p;
  p.dim = dim;
  for (std::size_t i = 0; i < xs.size(); ++i) {
    p.position.insert(p.position.end(), xs[i].begin(), xs[i].end());
    p.label.push_back(0);
    p.scan.push_back(scans[i]);
  }
  return p;
}

// The samples of `task.lookahead` of scan t, and their indices.
std::vector<std::size_t> of_scan(const LabelledPoints& test, std::int64_t t,
                                 std::vector<double>& pts) {
  std::vector<std::size_t> idx;
  pts.clear();
  for (std::size_t i = 0; i < test.size(); ++i)
    if (test.scan[i] == t) {
      idx.push_back(i);
      pts.insert(pts.end(), &test.position[i * test.dim], &test.position[(i + 1) * test.dim]);
    }
  return idx;
}

}  // namespace

// Beyond reach: no training sample of an earlier scan within the reach; a scan's own samples
// and later ones do not count.
TEST(LookAhead, BeyondReachCountsOnlyEarlierScans) {
  const LabelledPoints train = points(2, {{0, 0}, {10, 0}, {20, 0}}, {0, 1, 2});
  const LabelledPoints test =
      points(2, {{0.5, 0}, {3, 0}, {10.2, 0}, {10.2, 0}, {20, 0.9}}, {1, 1, 1, 2, 3});
  const std::vector<std::uint8_t> far = beyond_reach(test, train, 1.0);
  EXPECT_EQ(far, (std::vector<std::uint8_t>{0, 1, 1, 0, 0}));
  // 3D: the height counts.
  const LabelledPoints t3 = points(3, {{0, 0, 0}}, {0});
  const LabelledPoints q3 = points(3, {{0, 0, 0.8}, {0, 0, 1.2}}, {1, 1});
  EXPECT_EQ(beyond_reach(q3, t3, 1.0), (std::vector<std::uint8_t>{0, 1}));
  EXPECT_THROW(beyond_reach(test, train, 0), ArgumentError);
}

// OctoMap's look-ahead of scan k is a grid of the scans before k (unknown cells 0.5), and the
// first scan's samples are not scored.
TEST(LookAhead, TheGridsLookAheadIsTheGridOfTheEarlierScans) {
  const auto scans = street(5);
  LabelledPoints test;
  MapTask task = make_task(scans, {}, test);
  task.lookahead = &test;
  const FittedMap f = ogm_method(0.5).fit(nullptr, task);
  ASSERT_EQ(f.lookahead.size(), test.size());
  std::vector<double> pts;
  for (std::size_t i : of_scan(test, 0, pts)) EXPECT_TRUE(std::isnan(f.lookahead[i]));
  OgmOptions o;
  o.resolution = 0.5;
  OccupancyGrid grid(2, o);
  std::size_t unknown = 0, scored = 0;
  for (std::int64_t k = 1; k < 5; ++k) {
    grid.insert(task.train_scans[std::size_t(k - 1)]);
    const std::vector<std::size_t> idx = of_scan(test, k, pts);
    std::vector<double> p(idx.size());
    grid.probability(pts.data(), idx.size(), p.data());
    for (std::size_t j = 0; j < idx.size(); ++j) {
      EXPECT_FLOAT_EQ(f.lookahead[idx[j]], float(p[j])) << k << " " << j;
      unknown += p[j] == 0.5;
      ++scored;
    }
  }
  EXPECT_GT(scored, 100u);
  EXPECT_GT(unknown, 0u);  // the street goes on: some of each scan is new to the grid
  EXPECT_LT(unknown, scored);
}

// The joint BHM's look-ahead of scan k is the BHM learned on the scans before k: the map
// learned with scan k too scores its samples differently.
TEST(LookAhead, TheBhmsLookAheadIsTheMapOfTheEarlierScans) {
  const auto scans = street(4);
  LabelledPoints test;
  MapTask task = make_task(scans, {}, test);
  task.lookahead = &test;
  BhmSetup b;
  const FittedMap f = bhm_method(b).fit(&test::context(), task);
  ASSERT_EQ(f.lookahead.size(), test.size());
  const std::int64_t k = 2;
  std::vector<double> pts;
  const std::vector<std::size_t> idx = of_scan(test, k, pts);
  ASSERT_GT(idx.size(), 50u);
  auto learned_on = [&](std::int64_t last) {
    LabelledPoints s;
    s.dim = 2;
    for (std::size_t i = 0; i < task.train.size(); ++i)
      if (task.train.scan[i] <= last) {
        s.position.insert(s.position.end(), &task.train.position[2 * i],
                          &task.train.position[2 * i + 2]);
        s.label.push_back(task.train.label[i]);
        s.scan.push_back(task.train.scan[i]);
      }
    const KernelMap m = learn_bhm(nullptr, b, 2, task.lo, task.hi, s);
    return evaluate_exact(m, pts.data(), idx.size()).prob;
  };
  const std::vector<double> before = learned_on(k - 1), after = learned_on(k);
  double d_before = 0, d_after = 0;
  for (std::size_t j = 0; j < idx.size(); ++j) {
    d_before += std::abs(f.lookahead[idx[j]] - before[j]);
    d_after += std::abs(f.lookahead[idx[j]] - after[j]);
  }
  d_before /= double(idx.size());
  d_after /= double(idx.size());
  // The look-ahead reads the learner (its means at the update's tolerance), the map its polished
  // export: they agree to the solve's tolerance, far closer than to the map with scan k learned.
  EXPECT_LT(d_before, 0.001) << d_after;          // measured 6e-5
  EXPECT_GT(d_after, 20 * d_before) << d_before;  // measured 0.011
}
