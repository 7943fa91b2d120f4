// A long drive through the growable JointBhm (RePOT's persistent overall map without the
// transport): every scan of freiburg-079 streamed in order, cut at 20 m as the experiments cut
// the logs. The map's memory follows the area driven: once the building is covered, more scans
// (the robot drives its corridors again and again) add nothing. And the map still maps: the
// held-out beams of the last scans score well on it.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/learn/bhm_joint.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/metrics.hpp"
#include "test_support.hpp"

namespace potmap {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

TEST(JointBhmStream, Freiburg079MemoryFollowsTheAreaNotTheScans) {
  const Dataset ds = read_dataset(test::shared_data("radish/freiburg-079-corrected.log.gz"));
  const std::size_t n = ds.scans.size();
  ASSERT_GE(n, 4000u);  // 4,791 scans in the corrected log
  // Every `stride`-th scan (1: all of them; small inputs, under the sanitizers: every 16th, the
  // same drive over the same building, so the same memory bounds hold).
  const std::size_t stride = test::sized<std::size_t>(1, 16);
  const std::size_t last_tested = test::sized<std::size_t>(100, 40);

  JointBhm map(2);
  LabelOptions lo;  // 20 % of beams held out, 1 free sample per metre
  LabelledPoints test;
  test.dim = 2;
  // The poses' bounding box so far (printed: how much of the drive is new ground).
  double bb_lo[2] = {1e300, 1e300}, bb_hi[2] = {-1e300, -1e300};
  std::vector<std::size_t> memory(n, 0);
  std::vector<double> area(n, 0);
  const auto t0 = std::chrono::steady_clock::now();
  double update_s = 0;
  std::size_t streamed = 0;
  for (std::size_t i = 0; i < n; i += stride) {
    const Scan scan = experiment::limit_range(ds.scans[i], 20);
    LabelledSplit split;
    label_scan(scan, static_cast<std::int64_t>(i), lo, split);
    split.train.dim = split.test.dim = 2;
    const auto u0 = std::chrono::steady_clock::now();
    map.update(split.train);
    update_s += seconds_since(u0);
    ++streamed;
    if (i + last_tested * stride >= n) {
      test.position.insert(test.position.end(), split.test.position.begin(),
                           split.test.position.end());
      test.label.insert(test.label.end(), split.test.label.begin(), split.test.label.end());
    }
    const auto o = scan.origin();
    for (int d = 0; d < 2; ++d) {
      bb_lo[d] = std::min(bb_lo[d], o[d]);
      bb_hi[d] = std::max(bb_hi[d], o[d]);
    }
    memory[i] = map.memory_bytes();
    area[i] = (bb_hi[0] - bb_lo[0]) * (bb_hi[1] - bb_lo[1]);
  }
  const double stream_s = seconds_since(t0);
  // The first pass over the building: the first fifth of the log. By then the 20 m beams have
  // reached its walls from most of the robot's corridors; the rest of the log drives them
  // again (the poses' bounding box still grows a little, as the robot enters side rooms).
  const std::size_t covered = n / 5 / stride * stride;
  const std::size_t at_cover = memory[covered], at_end = map.memory_bytes();
  const auto e0 = std::chrono::steady_clock::now();
  const KernelMap exported = map.map();
  const double export_s = seconds_since(e0);
  MapEvaluator ev(test::context(), exported);
  const Scores sc = score(ev.evaluate(test.position).prob, test.label);
  std::printf(
      "freiburg-079: %zu of %zu scans streamed in %.1f s (updates %.1f s, %.2f ms a scan); "
      "after scan %zu (pose box %.0f m2): %.1f MB, at the end %.1f MB (pose box %.0f m2; %zu "
      "tiles, %zu kernels); "
      "export %.1f s; last %zu scans' held-out beams: AUC %.4f ACC %.4f NLL %.4f (%zu samples)\n",
      streamed, n, stream_s, update_s, 1e3 * update_s / double(streamed), covered, area[covered],
      at_cover / 1e6, at_end / 1e6, area[(n - 1) / stride * stride], map.tiles(), map.size(),
      export_s, last_tested, sc.auc, sc.acc, sc.nll, sc.n);
  // Memory after the whole log within a small factor of memory once the building is covered.
  EXPECT_LT(double(at_end), 1.5 * double(at_cover));
  // And it never grew with the scans: the second half of the log adds (almost) nothing.
  EXPECT_LT(double(at_end), 1.1 * double(memory[n / 2 / stride * stride]));
  EXPECT_GT(sc.auc, test::sized(0.95, 0.93));
}

}  // namespace
}  // namespace potmap
