#include "potmap/experiments/score_breakdown.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "potmap/experiments/experiment.hpp"

using namespace potmap;
using namespace potmap::experiment;

namespace {

// A 3D scan from a sensor 2 m up at (5, -3): ground hits at 8 and 25 m, wall hits at 15 and
// 35 m, one return at 60 m (past a 40 m cut) and a no-return pointing up.
Scan drive_like_scan() {
  Scan s;
  s.dim = 3;
  s.max_range = 80;
  s.pose3d = {1, 0, 0, 5, 0, 1, 0, -3, 0, 0, 1, 2};
  auto hit = [&](double x, double y, double z) { s.hits.insert(s.hits.end(), {x, y, z}); };
  for (int k = 0; k < 20; ++k) {
    const double a = 2 * M_PI * k / 20, c = std::cos(a), d = std::sin(a);
    hit(5 + 8 * c, -3 + 8 * d, 0.0);     // ground, 8 m
    hit(5 + 25 * c, -3 + 25 * d, 0.05);  // ground, 25 m
    hit(5 + 15 * c, -3 + 15 * d, 2.5);   // wall, 15 m
    hit(5 + 35 * c, -3 + 35 * d, 1.5);   // wall, 35 m
    hit(5 + 60 * c, -3 + 60 * d, 3.0);   // past the cut
    s.no_return.insert(s.no_return.end(), {c * 0.96, d * 0.96, 0.28});
  }
  return s;
}

}  // namespace

TEST(ScoreBreakdown, RangeBinsAreHalfOpenAndClampedAtTheEnds) {
  const std::vector<double> e{0, 10, 20, 30, 40};
  EXPECT_EQ(bin_index(0.0, e, false), 0u);
  EXPECT_EQ(bin_index(9.999, e, false), 0u);
  EXPECT_EQ(bin_index(10.0, e, false), 1u);
  EXPECT_EQ(bin_index(29.9, e, false), 2u);
  EXPECT_EQ(bin_index(30.0, e, false), 3u);
  EXPECT_EQ(bin_index(40.0, e, false), 3u);  // the cut itself: the last bin
  EXPECT_EQ(bin_index(55.0, e, false), 3u);
  EXPECT_EQ(bin_index(-1.0, e, false), 0u);
  const auto names = bin_names(e, false);
  ASSERT_EQ(names.size(), 4u);
  EXPECT_EQ(names[0], "0-10 m");
  EXPECT_EQ(names[3], "30-40 m");
}

TEST(ScoreBreakdown, HeightBinsAreOpenAtBothEnds) {
  const std::vector<double> e{-1.2, 0, 2};
  EXPECT_EQ(bin_index(-1.8, e, true), 0u);
  EXPECT_EQ(bin_index(-1.2, e, true), 1u);
  EXPECT_EQ(bin_index(-0.1, e, true), 1u);
  EXPECT_EQ(bin_index(0.0, e, true), 2u);
  EXPECT_EQ(bin_index(2.0, e, true), 3u);
  EXPECT_EQ(bin_index(9.0, e, true), 3u);
  const auto names = bin_names(e, true);
  ASSERT_EQ(names.size(), 4u);
  EXPECT_EQ(names[0], "< -1.2 m");
  EXPECT_EQ(names[1], "-1.2..0 m");
  EXPECT_EQ(names[3], ">= 2 m");
  EXPECT_THROW(bin_index(1.0, {1.0}, false), ArgumentError);
  EXPECT_THROW(bin_index(1.0, {0, 2, 1}, false), ArgumentError);
}

TEST(ScoreBreakdown, KindsFollowLabelHeightAndBeam) {
  const BreakdownOptions o;
  EXPECT_EQ(sample_kind(true, -1.9, false, o), SampleKind::ground_hit);
  EXPECT_EQ(sample_kind(true, -0.5, false, o), SampleKind::other_hit);
  EXPECT_EQ(sample_kind(false, -1.9, false, o), SampleKind::free_of_hit);
  EXPECT_EQ(sample_kind(false, 3.0, true, o), SampleKind::free_past_cut);
}

TEST(ScoreBreakdown, PlacesTheHeldOutSamplesOfMakeTask) {
  const Scan cut = limit_range(drive_like_scan(), 40);
  LabelOptions lo;
  lo.free_per_metre = 0.5;
  lo.holdout_fraction = 0.5;
  lo.seed = 3;
  LabelledPoints test;
  make_task({cut, cut}, lo, test, 5.0, 12);
  ASSERT_GT(test.size(), 50u);
  const SamplePlaces p = place_test_samples({cut, cut}, lo, 12, test);
  ASSERT_EQ(p.range.size(), test.size());
  std::map<SampleKind, std::size_t> kinds;
  for (std::size_t i = 0; i < test.size(); ++i) {
    EXPECT_NEAR(p.range[i], std::hypot(test.position[3 * i] - 5, test.position[3 * i + 1] + 3),
                1e-9);
    EXPECT_NEAR(p.height[i], test.position[3 * i + 2] - 2, 1e-9);
    EXPECT_LE(p.range[i], 40 + 1e-9);
    ++kinds[sample_kind(test.label[i] != 0, p.height[i], p.past_cut[i] != 0, {})];
    // A past-cut free sample lies on a beam that runs out to the cut: the no-returns rise,
    // the cut returns at 60 m rise 1 m over 60 m.
    if (p.past_cut[i]) EXPECT_FALSE(test.label[i]);
    // A free sample of a hit beam lies before its hit: closer to the sensor than the hit by
    // its distance to it.
    if (!test.label[i] && !p.past_cut[i]) {
      ASSERT_TRUE(std::isfinite(p.to_hit[i]));
      EXPECT_GT(p.to_hit[i], 0.0);
      EXPECT_LT(p.to_hit[i], 40.0);
    } else {
      EXPECT_TRUE(std::isnan(p.to_hit[i]));
    }
  }
  EXPECT_GT(kinds[SampleKind::ground_hit], 0u);
  EXPECT_GT(kinds[SampleKind::other_hit], 0u);
  EXPECT_GT(kinds[SampleKind::free_of_hit], 0u);
  EXPECT_GT(kinds[SampleKind::free_past_cut], 0u);
  // Another split is not this test set.
  LabelOptions other = lo;
  other.seed = 4;
  EXPECT_THROW(place_test_samples({cut, cut}, other, 12, test), InputError);
  EXPECT_THROW(place_test_samples({cut, cut}, lo, 11, test), InputError);
}

TEST(ScoreBreakdown, ScoresEachBinOnItsOwnSamples) {
  // Four samples: a ground hit at 5 m (p 0.9), a free sample at 5 m (p 0.2), a wall hit at
  // 35 m (p 0.4), a past-cut free sample at 35 m (p 0.6).
  LabelledPoints t;
  t.dim = 3;
  t.position.assign(12, 0.0);
  t.label = {1, 0, 1, 0};
  SamplePlaces p;
  p.range = {5, 5, 35, 35};
  p.height = {-1.8, -1.0, 0.5, 3.0};
  p.past_cut = {0, 0, 0, 1};
  p.to_hit = {NAN, 0.7, NAN, NAN};
  const std::vector<double> prob{0.9, 0.2, 0.4, 0.6};
  std::map<std::string, Scores> by;
  for (const BinScores& b : score_breakdown(prob, t, p)) by[b.axis + "/" + b.bin] = b.scores;
  EXPECT_EQ(by.count("range/10-20 m"), 0u);  // empty bins are left out
  EXPECT_EQ(by.at("range/0-10 m").n, 2u);
  EXPECT_DOUBLE_EQ(by.at("range/0-10 m").auc, 1.0);
  EXPECT_EQ(by.at("range/30-40 m").n, 1u);  // the wall hit; the past-cut sample apart
  EXPECT_EQ(by.at("range/past cut").n, 1u);
  EXPECT_NEAR(by.at("range/past cut").nll, -std::log(0.4), 1e-9);
  EXPECT_EQ(by.at("height/< -1.2 m").n, 1u);
  EXPECT_EQ(by.at("height/>= 2 m").n, 1u);
  EXPECT_NEAR(by.at("kind/hit ground").nll, -std::log(0.9), 1e-9);
  EXPECT_NEAR(by.at("kind/hit other").nll, -std::log(0.4), 1e-9);
  EXPECT_TRUE(std::isnan(by.at("kind/hit other").auc));
  EXPECT_EQ(by.at("kind@range/free (past cut) 30-40 m").n, 1u);
  EXPECT_EQ(by.at("free to hit/0.5..1 m").n, 1u);
  EXPECT_NEAR(by.at("free to hit/0.5..1 m").nll, -std::log(0.8), 1e-9);
  EXPECT_EQ(by.count("free to hit/< 0.5 m"), 0u);
  EXPECT_THROW(score_breakdown({0.5}, t, p), ArgumentError);
}
