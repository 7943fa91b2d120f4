#include "potmap/experiment.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "potmap/simulator.hpp"
#include "test_support.hpp"

using namespace potmap;
using namespace potmap::experiment;

namespace {
std::vector<Scan> drive(std::size_t n) {
  SimOptions o;
  o.scans = n;
  o.spacing = 2;
  return simulate(Town::builtin("town1", 0), o).scans;
}
}  // namespace

// The task holds the training part of label_scan's split and nothing of the held-out part.
TEST(Experiment, TaskIsTheTrainingSplit) {
  const auto scans = drive(4);
  LabelOptions lo;
  lo.seed = 5;
  LabelledPoints test;
  const MapTask task = make_task(scans, lo, test, 5.0, 10);
  LabelledSplit ref;
  for (std::size_t i = 0; i < scans.size(); ++i) label_scan(scans[i], 10 + long(i), lo, ref);
  EXPECT_EQ(task.train.position, ref.train.position);
  EXPECT_EQ(test.position, ref.test.position);
  EXPECT_EQ(task.train.scan.front(), 10);
  ASSERT_EQ(task.train_scans.size(), scans.size());
  for (std::size_t i = 0; i < scans.size(); ++i)
    EXPECT_EQ(task.train_scans[i].num_beams(),
              scans[i].num_beams() - std::size_t(std::lround(0.2 * scans[i].num_beams())));
  for (int k = 0; k < 2; ++k) EXPECT_LT(task.lo[k], task.hi[k]);
}

// Every baseline maps a simulated street far better than chance on held-out beams, and the
// device and CPU evaluations of one kernel map agree.
TEST(Experiment, BaselinesLearnAndEvaluatorsAgree) {
  const auto scans = drive(6);
  LabelledPoints test;
  const MapTask task = make_task(scans, {}, test);
  const FittedMap ogm = ogm_method(0.5).fit(nullptr, task);
  EXPECT_GT(score_map(ogm, test).auc, 0.85);
  BhmSetup b;
  const FittedMap bhm = bhm_method(b).fit(&test::context(), task);
  EXPECT_GT(score_map(bhm, test).auc, 0.9);
  ASSERT_TRUE(bhm.kernels);
  const FittedMap cpu = kernel_fitted_map(nullptr, bhm.kernels);
  std::vector<double> p1(test.size()), p2(test.size());
  bhm.query(test.position.data(), test.size(), p1.data(), nullptr);
  cpu.query(test.position.data(), test.size(), p2.data(), nullptr);
  for (std::size_t i = 0; i < test.size(); ++i) ASSERT_NEAR(p1[i], p2[i], 1e-5) << i;
  AbhmSetup a;
  a.count = 200;
  a.steps = 100;
  const FittedMap abhm = abhm_method(a).fit(&test::context(), task);
  EXPECT_GT(score_map(abhm, test).auc, 0.7);
  EXPECT_GT(abhm.fit_seconds, 0);
}
