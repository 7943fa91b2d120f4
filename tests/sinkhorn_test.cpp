#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "potmap/error.hpp"
#include "potmap/ot/sinkhorn.hpp"
#include "test_support.hpp"
#include "tuned_context.hpp"

using namespace potmap;

namespace {

Eigen::MatrixXd random_points(int n, int dim, unsigned seed, double spread = 1.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-spread, spread);
  Eigen::MatrixXd p(n, dim);
  for (int i = 0; i < n; ++i)
    for (int d = 0; d < dim; ++d) p(i, d) = u(rng);
  return p;
}

SinkhornProblem problem(int n, int m, int dim, unsigned seed, double eps) {
  SinkhornProblem q;
  q.source = random_points(n, dim, seed);
  q.target = random_points(m, dim, seed + 1000);
  q.epsilon = eps;
  q.tolerance = 1e-4;
  q.max_iterations = 5000;
  return q;
}

SinkhornResult solve_one(const SinkhornProblem& q, const SinkhornOptions& o = {}) {
  SinkhornBatch b;
  b.add(q);
  return b.run(test::context(), o).at(0);
}

SinkhornOptions full() {
  SinkhornOptions o;
  o.want_coupling = true;
  o.want_barycentric = true;
  return o;
}

// Brute-force optimal assignment of a square problem, and an epsilon small enough against the
// gap to the second-best assignment that the entropic plan must sit on the optimal one.
double assignment_epsilon(const SinkhornProblem& q, std::vector<int>& best, double& best_cost) {
  const Eigen::MatrixXd C = sinkhorn_cost(q);
  const int n = static_cast<int>(C.rows());
  std::vector<int> perm(n);
  std::iota(perm.begin(), perm.end(), 0);
  best_cost = 1e300;
  double second = 1e300;
  do {
    double c = 0;
    for (int i = 0; i < n; ++i) c += C(i, perm[i]);
    if (c < best_cost) {
      second = best_cost;
      best_cost = c;
      best = perm;
    } else if (c < second) {
      second = c;
    }
  } while (std::next_permutation(perm.begin(), perm.end()));
  return std::min(0.01, (second - best_cost) / 20);
}

}  // namespace

TEST(SinkhornReference, SmallProblemsApproachBruteForceAssignment) {
  for (int n = 2; n <= 7; ++n) {
    auto q = problem(n, n, 2, 10 + n, 0.01);
    q.normalise_cost = true;
    // Near a permutation Sinkhorn slows down (its contraction factor tends to 1), hence 1e-5.
    q.tolerance = 1e-5;
    q.max_iterations = 200000;
    std::vector<int> best;
    double best_cost = 0;
    q.epsilon = assignment_epsilon(q, best, best_cost);
    const auto r = sinkhorn_reference(q);
    ASSERT_TRUE(r.converged) << n << " eps " << q.epsilon << " err " << r.marginal_error << " it "
                             << r.iterations;
    for (int i = 0; i < n; ++i) EXPECT_NEAR(r.coupling(i, best[i]), 1.0 / n, 0.02 / n) << n;
    EXPECT_NEAR(r.cost, best_cost / n, 0.02 * best_cost / n + 1e-6);
  }
}

TEST(Sinkhorn, SmallProblemsApproachBruteForceAssignment) {
  for (int n = 2; n <= 7; ++n) {
    auto q = problem(n, n, 2, 10 + n, 0.01);
    q.normalise_cost = true;
    q.tolerance = 1e-5;
    q.max_iterations = 200000;
    std::vector<int> best;
    double best_cost = 0;
    q.epsilon = assignment_epsilon(q, best, best_cost);
    SinkhornOptions o = full();
    o.epsilon_start = 0.5;
    const auto r = solve_one(q, o);
    ASSERT_TRUE(r.converged) << n << " eps " << q.epsilon << " err " << r.marginal_error << " it "
                             << r.iterations;
    for (int i = 0; i < n; ++i) EXPECT_NEAR(r.coupling(i, best[i]), 1.0 / n, 0.03 / n) << n;
  }
}

TEST(Sinkhorn, MatchesReference) {
  for (int dim : {2, 3}) {
    auto q = problem(37, 53, dim, 3, 0.05);
    q.tolerance = 1e-5;
    q.angle = 0.7;
    q.centre = Eigen::Vector3d(0.3, -0.2, 0.5);
    q.scale = 0.8;
    SinkhornOptions o = full();
    o.stabilised = false;  // the log-domain scheme; StabilisedSchemeMatchesReference the other
    const auto r = solve_one(q, o);
    const auto ref = sinkhorn_reference(q);
    ASSERT_TRUE(r.converged);
    ASSERT_TRUE(ref.converged);
    EXPECT_LT(r.marginal_error, q.tolerance);
    EXPECT_NEAR(r.cost, ref.cost, 1e-4 * std::abs(ref.cost) + 1e-6);
    // Duals agree up to a constant moved from f to g.
    const double shift = (r.f - ref.f).mean();
    EXPECT_LT((r.f.array() - ref.f.array() - shift).abs().maxCoeff(), 1e-3 * q.epsilon * 10);
    EXPECT_LT((r.g.array() - ref.g.array() + shift).abs().maxCoeff(), 1e-3 * q.epsilon * 10);
    EXPECT_LT((r.coupling - ref.coupling).cwiseAbs().maxCoeff(), 1e-3 / (37.0));
    EXPECT_LT((r.barycentric - ref.barycentric).cwiseAbs().maxCoeff(), 1e-3);
    // Row marginals of the returned plan within the tolerance (the column ones are exact).
    const Eigen::VectorXd rows = r.coupling.rowwise().sum();
    EXPECT_LT((rows.array() - 1.0 / 37).abs().sum(), 2 * q.tolerance);
    const Eigen::VectorXd cols = r.coupling.colwise().sum();
    EXPECT_LT((cols.array() - 1.0 / 53).abs().sum(), 2 * q.tolerance);
  }
}

TEST(Sinkhorn, GivenMarginalsAndNormalisedCost) {
  auto q = problem(20, 30, 2, 5, 0.01);
  q.normalise_cost = true;
  Eigen::VectorXd a = Eigen::VectorXd::LinSpaced(20, 1, 3);
  q.source_weights = a / a.sum();
  Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(30, 2, 1);
  q.target_weights = b / b.sum();
  const auto r = solve_one(q, full());
  const auto ref = sinkhorn_reference(q);
  ASSERT_TRUE(r.converged);
  EXPECT_NEAR(r.cost, ref.cost, 1e-4 * ref.cost + 1e-6);
  const Eigen::VectorXd rows = r.coupling.rowwise().sum();
  EXPECT_LT((rows - q.source_weights).cwiseAbs().sum(), 2 * q.tolerance);
  EXPECT_LT((r.coupling - ref.coupling).cwiseAbs().maxCoeff(), 1e-4);
}

TEST(Sinkhorn, TranslationLeavesPlanUnchanged) {
  auto q = problem(40, 40, 2, 7, 0.02);
  auto moved = q;
  moved.source.rowwise() += Eigen::RowVector2d(3.0, -2.0);
  moved.target.rowwise() += Eigen::RowVector2d(3.0, -2.0);
  const auto r = solve_one(q, full()), s = solve_one(moved, full());
  EXPECT_LT((r.coupling - s.coupling).cwiseAbs().maxCoeff(), 2e-4 / 40);
}

TEST(Sinkhorn, KernelRotationEqualsHostRotation) {
  auto q = problem(30, 45, 2, 9, 0.02);
  q.angle = 1.1;
  q.centre = Eigen::Vector3d(0.4, 0.1, 0);
  auto host = q;
  host.angle = 0;
  const double c = std::cos(q.angle), s = std::sin(q.angle);
  for (int i = 0; i < host.source.rows(); ++i) {
    const double ux = q.source(i, 0) - 0.4, uy = q.source(i, 1) - 0.1;
    host.source(i, 0) = 0.4 + c * ux - s * uy;
    host.source(i, 1) = 0.1 + s * ux + c * uy;
  }
  const auto r = solve_one(q, full()), h = solve_one(host, full());
  EXPECT_LT((r.coupling - h.coupling).cwiseAbs().maxCoeff(), 2e-4 / 30);
  EXPECT_NEAR(r.cost, h.cost, 1e-4 * h.cost);
}

// Problems of different sizes in one launch (launched largest first) give what each gives alone.
TEST(Sinkhorn, RaggedBatchEqualsOneByOne) {
  SinkhornBatch batch;
  std::vector<SinkhornProblem> qs;
  const int sizes[][2] = {{5, 9}, {33, 17}, {16, 16}, {70, 41}, {1, 3}};
  unsigned seed = 20;
  for (auto& s : sizes) {
    qs.push_back(problem(s[0], s[1], 2, seed, 0.03 + 0.01 * (seed % 3)));
    ++seed;
    qs.back().angle = 0.3 * seed;
    batch.add(qs.back());
  }
  const auto all = batch.run(test::context(), full());
  for (std::size_t p = 0; p < qs.size(); ++p) {
    const auto one = solve_one(qs[p], full());
    EXPECT_EQ(all[p].iterations, one.iterations) << p;
    EXPECT_EQ(all[p].converged, one.converged) << p;
    EXPECT_FLOAT_EQ(all[p].cost, one.cost) << p;
    EXPECT_EQ((all[p].coupling - one.coupling).cwiseAbs().maxCoeff(), 0.0) << p;
    // The launch solves the largest first; every output must come back to its own problem.
    EXPECT_EQ((all[p].barycentric - one.barycentric).cwiseAbs().maxCoeff(), 0.0) << p;
    ASSERT_EQ(all[p].f.size(), one.f.size()) << p;
    ASSERT_EQ(all[p].g.size(), one.g.size()) << p;
    EXPECT_EQ((all[p].f - one.f).cwiseAbs().maxCoeff(), 0.0) << p;
    EXPECT_EQ((all[p].g - one.g).cwiseAbs().maxCoeff(), 0.0) << p;
  }
}

// Without duals (what a ranking asks for) the launch reads back the statistics alone: the same
// costs, iterations and convergence, and no f or g.
TEST(Sinkhorn, CostsWithoutDualsAreTheSame) {
  SinkhornBatch batch;
  unsigned seed = 40;
  for (int n : {12, 40, 7}) batch.add(problem(n, n + 5, 2, seed++, 0.03));
  SinkhornOptions lean;
  lean.want_duals = false;
  const auto with = batch.run(test::context(), SinkhornOptions{});
  const auto without = batch.run(test::context(), lean);
  ASSERT_EQ(with.size(), without.size());
  for (std::size_t p = 0; p < with.size(); ++p) {
    EXPECT_EQ(without[p].cost, with[p].cost) << p;
    EXPECT_EQ(without[p].iterations, with[p].iterations) << p;
    EXPECT_EQ(without[p].converged, with[p].converged) << p;
    EXPECT_GT(with[p].f.size(), 0) << p;
    EXPECT_EQ(without[p].f.size(), 0) << p;
    EXPECT_EQ(without[p].g.size(), 0) << p;
  }
}

// A batch too large for one launch (more than 2^18 padded points) is solved in several; the
// results must be those of the problems solved in small batches.
TEST(Sinkhorn, BatchSplitIntoLaunchesEqualsSmallBatches) {
  SinkhornBatch big;
  std::vector<SinkhornProblem> qs;
  for (unsigned p = 0; p < 1100; ++p) {
    qs.push_back(problem(100 + static_cast<int>(p % 7), 110, 2, 500 + p % 13, 0.05));
    qs.back().angle = 0.01 * p;
    qs.back().max_iterations = 50;
    big.add(qs.back());
  }
  SinkhornOptions o;
  o.want_barycentric = true;
  const auto all = big.run(test::context(), o);
  ASSERT_EQ(all.size(), qs.size());
  for (std::size_t first : {std::size_t{0}, std::size_t{540}, std::size_t{1090}}) {
    SinkhornBatch small;
    for (std::size_t p = first; p < first + 10; ++p) small.add(qs[p]);
    const auto part = small.run(test::context(), o);
    for (std::size_t k = 0; k < part.size(); ++k) {
      const std::size_t p = first + k;
      EXPECT_EQ(all[p].iterations, part[k].iterations) << p;
      EXPECT_FLOAT_EQ(all[p].cost, part[k].cost) << p;
      EXPECT_EQ((all[p].barycentric - part[k].barycentric).cwiseAbs().maxCoeff(), 0.0) << p;
    }
  }
}

// A started solve hands back what run() does, after the caller's own work; once only. Started
// and dropped unwaited, it must not free what the device still uses (ASan runs this too). A
// batch of several launches (chunk_slots small) runs its later launches in wait().
TEST(Sinkhorn, StartedSolveEqualsRun) {
  SinkhornBatch batch;
  unsigned seed = 70;
  for (int n : {40, 9, 25, 61}) batch.add(problem(n, n + 3, 2, seed++, 0.04));
  const auto ran = batch.run(test::context(), full());
  SinkhornRun pending = batch.start(test::context(), full());
  SinkhornBatch other;  // the host working meanwhile, on another batch
  other.add(problem(12, 12, 2, 90, 0.05));
  const auto other_result = other.run(test::context());
  EXPECT_TRUE(other_result[0].converged);
  SinkhornRun moved = std::move(pending);
  const auto started = moved.wait();
  ASSERT_EQ(started.size(), ran.size());
  for (std::size_t p = 0; p < ran.size(); ++p) {
    EXPECT_EQ(started[p].cost, ran[p].cost) << p;
    EXPECT_EQ(started[p].iterations, ran[p].iterations) << p;
    EXPECT_EQ((started[p].coupling - ran[p].coupling).cwiseAbs().maxCoeff(), 0.0) << p;
    EXPECT_EQ((started[p].barycentric - ran[p].barycentric).cwiseAbs().maxCoeff(), 0.0) << p;
  }
  EXPECT_THROW(moved.wait(), ArgumentError);
  EXPECT_THROW(pending.wait(), ArgumentError);  // moved from
  { SinkhornRun dropped = batch.start(test::context(), full()); }

  const auto tuned = test::tuned_context("sinkhorn.chunk_slots=100");
  SinkhornRun c = batch.start(*tuned, full());
  const auto parts = c.wait();
  ASSERT_EQ(parts.size(), ran.size());
  for (std::size_t p = 0; p < ran.size(); ++p) {
    EXPECT_EQ(parts[p].cost, ran[p].cost) << p;
    EXPECT_EQ((parts[p].coupling - ran[p].coupling).cwiseAbs().maxCoeff(), 0.0) << p;
  }
}

TEST(Sinkhorn, RankingSettingConverges) {
  // Authors' ranking setting: sector points (metres, 20 m) scaled by 1/50, eps 0.005.
  auto q = problem(200, 200, 2, 31, 0.005);
  q.source *= 20;
  q.target *= 20;
  q.scale = 1.0 / 50;
  q.tolerance = 1e-5;
  const auto r = solve_one(q);
  EXPECT_TRUE(r.converged) << r.marginal_error;
  EXPECT_TRUE(std::isfinite(r.cost));
  EXPECT_TRUE(r.f.allFinite());
}

TEST(Sinkhorn, HighQualitySettingConverges) {
  // 1500 x 1500, eps 0.0005 with max-normalised cost, single precision, with annealing.
  auto q = problem(1500, 1500, 2, 41, 0.0005);
  q.normalise_cost = true;
  q.tolerance = 1e-3;
  q.max_iterations = 2000;
  SinkhornOptions o;
  o.epsilon_start = 0.5;
  const auto r = solve_one(q, o);
  EXPECT_TRUE(r.converged) << r.marginal_error << " after " << r.iterations;
  EXPECT_TRUE(std::isfinite(r.cost));
  EXPECT_TRUE(r.f.allFinite() && r.g.allFinite());
}

TEST(Sinkhorn, AnnealingGivesTheTargetEpsilonResult) {
  auto q = problem(60, 50, 2, 51, 0.002);
  q.normalise_cost = true;
  q.tolerance = 1e-5;
  SinkhornOptions o = full();
  o.epsilon_start = 1.0;
  const auto r = solve_one(q, o);
  const auto ref = sinkhorn_reference(q);
  ASSERT_TRUE(r.converged);
  EXPECT_NEAR(r.cost, ref.cost, 1e-3 * ref.cost);
  EXPECT_LT((r.coupling - ref.coupling).cwiseAbs().maxCoeff(), 2e-3 / 60);
}

TEST(Sinkhorn, IterationLimitIsNotConvergence) {
  auto q = problem(50, 50, 2, 61, 0.001);
  q.max_iterations = 3;
  q.tolerance = 1e-6;
  const auto r = solve_one(q);
  EXPECT_FALSE(r.converged);
  EXPECT_GE(r.marginal_error, q.tolerance);
  EXPECT_EQ(r.iterations, 3);
  EXPECT_FALSE(sinkhorn_reference(q).converged);
}

TEST(Sinkhorn, EmptyAndNanInputsAreErrors) {
  SinkhornBatch b;
  b.add(problem(3, 3, 2, 1, 0.1));
  auto empty = problem(3, 3, 2, 1, 0.1);
  empty.target.resize(0, 2);
  try {
    b.add(empty);
    FAIL();
  } catch (const ArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("problem 1"), std::string::npos) << e.what();
  }
  auto nan = problem(3, 3, 2, 1, 0.1);
  nan.source(2, 1) = std::nan("");
  try {
    b.add(nan);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("point 2"), std::string::npos) << e.what();
  }
  EXPECT_EQ(b.size(), 1u);
}

TEST(Sinkhorn, OutOfSampleMap) {
  auto q = problem(25, 25, 2, 71, 0.02);
  q.angle = 0.5;
  q.extra_points = q.source.topRows(3);
  q.extra_points.rowwise() += Eigen::RowVector2d(0.01, 0.0);
  const auto r = solve_one(q, full());
  const auto ref = sinkhorn_reference(q);
  const double c = std::cos(0.5), s = std::sin(0.5);
  for (int e = 0; e < 3; ++e) {
    // The nearest sample is the one it was made from; its displacement is rotated with it.
    Eigen::RowVector2d expect = ref.barycentric.row(e) + Eigen::RowVector2d(0.01 * c, 0.01 * s);
    EXPECT_LT((r.extra_mapped.row(e) - expect).cwiseAbs().maxCoeff(), 1e-3);
  }
}

// The out-of-sample map finds each point's nearest source sample through a grid: the same
// sample as a scan of every source (the first of equally near ones), in 2D and 3D, for points
// inside the sources, on them, and far outside.
TEST(Sinkhorn, OutOfSampleMapTakesTheNearestSourceSample) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-3, 3);
  for (int dim : {2, 3}) {
    SinkhornProblem q;
    q.source.resize(300, dim);
    for (Eigen::Index i = 0; i < q.source.rows(); ++i)
      for (int d = 0; d < dim; ++d) q.source(i, d) = i % 5 == 0 ? std::round(u(rng)) : u(rng);
    q.angle = 0.7;
    Eigen::MatrixXd bary = q.source * 0.5;
    bary.col(0).array() += 1.0;
    Eigen::MatrixXd points(500, dim);
    for (Eigen::Index e = 0; e < points.rows(); ++e)
      for (int d = 0; d < dim; ++d)
        points(e, d) = e % 7 == 0 ? q.source(e % 300, d) : (e % 11 == 0 ? 40 : 1) * u(rng);
    const Eigen::MatrixXd got = out_of_sample_map(q, bary, points);
    const double c = std::cos(q.angle), s = std::sin(q.angle);
    for (Eigen::Index e = 0; e < points.rows(); ++e) {
      Eigen::Index k = 0;
      double best = HUGE_VAL;
      for (Eigen::Index i = 0; i < q.source.rows(); ++i) {
        const double d2 = (q.source.row(i) - points.row(e)).squaredNorm();
        if (d2 < best) {
          best = d2;
          k = i;
        }
      }
      const Eigen::RowVectorXd off = points.row(e) - q.source.row(k);
      Eigen::RowVectorXd want = bary.row(k);
      want(0) += c * off(0) - s * off(1);
      want(1) += s * off(0) + c * off(1);
      if (dim == 3) want(2) += off(2);
      ASSERT_EQ(got.row(e), want) << dim << "D point " << e;
    }
  }
  SinkhornProblem q;
  q.source = Eigen::MatrixXd::Zero(2, 2);
  Eigen::MatrixXd nan = Eigen::MatrixXd::Zero(1, 2);
  nan(0, 1) = std::nan("");
  EXPECT_THROW(out_of_sample_map(q, q.source, nan), ArgumentError);
}

TEST(Sinkhorn, StabilisedSchemeMatchesReference) {
  SinkhornOptions o = full();
  o.stabilised = true;
  for (int dim : {2, 3}) {
    auto q = problem(37, 53, dim, 3, 0.05);
    q.tolerance = 1e-5;
    q.angle = 0.7;
    q.centre = Eigen::Vector3d(0.3, -0.2, 0.5);
    q.scale = 0.8;
    const auto r = solve_one(q, o);
    const auto ref = sinkhorn_reference(q);
    ASSERT_TRUE(r.converged);
    EXPECT_NEAR(r.cost, ref.cost, 1e-4 * std::abs(ref.cost) + 1e-6);
    const double shift = (r.f - ref.f).mean();
    EXPECT_LT((r.f.array() - ref.f.array() - shift).abs().maxCoeff(), 1e-2 * q.epsilon);
    EXPECT_LT((r.coupling - ref.coupling).cwiseAbs().maxCoeff(), 1e-3 / 37.0);
    EXPECT_LT((r.barycentric - ref.barycentric).cwiseAbs().maxCoeff(), 1e-3);
  }
  // Ragged batch with annealing, small epsilon (absorptions happen) and the iteration limit.
  SinkhornBatch b;
  std::vector<SinkhornProblem> qs;
  qs.push_back(problem(5, 9, 2, 81, 0.002));
  qs.back().normalise_cost = true;
  qs.push_back(problem(70, 41, 2, 82, 0.001));
  qs.back().normalise_cost = true;
  qs.push_back(problem(30, 30, 2, 83, 0.001));
  qs.back().max_iterations = 2;
  qs.back().tolerance = 1e-7;
  for (auto& q : qs) b.add(q);
  o.epsilon_start = 0.5;
  const auto rs = b.run(test::context(), o);
  for (int p = 0; p < 2; ++p) {
    const auto ref = sinkhorn_reference(qs[p]);
    ASSERT_TRUE(rs[p].converged) << p;
    EXPECT_NEAR(rs[p].cost, ref.cost, 1e-3 * ref.cost) << p;
    EXPECT_LT((rs[p].coupling - ref.coupling).cwiseAbs().maxCoeff(), 2e-3 / qs[p].source.rows());
  }
  EXPECT_FALSE(rs[2].converged);
}

TEST(Sinkhorn, StabilisedSchemeInDoubleMatchesReference) {
  // Double precision runs the kernels 8 lanes wide (float: 16), with their own tile transpose of
  // K; sizes below, at and across the tile, small epsilon so that K is rebuilt many times.
  if (!test::context().info().has_fp64) GTEST_SKIP() << "the device has no cl_khr_fp64";
  SinkhornOptions o = full();
  o.stabilised = true;
  o.use_double = true;
  SinkhornBatch b;
  std::vector<SinkhornProblem> qs;
  const int sizes[][2] = {{5, 9}, {8, 11}, {16, 8}, {37, 53}, {70, 41}};
  unsigned seed = 90;
  for (auto& s : sizes) {
    qs.push_back(problem(s[0], s[1], 2, seed++, 0.002));
    qs.back().normalise_cost = true;
    qs.back().max_iterations = 20000;
    b.add(qs.back());
  }
  const auto rs = b.run(test::context(), o);
  for (std::size_t p = 0; p < qs.size(); ++p) {
    const auto ref = sinkhorn_reference(qs[p]);
    ASSERT_TRUE(rs[p].converged) << p;
    // Both stop within the 1e-4 tolerance of the marginals, on either side of the plan.
    EXPECT_NEAR(rs[p].cost, ref.cost, 1e-3 * ref.cost) << p;
    EXPECT_LT((rs[p].coupling - ref.coupling).cwiseAbs().maxCoeff(), 2 * qs[p].tolerance) << p;
  }
}

TEST(Sinkhorn, SmallSizesBothSchemesMatchReference) {
  // Fewer points than work-items per group: the case a PoCL 3.1 miscompilation broke (see
  // tests/pocl_quirks_test.cpp).
  const int sizes[][2] = {{1, 3}, {5, 9}, {15, 16}, {16, 5}, {17, 2}, {3, 40}};
  for (bool stab : {false, true}) {
    SinkhornBatch b;
    std::vector<SinkhornProblem> qs;
    unsigned seed = 200;
    for (auto& s : sizes) {
      qs.push_back(problem(s[0], s[1], 2, seed++, 0.02));
      qs.back().normalise_cost = true;
      qs.back().tolerance = 1e-6;
      b.add(qs.back());
    }
    SinkhornOptions o = full();
    o.stabilised = stab;
    const auto rs = b.run(test::context(), o);
    for (std::size_t p = 0; p < qs.size(); ++p) {
      const auto ref = sinkhorn_reference(qs[p]);
      ASSERT_TRUE(rs[p].converged) << "stabilised " << stab << " problem " << p;
      EXPECT_LT(rs[p].marginal_error, 1e-6);
      EXPECT_NEAR(rs[p].cost, ref.cost, 1e-4 * ref.cost + 1e-7) << stab << " " << p;
      EXPECT_LT((rs[p].coupling - ref.coupling).cwiseAbs().maxCoeff(), 1e-4) << stab << " " << p;
    }
  }
}

TEST(Sinkhorn, OverrelaxationKeepsTheResult) {
  // Plain Sinkhorn (w = 1), a fixed w and the adaptive default reach the same plan; the
  // over-relaxed runs need fewer iterations on this slowly converging problem.
  auto q = problem(60, 70, 2, 300, 0.002);
  q.normalise_cost = true;
  q.tolerance = 1e-6;
  q.max_iterations = 20000;
  for (bool stab : {false, true}) {
    SinkhornOptions o = full();
    o.stabilised = stab;
    o.overrelaxation = 1;
    const auto plain = solve_one(q, o);
    o.overrelaxation = 1.6;
    const auto fixed = solve_one(q, o);
    o.overrelaxation = 0;
    const auto adaptive = solve_one(q, o);
    ASSERT_TRUE(plain.converged && fixed.converged && adaptive.converged) << stab;
    EXPECT_LT(fixed.iterations, plain.iterations) << stab;
    EXPECT_LT(adaptive.iterations, plain.iterations) << stab;
    EXPECT_LT((fixed.coupling - plain.coupling).cwiseAbs().maxCoeff(), 1e-5) << stab;
    EXPECT_LT((adaptive.coupling - plain.coupling).cwiseAbs().maxCoeff(), 1e-5) << stab;
  }
  SinkhornOptions bad;
  bad.overrelaxation = 2.5;
  EXPECT_THROW(solve_one(q, bad), ArgumentError);
}

TEST(Sinkhorn, HighQualitySettingReachesTolerance1e7) {
  // The authors' high-quality setting at the tolerance 1e-7 with the default (stabilised)
  // scheme: its sums in double put the single-precision floor of the marginal error below 1e-7.
  auto q = problem(600, 600, 2, 42, 0.0005);
  q.normalise_cost = true;
  q.tolerance = 1e-7;
  q.max_iterations = 2000;
  SinkhornOptions o;
  o.epsilon_start = 0.05;
  o.epsilon_decay = 0.5;
  const auto r = solve_one(q, o);
  EXPECT_TRUE(r.converged) << r.marginal_error << " after " << r.iterations;
  EXPECT_LT(r.marginal_error, 1e-7);
}

TEST(Sinkhorn, DeviceBufferCallMatchesHostBatch) {
  namespace bc = boost::compute;
  auto& ctx = test::context();
  std::vector<SinkhornProblem> qs = {problem(12, 20, 2, 91, 0.02), problem(33, 7, 2, 92, 0.03)};
  SinkhornBatch host;
  SinkhornDeviceBatch dev;
  dev.dim = 2;
  dev.problems = qs.size();
  std::vector<float> src, tgt;
  for (auto& q : qs) {
    host.add(q);
    dev.source_offset.push_back(static_cast<int>(src.size() / 2));
    dev.target_offset.push_back(static_cast<int>(tgt.size() / 2));
    dev.source_count.push_back(static_cast<int>(q.source.rows()));
    dev.target_count.push_back(static_cast<int>(q.target.rows()));
    for (int i = 0; i < q.source.rows(); ++i)
      for (int d = 0; d < 2; ++d) src.push_back(static_cast<float>(q.source(i, d)));
    for (int j = 0; j < q.target.rows(); ++j)
      for (int d = 0; d < 2; ++d) tgt.push_back(static_cast<float>(q.target(j, d)));
    dev.params.push_back(q);
  }
  dev.source = bc::buffer(ctx.context(), src.size() * sizeof(float));
  dev.target = bc::buffer(ctx.context(), tgt.size() * sizeof(float));
  ctx.queue().enqueue_write_buffer(dev.source, 0, src.size() * sizeof(float), src.data());
  ctx.queue().enqueue_write_buffer(dev.target, 0, tgt.size() * sizeof(float), tgt.data());
  SinkhornOptions o;
  o.want_barycentric = true;
  const auto res = sinkhorn_device(ctx, dev, o);
  std::vector<float> stats(4 * qs.size()), bary(src.size());
  ctx.queue().enqueue_read_buffer(res.stats, 0, stats.size() * sizeof(float), stats.data());
  ctx.queue().enqueue_read_buffer(res.barycentric, 0, bary.size() * sizeof(float), bary.data());
  const auto ref = host.run(ctx, o);
  for (std::size_t p = 0; p < qs.size(); ++p) {
    EXPECT_FLOAT_EQ(stats[4 * p], static_cast<float>(ref[p].cost));
    EXPECT_EQ(static_cast<int>(stats[4 * p + 1]), ref[p].iterations);
    EXPECT_EQ(stats[4 * p + 3] != 0, ref[p].converged);
    const int o0 = dev.source_offset[p];
    for (int i = 0; i < dev.source_count[p]; ++i)
      EXPECT_FLOAT_EQ(bary[2 * (o0 + i) + 1], static_cast<float>(ref[p].barycentric(i, 1)));
  }
  // Offsets past the end of the buffers are refused before anything is enqueued.
  dev.source_count[1] = 1000;
  EXPECT_THROW(sinkhorn_device(ctx, dev, o), ArgumentError);
}

TEST(Sinkhorn, SingleSumsReachLooseTolerancesOnly) {
  // Single-precision sums (double_sums false) at the transport's and the coarse ranking's
  // tolerance give the double-sum result; at 1e-7 they stall above it, which is why
  // single_sums_reach() draws the line at 1e-6.
  std::vector<SinkhornProblem> qs;
  qs.push_back(problem(67, 50, 2, 500, 0.0005));
  qs.back().normalise_cost = true;
  qs.push_back(problem(48, 48, 2, 501, 0.005));
  qs.back().scale = 1.0 / 50;
  for (auto& q : qs) q.tolerance = 1e-5;
  SinkhornOptions dbl = full(), sgl = full();
  sgl.double_sums = false;
  EXPECT_TRUE(single_sums_reach(1e-5));
  EXPECT_TRUE(single_sums_reach(1e-6));
  EXPECT_FALSE(single_sums_reach(1e-7));
  for (const auto& q : qs) {
    const auto a = solve_one(q, dbl), b = solve_one(q, sgl);
    const auto ref = sinkhorn_reference(q);
    ASSERT_TRUE(a.converged && b.converged) << a.marginal_error << " " << b.marginal_error;
    EXPECT_LT(b.marginal_error, 1e-5);
    EXPECT_NEAR(b.cost, ref.cost, 1e-3 * ref.cost);
    EXPECT_NEAR(b.cost, a.cost, 1e-4 * a.cost);
    EXPECT_LT((b.coupling - a.coupling).cwiseAbs().maxCoeff(), 1e-3 / q.source.rows());
  }
  if (!test::context().info().has_fp64) return;  // double_sums has nothing to widen
  auto tight = qs[0];
  tight.tolerance = 1e-7;
  tight.max_iterations = 3000;
  const auto a = solve_one(tight, dbl), b = solve_one(tight, sgl);
  EXPECT_TRUE(a.converged) << a.marginal_error;
  EXPECT_GT(b.marginal_error, 1e-7) << "single sums met 1e-7: single_sums_reach() is too strict";
}
