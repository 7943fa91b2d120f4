// Mapper::save_state / load_state: a mapper saved after K scans and restored into a fresh one
// maps the rest to the same overall map, bit for bit, as one that never stopped (POT and RePOT,
// scan by scan and through map_scans' pipeline); states of another dictionary or other options,
// and truncated or corrupt files, are refused naming the file, the mapper unchanged.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <memory>

#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/mapper.hpp"
#include "test_support.hpp"

namespace potmap {
namespace {

MapperOptions small_options(bool refine) {
  MapperOptions o = test::small_mapper_options(refine);
  // The indexed ranking adds the atoms of recent scans to each sector's few nearest ones: the
  // restored mapper must carry them over.
  o.pot.ranking = PotRanking::indexed;
  o.pot.index_neighbours = 2;
  return o;
}

struct StateScene {
  Simulation sim;
  std::vector<Scan> targets;
  std::shared_ptr<Dictionary> dict = std::make_shared<Dictionary>();
  StateScene() {
    SimOptions so;
    so.scans = 8;
    so.spacing = 3;
    sim = simulate(Town::builtin("town1"), so);
    build_dictionary({sim.scans[0], sim.scans[1]}, test::grid_around(sim.scans[0].origin(), 30), {},
                     *dict);
    targets.assign(sim.scans.begin() + 2, sim.scans.end());
  }
};

const StateScene& state_scene() {
  static const StateScene s;
  return s;
}

OverallMapOptions capped() {
  OverallMapOptions o;
  o.max_kernels = 250;  // retirements too (225 kernels kept), so counts and ages must come back
  return o;
}

TEST(MapperState, RestoredMapperContinuesBitForBit) {
  const StateScene& s = state_scene();
  const std::string dir = test::temp_dir("mapper-state");
  for (const bool refine : {false, true}) {
    SCOPED_TRACE(refine ? "RePOT" : "POT");
    const MapperOptions o = small_options(refine);
    Mapper whole(&test::context(), s.dict, o, capped());
    for (const Scan& scan : s.targets) whole.add_scan(scan);

    const std::size_t k = 3;
    Mapper first(&test::context(), s.dict, o, capped());
    for (std::size_t i = 0; i < k; ++i) first.add_scan(s.targets[i]);
    const std::string path = dir + (refine ? "/repot.state" : "/pot.state");
    first.save_state(path, std::string("caller\0bytes", 12));

    Mapper resumed(&test::context(), s.dict, o, capped());
    EXPECT_EQ(resumed.load_state(path), std::string("caller\0bytes", 12));
    EXPECT_EQ(resumed.scans(), k);
    EXPECT_EQ(resumed.last().index, k - 1);
    test::expect_same_map(resumed.overall_map(), first.overall_map());
    for (std::size_t i = k; i < s.targets.size(); ++i) resumed.add_scan(s.targets[i]);
    EXPECT_EQ(resumed.scans(), whole.scans());
    test::expect_same_map(resumed.overall_map(), whole.overall_map());
    EXPECT_EQ(resumed.overall().counts(), whole.overall().counts());
    EXPECT_EQ(resumed.overall_kernels(), whole.overall_kernels());
    if (!refine) EXPECT_GT(whole.overall().size(), 0u);
  }
}

// The averaged overall map with kernels on the targets' samples (what the experiments run):
// its anchors' running sums come back too, and a state of the summed map is refused.
TEST(MapperState, AveragedOverallMapContinuesBitForBit) {
  const StateScene& s = state_scene();
  const std::string dir = test::temp_dir("mapper-state-averaged");
  MapperOptions o = small_options(false);
  o.pot.placement = PotPlacement::target_samples;
  o.average_overall = true;
  Mapper whole(&test::context(), s.dict, o);
  for (const Scan& scan : s.targets) whole.add_scan(scan);
  ASSERT_GT(whole.overall_kernels(), 100u);
  EXPECT_EQ(whole.overall().size(), 0u);  // the summed map stays empty

  const std::size_t k = 3;
  Mapper first(&test::context(), s.dict, o);
  for (std::size_t i = 0; i < k; ++i) first.add_scan(s.targets[i]);
  const std::string path = dir + "/averaged.state";
  first.save_state(path);
  Mapper resumed(&test::context(), s.dict, o);
  resumed.load_state(path);
  test::expect_same_map(resumed.overall_map(), first.overall_map());
  for (std::size_t i = k; i < s.targets.size(); ++i) resumed.add_scan(s.targets[i]);
  test::expect_same_map(resumed.overall_map(), whole.overall_map());
  EXPECT_GT(resumed.overall_memory_bytes(), 0u);

  MapperOptions summed = o;
  summed.average_overall = false;
  Mapper other(&test::context(), s.dict, summed);
  EXPECT_THROW(other.load_state(path), Error);
}

// What `potmap map --resume` does: map_scans (pipelined) from the restored mapper's
// continuation(), each scan added with add_mapped().
TEST(MapperState, MapScansContinuesARestoredRun) {
  const StateScene& s = state_scene();
  const std::string dir = test::temp_dir("mapper-state-pipeline");
  for (const bool refine : {false, true}) {
    SCOPED_TRACE(refine ? "RePOT" : "POT");
    const MapperOptions o = small_options(refine);
    Mapper whole(&test::context(), s.dict, o);
    map_scans(&test::context(), *s.dict, s.targets, o,
              [&](MappedScan&& m) { whole.add_mapped(std::move(m)); });
    ASSERT_EQ(whole.scans(), s.targets.size());

    Mapper first(&test::context(), s.dict, o);
    const std::vector<Scan> head(s.targets.begin(), s.targets.begin() + 4);
    map_scans(&test::context(), *s.dict, head, o,
              [&](MappedScan&& m) { first.add_mapped(std::move(m)); });
    first.save_state(dir + "/run.state");

    Mapper resumed(&test::context(), s.dict, o);
    EXPECT_EQ(resumed.load_state(dir + "/run.state"), "");
    const MapScansStart start = resumed.continuation();
    EXPECT_EQ(start.first, 4u);
    EXPECT_FALSE(start.warm_last.empty());
    std::vector<std::size_t> indices;
    map_scans(
        &test::context(), *s.dict, s.targets, o,
        [&](MappedScan&& m) {
          indices.push_back(m.index);
          resumed.add_mapped(std::move(m));
        },
        start);
    EXPECT_EQ(indices, (std::vector<std::size_t>{4, 5}));
    test::expect_same_map(resumed.overall_map(), whole.overall_map());
    // A scan out of order is refused.
    MappedScan stray;
    stray.index = 9;
    stray.transfer.map.dim = 2;
    EXPECT_THROW(resumed.add_mapped(std::move(stray)), ArgumentError);
    EXPECT_EQ(resumed.scans(), s.targets.size());
  }
}

std::string message_of(Mapper& m, const std::string& path) {
  try {
    m.load_state(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(MapperState, RefusesOtherInputsAndBrokenFilesNamingThem) {
  const StateScene& s = state_scene();
  const std::string dir = test::temp_dir("mapper-state-refusals");
  const MapperOptions o = small_options(false);
  Mapper saved(&test::context(), s.dict, o);
  saved.add_scan(s.targets[0]);
  saved.add_scan(s.targets[1]);
  const std::string path = dir + "/pot.state";
  saved.save_state(path);
  const std::string bytes = test::file_bytes(path);
  ASSERT_GT(bytes.size(), 100u);

  MapperOptions other = o;
  other.pot.seed = 4;
  Mapper wrong_options(&test::context(), s.dict, other);
  std::string e = message_of(wrong_options, path);
  EXPECT_NE(e.find(path), std::string::npos) << e;
  EXPECT_NE(e.find("other mapper options"), std::string::npos) << e;
  EXPECT_EQ(wrong_options.scans(), 0u);

  Mapper wrong_overall(&test::context(), s.dict, o, capped());
  e = message_of(wrong_overall, path);
  EXPECT_NE(e.find("other mapper options"), std::string::npos) << e;

  auto dict2 = std::make_shared<Dictionary>(*s.dict);
  dict2->atoms.pop_back();
  Mapper wrong_dict(&test::context(), dict2, o);
  e = message_of(wrong_dict, path);
  EXPECT_NE(e.find("another dictionary"), std::string::npos) << e;

  Mapper repot(&test::context(), s.dict, small_options(true));
  e = message_of(repot, path);
  EXPECT_NE(e.find(path), std::string::npos) << e;

  Mapper fresh(&test::context(), s.dict, o);
  for (const std::size_t keep :
       {std::size_t(0), std::size_t(5), std::size_t(30), bytes.size() / 2, bytes.size() - 1}) {
    SCOPED_TRACE(keep);
    const std::string cut = dir + "/cut.state";
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, keep);
    e = message_of(fresh, cut);
    EXPECT_NE(e.find(cut), std::string::npos) << e;
    EXPECT_NE(e.find("truncated"), std::string::npos) << e;
  }
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x10;
  std::ofstream(dir + "/flip.state", std::ios::binary) << flipped;
  e = message_of(fresh, dir + "/flip.state");
  EXPECT_NE(e.find("checksum"), std::string::npos) << e;
  e = message_of(fresh, dir + "/missing.state");
  EXPECT_NE(e.find("missing.state"), std::string::npos) << e;
  EXPECT_EQ(fresh.scans(), 0u);
  EXPECT_TRUE(fresh.overall_map().empty());

  // And the mapper still works: the good file restores it.
  fresh.load_state(path);
  EXPECT_EQ(fresh.scans(), 2u);
  test::expect_same_map(fresh.overall_map(), saved.overall_map());
}

}  // namespace
}  // namespace potmap
