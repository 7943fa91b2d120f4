// Forgetting in the joint BHM (JointBhmOptions::half_life, JointBhm::set_time): the data's part
// of the posterior fades toward the prior, lazily per tile, exactly as fading every tile at
// every scan would, and through states, map files, merging and retired tiles.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "potmap/data/drive.hpp"
#include "potmap/error.hpp"
#include "potmap/learn/bhm_joint.hpp"
#include "potmap/learn/bhm_joint_merge.hpp"
#include "potmap/mapping/drive_mapper.hpp"
#include "potmap/map/evaluate.hpp"
#include "test_support.hpp"

namespace {

using namespace potmap;

// Beams up the y axis at x in [x0, x0 + 1], the sensor on y = 0. With the car: each ends on it
// at y = 2. Without: it passes through y = 2 and ends on a wall at y = 5. Free samples every
// half metre before the end, shifted by `seed`.
LabelledPoints street_scan(double x0, bool car, int seed) {
  LabelledPoints p;
  p.dim = 2;
  const double end = car ? 2.0 : 5.0, shift = 0.05 * (seed % 7);
  for (int b = 0; b <= 10; ++b) {
    const double x = x0 + 0.1 * b;
    p.position.insert(p.position.end(), {x, end});
    p.label.push_back(1);
    for (double y = 0.2 + shift; y < end - 0.3; y += 0.5) {
      p.position.insert(p.position.end(), {x, y});
      p.label.push_back(0);
    }
  }
  return p;
}

JointBhmOptions fading(double half_life) {
  JointBhmOptions o;
  o.half_life = half_life;
  o.sums = JointBhmSums::host;
  return o;
}

// Predictive mean and variance of the logit at (x, y) (exact sparse solve).
std::pair<double, double> logit_at(const JointBhm& m, double x, double y) {
  const double q[2] = {x, y};
  double mean = 0, var = 0;
  m.predict_exact(q, 1, &mean, &var);
  return {mean, var};
}

double prob_at(const JointBhm& m, double x, double y) {
  const auto [mean, var] = logit_at(m, x, y);
  return probit_probability(mean, var);
}

TEST(JointBhmForget, HalfLifeZeroIgnoresTheClock) {
  JointBhm plain(2, fading(0)), clocked(2, fading(0));
  for (int t = 0; t < 6; ++t) {
    clocked.set_time(100.0 * t);
    plain.update(street_scan(0, t < 3, t));
    clocked.update(street_scan(0, t < 3, t));
  }
  EXPECT_EQ(clocked.time(), 500.0);
  test::expect_same_map(plain.map(), clocked.map());
}

TEST(JointBhmForget, APlaceNoLongerSeenReturnsToItsPrior) {
  JointBhm m(2, fading(1.0)), empty(2, fading(1.0));
  m.set_time(0);
  for (int t = 0; t < 5; ++t) {
    m.set_time(t);
    m.update(street_scan(0, true, t));
  }
  const auto [seen, seen_var] = logit_at(m, 0.5, 2.0);
  ASSERT_GT(seen, 1.0);  // the car, firmly
  m.set_time(4 + 40);    // forty half-lives later: the data weigh 2^-40
  const auto [later, later_var] = logit_at(m, 0.5, 2.0);
  const auto [prior, prior_var] = logit_at(empty, 0.5, 2.0);
  EXPECT_LT(std::abs(later - prior), 1e-6 * std::abs(seen));
  EXPECT_NEAR(later_var, prior_var, 1e-6 * prior_var);
  EXPECT_GT(prior_var, 10 * seen_var);
  // The exported map says the same.
  const KernelMap exported = m.map();
  for (std::size_t k = 0; k < exported.size(); ++k)
    EXPECT_LT(std::abs(exported.w_mean[k]), 1e-6 * std::abs(seen)) << "kernel " << k;
}

TEST(JointBhmForget, ACarThatLeftReadsFreeWithinAFewScans) {
  // Ten scans with the car, then three without it, 0.1 s apart. Without forgetting the ten
  // outvote the three; with a half-life of 0.1 s the three win.
  JointBhm keep(2, fading(0)), forget(2, fading(0.1));
  for (int t = 0; t < 13; ++t) {
    for (JointBhm* m : {&keep, &forget}) {
      m->set_time(0.1 * t);
      m->update(street_scan(0, t < 10, t));
    }
    if (t == 9) {
      EXPECT_GT(prob_at(keep, 0.5, 2.0), 0.9);
      EXPECT_GT(prob_at(forget, 0.5, 2.0), 0.9);
    }
  }
  const double p_keep = prob_at(keep, 0.5, 2.0), p_forget = prob_at(forget, 0.5, 2.0);
  EXPECT_GT(p_keep, 0.5) << "the ten scans with the car still outvote the three without";
  EXPECT_LT(p_forget, 0.25) << "faded, the car's evidence loses to three scans of free space";
  // Where nothing changed (the road before the car) both read free.
  EXPECT_LT(prob_at(forget, 0.5, 1.0), 0.25);
  EXPECT_LT(prob_at(keep, 0.5, 1.0), 0.25);
}

TEST(JointBhmForget, LazyFadingEqualsFadingEveryTileAtEveryScan) {
  // Scans in places two tiles apart and back (a tile is 16 m), so that tiles wait between
  // the scans that reach them. The eager learner fades every tile before every update.
  JointBhm lazy(2, fading(0.5)), eager(2, fading(0.5));
  const double places[] = {0, 40, 80, 40, 0, 80, 0};
  for (int t = 0; t < 7; ++t)
    for (JointBhm* m : {&lazy, &eager}) {
      m->set_time(0.3 * t);
      if (m == &eager) m->catch_up();
      m->update(street_scan(places[t], t % 2 == 0, t));
    }
  const KernelMap a = lazy.map(), b = eager.map();
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    EXPECT_NEAR(a.w_mean[k], b.w_mean[k], 1e-9 + 1e-7 * std::abs(b.w_mean[k])) << "kernel " << k;
    EXPECT_NEAR(a.w_var[k], b.w_var[k], 1e-9 * b.w_var[k]) << "kernel " << k;
  }
  EXPECT_NEAR(a.bias_mean, b.bias_mean, 1e-9);
  for (double x : {0.5, 40.5, 80.5})
    EXPECT_NEAR(logit_at(lazy, x, 2).first, logit_at(eager, x, 2).first, 1e-7);
  // map() faded a copy: the learner itself is unchanged, and exports the same again.
  test::expect_same_map(a, lazy.map());
}

TEST(JointBhmForget, MapFileKeepsTheClockAndContinuesBitForBit) {
  JointBhm m(2, fading(0.5));
  for (int t = 0; t < 4; ++t) {
    m.set_time(0.2 * t);
    m.update(street_scan(t % 2 ? 40 : 0, true, t));
  }
  const std::string path = test::temp_dir("forget_file") + "/map.potmap";
  write_joint_bhm_map(m, path);
  std::optional<JointBhm> back = read_joint_bhm_information(path);
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(back->options().half_life, 0.5);
  EXPECT_EQ(back->time(), m.time());
  for (int t = 4; t < 7; ++t)
    for (JointBhm* x : {&m, &*back}) {
      x->set_time(0.2 * t);
      x->update(street_scan(t % 2 ? 40 : 0, false, t));
    }
  test::expect_same_map(m.map(), back->map());
}

TEST(JointBhmForget, MergeFadesEveryMapToTheLatestClock) {
  // One robot saw the car long ago, another sees the street empty now.
  JointBhm early(2, fading(1.0)), late(2, fading(1.0));
  for (int t = 0; t < 5; ++t) {
    early.set_time(t);
    early.update(street_scan(0, true, t));
    late.set_time(50 + t);
    late.update(street_scan(0, false, 10 + t));
  }
  const JointBhm merged = merge_joint_bhm({&early, &late});
  EXPECT_EQ(merged.time(), late.time());
  EXPECT_NEAR(logit_at(merged, 0.5, 2.0).first, logit_at(late, 0.5, 2.0).first, 1e-6);
  // Without forgetting the early robot's car stays in the merged map.
  JointBhm early0(2, fading(0)), late0(2, fading(0));
  for (int t = 0; t < 5; ++t) {
    early0.update(street_scan(0, true, t));
    late0.update(street_scan(0, false, 10 + t));
  }
  const JointBhm merged0 = merge_joint_bhm({&early0, &late0});
  EXPECT_GT(logit_at(merged0, 0.5, 2.0).first, logit_at(merged, 0.5, 2.0).first + 1.0);
}

// Three scans of the car, its tiles retired (the sensor went far away), twenty half-lives, then
// one scan of the empty street there. Returns the car's probability after it, and checks the
// retired tiles' export on the way.
double car_after_revival(double half_life) {
  JointBhm m(2, fading(half_life));
  for (int t = 0; t < 3; ++t) {
    m.set_time(t);
    m.update(street_scan(0, true, t));
  }
  auto largest_weight = [](const KernelMap& k) {
    double w = 0;
    for (double x : k.w_mean) w = std::max(w, std::abs(x));
    return w;
  };
  const double before = largest_weight(m.map());
  const double far[3] = {500, 0, 0};
  EXPECT_GT(m.retire_far(far, 100), 0u);
  EXPECT_EQ(m.tiles(), 0u);
  m.set_time(22);
  // Exported, the retired means fade: a retired kernel is a diagonal Gaussian (mean m, variance
  // v), whose data part faded by a = 2^-20 leaves the mean a m (prior_var / v) / (1 + ...),
  // at most a thousandth of it for variances down to 1/100 of the prior's. Kept, they are the
  // learner's means at retirement (the export before polished them to a finer tolerance).
  const double after = largest_weight(m.map());
  if (half_life > 0)
    EXPECT_LT(after, 1e-3 * before) << "retired means fade in the export";
  else
    EXPECT_NEAR(after, before, 1e-2 * before);
  m.update(street_scan(0, false, 3));  // revives the tiles
  EXPECT_GT(m.tiles(), 0u);
  return prob_at(m, 0.5, 2.0);
}

TEST(JointBhmForget, RetiredTilesFadeAndReviveFaded) {
  EXPECT_GT(car_after_revival(0), 0.5) << "kept, three scans of the car outvote one without";
  EXPECT_LT(car_after_revival(1.0), 0.3) << "faded while retired, the car is gone at revival";
}

// A drive mapper that forgets, saved mid-drive and restored, continues as the one that never
// stopped, bit for bit (the clocks of the learner and of its tiles are in the state), and its
// map is not the one of a mapper that never forgets.
TEST(JointBhmForget, DriveMapperStateContinuesBitForBit) {
  const Drive drive = open_drive(test::shared_data("drives3d/hku-1"));
  DriveMapperOptions o;
  o.bhm.half_life = 0.5;
  o.bhm.sums = JointBhmSums::host;
  o.range_cut = 20;
  DriveMapperOptions keep = o;
  keep.bhm.half_life = 0;
  DriveMapper a(o), never(keep);
  const std::string path = test::temp_dir("forget-drive-state") + "/m.state";
  std::optional<DriveMapper> b;
  for (std::size_t i = 0; i < 6; ++i) {
    const Scan k = read_keyframe(drive, i);
    a.add(k, std::int64_t(i));
    never.add(k, std::int64_t(i));
    if (b) b->add(k, std::int64_t(i));
    if (i == 2) {
      a.save_state(path);
      b.emplace(o);
      b->load_state(path);
    }
  }
  ASSERT_GT(a.learner().time(), 0.0);
  EXPECT_EQ(b->learner().time(), a.learner().time());
  test::expect_same_map(a.map(), b->map());
  EXPECT_NE(a.map().w_mean, never.map().w_mean);
}

TEST(JointBhmForget, RefusesBadHalfLivesAndTimes) {
  for (double h : {-1.0, std::nan(""), std::numeric_limits<double>::infinity()})
    EXPECT_THROW(JointBhm(2, fading(h)), ArgumentError) << h;
  JointBhm m(2, fading(1.0));
  EXPECT_THROW(m.set_time(std::nan("")), ArgumentError);
  // An earlier time after a later one changes nothing (no rejuvenation).
  m.set_time(10);
  m.update(street_scan(0, true, 0));
  const auto before = logit_at(m, 0.5, 2.0);
  m.set_time(3);
  EXPECT_EQ(m.time(), 10.0);
  EXPECT_EQ(logit_at(m, 0.5, 2.0), before);
}

}  // namespace
