// gather_keyframe: a real keyframe's samples drawn and gathered per voxel on the device, the
// same as the host reference bit for bit, and the same as label_scan() + aggregate_voxels().
#include "potmap/data/keyframe_samples.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "potmap/data/drive.hpp"
#include "potmap/error.hpp"
#include "potmap/runtime/context.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

Scan riverside_keyframe(std::size_t i, double cut) {
  const Drive d = open_drive(test::shared_data("drives3d/riverside-a"));
  return limit_range(read_keyframe(d, i), cut);
}

LabelOptions drive_labels() {
  LabelOptions o;
  o.free_per_metre = 0.5;
  return o;
}

void expect_same_points(const LabelledPoints& a, const LabelledPoints& b) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(a.position, b.position);
  EXPECT_EQ(a.label, b.label);
  EXPECT_EQ(a.scan, b.scan);
  EXPECT_EQ(a.weight, b.weight);
}

}  // namespace

TEST(KeyframeSamples, DeviceGathersAsTheReferenceBitForBit) {
  Context& ctx = test::context();
  if (!ctx.info().has_fp64 || !ctx.info().has_int64_atomics)
    GTEST_SKIP() << "the device has no cl_khr_fp64 or cl_khr_int64_base_atomics";
  for (const double cut : {20.0, 40.0}) {
    const Scan k = riverside_keyframe(12, cut);
    const KeyframeSamples dev = gather_keyframe(k, 12, drive_labels(), 0.5, &ctx);
    const KeyframeSamples ref = gather_keyframe_reference(k, 12, drive_labels(), 0.5);
    EXPECT_TRUE(dev.on_device);
    EXPECT_FALSE(ref.on_device);
    EXPECT_EQ(dev.samples, ref.samples);
    EXPECT_GT(ref.samples, 2 * ref.train.size());  // several samples a voxel at 0.5 m
    expect_same_points(dev.train, ref.train);
    expect_same_points(dev.test, ref.test);
  }
}

TEST(KeyframeSamples, TheReferenceIsLabelScanGatheredPerVoxel) {
  const Scan k = riverside_keyframe(30, 40);
  const LabelOptions o = drive_labels();
  LabelledSplit split;
  label_scan(k, 30, o, split);
  const LabelledPoints want = aggregate_voxels(split.train, 0.5);
  const KeyframeSamples got = gather_keyframe_reference(k, 30, o, 0.5);
  EXPECT_EQ(got.samples, split.train.size());
  EXPECT_EQ(got.points_dropped, split.points_dropped);
  expect_same_points(got.test, split.test);
  ASSERT_EQ(got.train.size(), want.size());
  EXPECT_EQ(got.train.label, want.label);
  EXPECT_EQ(got.train.weight, want.weight);
  // The voxel's mean in fixed point: within 2^-20 of the edge of the exact mean.
  double worst = 0;
  for (std::size_t i = 0; i < want.position.size(); ++i)
    worst = std::max(worst, std::abs(got.train.position[i] - want.position[i]));
  EXPECT_LT(worst, 0.5 / 1048576.0 + 1e-9);
}

TEST(KeyframeSamples, FarFromTheOriginTheHostGathers) {
  Context& ctx = test::context();
  Scan k = riverside_keyframe(5, 20);
  // 300 km east: beyond the keys' 2^19 voxels at 0.5 m.
  for (std::size_t i = 0; i < k.hits.size(); i += 3) k.hits[i] += 3e5;
  k.pose3d[3] += 3e5;
  const KeyframeSamples got = gather_keyframe(k, 5, drive_labels(), 0.5, &ctx);
  EXPECT_FALSE(got.on_device);
  LabelledSplit split;
  label_scan(k, 5, drive_labels(), split);
  expect_same_points(got.train, aggregate_voxels(split.train, 0.5));
}

TEST(KeyframeSamples, RefusesBadInput) {
  Scan flat;
  flat.dim = 2;
  EXPECT_THROW(gather_keyframe_reference(flat, 0, {}, 0.5), ArgumentError);
  const Scan k = riverside_keyframe(0, 20);
  EXPECT_THROW(gather_keyframe_reference(k, 0, {}, 0), ArgumentError);
  EXPECT_THROW(gather_keyframe_reference(k, 0, {}, NAN), ArgumentError);
  LabelOptions bad;
  bad.holdout_fraction = 1.5;
  EXPECT_THROW(gather_keyframe(k, 0, bad, 0.5, &test::context()), ArgumentError);
}
