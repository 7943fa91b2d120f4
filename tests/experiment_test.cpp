#include "potmap/experiments/experiment.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "potmap/data/simulator.hpp"
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

// Returns past the range become no-returns along the same direction; nearer ones stay hits.
TEST(Experiment, LimitRangeTurnsFarReturnsIntoNoReturns) {
  Scan s;
  s.dim = 2;
  s.max_range = 80;
  s.pose2d = {1, 2, 0};
  s.hits = {11, 2, 1, 32, -29, 2};  // 10 m, 30 m, 30 m from (1, 2)
  s.no_return = {0, 1};
  const Scan c = limit_range(s, 20);
  EXPECT_EQ(c.max_range, 20);
  EXPECT_EQ(c.hits, (std::vector<double>{11, 2}));
  ASSERT_EQ(c.num_no_return(), 3u);
  EXPECT_EQ(c.no_return[0], 0);
  EXPECT_EQ(c.no_return[1], 1);
  EXPECT_NEAR(c.no_return[2], 0, 1e-12);
  EXPECT_NEAR(c.no_return[3], 1, 1e-12);
  EXPECT_NEAR(c.no_return[4], -1, 1e-12);
  EXPECT_NEAR(c.no_return[5], 0, 1e-12);
  EXPECT_EQ(limit_range(s, 100).hits, s.hits);  // already within
  EXPECT_EQ(limit_range(s, 0).hits, s.hits);    // 0: keep
}

namespace {
// Direction of a beam from the sensor, radians.
double bearing(const double* p, const std::array<double, 3>& o) {
  return std::atan2(p[1] - o[1], p[0] - o[0]);
}
bool on_some_beam(double a, const std::vector<double>& beams) {
  for (double b : beams)
    if (std::abs(std::remainder(a - b, 2 * M_PI)) < 1e-6) return true;
  return false;
}
std::vector<double> beam_bearings(const Scan& s) {
  std::vector<double> out;
  const auto o = s.origin();
  for (std::size_t i = 0; i < s.num_hits(); ++i) out.push_back(bearing(&s.hits[2 * i], o));
  for (std::size_t i = 0; i < s.num_no_return(); ++i)
    out.push_back(std::atan2(s.no_return[2 * i + 1], s.no_return[2 * i]));
  return out;
}
}  // namespace

// Every sample POT transports or refines with lies on a training beam of its scan, none on a
// held-out beam; the held-out samples are all on held-out beams.
TEST(Experiment, PotSeesOnlyTrainingBeams) {
  const auto scans = drive(5);
  LabelOptions lo;
  lo.seed = 3;
  LabelledPoints test;
  const MapTask task = make_task(scans, lo, test, 5.0, 7);
  std::size_t checked = 0;
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const auto train_beams = beam_bearings(split_beams(scans[i], 7 + long(i), lo, false));
    const auto held_beams = beam_bearings(split_beams(scans[i], 7 + long(i), lo, true));
    ASSERT_FALSE(held_beams.empty());
    const auto o = scans[i].origin();
    const LabelledPoints p = scan_training_samples(task, i, 20);
    ASSERT_GT(p.size(), 100u);
    for (std::size_t k = 0; k < p.size(); ++k, ++checked) {
      ASSERT_EQ(p.scan[k], 7 + long(i));
      const double a = bearing(&p.position[2 * k], o);
      ASSERT_TRUE(on_some_beam(a, train_beams)) << "scan " << i << " sample " << k;
      ASSERT_FALSE(on_some_beam(a, held_beams)) << "scan " << i << " sample " << k;
    }
  }
  EXPECT_EQ(checked, task.train.size());  // every training sample is within the 20 m range
  for (std::size_t k = 0; k < test.size(); ++k) {
    const std::size_t i = std::size_t(test.scan[k] - 7);
    EXPECT_TRUE(on_some_beam(bearing(&test.position[2 * k], scans[i].origin()),
                             beam_bearings(split_beams(scans[i], test.scan[k], lo, true))));
  }
}

// What the held-out beams say cannot change the RePOT map: turning every held-out return to
// another bearing (same range, so label_scan draws the same random numbers) leaves the training
// samples and the fitted kernels bit for bit the same, while the held-out samples do change.
TEST(Experiment, RepotMapIgnoresHeldOutBeams) {
  SimOptions so;
  so.scans = 4;
  so.spacing = 2;
  so.seed = 2;
  std::vector<Scan> source = simulate(Town::builtin("town2", 0), so).scans;
  auto scans = drive(3);
  LabelOptions lo;
  LabelledPoints test1, test2;
  MapTask t1 = make_task(scans, lo, test1);
  for (std::size_t i = 0; i < scans.size(); ++i) {
    const auto held = heldout_beams(scans[i], long(i), lo);
    const auto o = scans[i].origin();
    for (std::size_t k = 0; k < scans[i].num_hits(); ++k)
      if (held[k]) {
        double* p = &scans[i].hits[2 * k];
        const double dx = p[0] - o[0], dy = p[1] - o[1], c = std::cos(0.3), s = std::sin(0.3);
        p[0] = o[0] + c * dx - s * dy;
        p[1] = o[1] + s * dx + c * dy;
      }
    ASSERT_EQ(heldout_beams(scans[i], long(i), lo), held);
  }
  MapTask t2 = make_task(scans, lo, test2);
  ASSERT_NE(test1.position, test2.position);
  t1.source = t2.source = {source};
  PotSetup ps;
  ps.pot.refine = true;
  ps.atom_scans = 4;
  const Method m = pot_method(ps, "RePOT");
  ASSERT_EQ(t1.train.position, t2.train.position);
  ASSERT_EQ(t1.train.label, t2.train.label);
  const FittedMap f1 = m.fit(&test::context(), t1), f2 = m.fit(&test::context(), t2);
  ASSERT_TRUE(f1.kernels && f2.kernels);
  ASSERT_GT(f1.kernels->size(), 10u);
  EXPECT_GT(f1.info.at("refine_ms"), 0);
  EXPECT_EQ(f1.kernels->position, f2.kernels->position);
  EXPECT_EQ(f1.kernels->gamma, f2.kernels->gamma);
  EXPECT_EQ(f1.kernels->w_mean, f2.kernels->w_mean);
  EXPECT_EQ(f1.kernels->w_var, f2.kernels->w_var);
  // And the map is a map: held-out hits above held-out free samples.
  EXPECT_GT(score_map(f1, test1).auc, 0.65);  // measured 0.74
}

TEST(Experiment, AWholeDriveBoxSaysWhereWholeDrivesAreMapped) {
  // A 2.4 km drive's box at 1 m kernels is more than the bounded joint BHM may hold.
  experiment::BhmSetup s;
  s.joint = true;
  s.spacing = 1;
  const double lo[3] = {0, 0, -10}, hi[3] = {2400, 1800, 40};
  LabelledPoints one;
  one.dim = 3;
  one.position = {1, 1, 1};
  one.label = {1};
  one.scan = {0};
  try {
    experiment::learn_bhm(nullptr, s, 3, lo, hi, one);
    FAIL() << "no ArgumentError";
  } catch (const ArgumentError& e) {
    const std::string m = e.what();
    for (const char* n : {"too many kernels", "2400 m x 1800 m x 50 m", "potmap mapping DRIVE"})
      EXPECT_NE(m.find(n), std::string::npos) << m << " lacks " << n;
  }
}
