// potmap::Mapper, the incremental form of map_scans: same instantaneous maps scan by scan, the
// overall map (POT's OverallMap, RePOT's persistent RepotMap) on them, reset, and refusals that
// leave the mapper unchanged.
#include <gtest/gtest.h>

#include <memory>

#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/metrics.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/mapper.hpp"
#include "test_support.hpp"

namespace potmap {
namespace {

struct Scene {
  Simulation sim;
  std::shared_ptr<Dictionary> dict = std::make_shared<Dictionary>();
  Scene() {
    SimOptions so;
    so.scans = 6;
    so.spacing = 4;
    sim = simulate(Town::builtin("town1"), so);
    build_dictionary({sim.scans[0], sim.scans[1]}, test::grid_around(sim.scans[0].origin(), 30), {},
                     *dict);
  }
};

void expect_same(const KernelMap& a, const KernelMap& b) {
  ASSERT_EQ(a.size(), b.size());
  EXPECT_EQ(a.position, b.position);
  EXPECT_EQ(a.gamma, b.gamma);
  EXPECT_EQ(a.w_mean, b.w_mean);
  EXPECT_EQ(a.w_var, b.w_var);
}

TEST(PotMapper, AddScanGivesWhatMapScansGives) {
  const Scene s;
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
        expect_same(got.transfer.map, want[i].transfer.map);
        EXPECT_EQ(got.test.position, want[i].test.position);
        EXPECT_EQ(got.transfer.timing.refine_ms > 0, refine);
        // POT merges every instantaneous kernel; RePOT's persistent map seeds instead.
        EXPECT_EQ(mapper.last_merge().stats.added + mapper.last_merge().stats.merged,
                  refine ? 0u : got.transfer.map.size());
        if (refine && i == 0) EXPECT_GT(mapper.last_merge().seeded, 0u);
      }
      EXPECT_EQ(mapper.scans(), targets.size());
      EXPECT_EQ(mapper.repot() != nullptr, refine);
      expect_same(mapper.overall_map(), refine ? repot.map() : overall.map());
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

// RePOT's two overall maps: per-scan refinement merged (persistent_refine false, the old
// design: refined instantaneous maps) and the persistent joint BHM (transported instantaneous
// maps, POT's). Driving over the same scans again leaves the persistent map's memory about as it
// was, and it still maps the place: the scans' own held-out samples score well on it.
TEST(PotMapper, PersistentRepotMapKeepsItsMemoryOverRepeatedDrives) {
  const Scene s;
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
        expect_same(c.transfer.map, b.transfer.map);
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

TEST(PotMapper, RefusesBadDictionaryAndScanWithoutChange) {
  EXPECT_THROW(Mapper(&test::context(), nullptr), ArgumentError);
  EXPECT_THROW(Mapper(&test::context(), std::make_shared<Dictionary>()), ArgumentError);
  const Scene s;
  Mapper mapper(&test::context(), s.dict, test::small_mapper_options(false));
  mapper.add_scan(s.sim.scans[2]);
  const KernelMap before = mapper.overall().map();
  Scan wrong = s.sim.scans[3];
  wrong.dim = 3;
  wrong.hits.resize(wrong.hits.size() / 6 * 6);
  wrong.no_return.resize(wrong.no_return.size() / 6 * 6);
  EXPECT_THROW(mapper.add_scan(wrong), ArgumentError);
  EXPECT_EQ(mapper.scans(), 1u);
  expect_same(mapper.overall().map(), before);
  EXPECT_EQ(mapper.last().index, 0u);
}

}  // namespace
}  // namespace potmap
