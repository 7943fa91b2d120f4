// DriveMapper: a real drive's keyframes into the joint BHM at the drive defaults, memory that
// follows the place (retired tiles), and a saved state that continues bit for bit.
#include "potmap/mapping/drive_mapper.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>

#include "potmap/data/drive.hpp"
#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/metrics.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

Scores held_out_scores(const DriveMapper& m, const KernelMap& map) {
  const LabelledPoints& t = m.held_out();
  MapEvaluator ev(test::context(), map);
  std::vector<float> prob(t.size());
  ev.evaluate(t.position.data(), t.size(), nullptr, nullptr, prob.data());
  return score(prob, t.label);
}

Scores held_out_scores(const DriveMapper& m) {
  return held_out_scores(m, m.map());
}

}  // namespace

TEST(DriveMapper, RiversideKeyframesBeatTheGridWithBoundedMemory) {
  const Drive d = open_drive(test::shared_data("drives3d/riverside-a"));
  DriveMapperOptions o;
  o.range_cut = 20;
  o.test_stride = 16;
  o.retire_radius = 30;
  DriveMapper m(o);
  std::size_t retired = 0, peak = 0;
  const std::size_t keyframes = test::sized(10, 4);
  for (std::size_t i = 0; i < keyframes; ++i) {
    const KeyframeStats st = m.add(read_keyframe(d, i), std::int64_t(i));
    EXPECT_LT(st.gathered, st.samples);  // gathered per voxel
    retired += st.retired;
    peak = std::max(peak, st.memory_bytes);
  }
  EXPECT_GT(retired, 0u);
  EXPECT_EQ(m.keyframes(), keyframes);
  // Measured 0.983 / 0.094, 49 MB at most (OctoMap at 0.2 m on keyframes 10-29 at this cut:
  // 0.91 / 0.30, bench/drive3d.py).
  const Scores s = held_out_scores(m);
  std::printf("riverside-a keyframes 0-9, 20 m: AUC %.4f NLL %.4f, peak %.1f MB\n", s.auc, s.nll,
              peak / 1e6);
  EXPECT_GT(s.auc, 0.97);
  EXPECT_LT(s.nll, 0.13);
  EXPECT_LT(peak, std::size_t(80) << 20);
  // The map carries its learner's feature cut-off, and is scored at it: the evaluators' own 18
  // gives the same scores.
  KernelMap full = m.map();
  EXPECT_EQ(full.cutoff_tau, m.learner().options().tau);
  full.cutoff_tau = std::numeric_limits<double>::infinity();
  const Scores s18 = held_out_scores(m, full);
  EXPECT_NEAR(s.auc, s18.auc, 1e-3);
  EXPECT_NEAR(s.nll, s18.nll, 2e-3);
  EXPECT_THROW(m.add(Scan{}, 10), ArgumentError);  // a 2D scan
}

TEST(DriveMapper, TheLookAheadScoresEachKeyframeBeforeItIsLearned) {
  const Drive d = open_drive(test::shared_data("drives3d/riverside-a"));
  DriveMapperOptions o;
  o.range_cut = 20;
  o.test_stride = 8;
  DriveMapper plain(o);
  o.lookahead = true;
  DriveMapper ahead(o);
  // Every 4th keyframe: the car moves about 30 m between them, so each sees new space too.
  std::size_t later = 0;  // held-out samples of the keyframes after the first
  for (std::size_t i = 0; i < 20; i += 4) {
    const Scan k = read_keyframe(d, i);
    plain.add(k, std::int64_t(i));
    const KeyframeStats st = ahead.add(k, std::int64_t(i));
    if (i > 0) later += st.held_out;
  }
  test::expect_same_map(plain.map(), ahead.map());  // scoring changes nothing
  EXPECT_EQ(plain.lookahead().size(), 0u);
  const LookAhead& la = ahead.lookahead();
  ASSERT_EQ(la.size(), later);
  Scores all, beyond;
  lookahead_scores(la, all, beyond);
  std::printf(
      "riverside-a keyframes 4-16 ahead, 20 m: AUC %.4f NLL %.4f (%zu), beyond reach "
      "AUC %.4f NLL %.4f (%zu)\n",
      all.auc, all.nll, all.n, beyond.auc, beyond.nll, beyond.n);
  // Much of what the car sees it saw from the keyframe before: the map predicts it.
  EXPECT_GT(all.auc, 0.8);
  EXPECT_LT(all.nll, 0.4);
  // Some of each keyframe is new: beyond every earlier sample's reach, where the map has only
  // its prior to say (and RePOT its seeds).
  EXPECT_GT(beyond.n, 100u);
  EXPECT_LT(beyond.n, all.n / 2);
}

TEST(DriveMapper, ASavedStateContinuesBitForBit) {
  const Drive d = open_drive(test::shared_data("drives3d/riverside-a"));
  DriveMapperOptions o;
  o.range_cut = 15;
  o.test_stride = 32;
  o.retire_radius = 20;  // tiles retire within these keyframes: the state carries them
  o.lookahead = true;    // and the look-ahead so far
  DriveMapper a(o), b(o);
  for (std::size_t i = 0; i < 4; ++i) {
    const Scan k = read_keyframe(d, i);
    a.add(k, std::int64_t(i));
    b.add(k, std::int64_t(i));
  }
  ASSERT_GT(a.learner().retired_tiles(), 0u);
  const std::string path = test::temp_dir("drive-mapper-state") + "/s.potdrv";
  b.save_state(path, "run record");
  EXPECT_TRUE(test::file_bytes(path) ==
              b.state_bytes("run record"));  // what a writer thread writes
  DriveMapper c(o);
  EXPECT_EQ(c.load_state(path), "run record");
  EXPECT_EQ(DriveMapper::state_extra(path), "run record");
  for (std::size_t i = 4; i < 6; ++i) {
    const Scan k = read_keyframe(d, i);
    a.add(k, std::int64_t(i));
    c.add(k, std::int64_t(i));
  }
  test::expect_same_map(a.map(), c.map());
  // The map polished on a context's host team and every core is the same, bit for bit.
  test::expect_same_map(a.map(), a.map(&test::context()));
  EXPECT_EQ(a.held_out().position, c.held_out().position);
  EXPECT_EQ(a.lookahead().prob, c.lookahead().prob);
  EXPECT_EQ(a.lookahead().beyond, c.lookahead().beyond);
  // Other options: refused, naming the file.
  DriveMapperOptions other = o;
  other.range_cut = 16;
  DriveMapper e(other);
  test::expect_input_error([&] { e.load_state(path); }, {path, "other drive mapper options"});
}

TEST(DriveMapper, RepotSeedsWhereNoSampleReachesAndScoresAsBhm) {
  const Drive d = open_drive(test::shared_data("drives3d/riverside-a"));
  DriveMapperOptions o;
  o.range_cut = 20;
  o.test_stride = 16;
  DriveMapper bhm(o);
  o.dictionary = test::drive_atoms("drives3d/riverside-a", test::sized(4u, 2u));
  o.transfer_every = 2;
  ASSERT_GT(o.dictionary->size(), 4u);
  DriveMapper repot(o);
  std::size_t seeded = 0;
  for (std::size_t i = 20; i < 20 + test::sized(4u, 2u); ++i) {
    const Scan k = read_keyframe(d, i);
    const KeyframeStats st = repot.add(k, std::int64_t(i), &test::context());
    bhm.add(k, std::int64_t(i), &test::context());
    // Every second keyframe transfers (the seeds last until samples reach them).
    if (i % 2 == 0)
      EXPECT_GT(st.transfer_ms, 0);
    else
      EXPECT_EQ(st.transfer_ms, 0);
    seeded += st.seeded;
  }
  EXPECT_GT(seeded, 0u);
  // Where samples reach, the seeds have yielded: RePOT's held-out scores are BHM's up to the
  // solver's tolerance (measured equal to 1e-4); past the data it holds the seeded kernels.
  const Scores r = held_out_scores(repot), b = held_out_scores(bhm);
  std::printf("riverside-a keyframes 20-23, 20 m: RePOT AUC %.4f NLL %.4f, BHM %.4f %.4f\n", r.auc,
              r.nll, b.auc, b.nll);
  EXPECT_NEAR(r.auc, b.auc, 0.002);
  EXPECT_NEAR(r.nll, b.nll, 0.005);
  const KernelMap rm = repot.map(), bm = bhm.map();
  std::map<std::array<long, 3>, double> bhm_mean;
  auto key = [](const KernelMap& m, std::size_t k) {
    return std::array<long, 3>{std::lround(m.position[3 * k] * 1e3),
                               std::lround(m.position[3 * k + 1] * 1e3),
                               std::lround(m.position[3 * k + 2] * 1e3)};
  };
  for (std::size_t k = 0; k < bm.size(); ++k) bhm_mean[key(bm, k)] = bm.w_mean[k];
  std::size_t moved = 0;  // seeded kernels no sample reached
  for (std::size_t k = 0; k < rm.size(); ++k) {
    const auto it = bhm_mean.find(key(rm, k));
    moved += it == bhm_mean.end() || std::abs(it->second - rm.w_mean[k]) > 1e-3;
  }
  EXPECT_GT(moved, 0u);
  // A state saved with one dictionary does not load into a mapper of another, or none.
  const std::string path = test::temp_dir("drive-mapper-repot") + "/s.potdrv";
  repot.save_state(path);
  test::expect_input_error([&] { bhm.load_state(path); }, {path, "other drive mapper options"});
  // A 2D dictionary is refused.
  auto flat = std::make_shared<Dictionary>();
  flat->dim = 2;
  o.dictionary = flat;
  EXPECT_THROW(DriveMapper{o}, ArgumentError);
}

// The joint BHM's features and sums on the device against the host's. One keyframe with one EM
// round: the precision and eta are the sums alone (the bound starts at the prior), so the
// exact posterior (a Cholesky factorisation, no CG) agrees to rounding. Over keyframes at the
// drive defaults each round's bound starts from the last solve, which stops at the CG's
// tolerance; on these ill-conditioned systems (variances from 0.01 to the prior's 10) sums
// rounded in another order move the means by up to 0.014 where the data say little, and the
// held-out scores by 2e-6.
TEST(DriveMapper, SumsOnTheDeviceGiveTheHostsMap) {
  if (!test::context().info().has_fp64) GTEST_SKIP() << "the device has no doubles";
  const Drive d = open_drive(test::shared_data("drives3d/riverside-a"));
  DriveMapperOptions o;
  o.range_cut = 20;
  auto pair = [&](DriveMapperOptions opt) {
    opt.bhm.sums = JointBhmSums::host;
    std::array<DriveMapper, 2> m{DriveMapper(opt), DriveMapper(opt)};
    opt.bhm.sums = JointBhmSums::device;
    m[1] = DriveMapper(opt);
    return m;
  };
  {
    DriveMapperOptions one = o;
    one.bhm.em_iterations = 1;
    std::array<DriveMapper, 2> m = pair(one);
    const Scan k = read_keyframe(d, 0);
    for (DriveMapper& x : m) x.add(k, 0, &test::context());
    EXPECT_FALSE(m[0].learner().last_stats().sums_on_device);
    EXPECT_TRUE(m[1].learner().last_stats().sums_on_device);
    EXPECT_EQ(m[1].learner().last_stats().samples, m[0].learner().last_stats().samples);
    const LabelledPoints& t = m[0].held_out();
    const std::size_t n = std::min<std::size_t>(t.size(), 400);
    std::vector<double> mean[2], var[2];
    for (int i = 0; i < 2; ++i) {
      mean[i].resize(n);
      var[i].resize(n);
      m[i].learner().predict_exact(t.position.data(), n, mean[i].data(), var[i].data());
    }
    double worst = 0;
    for (std::size_t j = 0; j < n; ++j)
      worst = std::max({worst, std::abs(mean[0][j] - mean[1][j]) / (1 + std::abs(mean[0][j])),
                        std::abs(var[0][j] - var[1][j]) / var[0][j]});
    EXPECT_LT(worst, 1e-10);
  }
  std::array<DriveMapper, 2> m = pair(o);
  for (std::size_t i = 0; i < test::sized(3, 2); ++i) {
    const Scan k = read_keyframe(d, i);
    for (DriveMapper& x : m) x.add(k, std::int64_t(i), &test::context());
    EXPECT_EQ(m[1].learner().last_stats().samples, m[0].learner().last_stats().samples);
  }
  const Scores sh = held_out_scores(m[0]), sd = held_out_scores(m[1]);
  EXPECT_NEAR(sd.auc, sh.auc, 1e-4);
  EXPECT_NEAR(sd.nll, sh.nll, 1e-4);
}
