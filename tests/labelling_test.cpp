#include "potmap/labelling.hpp"

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
