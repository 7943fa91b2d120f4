// Single 3D frames (experiment_frames.hpp): BHM on the frame's training beams, POT and RePOT with
// atoms from other frames, scored on the frame's held-out beams. The frames are thinned (every
// k-th return) and cut at 15 m so that each test stays well under a minute on 2 cores, under the
// sanitizers too; the full frames are measured in docs/results-3d.md.
#include <gtest/gtest.h>

#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"
#include "potmap/experiments/experiment_frames.hpp"
#include "test_support.hpp"

namespace potmap::experiment {
namespace {

// Every k-th return of a frame (no-returns kept): a sparser sensor over the same scene.
Scan thin(const Scan& s, std::size_t k) {
  Scan o = s;
  o.hits.clear();
  for (std::size_t i = 0; i < s.num_hits(); i += k)
    o.hits.insert(o.hits.end(), &s.hits[i * 3], &s.hits[i * 3] + 3);
  return o;
}

Scan real_frame(const std::string& name, std::size_t k) {
  const Dataset d = read_dataset(test::shared_data("lidar3d/" + name));
  EXPECT_EQ(d.scans.size(), 1u);
  return thin(d.scans.at(0), k);
}

FrameSetup small_setup() {
  FrameSetup s = frame_setup_3d();
  // The kernels fill the cut's ball, so the cut sets the cost. The same 15 m under the
  // sanitizers: with the joint BHM's own cut-off a frame costs a second or two
  // there too, and a 10 m cut was a different, thinner test (RePOT's NLL 3e-5 above BHM's).
  s.max_range = 15.0;
  return s;
}

// Every k-th beam of a simulated frame: no-returns and returns alike.
Scan thin_sim(const Scan& s, std::size_t k) {
  Scan o = thin(s, k);
  o.no_return.clear();
  for (std::size_t i = 0; i < s.num_no_return(); i += k)
    o.no_return.insert(o.no_return.end(), &s.no_return[i * 3], &s.no_return[i * 3] + 3);
  return o;
}

FrameSource sim_source(const std::vector<std::string>& towns, std::size_t scans, std::size_t k) {
  FrameSource src;
  src.label = "sim3d";
  for (const std::string& t : towns) {
    src.places.emplace_back();
    for (const Scan& s : simulate(Town::builtin(t), sim_options_3d(scans, 0)).scans)
      src.places.back().push_back(thin_sim(s, k));
  }
  return src;
}

const FrameResult& result(const FrameEvaluation& e, const std::string& method) {
  for (const FrameResult& r : e.results)
    if (r.method == method) return r;
  throw std::runtime_error("no result for " + method);
}

void print(const std::string& what, const FrameEvaluation& e) {
  for (const FrameResult& r : e.results)
    std::printf("%s %-6s ACC %.3f AUC %.3f NLL %.3f fit %.2f s\n", what.c_str(), r.method.c_str(),
                r.scores.acc, r.scores.auc, r.scores.nll, r.fit_s);
}

// RePOT is the frame's BHM seeded by the transported kernels where no sample reached: it must
// not lose to BHM (seeds yield fully by default, so near the data it is BHM up to the conjugate
// gradients' tolerance, 1e-5 of the residual: measured, the scores move by about 1e-6 in 3D);
// POT alone must rank the held-out samples well.
void expect_targets(const FrameEvaluation& e, double pot_auc, double pot_nll) {
  const Scores& bhm = result(e, "BHM").scores;
  const Scores& pot = result(e, "POT").scores;
  const Scores& repot = result(e, "RePOT").scores;
  constexpr double kRounding = 1e-5;
  EXPECT_GT(bhm.auc, 0.95);
  EXPECT_GE(repot.auc, bhm.auc - kRounding);
  EXPECT_LE(repot.nll, bhm.nll + kRounding);
  EXPECT_GT(pot.auc, pot_auc);
  EXPECT_LT(pot.nll, pot_nll);
  EXPECT_GT(e.test.size(), 1000u);
}

// Measured (frame every 8th return, one thinned scan of town1 as source): BHM AUC 0.975 NLL
// 0.185; POT AUC 0.861 NLL 0.408 (kernels on the frame's samples and the averaged map; with the
// barycentric placement 0.800 / 1.76; with three towns and the full frame POT reaches 0.888 /
// 0.447); RePOT AUC 0.975 NLL 0.179 (seeds yield to data). At a 10 m cut RePOT's NLL came out 3e-5
// above BHM's, and 0.0019 above at 8 m: the margin is thin on small cuts of this frame.
TEST(Frames3d, NuScenesFromSimulatedTowns) {
  const Scan frame = real_frame("nuscenes_lidar_top_1532402927647951.bin", 8);
  const FrameEvaluation e =
      evaluate_frame(&test::context(), frame, {sim_source({"town1"}, 1, 4)}, small_setup(), 0);
  print("nuscenes<-sim", e);
  expect_targets(e, 0.84, 0.45);
}

// Real to real. Measured: BHM AUC 0.986 NLL 0.109; POT AUC 0.926 NLL 0.384 (barycentric: 0.930 /
// 0.399); RePOT AUC 0.986 NLL 0.107.
TEST(Frames3d, KittiFromNuScenes) {
  FrameSource src;
  src.label = "nuscenes";
  src.places = {{real_frame("nuscenes_lidar_top_1532402927647951.bin", 8)}};
  const FrameEvaluation e =
      evaluate_frame(&test::context(), real_frame("kitti_000008.bin", 4), {src}, small_setup(), 0);
  print("kitti<-nuscenes", e);
  expect_targets(e, 0.9, 0.43);
}

// Measured (town2 frame every 4th beam, one thinned scan of town1): BHM AUC 0.979 NLL 0.130;
// POT AUC 0.975 NLL 0.213 (barycentric: 0.965 / 0.225); RePOT AUC 0.980 NLL 0.122.
TEST(Frames3d, SimulatedTownFromOtherTowns) {
  const Scan frame =
      thin_sim(simulate(Town::builtin("town2"), sim_options_3d(3, 1000)).scans.at(2), 4);
  const FrameEvaluation e =
      evaluate_frame(&test::context(), frame, {sim_source({"town1"}, 1, 4)}, small_setup(), 0);
  print("town2<-sim", e);
  expect_targets(e, 0.955, 0.26);
}

TEST(Frames3d, RejectsA2dFrameAndUnknownMethods) {
  Scan s2;
  s2.dim = 2;
  EXPECT_THROW(evaluate_frame(nullptr, s2, {}, frame_setup_3d(), 0), ArgumentError);
  Scan s3;
  s3.dim = 3;
  EXPECT_THROW(evaluate_frame(nullptr, s3, {}, frame_setup_3d(), 0, {"ogm"}), ArgumentError);
}

}  // namespace
}  // namespace potmap::experiment
