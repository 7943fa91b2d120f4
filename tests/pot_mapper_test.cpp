// potmap::Mapper, the incremental form of map_scans: same instantaneous maps scan by scan, the
// overall map (POT's OverallMap, RePOT's persistent RepotMap) on them, reset, and refusals that
// leave the mapper unchanged.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <memory>
#include <string>

#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/metrics.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/mapper.hpp"
#include "test_support.hpp"
#include "tuned_context.hpp"

namespace potmap {
namespace {

struct MapperScene {
  Simulation sim;
  std::shared_ptr<Dictionary> dict = std::make_shared<Dictionary>();
  MapperScene() {
    SimOptions so;
    so.scans = 6;
    so.spacing = 4;
    sim = simulate(Town::builtin("town1"), so);
    build_dictionary({sim.scans[0], sim.scans[1]}, test::grid_around(sim.scans[0].origin(), 30), {},
                     *dict);
  }
};

void expect_same_map(const KernelMap& a, const KernelMap& b) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(a.position, b.position);
  EXPECT_EQ(a.gamma, b.gamma);
  EXPECT_EQ(a.w_mean, b.w_mean);
  EXPECT_EQ(a.w_var, b.w_var);
}

TEST(PotMapper, AddScanGivesWhatMapScansGives) {
  const MapperScene s;
  ASSERT_GE(s.dict->size(), 4u);
  const std::vector<Scan> targets(s.sim.scans.begin() + 2, s.sim.scans.end());
  for (const bool refine : {false, true}) {
    SCOPED_TRACE(refine ? "RePOT" : "POT");
    const MapperOptions o = test::small_mapper_options(refine);
    std::vector<MappedScan> want;
    map_scans(&test::context(), *s.dict, targets, o,
              [&](MappedScan&& m) { want.push_back(std::move(m)); });
    ASSERT_EQ(want.size(), targets.size());
    OverallMap overall(2);
    RepotMap repot(2, o);  // RePOT's persistent map, fed as map_scans' caller would
    for (const MappedScan& m : want) {
      EXPECT_EQ(m.train.empty(), !refine);
      if (refine)
        repot.add(m.transfer.map, m.train);
      else if (!m.transfer.map.empty())
        overall.add(m.transfer.map);
    }

    Mapper mapper(&test::context(), s.dict, o);
    for (int pass = 0; pass < 2; ++pass) {  // the second after reset(): the same again
      for (std::size_t i = 0; i < targets.size(); ++i) {
        const MappedScan& got = mapper.add_scan(targets[i]);
        EXPECT_EQ(got.index, i);
        EXPECT_EQ(&got, &mapper.last());
        expect_same_map(got.transfer.map, want[i].transfer.map);
        EXPECT_EQ(got.test.position, want[i].test.position);
        EXPECT_EQ(got.transfer.timing.refine_ms > 0, refine);
        // POT merges every instantaneous kernel; RePOT's persistent map seeds instead.
        EXPECT_EQ(mapper.last_merge().stats.added + mapper.last_merge().stats.merged,
                  refine ? 0u : got.transfer.map.size());
        if (refine && i == 0) EXPECT_GT(mapper.last_merge().seeded, 0u);
      }
      EXPECT_EQ(mapper.scans(), targets.size());
      EXPECT_EQ(mapper.repot() != nullptr, refine);
      expect_same_map(mapper.overall_map(), refine ? repot.map() : overall.map());
      EXPECT_EQ(mapper.overall_map().has_bias, refine);
      EXPECT_GT(mapper.overall_kernels(), 0u);
      EXPECT_GT(mapper.overall_memory_bytes(), 0u);
      EXPECT_EQ(mapper.overall().size() > 0, !refine);
      mapper.reset();
      EXPECT_EQ(mapper.scans(), 0u);
      EXPECT_TRUE(mapper.overall().map().empty());
      EXPECT_TRUE(mapper.overall_map().empty());
      EXPECT_TRUE(mapper.last().transfer.map.empty());
    }
  }
}

// `potmap bench`'s pot sweep moves the number of scans in flight (MapperOptions::pipeline) and
// sinkhorn.work_group: neither may change the maps. The pipeline changes only which thread
// prepares a scan and which places its kernels, beside the next scan's solve (the warm
// candidates are those of scan i - 2 either way): bit for bit, and the scans in order. The
// work-group changes the order of the solver's sums: the same atoms and rotations win, and the
// kernels land within 1e-4 m and 1e-3 in weight.
TEST(PotMapper, MapsDoNotDependOnScansInFlightOrSinkhornWorkGroup) {
  const MapperScene s;
  const std::vector<Scan> targets(s.sim.scans.begin() + 2, s.sim.scans.end());
  const auto run = [&](Context& ctx, bool pipeline) {
    MapperOptions o = test::small_mapper_options(false);
    o.pipeline = pipeline;
    std::vector<MappedScan> out;
    map_scans(&ctx, *s.dict, targets, o, [&](MappedScan&& m) { out.push_back(std::move(m)); });
    return out;
  };
  const std::vector<MappedScan> on = run(test::context(), true);
  const std::vector<MappedScan> off = run(test::context(), false);
  ASSERT_EQ(on.size(), targets.size());
  ASSERT_EQ(off.size(), targets.size());
  std::size_t kernels = 0;
  for (std::size_t i = 0; i < on.size(); ++i) {
    EXPECT_EQ(on[i].index, i);
    EXPECT_EQ(off[i].index, i);
    expect_same_map(on[i].transfer.map, off[i].transfer.map);
    EXPECT_EQ(on[i].test.label, off[i].test.label);
    kernels += on[i].transfer.map.size();
  }
  EXPECT_GT(kernels, 0u);

  for (const int wg : {2, 8}) {
    SCOPED_TRACE("sinkhorn.work_group=" + std::to_string(wg));
    const auto tuned = test::tuned_context("sinkhorn.work_group=" + std::to_string(wg));
    Context& ctx = *tuned;
    ASSERT_EQ(ctx.tuning().sinkhorn.work_group, wg);
    const std::vector<MappedScan> other = run(ctx, true);
    ASSERT_EQ(other.size(), on.size());
    for (std::size_t i = 0; i < on.size(); ++i) {
      const ScanTransfer &a = on[i].transfer, &b = other[i].transfer;
      ASSERT_EQ(a.sectors.size(), b.sectors.size());
      for (std::size_t k = 0; k < a.sectors.size(); ++k) {
        EXPECT_EQ(a.sectors[k].atom, b.sectors[k].atom) << "scan " << i << " sector " << k;
        EXPECT_EQ(a.sectors[k].rotation, b.sectors[k].rotation) << "scan " << i << " sector " << k;
      }
      ASSERT_EQ(a.map.size(), b.map.size()) << "scan " << i;
      for (std::size_t j = 0; j < a.map.position.size(); ++j)
        ASSERT_NEAR(a.map.position[j], b.map.position[j], 1e-4) << "scan " << i;
      for (std::size_t j = 0; j < a.map.size(); ++j) {
        ASSERT_NEAR(a.map.w_mean[j], b.map.w_mean[j], 1e-3) << "scan " << i;
        ASSERT_NEAR(a.map.w_var[j], b.map.w_var[j], 1e-3) << "scan " << i;
      }
    }
  }
}

// RePOT's two overall maps: per-scan refinement merged (persistent_refine false, the old
// design: refined instantaneous maps) and the persistent joint BHM (transported instantaneous
// maps, POT's). Driving over the same scans again leaves the persistent map's memory about as it
// was, and it still maps the place: the scans' own held-out samples score well on it.
TEST(PotMapper, PersistentRepotMapKeepsItsMemoryOverRepeatedDrives) {
  const MapperScene s;
  const std::vector<Scan> targets(s.sim.scans.begin() + 2, s.sim.scans.end());
  MapperOptions per_scan = test::small_mapper_options(true);
  per_scan.persistent_refine = false;
  Mapper old_design(&test::context(), s.dict, per_scan);
  Mapper pot(&test::context(), s.dict, test::small_mapper_options(false));
  Mapper persistent(&test::context(), s.dict, test::small_mapper_options(true));
  LabelledPoints test;
  test.dim = 2;
  std::vector<std::size_t> memory;
  for (int pass = 0; pass < 3; ++pass) {
    for (const Scan& sc : targets) {
      const MappedScan& a = old_design.add_scan(sc);
      const MappedScan& b = pot.add_scan(sc);
      const MappedScan& c = persistent.add_scan(sc);
      EXPECT_GT(a.transfer.timing.refine_ms, 0.0);  // refined per scan
      EXPECT_TRUE(a.train.empty());
      if (pass == 0) {
        // The persistent mapper's instantaneous maps are POT's (same scan index, same seeds).
        expect_same_map(c.transfer.map, b.transfer.map);
        test.position.insert(test.position.end(), c.test.position.begin(), c.test.position.end());
        test.label.insert(test.label.end(), c.test.label.begin(), c.test.label.end());
      }
    }
    memory.push_back(persistent.overall_memory_bytes());
  }
  EXPECT_EQ(old_design.repot(), nullptr);
  EXPECT_GT(old_design.overall().size(), 0u);
  ASSERT_NE(persistent.repot(), nullptr);
  // Later passes transport other kernels (the scan index seeds the subsampling), whose seeds
  // may reach a little past the first pass's: a tile or two, never a pass's worth again.
  EXPECT_LT(double(memory[2]), 1.5 * double(memory[0]));
  EXPECT_LT(double(memory[2] - memory[1]), 0.1 * double(memory[0]));
  const MapValuesExact v =
      evaluate_exact(persistent.overall_map(), test.position.data(), test.size());
  std::vector<float> prob(v.prob.begin(), v.prob.end());
  const Scores sc = score(prob, test.label);
  EXPECT_GT(sc.auc, 0.9);
}

// MapperOptions::async_merge: add_scan() hands the scan back before its merge, which runs
// beside the next scan's transfer. The overall map, the merge records and a checkpoint are
// those of the synchronous mapper, bit for bit, for the three overall maps (POT's merged and
// averaged maps, RePOT's persistent map); reading the map between scans and reset() wait for
// the merge in flight. Under ThreadSanitizer (potmap_thread_tests) this is also the check that
// the caller's reads of last() and the merge's writes do not race.
TEST(PotMapper, AsyncMergeGivesTheSynchronousMaps) {
  const MapperScene s;
  const std::vector<Scan> targets(s.sim.scans.begin() + 2, s.sim.scans.end());
  const std::string dir = test::temp_dir("pot-mapper-async");
  for (const int kind : {0, 1, 2}) {
    SCOPED_TRACE(kind == 0 ? "POT merged" : kind == 1 ? "POT averaged" : "RePOT persistent");
    MapperOptions o = test::small_mapper_options(kind == 2);
    o.average_overall = kind == 1;
    Mapper sync(&test::context(), s.dict, o);
    o.async_merge = true;
    Mapper async(&test::context(), s.dict, o);
    for (std::size_t i = 0; i < targets.size(); ++i) {
      const MappedScan& a = sync.add_scan(targets[i]);
      const MappedScan& b = async.add_scan(targets[i]);
      EXPECT_EQ(b.index, i);
      EXPECT_EQ(&b, &async.last());
      expect_same_map(b.transfer.map, a.transfer.map);  // read while b's merge may be running
      EXPECT_EQ(async.scans(), i + 1);
      if (i % 2) continue;  // every other scan goes on with its merge in flight
      const MapperMerge &ma = sync.last_merge(), &mb = async.last_merge();
      EXPECT_EQ(mb.stats.added, ma.stats.added);
      EXPECT_EQ(mb.stats.merged, ma.stats.merged);
      EXPECT_EQ(mb.seeded, ma.seeded);
      if (kind == 2) EXPECT_GT(mb.merge_ms, 0.0);  // the persistent update, counted here
      expect_same_map(async.overall_map(), sync.overall_map());
    }
    expect_same_map(async.overall_map(), sync.overall_map());
    EXPECT_EQ(async.overall_kernels(), sync.overall_kernels());
    EXPECT_GT(async.overall_kernels(), 0u);
    // A checkpoint of the asynchronous mapper restores the synchronous one's map (the files
    // differ only in the last merge's time, which they record).
    const std::string fa = dir + "/sync-" + std::to_string(kind) + ".state";
    const std::string fb = dir + "/async-" + std::to_string(kind) + ".state";
    async.add_scan(targets[0]);  // a merge in flight when the state is saved
    sync.add_scan(targets[0]);
    async.save_state(fb);
    sync.save_state(fa);
    EXPECT_EQ(test::file_bytes(fa).size(), test::file_bytes(fb).size());
    o.async_merge = false;
    Mapper from_sync(&test::context(), s.dict, o), from_async(&test::context(), s.dict, o);
    from_sync.load_state(fa);
    from_async.load_state(fb);
    expect_same_map(from_async.overall_map(), from_sync.overall_map());
    expect_same_map(from_async.overall_map(), sync.overall_map());
    from_async.add_scan(targets[1]);
    sync.add_scan(targets[1]);
    expect_same_map(from_async.overall_map(), sync.overall_map());
    // Copied and moved with a merge in flight: each copy holds the finished map.
    async.add_scan(targets[1]);
    const Mapper copy = async;
    Mapper moved = std::move(async);
    expect_same_map(copy.overall_map(), sync.overall_map());
    expect_same_map(moved.overall_map(), sync.overall_map());
    async = std::move(moved);
    async.add_scan(targets[2]);
    async.reset();  // waits for the merge in flight
    EXPECT_EQ(async.scans(), 0u);
    EXPECT_EQ(async.overall_kernels(), 0u);
  }
}

// MapperOptions::refine_on_host_team with the host's sums: RePOT's persistent update in two
// parts on the host helper gives the persistent map of the update on the mapper's thread, bit
// for bit, synchronous and with the merge behind add_scan.
TEST(PotMapper, RepotUpdateOnTheHostTeamGivesTheSameMap) {
  const MapperScene s;
  const std::vector<Scan> targets(s.sim.scans.begin() + 2, s.sim.scans.end());
  for (const bool async : {false, true}) {
    SCOPED_TRACE(async ? "async merge" : "sync merge");
    MapperOptions o = test::small_mapper_options(true);
    o.async_merge = async;
    o.refine_map.sums = JointBhmSums::host;
    Mapper alone(&test::context(), s.dict, o);
    o.refine_on_host_team = true;
    Mapper team(&test::context(), s.dict, o);
    for (const Scan& t : targets) {
      alone.add_scan(t);
      team.add_scan(t);
    }
    EXPECT_GT(team.overall_kernels(), 0u);
    expect_same_map(team.overall_map(), alone.overall_map());
  }
}

TEST(PotMapper, RefusesBadDictionaryAndScanWithoutChange) {
  EXPECT_THROW(Mapper(&test::context(), nullptr), ArgumentError);
  EXPECT_THROW(Mapper(&test::context(), std::make_shared<Dictionary>()), ArgumentError);
  const MapperScene s;
  Mapper mapper(&test::context(), s.dict, test::small_mapper_options(false));
  mapper.add_scan(s.sim.scans[2]);
  const KernelMap before = mapper.overall().map();
  Scan wrong = s.sim.scans[3];
  wrong.dim = 3;
  wrong.hits.resize(wrong.hits.size() / 6 * 6);
  wrong.no_return.resize(wrong.no_return.size() / 6 * 6);
  EXPECT_THROW(mapper.add_scan(wrong), ArgumentError);
  EXPECT_EQ(mapper.scans(), 1u);
  expect_same_map(mapper.overall().map(), before);
  EXPECT_EQ(mapper.last().index, 0u);
}

}  // namespace
}  // namespace potmap
