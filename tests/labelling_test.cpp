#include "potmap/data/labelling.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "test_support.hpp"

using namespace potmap;

namespace {
// 100 beams fanned around (1, 2): hits at 10 m.
Scan fan(std::size_t n = 100) {
  Scan s;
  s.dim = 2;
  s.max_range = 20;
  s.pose2d = {1, 2, 0};
  for (std::size_t i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    s.hits.push_back(1 + 10 * std::cos(a));
    s.hits.push_back(2 + 10 * std::sin(a));
  }
  return s;
}
}  // namespace

TEST(Labelling, HitsAndFreeSamplesOnTheSegment) {
  LabelOptions o;
  o.holdout_fraction = 0;
  LabelledSplit out;
  label_scan(fan(1), 7, o, out);
  ASSERT_EQ(out.train.size(), 11u);  // one hit + one free sample per metre of a 10 m beam
  EXPECT_TRUE(out.test.empty());
  std::size_t hits = 0;
  for (std::size_t i = 0; i < out.train.size(); ++i) {
    const double x = out.train.position[2 * i], y = out.train.position[2 * i + 1];
    EXPECT_EQ(out.train.scan[i], 7);
    EXPECT_NEAR(y, 2, 1e-12);
    if (out.train.label[i]) {
      ++hits;
      EXPECT_DOUBLE_EQ(x, 11);
    } else {
      EXPECT_GE(x, 1);
      EXPECT_LT(x, 11);
    }
  }
  EXPECT_EQ(hits, 1u);
}

TEST(Labelling, NoReturnBeamsAreFreeUpToMaxRange) {
  Scan s;
  s.dim = 2;
  s.max_range = 20;
  s.no_return = {0, 1};
  LabelOptions o;
  o.holdout_fraction = 0;
  o.free_per_metre = 0.5;
  LabelledSplit out;
  label_scan(s, 0, o, out);
  ASSERT_EQ(out.train.size(), 10u);
  for (std::size_t i = 0; i < 10; ++i) {
    EXPECT_EQ(out.train.label[i], 0);
    EXPECT_LE(out.train.position[2 * i + 1], 20);
  }
}

TEST(Labelling, HoldOutIsTwentyPercentOfBeamsWithAllTheirSamples) {
  LabelledSplit out;
  label_scan(fan(100), 0, LabelOptions{}, out);
  std::size_t test_hits = 0, train_hits = 0;
  for (auto y : out.test.label) test_hits += y;
  for (auto y : out.train.label) train_hits += y;
  EXPECT_EQ(test_hits, 20u);
  EXPECT_EQ(train_hits, 80u);
  EXPECT_EQ(out.test.size(), 20u * 11);
}

TEST(Labelling, SeededAndReproducible) {
  LabelOptions a, b;
  b.seed = 1;
  LabelledSplit x, y, z;
  label_scan(fan(), 0, a, x);
  label_scan(fan(), 0, a, y);
  label_scan(fan(), 0, b, z);
  EXPECT_EQ(x.train.position, y.train.position);
  EXPECT_NE(x.train.position, z.train.position);
}

TEST(Labelling, NanPointsDroppedAndCounted) {
  Scan s = fan(10);
  s.hits[4] = std::nan("");
  s.hits[9] = INFINITY;
  LabelOptions o;
  o.holdout_fraction = 0;
  LabelledSplit out;
  label_scan(s, 0, o, out);
  EXPECT_EQ(out.points_dropped, 2u);
  EXPECT_EQ(out.train.size(), 8u * 11);
  for (double v : out.train.position) EXPECT_TRUE(std::isfinite(v));
}

TEST(Labelling, EmptyScanIsANoOp) {
  Scan s;
  LabelledSplit out;
  label_scan(s, 0, LabelOptions{}, out);
  EXPECT_TRUE(out.train.empty());
  EXPECT_TRUE(out.test.empty());
}

TEST(Labelling, SliceOf3DScanKeepsTheHeightBand) {
  Scan s;
  s.dim = 3;
  s.max_range = 50;
  s.pose3d[11] = 1.7;  // sensor 1.7 m above ground
  s.hits = {5, 0, 1.7, 6, 0, 0.0, 7, 1, 1.75, 8, 0, 3.0};
  const Scan t = slice_2d(s, -0.1, 0.1);
  EXPECT_EQ(t.dim, 2);
  ASSERT_EQ(t.num_hits(), 2u);
  EXPECT_DOUBLE_EQ(t.hits[0], 5);
  EXPECT_DOUBLE_EQ(t.hits[2], 7);
  EXPECT_DOUBLE_EQ(t.hits[3], 1);
}

TEST(Labelling, KittiFrameLabelsEveryPoint) {
  const Scan s = read_kitti_bin(test::shared_data("lidar3d/kitti_000008.bin"));
  LabelledSplit out;
  label_scan(s, 0, LabelOptions{}, out);
  std::size_t hits = 0;
  for (auto y : out.train.label) hits += y;
  for (auto y : out.test.label) hits += y;
  EXPECT_EQ(hits, 17238u);  // every point of the frame is within KITTI's 120 m
  EXPECT_EQ(out.train.dim, 3);
}

TEST(Labelling, AbsurdRangeIsBoundedNotALongLoop) {
  Scan s;
  s.dim = 2;
  s.max_range = 1e300;  // what a corrupt log's largest range makes of FLASER's automatic maximum
  s.no_return = {1, 0};
  LabelOptions o;
  o.holdout_fraction = 0;
  LabelledSplit out;
  label_scan(s, 0, o, out);
  EXPECT_EQ(out.train.size(), static_cast<std::size_t>(o.max_free_per_beam));
}

// The beams split_beams keeps are exactly those whose samples label_scan puts in train: the
// hits of each part match point for point, and no-returns land on the right side too.
TEST(Labelling, SplitBeamsAgreesWithLabelScan) {
  Scan s = fan(60);
  for (int i = 0; i < 15; ++i) {  // no-return beams as well
    const double a = 0.1 + 0.4 * i;
    s.no_return.push_back(std::cos(a));
    s.no_return.push_back(std::sin(a));
  }
  LabelOptions o;
  o.seed = 11;
  LabelledSplit lab;
  label_scan(s, 4, o, lab);
  const Scan train = split_beams(s, 4, o);
  const Scan held = split_beams(s, 4, o, true);
  EXPECT_EQ(train.num_beams() + held.num_beams(), s.num_beams());
  EXPECT_EQ(held.num_beams(), std::size_t(std::lround(0.2 * s.num_beams())));
  const auto hits_of = [](const LabelledPoints& p) {
    std::vector<double> h;
    for (std::size_t i = 0; i < p.size(); ++i)
      if (p.label[i]) h.insert(h.end(), &p.position[2 * i], &p.position[2 * i] + 2);
    return h;
  };
  EXPECT_EQ(hits_of(lab.train), train.hits);
  EXPECT_EQ(hits_of(lab.test), held.hits);
  // Free samples of a held-out no-return beam lie on its ray: count test free samples on the
  // held-out no-return directions (10 m of 20 m... all 20 per beam at 1 per metre).
  std::size_t free_on_held_rays = 0;
  for (std::size_t i = 0; i < lab.test.size(); ++i) {
    if (lab.test.label[i]) continue;
    const double x = lab.test.position[2 * i] - 1, y = lab.test.position[2 * i + 1] - 2;
    for (std::size_t b = 0; b < held.num_no_return(); ++b) {
      const double ux = held.no_return[2 * b], uy = held.no_return[2 * b + 1];
      if (std::abs(x * uy - y * ux) < 1e-9 && x * ux + y * uy > 0) ++free_on_held_rays;
    }
  }
  EXPECT_EQ(free_on_held_rays, 20 * held.num_no_return());
  const std::vector<std::uint8_t> flags = heldout_beams(s, 4, o);
  EXPECT_EQ(flags.size(), s.num_beams());
}
