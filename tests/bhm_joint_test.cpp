#include "potmap/learn/bhm_joint.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <vector>

#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/metrics.hpp"
#include "potmap/runtime/context.hpp"
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

// A wall at x = 2 (a plane in 3D, |z| <= 1) seen from the origin: hits on it, free samples
// before it.
LabelledPoints wall_scan_3d(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  LabelledPoints s;
  s.dim = 3;
  for (int b = 0; b < 60; ++b) {
    const double y = -1.5 + 3 * u(rng), z = -1 + 2 * u(rng);
    s.position.insert(s.position.end(), {2.0, y, z});
    s.label.push_back(1);
    for (int f = 0; f < 2; ++f) {
      const double q = u(rng) * 0.9;
      s.position.insert(s.position.end(), {2.0 * q, y * q, z * q});
      s.label.push_back(0);
    }
  }
  return s;
}

// One scan, one EM iteration: the posterior is the closed form of the Jaakkola-Jordan bound
// with xi from the prior, P = I / v0 + 2 Phi^T Lambda Phi, mean = P^-1 Phi^T (y - 1/2); built
// here densely from the kernel positions alone. Returns the largest difference of the map's
// means from it, relative to their scale (at least 1), and checks the data moved the weights.
double closed_form_error(const KernelMap& map, const LabelledPoints& s, const JointBhmOptions& o) {
  const std::size_t m = map.size(), n = s.size(), dim = std::size_t(s.dim);
  Eigen::MatrixXd phi = Eigen::MatrixXd::Zero(Eigen::Index(n), Eigen::Index(m));
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t k = 0; k < m; ++k) {
      double d2 = 0;
      for (std::size_t d = 0; d < dim; ++d) {
        const double e = s.position[dim * i + d] - map.position[dim * k + d];
        d2 += e * e;
      }
      const double g = map.gamma[k] * d2;
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
  EXPECT_GT(mean.cwiseAbs().maxCoeff(), 0.5);  // the data moved the weights
  return max_err / std::max(1.0, mean.cwiseAbs().maxCoeff());
}

JointBhmOptions closed_form_options() {
  JointBhmOptions o;
  o.em_iterations = 1;
  o.bias = false;
  o.cg_tolerance = 1e-12;
  o.cg_max_iterations = 2000;
  return o;
}

TEST(JointBhm, OneScanMatchesTheDenseClosedForm) {
  const double lo[3] = {-1, -2, 0}, hi[3] = {3, 2, 0};
  const JointBhmOptions o = closed_form_options();
  JointBhm learner(2, lo, hi, o);
  const LabelledPoints s = wall_scan(3, 0);
  learner.update(s);
  const KernelMap map = learner.map();
  ASSERT_EQ(map.size(), 9u * 9u);
  EXPECT_LT(closed_form_error(map, s, o), 1e-6);
}

// The same in 3D, where a kernel stores the couplings of the layers above it and of the rows
// after it in its own layer (the half stencil), and the products mirror them.
TEST(JointBhm, OneScanMatchesTheDenseClosedForm3D) {
  const double lo[3] = {-1, -2, -1.5}, hi[3] = {3, 2, 1.5};
  const JointBhmOptions o = closed_form_options();
  JointBhm learner(3, lo, hi, o);
  const LabelledPoints s = wall_scan_3d(5);
  learner.update(s);
  const KernelMap map = learner.map();
  ASSERT_EQ(map.size(), 9u * 9u * 7u);
  EXPECT_LT(closed_form_error(map, s, o), 1e-6);
}

// The exported map against the learner's own posterior (its features cut at its tau),
// evaluated densely (no cut-off), on a grid of points: the means' largest difference and
// scale, and the sorted ratios of the variances (the export's per-kernel variance is an
// approximation: JointBhm::map()).
struct ExportCheck {
  double mean_err = 0, scale = 0;
  std::vector<double> ratio;
};

ExportCheck check_export(const JointBhm& learner, double x0, double x1, double y0, double y1) {
  const KernelMap map = learner.map();
  std::vector<double> pts;
  for (double x = x0; x <= x1; x += 0.25)
    for (double y = y0; y <= y1; y += 0.25) pts.insert(pts.end(), {x, y});
  const std::size_t n = pts.size() / 2;
  std::vector<double> mean(n), var(n);
  learner.predict_exact(pts.data(), n, mean.data(), var.data());
  const MapValuesExact e = evaluate_exact(map, pts.data(), n);
  ExportCheck c;
  for (std::size_t i = 0; i < n; ++i) {
    c.mean_err = std::max(c.mean_err, std::abs(e.mean[i] - mean[i]));
    c.scale = std::max(c.scale, std::abs(mean[i]));
    c.ratio.push_back(e.var[i] / var[i]);
  }
  std::sort(c.ratio.begin(), c.ratio.end());
  return c;
}

// At the evaluators' cut-off (18) the dense sum and the learner's differ by terms below e^-18
// of a kernel's peak; at the learner's default (6) by terms below e^-6, so the means agree to
// a few thousandths of their scale (measured 2.1e-3).
void expect_export_is_posterior(const ExportCheck& c, double tau) {
  const bool evaluators = tau >= kDefaultCutoffTau;
  EXPECT_GT(c.scale, 1.0);
  EXPECT_LT(c.mean_err, (evaluators ? 1e-4 : 5e-3) * c.scale);
  const double median = c.ratio[c.ratio.size() / 2];
  EXPECT_GT(median, 0.5);
  EXPECT_LT(median, 2.0);
}

// After several scans with EM, the conjugate-gradient means equal the exact solve of the same
// precision (sparse Cholesky), and the exported per-kernel variances reproduce the exact
// predictive variance near the data within a small factor.
TEST(JointBhm, MeansAndVariancesAgreeWithTheExactPosterior) {
  for (double tau : {kDefaultCutoffTau, JointBhmOptions{}.tau}) {
    SCOPED_TRACE(tau);
    const double lo[3] = {-1, -3, 0}, hi[3] = {3, 3, 0};
    JointBhmOptions o;
    o.tau = tau;
    JointBhm learner(2, lo, hi, o);
    for (int t = 0; t < 4; ++t) learner.update(wall_scan(10 + t, t, -2.5 + 0.5 * t, 0.5 + 0.5 * t));
    const ExportCheck c = check_export(learner, -0.5, 2.5, -2, 2);
    expect_export_is_posterior(c, tau);
    EXPECT_GT(c.ratio[c.ratio.size() / 10], 0.2);
    EXPECT_LT(c.ratio[c.ratio.size() * 9 / 10], 5.0);
  }
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
// The Intel log's scans [10, last) cut at 20 m, 20 % of their beams held out into `held_out`.
experiment::MapTask intel_task(std::size_t last, LabelledPoints& held_out) {
  Dataset ds = read_dataset(test::shared_data("radish/intel-corrected.log.gz"));
  EXPECT_GE(ds.scans.size(), last);
  std::vector<Scan> scans;
  for (std::size_t i = 10; i < std::min(last, ds.scans.size()); ++i)
    scans.push_back(experiment::limit_range(ds.scans[i], 20));
  LabelOptions lo;
  return experiment::make_task(scans, lo, held_out, 5.0, 10);
}

TEST(JointBhm, IntelLogBeatsTheOccupancyGrid) {
  LabelledPoints test;
  const experiment::MapTask task = intel_task(30, test);
  const Scores bhm = experiment::score_map(
      experiment::bhm_method(experiment::BhmSetup{}).fit(nullptr, task), test);
  const Scores ogm = experiment::score_map(experiment::ogm_method(0.1).fit(nullptr, task), test);
  // Measured: BHM AUC 0.976, NLL 0.135; OGM 0.915, 0.301.
  EXPECT_GT(bhm.auc, 0.965);
  EXPECT_LT(bhm.nll, 0.17);
  EXPECT_GT(bhm.auc, ogm.auc + 0.03);
  EXPECT_LT(bhm.nll, ogm.nll - 0.1);
}

// A long wall along x = 2 seen from (-3, y) for y every 2 m over [y0, y1]: hits on the wall,
// free samples on the beams. It crosses the growable map's tile borders (every 16 m at the
// default spacing: y = -16, 0, 16; x = 0).
LabelledPoints long_wall_scan(std::uint32_t seed, std::int64_t t, double y0, double y1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  LabelledPoints s;
  s.dim = 2;
  for (double sy = y0; sy <= y1; sy += 2) {
    for (int b = 0; b < 12; ++b) {
      const double y = sy - 1.5 + 3.0 * (b + u(rng)) / 12;
      s.position.insert(s.position.end(), {2.0, y});
      s.label.push_back(1);
      s.scan.push_back(t);
      for (int f = 0; f < 3; ++f) {
        const double q = u(rng) * 0.95;
        s.position.insert(s.position.end(), {-3.0 + 5.0 * q, sy + (y - sy) * q});
        s.label.push_back(0);
        s.scan.push_back(t);
      }
    }
  }
  return s;
}

// Grid coordinates of a kernel position (the maps' kernels sit on multiples of 0.5 m here).
std::pair<long, long> cell_key(const KernelMap& m, std::size_t k, double spacing) {
  return {std::lround(m.position[2 * k] / spacing), std::lround(m.position[2 * k + 1] / spacing)};
}

// The growable map (tiles allocated on demand, borders at multiples of 16 m) and the bounded
// one (tiles anchored at lo, borders elsewhere) on the same scans of a wall that crosses tile
// borders: the same posterior, kernel by kernel, wherever both have the kernel; the growable
// map's extra kernels (beyond the bounds) keep the prior.
TEST(JointBhm, GrowableEqualsBoundedAcrossTileBorders) {
  JointBhmOptions o;
  o.cg_tolerance = 1e-10;
  o.cg_max_iterations = 2000;
  const double lo[3] = {-9, -27, 0}, hi[3] = {9, 27, 0};
  JointBhm bounded(2, lo, hi, o);
  JointBhm grow(2, o);
  EXPECT_FALSE(grow.bounded());
  EXPECT_EQ(grow.size(), 0u);
  for (int t = 0; t < 4; ++t) {
    const LabelledPoints s = long_wall_scan(20 + t, t, -20 + 2 * t, 14 + 2 * t);
    bounded.update(s);
    grow.update(s);
    EXPECT_EQ(grow.last_stats().samples, bounded.last_stats().samples);
  }
  // The wall spans y in [-21.5, 21.5]: growable tiles cover x in [-16, 16), y in [-32, 32).
  EXPECT_EQ(grow.tiles(), 2u * 4u);
  const KernelMap a = bounded.map(), b = grow.map();
  EXPECT_EQ(b.size(), grow.size());
  std::map<std::pair<long, long>, std::size_t> at;
  for (std::size_t k = 0; k < a.size(); ++k) at[cell_key(a, k, o.spacing)] = k;
  double scale = 0, mean_err = 0, var_err = 0;
  std::size_t common = 0, extra = 0;
  for (std::size_t k = 0; k < b.size(); ++k) {
    const auto it = at.find(cell_key(b, k, o.spacing));
    if (it == at.end()) {
      ++extra;
      EXPECT_EQ(b.w_mean[k], 0.0);
      EXPECT_EQ(b.w_var[k], o.prior_var);
      continue;
    }
    ++common;
    scale = std::max(scale, std::abs(a.w_mean[it->second]));
    mean_err = std::max(mean_err, std::abs(a.w_mean[it->second] - b.w_mean[k]));
    var_err = std::max(var_err, std::abs(a.w_var[it->second] - b.w_var[k]) / a.w_var[it->second]);
  }
  EXPECT_EQ(common, a.size());  // every bounded kernel is stored by the growable map
  EXPECT_GT(extra, 0u);
  EXPECT_GT(scale, 1.0);
  // The two differ only in the order of their sums (tiles anchored elsewhere): the conjugate
  // gradients stop at slightly different points, within their tolerance (1e-10 a scan, 1e-8
  // for the export's polish). A wrong neighbour across a tile border would differ by O(1).
  EXPECT_LT(mean_err, 1e-7 * scale) << "max mean difference " << mean_err;
  EXPECT_LT(var_err, 1e-7) << "max relative variance difference";
  EXPECT_NEAR(a.bias_mean, b.bias_mean, 1e-7 * std::max(1.0, std::abs(a.bias_mean)));
  EXPECT_NEAR(a.bias_var, b.bias_var, 1e-7 * a.bias_var);
  std::printf("growable vs bounded: max mean difference %.3g (scale %.3g), variance %.3g\n",
              mean_err, scale, var_err);
}

// The host's update split in two parts on a context's host team gives the map of the update on
// this thread alone, bit for bit (the parts are the same either way), on the Intel log's scans
// and across the growable map's tile borders, bounded and growable.
TEST(JointBhm, UpdateOnTheHostTeamIsTheSameBitForBit) {
  Context& ctx = test::context();
  JointBhmOptions on_host;
  on_host.sums = JointBhmSums::host;
  LabelledPoints held_out;
  const experiment::MapTask task = intel_task(16, held_out);
  ASSERT_EQ(task.train_scans.size(), 6u);
  auto expect_same = [](const KernelMap& a, const KernelMap& b, const char* what) {
    ASSERT_EQ(a.size(), b.size()) << what;
    ASSERT_GT(a.size(), 0u) << what;
    EXPECT_TRUE(a.w_mean == b.w_mean) << what << ": means differ";
    EXPECT_TRUE(a.w_var == b.w_var) << what << ": variances differ";
    EXPECT_EQ(a.bias_mean, b.bias_mean) << what;
    EXPECT_EQ(a.bias_var, b.bias_var) << what;
  };
  JointBhm alone(2), team(2, on_host);
  for (std::size_t i = 0; i < task.train_scans.size(); ++i) {
    const LabelledPoints s = experiment::scan_training_samples(task, i, 0);
    alone.update(s);
    team.update(s, &ctx);
    EXPECT_FALSE(team.last_stats().sums_on_device);
    EXPECT_EQ(team.last_stats().cg_iterations, alone.last_stats().cg_iterations) << "scan " << i;
  }
  expect_same(alone.map(), team.map(), "Intel, growable");

  const double lo3[3] = {-9, -27, 0}, hi3[3] = {9, 27, 0};
  JointBhm bounded_alone(2, lo3, hi3), bounded_team(2, lo3, hi3, on_host), grow_alone(2),
      grow_team(2, on_host);
  for (int t = 0; t < 4; ++t) {
    const LabelledPoints s = long_wall_scan(20 + t, t, -20 + 2 * t, 14 + 2 * t);
    bounded_alone.update(s);
    bounded_team.update(s, &ctx);
    grow_alone.update(s);
    grow_team.update(s, &ctx);
  }
  expect_same(bounded_alone.map(), bounded_team.map(), "wall, bounded");
  expect_same(grow_alone.map(), grow_team.map(), "wall, growable");
}

// The features and sums on the device (kernels/learn/bhm_joint_sums.cl) against the host's:
// the same samples, rows and solves, sums taken in another order (relative 1e-10 after the
// solves' own tolerance is met the same way: the CG counts agree within one an update).
void expect_close(const KernelMap& a, const KernelMap& b, double tol, const char* what) {
  ASSERT_EQ(a.size(), b.size()) << what;
  ASSERT_GT(a.size(), 0u) << what;
  double worst_mean = 0, worst_var = 0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    worst_mean =
        std::max(worst_mean, std::abs(a.w_mean[k] - b.w_mean[k]) / (1.0 + std::abs(a.w_mean[k])));
    worst_var = std::max(worst_var, std::abs(a.w_var[k] - b.w_var[k]) / a.w_var[k]);
  }
  EXPECT_LT(worst_mean, tol) << what;
  EXPECT_LT(worst_var, tol) << what;
  EXPECT_NEAR(a.bias_mean, b.bias_mean, tol * (1 + std::abs(a.bias_mean))) << what;
}

TEST(JointBhm, SumsOnTheDeviceMatchTheHost) {
  Context& ctx = test::context();
  if (!ctx.info().has_fp64) GTEST_SKIP() << "the device has no doubles";
  LabelledPoints held_out;
  const experiment::MapTask task = intel_task(test::sized(16, 13), held_out);
  JointBhmOptions on_host, on_device;
  on_host.sums = JointBhmSums::host;
  on_device.sums = JointBhmSums::device;
  JointBhm host(2, on_host), device(2, on_device);
  for (std::size_t i = 0; i < task.train_scans.size(); ++i) {
    const LabelledPoints s = experiment::scan_training_samples(task, i, 0);
    host.update(s, &ctx);
    device.update(s, &ctx);
    EXPECT_FALSE(host.last_stats().sums_on_device);
    EXPECT_TRUE(device.last_stats().sums_on_device);
    EXPECT_EQ(device.last_stats().samples, host.last_stats().samples) << "scan " << i;
    EXPECT_EQ(device.last_stats().active, host.last_stats().active) << "scan " << i;
    EXPECT_NEAR(double(device.last_stats().cg_iterations), double(host.last_stats().cg_iterations),
                3.0)
        << "scan " << i;
  }
  expect_close(host.map(), device.map(), 1e-6, "Intel, growable");

  // Bounded, weighted, with samples outside the grid and one not finite.
  const double lo3[3] = {-9, -27, 0}, hi3[3] = {9, 27, 0};
  JointBhm bounded_host(2, lo3, hi3, on_host), bounded_device(2, lo3, hi3, on_device);
  for (int t = 0; t < 4; ++t) {
    LabelledPoints s = long_wall_scan(20 + t, t, -20 + 2 * t, 14 + 2 * t);
    s.weight.assign(s.size(), 1.0);
    for (std::size_t i = 0; i < s.size(); i += 3) s.weight[i] = 2.5;
    s.position[0] = std::nan("");
    bounded_host.update(s, &ctx);
    bounded_device.update(s, &ctx);
    EXPECT_EQ(bounded_device.last_stats().samples, bounded_host.last_stats().samples);
  }
  expect_close(bounded_host.map(), bounded_device.map(), 1e-6, "wall, bounded, weighted");
}

// The growable map's means and variances against the exact posterior of its own precision
// (sparse Cholesky), at points on both sides of tile borders.
TEST(JointBhm, GrowableMatchesItsExactPosterior) {
  for (double tau : {kDefaultCutoffTau, JointBhmOptions{}.tau}) {
    SCOPED_TRACE(tau);
    JointBhmOptions o;
    o.tau = tau;
    JointBhm grow(2, o);
    for (int t = 0; t < 3; ++t) grow.update(long_wall_scan(40 + t, t, -4 + 2 * t, 4 + 2 * t));
    expect_export_is_posterior(check_export(grow, -2.5, 3, -4, 8), tau);
  }
}

// Samples of one update far apart (the same walls 300 m apart): a box of cells around the
// solve's rows would be mostly empty, so the products find each coupling through the tiles
// instead. The same posterior as its exact solve, at both places.
TEST(JointBhm, FarApartSamplesMatchTheExactPosterior) {
  JointBhm grow(2);
  for (int t = 0; t < 3; ++t) {
    LabelledPoints s = long_wall_scan(50 + t, t, -4 + 2 * t, 4 + 2 * t);
    const std::size_t n = s.size();
    for (std::size_t i = 0; i < n; ++i) {
      s.position.insert(s.position.end(), {s.position[2 * i] + 300, s.position[2 * i + 1] + 300});
      s.label.push_back(s.label[i]);
      s.scan.push_back(s.scan[i]);
    }
    grow.update(s);
  }
  const double tau = grow.options().tau;
  expect_export_is_posterior(check_export(grow, -2.5, 3, -4, 8), tau);
  expect_export_is_posterior(check_export(grow, 297.5, 303, 296, 308), tau);
}

// Driving back and forth along one corridor allocates its tiles on the first pass and nothing
// after: memory follows the area, not the number of scans. A new place grows it again.
TEST(JointBhm, MemoryGrowsWithAreaNotScans) {
  JointBhm grow(2);
  auto corridor_scan = [](double x0, std::int64_t t) {
    LabelledPoints s = wall_scan(std::uint32_t(t), t);
    for (std::size_t i = 0; i < s.size(); ++i) s.position[2 * i] += x0;
    return s;
  };
  std::int64_t t = 0;
  std::vector<std::size_t> after_pass;
  for (int pass = 0; pass < 3; ++pass) {
    for (int k = 0; k <= 20; ++k) grow.update(corridor_scan(2.0 * (pass % 2 ? 20 - k : k), t++));
    after_pass.push_back(grow.memory_bytes());
  }
  const std::size_t tiles = grow.tiles();
  EXPECT_GT(tiles, 1u);
  // The stencils are counted: a kernel stores its diagonal and its couplings to the kernels
  // after it within 2 sqrt(tau / gamma) (the half of the disc's grid points, P being
  // symmetric), well under the stencil's whole box.
  const JointBhmOptions& o = grow.options();
  const double reach = 2 * std::sqrt(o.tau / grow.gamma()) / o.spacing;
  const auto pad = static_cast<int>(std::ceil(reach));
  std::size_t disc = 0;
  for (int dy = -pad; dy <= pad; ++dy)
    for (int dx = -pad; dx <= pad; ++dx) disc += dx * dx + dy * dy <= reach * reach ? 1 : 0;
  const std::size_t half = (disc - 1) / 2 + 1, box = std::size_t(2 * pad + 1) * (2 * pad + 1);
  EXPECT_GT(after_pass[0], tiles * 1024 * half * sizeof(double));
  EXPECT_LT(after_pass[0], tiles * 1024 * box * sizeof(double));
  EXPECT_LT(half * 3, box);
  EXPECT_EQ(after_pass[1], after_pass[0]);
  EXPECT_EQ(after_pass[2], after_pass[0]);
  // Exporting does not grow it either (its cache is part of the tiles).
  (void)grow.map();
  EXPECT_EQ(grow.memory_bytes(), after_pass[0]);
  grow.update(corridor_scan(200, t++));
  EXPECT_GT(grow.tiles(), tiles);
  EXPECT_GT(grow.memory_bytes(), after_pass[0]);
}

TEST(JointBhm, GrowableBadInput) {
  JointBhmOptions o;
  o.spacing = -1;
  EXPECT_THROW(JointBhm(2, o), ArgumentError);
  EXPECT_THROW(JointBhm(1), ArgumentError);
  o = {};
  o.tau = NAN;
  EXPECT_THROW(JointBhm(2, o), ArgumentError);
  JointBhm grow(2);
  LabelledPoints far;
  far.dim = 2;
  // NaN, infinite and absurdly distant points are ignored: they reach no kernel, store nothing.
  far.position = {NAN, 0, INFINITY, 1, 1e300, 0, 0, -1e12};
  far.label = {1, 0, 1, 1};
  grow.update(far);
  EXPECT_EQ(grow.last_stats().samples, 0u);
  EXPECT_EQ(grow.tiles(), 0u);
  EXPECT_TRUE(grow.map().w_mean.empty());
  LabelledPoints s3;
  s3.dim = 3;
  s3.position = {0, 0, 0};
  s3.label = {1};
  EXPECT_THROW(grow.update(s3), ArgumentError);
  KernelMap seed3;
  seed3.dim = 3;
  EXPECT_THROW(grow.seed_unreached(seed3), ArgumentError);
  LabelledPoints mismatch;
  mismatch.dim = 2;
  mismatch.position = {0, 0, 1};
  mismatch.label = {1};
  EXPECT_THROW(grow.update(mismatch), ArgumentError);
  // Past max_kernels: refused whole, the posterior as it was.
  JointBhmOptions capped;
  capped.max_kernels = 4 * 1024;  // the wall scan's four tiles
  JointBhm small(2, capped);
  small.update(wall_scan(1, 0));
  const KernelMap before = small.map();
  LabelledPoints spread;
  spread.dim = 2;
  for (int i = 0; i < 4; ++i) {
    spread.position.insert(spread.position.end(), {100.0 * i + 50, 50.0});
    spread.label.push_back(1);
  }
  EXPECT_THROW(small.update(spread), ArgumentError);
  const KernelMap after = small.map();
  ASSERT_EQ(after.size(), before.size());
  EXPECT_EQ(after.w_mean, before.w_mean);
  EXPECT_EQ(after.w_var, before.w_var);
}

// Seeds land where no sample reached, in tiles allocated for them, and never replace data.
TEST(JointBhm, GrowableSeedsOnlyUnreachedKernels) {
  JointBhm grow(2);
  grow.update(wall_scan(5, 0));
  const KernelMap data = grow.map();
  KernelMap field;
  field.dim = 2;
  for (double x = -2; x <= 40; x += 0.5)
    for (double y = -2; y <= 2; y += 0.5) {
      const double p[3] = {x, y, 0};
      field.push_back(p, grow.gamma(), 2.0, 1.0);
    }
  const std::size_t tiles = grow.tiles();
  const std::size_t seeded = grow.seed_unreached(field, 1.0);
  EXPECT_GT(seeded, 0u);
  EXPECT_GT(grow.tiles(), tiles);  // the field reaches x = 40: tiles of their own
  const KernelMap m = grow.map();
  std::map<std::pair<long, long>, std::size_t> at;
  for (std::size_t k = 0; k < m.size(); ++k) at[cell_key(m, k, 0.5)] = k;
  std::size_t far_seeded = 0;
  for (std::size_t k = 0; k < m.size(); ++k)
    if (m.position[2 * k] >= 20 && m.position[2 * k] <= 38 && std::abs(m.position[2 * k + 1]) < 1)
      far_seeded += m.w_mean[k] > 0.1;
  EXPECT_GT(far_seeded, 50u);
  // A second seed reaches nothing new.
  EXPECT_EQ(grow.seed_unreached(field, 1.0), 0u);
}

}  // namespace
}  // namespace potmap

namespace potmap {
namespace {

// A seed speaks only for space no sample has reached: once samples arrive, the kernels they
// reach return to the plain prior (seeds_yield; the seed's mean only starts the bound's xi), so
// their posterior is the unseeded one up to how tight the bound is, while the seeds beyond them
// stay. With seeds_yield off the seeds stay under the data and pull the posterior there.
TEST(JointBhm, SeedsYieldToData) {
  KernelMap field;
  field.dim = 2;
  for (double x = -2; x <= 12; x += 0.5)
    for (double y = -2; y <= 2; y += 0.5) {
      const double p[3] = {x, y, 0};
      field.push_back(p, JointBhm(2).gamma(), 2.0, 1.0);
    }
  auto run = [&](bool seeded, bool yield, int em, bool fully = false) {
    JointBhmOptions o;
    o.seeds_yield = yield;
    o.seeds_yield_fully = fully;
    o.em_iterations = em;
    JointBhm m(2, o);
    if (seeded) EXPECT_GT(m.seed_unreached(field, 10.0), 0u);
    m.update(wall_scan(5, 0));
    m.update(wall_scan(6, 1));
    return m.map();
  };
  // The default EM (3 rounds) and one run to convergence, where the bound's start is forgotten.
  for (const int em : {3, 40}) {
    const KernelMap plain = run(false, true, em), yielded = run(true, true, em),
                    kept = run(true, false, em);
    std::map<std::pair<long, long>, std::size_t> at;
    for (std::size_t k = 0; k < plain.size(); ++k) at[cell_key(plain, k, 0.5)] = k;
    // Largest change of a mean against the unseeded map where the data are; the seeds far away.
    auto near_change = [&](const KernelMap& m, std::size_t* far_seeds) {
      double change = 0;
      std::size_t near = 0;
      for (std::size_t k = 0; k < m.size(); ++k) {
        const double x = m.position[2 * k], y = m.position[2 * k + 1];
        const auto it = at.find(cell_key(m, k, 0.5));
        if (x >= 0.5 && x <= 2.5 && std::abs(y) <= 1 && it != at.end()) {
          change = std::max(change, std::abs(m.w_mean[k] - plain.w_mean[it->second]));
          ++near;
        }
        // The wall is at x = 2 and the features' cut-off about 1.6 m: no sample reaches x >= 6.
        if (x >= 6 && x <= 10 && std::abs(y) <= 1 && std::abs(m.w_mean[k] - 2.0) < 0.3)
          ++*far_seeds;
      }
      EXPECT_GT(near, 10u);
      return change;
    };
    std::size_t far_yielded = 0, far_kept = 0, far_fully = 0;
    const double yielded_change = near_change(yielded, &far_yielded);
    const double kept_change = near_change(kept, &far_kept);
    // Yielding fully (the mean too, and within the solve's margin), the map near the data is
    // the unseeded one to the solver's rounding (conjugate gradients stop at a relative
    // residual of 1e-5), however few EM rounds; seeds beyond stay.
    const double fully_change = near_change(run(true, true, em, true), &far_fully);
    EXPECT_LT(fully_change, JointBhmOptions{}.cg_tolerance) << em;
    EXPECT_LT(fully_change, 1e-3 * yielded_change) << em;
    EXPECT_EQ(far_fully, far_yielded);
    EXPECT_GT(far_yielded, 10u);
    EXPECT_EQ(far_yielded, far_kept);
    EXPECT_GT(kept_change, 0.5) << em;
    EXPECT_LT(yielded_change, (em == 3 ? 0.5 : 0.01) * kept_change)
        << em << ": " << yielded_change << " vs " << kept_change;
  }
}

}  // namespace
}  // namespace potmap

namespace potmap {
namespace {

// The wall scan with every sample repeated `copies` times, or weighing `copies` once.
LabelledPoints repeated(const LabelledPoints& s, int copies, bool as_weight) {
  LabelledPoints out;
  out.dim = s.dim;
  for (std::size_t i = 0; i < s.size(); ++i)
    for (int c = 0; c < (as_weight ? 1 : copies); ++c) {
      for (int d = 0; d < s.dim; ++d) out.position.push_back(s.position[i * s.dim + d]);
      out.label.push_back(s.label[i]);
      if (as_weight) out.weight.push_back(copies);
    }
  return out;
}

}  // namespace

// A sample of weight n is n samples at one place: the same bound, the same posterior (up to
// the solver's tolerance), over three EM rounds and two scans.
TEST(JointBhm, AWeightedSampleIsThatManySamplesAtOnePlace) {
  for (int dim : {2, 3}) {
    SCOPED_TRACE(dim);
    JointBhmOptions o;
    o.cg_tolerance = 1e-10;
    o.cg_max_iterations = 2000;
    JointBhm copies(dim, o), weighted(dim, o);
    for (std::uint32_t t = 0; t < 2; ++t) {
      const LabelledPoints s = dim == 2 ? wall_scan(7 + t, t) : wall_scan_3d(7 + t);
      copies.update(repeated(s, 3, false));
      weighted.update(repeated(s, 3, true));
    }
    const KernelMap a = copies.map(), b = weighted.map();
    ASSERT_EQ(a.size(), b.size());
    double scale = 0, diff = 0;
    for (std::size_t k = 0; k < a.size(); ++k) {
      scale = std::max(scale, std::abs(a.w_mean[k]));
      diff = std::max(diff, std::abs(a.w_mean[k] - b.w_mean[k]));
      EXPECT_NEAR(a.w_var[k], b.w_var[k], 1e-6 * a.w_var[k]);
    }
    EXPECT_GT(scale, 0.5);
    EXPECT_LT(diff, 1e-6 * scale);
    // And not the map of the scan taken once: the weights count.
    JointBhm once(dim, o);
    once.update(dim == 2 ? wall_scan(7, 0) : wall_scan_3d(7));
    once.update(dim == 2 ? wall_scan(8, 1) : wall_scan_3d(8));
    const KernelMap c = once.map();
    double moved = 0;
    for (std::size_t k = 0; k < c.size() && k < a.size(); ++k)
      moved = std::max(moved, std::abs(c.w_var[k] - a.w_var[k]));
    EXPECT_GT(moved, 1e-3);
  }
}

TEST(JointBhm, RefusesBadWeights) {
  JointBhm learner(2);
  LabelledPoints s = wall_scan(1, 0);
  s.weight.assign(s.size() - 1, 1.0);
  EXPECT_THROW(learner.update(s), ArgumentError);
  s.weight.assign(s.size(), 1.0);
  s.weight[3] = -1;
  EXPECT_THROW(learner.update(s), ArgumentError);
  s.weight[3] = std::nan("");
  EXPECT_THROW(learner.update(s), ArgumentError);
}

}  // namespace potmap

namespace potmap {

// A corridor driven along x: tiles the scans have left are retired and keep their kernels'
// means and variances; the map stays what the learner that never retired holds (up to the
// couplings across the border), memory drops to the tiles near the scans, and driving back
// revives the retired tiles and goes on learning there.
TEST(JointBhm, RetiredTilesKeepTheMapAndComeBackWhenReached) {
  auto corridor_scan = [](double x0, std::int64_t t) {
    LabelledPoints s = wall_scan(std::uint32_t(t), t);
    for (std::size_t i = 0; i < s.size(); ++i) s.position[2 * i] += x0;
    return s;
  };
  JointBhm keep(2), retire(2);
  std::int64_t t = 0;
  for (int k = 0; k <= 40; ++k) {
    const LabelledPoints s = corridor_scan(3.0 * k, t++);
    keep.update(s);
    retire.update(s);
    const double at[3] = {3.0 * k + 1, 0, 0};
    retire.retire_far(at, 40);
  }
  EXPECT_GT(retire.retired_tiles(), 2u);
  EXPECT_EQ(retire.size(), keep.size());
  EXPECT_LT(retire.memory_bytes() * 2, keep.memory_bytes());
  // The maps agree wherever the scans went: probabilities along the corridor.
  const KernelMap a = keep.map(), b = retire.map();
  std::vector<double> pts;
  for (double x = 0; x <= 120; x += 0.7)
    for (double y : {-1.0, 0.0, 1.0}) pts.insert(pts.end(), {x, y});
  pts.insert(pts.end(), {2.0, 0.3, 62.0, -0.4});  // on the wall
  const MapValuesExact va = evaluate_exact(a, pts.data(), pts.size() / 2);
  const MapValuesExact vb = evaluate_exact(b, pts.data(), pts.size() / 2);
  double worst = 0;
  for (std::size_t i = 0; i < va.prob.size(); ++i)
    worst = std::max(worst, std::abs(va.prob[i] - vb.prob[i]));
  EXPECT_LT(worst, 0.02);
  // Back to the start: the first tiles come back and learn again.
  const std::size_t retired = retire.retired_tiles();
  for (int k = 0; k < 3; ++k) retire.update(corridor_scan(3.0 * k, t++));
  EXPECT_LT(retire.retired_tiles(), retired);
  EXPECT_GT(retire.last_stats().samples, 0u);
  const MapValuesExact back = evaluate_exact(retire.map(), pts.data(), pts.size() / 2);
  EXPECT_GT(back.prob[pts.size() / 2 - 2], 0.5);  // the wall at x = 2 still reads occupied
  EXPECT_LT(back.prob[1], 0.5);                   // the corridor at x = 0 free
  // Bounded maps and a radius of 0 retire nothing.
  const double at[3] = {1e6, 0, 0};
  EXPECT_EQ(keep.retire_far(at, 0), 0u);
  const double lo[3] = {-5, -5, 0}, hi[3] = {5, 5, 0};
  JointBhm bounded(2, lo, hi);
  bounded.update(corridor_scan(0, 0));
  EXPECT_EQ(bounded.retire_far(at, 1), 0u);
}

// predict(): the map as the last update left it, read at points. After one scan the exported
// map's polish has nothing left to do, so predict() equals the map summed with the learner's
// own cut-off (strictly: the terms with gamma d^2 <= tau), growable and bounded, and once its
// tiles retired; reached() tells the places a sample has been from the rest.
TEST(JointBhm, PredictReadsTheMapAsItStands) {
  JointBhmOptions o;
  o.cg_tolerance = 1e-13;
  o.cg_max_iterations = 20000;
  auto corridor_scan = [](double x0, std::int64_t t) {
    LabelledPoints s = wall_scan(std::uint32_t(t), t);
    for (std::size_t i = 0; i < s.size(); ++i) s.position[2 * i] += x0;
    return s;
  };
  const double lo[3] = {-6, -6, 0}, hi[3] = {60, 6, 0};
  JointBhm grow(2, o), bounded(2, lo, hi, o);
  std::vector<double> pts;
  for (double x = -3; x <= 70; x += 0.37)
    for (double y : {-2.1, -0.4, 0.3, 1.9}) pts.insert(pts.end(), {x, y});
  const std::size_t n = pts.size() / 2;
  auto expect_predicts_its_map = [&](const JointBhm& m, const char* what) {
    SCOPED_TRACE(what);
    const KernelMap map = m.map(nullptr, 1e-13);
    std::vector<double> mean(n), var(n);
    m.predict(pts.data(), n, mean.data(), var.data());
    std::vector<double> mean_team(n), var_team(n);  // the variances on a host team: the same
    m.predict(pts.data(), n, mean_team.data(), var_team.data(), &test::context());
    EXPECT_EQ(mean_team, mean);
    EXPECT_EQ(var_team, var);
    double worst = 0;
    for (std::size_t i = 0; i < n; ++i) {
      double mu = map.has_bias ? map.bias_mean : 0, s2 = map.has_bias ? map.bias_var : 0;
      for (std::size_t k = 0; k < map.size(); ++k) {
        const double dx = pts[2 * i] - map.position[2 * k],
                     dy = pts[2 * i + 1] - map.position[2 * k + 1];
        const double a = map.gamma[k] * (dx * dx + dy * dy);
        if (a > m.options().tau) continue;
        mu += std::exp(-a) * map.w_mean[k];
        s2 += std::exp(-2 * a) * map.w_var[k];
      }
      worst = std::max(
          {worst, std::abs(mean[i] - mu) / (1 + std::abs(mu)), std::abs(var[i] - s2) / (1 + s2)});
    }
    EXPECT_LT(worst, 1e-6);
  };
  const LabelledPoints first = corridor_scan(0, 0);
  grow.update(first);
  bounded.update(first);
  expect_predicts_its_map(grow, "growable");
  expect_predicts_its_map(bounded, "bounded");
  const double away[3] = {1000, 0, 0};
  ASSERT_GT(grow.retire_far(away, 10), 0u);
  EXPECT_EQ(grow.tiles(), 0u);
  expect_predicts_its_map(grow, "growable, every tile retired");
  // Where a scan's samples reached, and farther down the corridor, where none did yet.
  JointBhm walk(2, o);
  std::int64_t t = 0;
  for (int k = 0; k <= 6; ++k) walk.update(corridor_scan(3.0 * k, t++));
  const double probe[6] = {1.0, 0.3, 40.0, 0.3, 70.0, 0.3};
  std::uint8_t seen[3];
  walk.reached(probe, 3, seen);
  EXPECT_EQ(seen[0], 1);
  EXPECT_EQ(seen[1], 0);
  EXPECT_EQ(seen[2], 0);
  for (int k = 7; k <= 20; ++k) {
    walk.update(corridor_scan(3.0 * k, t++));
    const double at[3] = {3.0 * k + 1, 0, 0};
    walk.retire_far(at, 30);
  }
  ASSERT_GT(walk.retired_tiles(), 0u);
  walk.reached(probe, 3, seen);
  EXPECT_EQ(seen[0], 1);  // in a retired tile
  EXPECT_EQ(seen[1], 1);  // reached since
  EXPECT_EQ(seen[2], 0);
}

}  // namespace potmap
