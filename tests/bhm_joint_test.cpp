#include "potmap/bhm_joint.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "potmap/error.hpp"
#include "potmap/evaluate.hpp"
#include "potmap/experiment.hpp"
#include "potmap/metrics.hpp"
#include "potmap/scan.hpp"
#include "test_support.hpp"

namespace potmap {
namespace {

double sigmoid(double x) {
  return 1.0 / (1.0 + std::exp(-x));
}

// A wall along x = 2 seen from the origin: hits on it, free samples before it.
LabelledPoints wall_scan(std::uint32_t seed, std::int64_t t, double y0 = -1.5, double y1 = 1.5) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  LabelledPoints s;
  s.dim = 2;
  for (int b = 0; b < 40; ++b) {
    const double y = y0 + (y1 - y0) * (b + u(rng)) / 40;
    s.position.insert(s.position.end(), {2.0, y});
    s.label.push_back(1);
    s.scan.push_back(t);
    for (int f = 0; f < 2; ++f) {
      const double q = u(rng) * 0.9;
      s.position.insert(s.position.end(), {2.0 * q, y * q});
      s.label.push_back(0);
      s.scan.push_back(t);
    }
  }
  return s;
}

// One scan, one EM iteration: the posterior is the closed form of the Jaakkola-Jordan bound
// with xi from the prior, P = I / v0 + 2 Phi^T Lambda Phi, mean = P^-1 Phi^T (y - 1/2); built
// here densely from the kernel positions alone.
TEST(JointBhm, OneScanMatchesTheDenseClosedForm) {
  const double lo[3] = {-1, -2, 0}, hi[3] = {3, 2, 0};
  JointBhmOptions o;
  o.em_iterations = 1;
  o.bias = false;
  o.cg_tolerance = 1e-12;
  o.cg_max_iterations = 2000;
  JointBhm learner(2, lo, hi, o);
  const LabelledPoints s = wall_scan(3, 0);
  learner.update(s);
  const KernelMap map = learner.map();
  const std::size_t m = map.size(), n = s.size();
  ASSERT_EQ(m, 9u * 9u);
  Eigen::MatrixXd phi = Eigen::MatrixXd::Zero(Eigen::Index(n), Eigen::Index(m));
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t k = 0; k < m; ++k) {
      const double dx = s.position[2 * i] - map.position[2 * k];
      const double dy = s.position[2 * i + 1] - map.position[2 * k + 1];
      const double g = map.gamma[k] * (dx * dx + dy * dy);
      if (g <= o.tau) phi(Eigen::Index(i), Eigen::Index(k)) = std::exp(-g);
    }
  Eigen::MatrixXd P = Eigen::MatrixXd::Identity(Eigen::Index(m), Eigen::Index(m)) / o.prior_var;
  Eigen::VectorXd eta = Eigen::VectorXd::Zero(Eigen::Index(m));
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::VectorXd f = phi.row(Eigen::Index(i)).transpose();
    const double xi = std::sqrt(o.prior_var * f.squaredNorm());
    const double lambda = (sigmoid(xi) - 0.5) / (2 * xi);
    P += 2 * lambda * f * f.transpose();
    eta += (s.label[i] ? 0.5 : -0.5) * f;
  }
  const Eigen::VectorXd mean = P.ldlt().solve(eta);
  double max_err = 0;
  for (std::size_t k = 0; k < m; ++k)
    max_err = std::max(max_err, std::abs(mean[Eigen::Index(k)] - map.w_mean[k]));
  EXPECT_LT(max_err, 1e-6 * std::max(1.0, mean.cwiseAbs().maxCoeff()));
  EXPECT_GT(mean.cwiseAbs().maxCoeff(), 0.5);  // the data moved the weights
}

// After several scans with EM, the conjugate-gradient means equal the exact solve of the same
// precision (sparse Cholesky), and the exported per-kernel variances reproduce the exact
// predictive variance near the data within a small factor.
TEST(JointBhm, MeansAndVariancesAgreeWithTheExactPosterior) {
  const double lo[3] = {-1, -3, 0}, hi[3] = {3, 3, 0};
  JointBhm learner(2, lo, hi);
  for (int t = 0; t < 4; ++t) learner.update(wall_scan(10 + t, t, -2.5 + 0.5 * t, 0.5 + 0.5 * t));
  const KernelMap map = learner.map();
  std::vector<double> pts;
  for (double x = -0.5; x <= 2.5; x += 0.25)
    for (double y = -2; y <= 2; y += 0.25) pts.insert(pts.end(), {x, y});
  const std::size_t n = pts.size() / 2;
  std::vector<double> mean(n), var(n);
  learner.predict_exact(pts.data(), n, mean.data(), var.data());
  const MapValuesExact e = evaluate_exact(map, pts.data(), n);
  double max_mean_err = 0, scale = 0;
  std::vector<double> ratio;
  for (std::size_t i = 0; i < n; ++i) {
    max_mean_err = std::max(max_mean_err, std::abs(e.mean[i] - mean[i]));
    scale = std::max(scale, std::abs(mean[i]));
    ratio.push_back(e.var[i] / var[i]);
  }
  EXPECT_GT(scale, 1.0);
  EXPECT_LT(max_mean_err, 1e-4 * scale);
  std::sort(ratio.begin(), ratio.end());
  const double median = ratio[ratio.size() / 2];
  EXPECT_GT(median, 0.5);
  EXPECT_LT(median, 2.0);
  EXPECT_GT(ratio[ratio.size() / 10], 0.2);
  EXPECT_LT(ratio[ratio.size() * 9 / 10], 5.0);
}

TEST(JointBhm, UnobservedSpaceKeepsThePrior) {
  const double lo[3] = {-1, -3, 0}, hi[3] = {12, 3, 0};
  JointBhm learner(2, lo, hi);
  learner.update(wall_scan(1, 0));
  const KernelMap map = learner.map();
  // Kernels far beyond the wall (x >= 8) saw nothing.
  for (std::size_t k = 0; k < map.size(); ++k)
    if (map.position[2 * k] >= 8) {
      EXPECT_EQ(map.w_mean[k], 0.0);
      EXPECT_EQ(map.w_var[k], learner.options().prior_var);
    }
  EXPECT_GT(learner.last_stats().active, 0u);
  EXPECT_GT(learner.last_stats().cg_iterations, 0u);
}

TEST(JointBhm, BadInput) {
  const double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 0};
  JointBhmOptions o;
  o.spacing = 0;
  EXPECT_THROW(JointBhm(2, lo, hi, o), ArgumentError);
  o = {};
  o.neighbour_phi = 1.5;
  EXPECT_THROW(JointBhm(2, lo, hi, o), ArgumentError);
  EXPECT_THROW(JointBhm(4, lo, hi), ArgumentError);
  const double bad[3] = {0, -1, 0};
  EXPECT_THROW(JointBhm(2, lo, bad), ArgumentError);
  JointBhm ok(2, lo, hi);
  LabelledPoints s3;
  s3.dim = 3;
  s3.position = {0, 0, 0};
  s3.label = {1};
  EXPECT_THROW(ok.update(s3), ArgumentError);
  LabelledPoints empty;
  ok.update(empty);  // valid, does nothing
  EXPECT_EQ(ok.last_stats().samples, 0u);
  LabelledPoints nan;
  nan.position = {NAN, 0.5};
  nan.label = {1};
  ok.update(nan);  // NaN points are skipped
  EXPECT_EQ(ok.last_stats().samples, 0u);
}

// The real Intel log, scans 10 to 29 cut at 20 m, 20 % of beams held out (SPEC section 7's
// reference setting): the joint BHM beats the occupancy grid at 0.1 m on AUC and NLL.
TEST(JointBhm, IntelLogBeatsTheOccupancyGrid) {
  Dataset ds = read_dataset(test::shared_data("radish/intel-corrected.log.gz"));
  ASSERT_GE(ds.scans.size(), 30u);
  std::vector<Scan> scans;
  for (std::size_t i = 10; i < 30; ++i) scans.push_back(experiment::limit_range(ds.scans[i], 20));
  LabelOptions lo;
  LabelledPoints test;
  const experiment::MapTask task = experiment::make_task(scans, lo, test, 5.0, 10);
  const Scores bhm = experiment::score_map(
      experiment::bhm_method(experiment::BhmSetup{}).fit(nullptr, task), test);
  const Scores ogm = experiment::score_map(experiment::ogm_method(0.1).fit(nullptr, task), test);
  // Measured: BHM AUC 0.976, NLL 0.135; OGM 0.915, 0.301.
  EXPECT_GT(bhm.auc, 0.965);
  EXPECT_LT(bhm.nll, 0.17);
  EXPECT_GT(bhm.auc, ogm.auc + 0.03);
  EXPECT_LT(bhm.nll, ogm.nll - 0.1);
}

}  // namespace
}  // namespace potmap
