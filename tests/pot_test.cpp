// Scan transfer by POT and RePOT (SPEC section 4, steps 2 to 7).
#include <gtest/gtest.h>

#include <cmath>
#include <future>
#include <map>
#include <memory>
#include <set>

#include "potmap/data/labelling.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/metrics.hpp"
#include "potmap/pot/atom_descriptor.hpp"
#include "potmap/pot/atom_index.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/transfer.hpp"
#include "test_support.hpp"

namespace potmap {
namespace {

using test::training_samples;

// Kernels every `step` metres around a point, each weight mean tagging its index.
KernelMap tagged_grid(const std::array<double, 3>& c, double half, double step) {
  KernelMap map;
  map.dim = 2;
  for (double x = -half; x <= half + 1e-9; x += step)
    for (double y = -half; y <= half + 1e-9; y += step) {
      const double p[2] = {c[0] + x, c[1] + y};
      map.push_back(p, 2.0, static_cast<double>(map.size()), 0.5);
    }
  return map;
}

// Three town1 scans 12 m apart and the atoms of a tagged grid around the middle one.
struct TownAtoms {
  std::vector<Scan> scans;
  Dictionary dict;
};
TownAtoms town_atoms() {
  SimOptions so;
  so.scans = 3;
  so.spacing = 12;
  TownAtoms t;
  t.scans = simulate(Town::builtin("town1"), so).scans;
  build_dictionary(t.scans, tagged_grid(t.scans[1].origin(), 40, 2), {}, t.dict);
  return t;
}

// Small problems so that the CPU reference stays quick.
// The paper's rules (the exhaustive ranking), which these tests check.
PotOptions small_options() {
  PotOptions o = PotOptions::paper();
  o.rank_hits = 40;
  o.rank_free = 20;
  o.transport_points = 120;
  o.transport_max_iterations = 600;
  o.transport_tolerance = 1e-4;
  return o;
}

// The same kernels bit for bit, and the same atoms and kernel counts in every sector.
void expect_same_transfer(const ScanTransfer& got, const ScanTransfer& want) {
  EXPECT_EQ(got.map.position, want.map.position);
  EXPECT_EQ(got.map.w_mean, want.map.w_mean);
  EXPECT_EQ(got.map.w_var, want.map.w_var);
  EXPECT_EQ(got.map.gamma, want.map.gamma);
  ASSERT_EQ(got.sectors.size(), want.sectors.size());
  for (std::size_t s = 0; s < want.sectors.size(); ++s) {
    EXPECT_EQ(got.sectors[s].atom, want.sectors[s].atom) << "sector " << s;
    EXPECT_EQ(got.sectors[s].kernels_placed, want.sectors[s].kernels_placed) << "sector " << s;
    EXPECT_EQ(got.sectors[s].kernels_dropped, want.sectors[s].kernels_dropped) << "sector " << s;
  }
}

// 0: kernels follow hits only (SPEC step 4). 1: free samples are transported too, all of them
// (the cap is above a sector's count) so that both sides of the self-transport hold the same
// points; kernels in free space then follow free samples, which lie farther apart than hits,
// so the blur moves them more (measured 0.20 m). 2: free samples thinned evenly to 30 a side:
// the thinning must pick the same samples on both sides of a self-transport, or kernels move.
class PotSelf : public ::testing::TestWithParam<int> {};

TEST_P(PotSelf, ScanOntoItselfPutsKernelsBack) {
  SimOptions so;
  so.scans = 1;
  const Scan scan = simulate(Town::builtin("town1"), so).scans[0];
  const KernelMap map = tagged_grid(scan.origin(), 20, 2);
  // Fewer free samples when they are transported (a free sample every 5 m of beam): the test
  // stays quick with every sample in the plan.
  DictionaryOptions dopt;
  dopt.labels.free_per_metre = GetParam() == 1 ? 0.2 : 1;
  Dictionary dict;
  build_dictionary({scan}, map, dopt, dict);
  ASSERT_GE(dict.size(), 3u);
  PotOptions o = small_options();
  o.rotations = {0, test::kPi / 2, test::kPi, 3 * test::kPi / 2};
  o.transport_free = GetParam() > 0;
  o.transport_free_points = GetParam() == 1 ? 5000 : 30;
  const LabelledPoints train = training_samples(scan, 0, dopt.labels.free_per_metre);
  const ScanTransfer t =
      transfer_scan(&test::context(), dict, train, scan.origin(), scan_heading(scan), 0, o);
  ASSERT_EQ(t.sectors.size(), dict.size());
  std::size_t placed = 0, total = 0;
  for (std::size_t s = 0; s < t.sectors.size(); ++s) {
    const SectorTransfer& st = t.sectors[s];
    // Every sector is its own atom, unrotated.
    EXPECT_EQ(st.atom, static_cast<long>(s)) << "sector " << st.sector;
    EXPECT_NEAR(st.rotation, 0, 1e-12);
    placed += st.kernels_placed;
    total += dict.atoms[s].kernels.size();
  }
  EXPECT_EQ(placed, t.map.size());
  EXPECT_GE(placed, total * 9 / 10);
  double worst = 0;
  for (std::size_t k = 0; k < t.map.size(); ++k) {
    const auto m = static_cast<std::size_t>(t.map.w_mean[k]);
    const double dx = t.map.position[2 * k] - map.position[2 * m];
    const double dy = t.map.position[2 * k + 1] - map.position[2 * m + 1];
    worst = std::max(worst, std::hypot(dx, dy));
    EXPECT_EQ(t.map.gamma[k], map.gamma[m]);
    EXPECT_EQ(t.map.w_var[k], map.w_var[m]);
  }
  // The entropic blur at epsilon 0.0005 of the normalised cost moves samples by a fraction of
  // their spacing; kernels follow their nearest sample.
  RecordProperty("worst_displacement_m", std::to_string(worst));
  EXPECT_LT(worst, 0.6);  // measured 0.20 m (every free sample), 0.14 m (30 a side)
}

INSTANTIATE_TEST_SUITE_P(Pot, PotSelf, ::testing::Values(0, 1, 2));

// Descriptor pre-selection (PotOptions::candidates): only k atoms per sector reach the
// ranking, and a sector's own atom (descriptor distance 0) is among them and wins.
TEST(Pot, PreselectionRanksOnlyKAtomsAndKeepsTheOwnAtom) {
  SimOptions so;
  so.scans = 3;
  so.spacing = 12;
  const std::vector<Scan> scans = simulate(Town::builtin("town1"), so).scans;
  const KernelMap map = tagged_grid(scans[1].origin(), 40, 2);
  Dictionary dict;
  build_dictionary(scans, map, {}, dict);
  ASSERT_GE(dict.size(), 10u);
  PotOptions o = small_options();
  o.rotations = {0, test::kPi};
  o.candidates = 2;
  const LabelledPoints train = training_samples(scans[1], 1);
  const PreparedTransfer pt =
      prepare_transfer(dict, train, scans[1].origin(), scan_heading(scans[1]), 1, o);
  ASSERT_EQ(pt.sectors.size(), 5u);
  for (const auto& cands : pt.candidates) {
    std::set<std::size_t> atoms;
    for (const auto& c : cands) atoms.insert(c.atom);
    EXPECT_LE(atoms.size(), 2u);
    EXPECT_LE(cands.size(), 2u * o.rotations.size());
  }
  o.preselector = std::make_shared<const AtomPreselector>(dict);  // as map_scans passes it
  const ScanTransfer t =
      transfer_scan(&test::context(), dict, train, scans[1].origin(), scan_heading(scans[1]), 1, o);
  // Atoms of scan 1 are the dictionary's 5..9, in sector order (build_dictionary keeps order).
  for (const SectorTransfer& st : t.sectors) {
    EXPECT_EQ(st.atom, static_cast<long>(5 + st.sector)) << "sector " << st.sector;
    EXPECT_NEAR(st.rotation, 0, 1e-12);
  }
  Dictionary fewer = dict;
  fewer.atoms.pop_back();
  o.preselector = std::make_shared<const AtomPreselector>(fewer);
  EXPECT_THROW(transfer_scan(nullptr, dict, train, scans[1].origin(), scan_heading(scans[1]), 1, o),
               ArgumentError);
}

// solve_transfer() and place_transfer() are finish_transfer() in two stages, so that a mapper
// places one scan's kernels while the device solves the next: placed on another thread beside
// another scan's solve, a scan's map is finish_transfer()'s bit for bit. Parts that disagree
// are refused.
TEST(Pot, SolvedTransferPlacedBesideAnotherSolveIsFinishTransfer) {
  const TownAtoms town = town_atoms();
  const std::vector<Scan>& scans = town.scans;
  const Dictionary& dict = town.dict;
  const PotOptions o = small_options();
  auto prepared = [&](std::size_t i) {
    return prepare_transfer(dict, training_samples(scans[i], i), scans[i].origin(),
                            scan_heading(scans[i]), static_cast<std::int64_t>(i), o);
  };
  Context& ctx = test::context();
  const ScanTransfer whole = finish_transfer(&ctx, dict, prepared(1), o);
  ASSERT_GT(whole.map.size(), 0u);

  SolvedTransfer solved = solve_transfer(&ctx, dict, prepared(1), o);
  EXPECT_TRUE(solved.transfer.map.empty());
  EXPECT_EQ(chosen_atoms(solved), chosen_atoms(whole));
  std::future<ScanTransfer> placed = std::async(
      std::launch::async, [&] { return place_transfer(&ctx, dict, std::move(solved), o); });
  const SolvedTransfer next = solve_transfer(&ctx, dict, prepared(2), o);
  const ScanTransfer split = placed.get();
  EXPECT_FALSE(next.plans.empty());
  expect_same_transfer(split, whole);

  SolvedTransfer broken = solve_transfer(&ctx, dict, prepared(1), o);
  ASSERT_FALSE(broken.plans.empty());
  broken.plans.pop_back();
  EXPECT_THROW(place_transfer(&ctx, dict, std::move(broken), o), ArgumentError);
}

// The context's host helper assembles the indexed ranking's sectors and places their anchors
// beside the scan's thread (Context::host_parallel_for); the transfer is the one this thread
// alone makes, bit for bit: the same problems in the same order, the same map.
TEST(Pot, HostHelperChangesNothingInATransfer) {
  const TownAtoms town = town_atoms();
  const std::vector<Scan>& scans = town.scans;
  const Dictionary& dict = town.dict;
  PotOptions o = small_options();
  o.ranking = PotRanking::indexed;
  o.index = std::make_shared<const AtomIndex>(dict);
  o.placement = PotPlacement::target_samples;
  o.wall_clearance = 0.5;
  Context& ctx = test::context();
  const LabelledPoints train = training_samples(scans[1], 1);
  auto prepared = [&](Context* helper) {
    return prepare_transfer(dict, train, scans[1].origin(), scan_heading(scans[1]), 1, o, {0, 7},
                            helper);
  };
  for (int round = 0; round < 5; ++round) {
    const PreparedTransfer alone = prepared(nullptr), helped = prepared(&ctx);
    ASSERT_EQ(helped.ranking.size(), alone.ranking.size());
    ASSERT_GT(alone.ranking.size(), 10u);
    for (std::size_t i = 0; i < alone.ranking.size(); ++i) {
      EXPECT_EQ(helped.ranking.problem(i).source, alone.ranking.problem(i).source) << i;
      EXPECT_EQ(helped.ranking.problem(i).target, alone.ranking.problem(i).target) << i;
      EXPECT_EQ(helped.ranking.problem(i).angle, alone.ranking.problem(i).angle) << i;
    }
    ASSERT_EQ(helped.candidates.size(), alone.candidates.size());
    for (std::size_t s = 0; s < alone.candidates.size(); ++s) {
      ASSERT_EQ(helped.candidates[s].size(), alone.candidates[s].size()) << "sector " << s;
      for (std::size_t c = 0; c < alone.candidates[s].size(); ++c) {
        EXPECT_EQ(helped.candidates[s][c].atom, alone.candidates[s][c].atom);
        EXPECT_EQ(helped.candidates[s][c].hits_problem, alone.candidates[s][c].hits_problem);
        EXPECT_EQ(helped.candidates[s][c].free_problem, alone.candidates[s][c].free_problem);
      }
    }
    ASSERT_EQ(helped.rank_hits.size(), alone.rank_hits.size());
    for (std::size_t s = 0; s < alone.rank_hits.size(); ++s) {
      EXPECT_EQ(helped.rank_hits[s], alone.rank_hits[s]);
      EXPECT_EQ(helped.rank_free[s], alone.rank_free[s]);
    }

    SolvedTransfer solved = solve_transfer(&ctx, dict, prepared(&ctx), o);
    SolvedTransfer copy = solved;
    // The anchors' sites found beside the transport's solve, or by the placement itself.
    ASSERT_EQ(solved.anchor_sites.size(), solved.prepared.sectors.size());
    SolvedTransfer unfound = solved;
    unfound.anchor_sites.clear();
    const ScanTransfer one = place_transfer(nullptr, dict, std::move(copy), o);
    const ScanTransfer three = place_transfer(nullptr, dict, std::move(unfound), o);
    const ScanTransfer two = place_transfer(&ctx, dict, std::move(solved), o);
    ASSERT_GT(one.map.size(), 0u);
    expect_same_transfer(two, one);
    expect_same_transfer(three, one);
  }
}

TEST(Pot, RotatedAtomIsRankedBestAtItsRotation) {
  SimOptions so;
  so.scans = 3;
  so.spacing = 12;
  const Simulation sim = simulate(Town::builtin("town3"), so);
  const Scan& scan = sim.scans[1];
  const KernelMap map = tagged_grid(scan.origin(), 20, 4);
  Dictionary dict;
  DictionaryOptions dopt;
  dopt.sectors.sectors = 1;
  build_dictionary(sim.scans, map, dopt, dict);
  ASSERT_EQ(dict.size(), 3u);
  // The target: scan 1 turned by 90 degrees about its sensor and moved 500 m away.
  const double angle = test::kPi / 2;
  const auto o = scan.origin();
  LabelledPoints target = training_samples(scan, 1);
  for (std::size_t i = 0; i < target.size(); ++i) {
    double* p = &target.position[2 * i];
    const double ux = p[0] - o[0], uy = p[1] - o[1];
    p[0] = o[0] + 500 + std::cos(angle) * ux - std::sin(angle) * uy;
    p[1] = o[1] - 300 + std::sin(angle) * ux + std::cos(angle) * uy;
  }
  PotOptions opt = small_options();
  opt.sectors = 1;
  const ScanTransfer t =
      transfer_scan(&test::context(), dict, target, {o[0] + 500, o[1] - 300, 0}, 0, 1, opt);
  ASSERT_EQ(t.sectors.size(), 1u);
  EXPECT_EQ(t.sectors[0].atom, 1);
  EXPECT_NEAR(t.sectors[0].rotation, angle, 1e-12);
}

TEST(Pot, DeviceChoosesWhatTheReferenceChooses) {
  SimOptions so;
  so.scans = 4;
  so.spacing = 6;
  const Simulation sim = simulate(Town::builtin("town2"), so);
  const KernelMap map = tagged_grid(sim.scans[0].origin(), 40, 4);
  Dictionary dict;
  build_dictionary({sim.scans[0], sim.scans[1]}, map, {}, dict);
  PotOptions o = small_options();
  o.rotations = {0, test::kPi};
  // Both converged to the same tolerance, so both plans are the same one up to it.
  o.transport_tolerance = 1e-5;
  o.transport_free_tolerance = 1e-5;
  o.transport_max_iterations = 20000;
  const Scan& scan = sim.scans[3];
  const LabelledPoints train = training_samples(scan, 3);
  const ScanTransfer dev =
      transfer_scan(&test::context(), dict, train, scan.origin(), scan_heading(scan), 3, o);
  const ScanTransfer ref =
      transfer_scan(nullptr, dict, train, scan.origin(), scan_heading(scan), 3, o);
  ASSERT_EQ(dev.sectors.size(), ref.sectors.size());
  for (std::size_t s = 0; s < dev.sectors.size(); ++s) {
    EXPECT_EQ(dev.sectors[s].atom, ref.sectors[s].atom) << "sector " << s;
    EXPECT_EQ(dev.sectors[s].rotation, ref.sectors[s].rotation) << "sector " << s;
    EXPECT_NEAR(dev.sectors[s].score, ref.sectors[s].score, 1e-3);
    EXPECT_TRUE(dev.sectors[s].transport_converged) << "sector " << s;
    EXPECT_TRUE(ref.sectors[s].transport_converged) << "sector " << s;
  }
  ASSERT_EQ(dev.map.size(), ref.map.size());
  for (std::size_t i = 0; i < dev.map.position.size(); ++i)
    EXPECT_NEAR(dev.map.position[i], ref.map.position[i], 0.05);
}

TEST(Pot, RejectsEmptyDictionaryAndWrongDimension) {
  Dictionary dict;
  LabelledPoints lp;
  lp.dim = 2;
  EXPECT_THROW(transfer_scan(nullptr, dict, lp, {0, 0, 0}, 0, 0), ArgumentError);
  dict.dim = 3;
  dict.atoms.resize(1);
  EXPECT_THROW(transfer_scan(nullptr, dict, lp, {0, 0, 0}, 0, 0), ArgumentError);
  dict.dim = 2;
  PotOptions o;
  o.rotations.clear();
  EXPECT_THROW(transfer_scan(nullptr, dict, lp, {0, 0, 0}, 0, 0, o), ArgumentError);
  PotOptions sweeps;
  sweeps.anchor_sweeps = -1;
  EXPECT_THROW(transfer_scan(nullptr, dict, lp, {0, 0, 0}, 0, 0, sweeps), ArgumentError);
  for (double gain : {0.0, -1.0, std::nan("")}) {
    PotOptions g;
    g.logit_gain = gain;
    EXPECT_THROW(transfer_scan(nullptr, dict, lp, {0, 0, 0}, 0, 0, g), ArgumentError) << gain;
  }
}

TEST(Pot, EmptyScanGivesAnEmptyMap) {
  SimOptions so;
  so.scans = 1;
  const Scan scan = simulate(Town::builtin("town1"), so).scans[0];
  Dictionary dict;
  build_dictionary({scan}, tagged_grid(scan.origin(), 20, 4), {}, dict);
  LabelledPoints none;
  none.dim = 2;
  const ScanTransfer t = transfer_scan(&test::context(), dict, none, scan.origin(), 0, 0);
  EXPECT_TRUE(t.map.empty());
  EXPECT_TRUE(t.sectors.empty());
}

}  // namespace
}  // namespace potmap
