// Memory over a drive that keeps returning to the same place: the mapper's
// overall map and the process's resident memory level off after the first pass. The full
// curves (every scan of freiburg-079, ten loops of intel) are bench/memory_curve.py's, in
// docs/memory-curve.md; this is the short version on real scans, so that a map or a cache that
// grows with scans instead of with area fails CI.
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "potmap/data/scan.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/pot/mapper.hpp"
#include "process_memory.hpp"
#include "test_support.hpp"

namespace {

using namespace potmap;
namespace ex = potmap::experiment;

struct Loops {
  std::vector<std::size_t> kernels, map_bytes, rss;
};

// Maps intel scans [10, 50) `loops` times with the intra-domain dictionary of scans [0, 10).
Loops drive(bool refine, int loops) {
  std::vector<Scan> scans;
  const auto all = read_dataset(test::shared_data("radish/intel-corrected.log.gz")).scans;
  for (std::size_t i = 0; i < 50; ++i) scans.push_back(ex::limit_range(all[i], 20.0));
  ex::PotSetup setup;
  const std::vector<Scan> head(scans.begin(), scans.begin() + 10);
  auto dict =
      std::make_shared<const Dictionary>(ex::build_atoms(&test::context(), {head}, setup, 0));
  MapperOptions mo;
  mo.pot = setup.pot;
  mo.pot.refine = refine;
  mo.pot.ranking = PotRanking::indexed;  // the bench's ranking; the exhaustive one is slower only
  Mapper mapper(&test::context(), dict, mo);
  Loops out;
  for (int pass = 0; pass < loops; ++pass) {
    for (std::size_t i = 10; i < scans.size(); ++i) mapper.add_scan(scans[i]);
    out.kernels.push_back(mapper.overall_kernels());
    out.map_bytes.push_back(mapper.overall_memory_bytes());
    out.rss.push_back(test::memory_in_use());
  }
  return out;
}

constexpr int kPasses = 6;

std::string passes(const Loops& m) {
  std::string s;
  for (std::size_t i = 0; i < m.kernels.size(); ++i)
    s += std::to_string(m.kernels[i]) + " kernels / " + std::to_string(m.rss[i] / 1048576) +
         " MB in use; ";
  return s;
}

// Resident memory: the map's bytes plus allocator slack; 8 MB over four passes is far below
// what keeping each pass's scans, maps or device buffers would cost (tens of MB a pass).
void expect_resident_flat(const Loops& m) {
  const double grown = (double(m.rss[kPasses - 1]) - double(m.rss[1])) / 1048576;
  EXPECT_LT(grown, 8.0) << test::memory_in_use_name() << " grew " << grown
                        << " MB after the second pass: " << passes(m);
}

TEST(MapperMemory, PotLevelsOffOverRepeatedPassesOfARealLog) {
  const Loops m = drive(false, kPasses);
  std::printf("POT: %s\n", passes(m).c_str());
  // POT merges a transported kernel into one within d^2 gamma < merge_radius; kernels a little
  // farther apart stay, so passes over the same place keep packing them closer, ever more
  // slowly (bounded by the packing, docs/memory-curve.md): each pass adds less.
  const auto added = [&](int pass) { return double(m.kernels[pass] - m.kernels[pass - 1]); };
  EXPECT_LT(added(kPasses - 1) + added(kPasses - 2), added(1)) << passes(m);
  EXPECT_LT(added(kPasses - 1) + added(kPasses - 2), 0.25 * double(m.kernels[0])) << passes(m);
  expect_resident_flat(m);
}

TEST(MapperMemory, RepotLevelsOffOverRepeatedPassesOfARealLog) {
  const Loops m = drive(true, kPasses);
  std::printf("RePOT: %s\n", passes(m).c_str());
  // One persistent map over the area: later passes update its kernels; it grows by a tile of
  // kernels where a pass's seeds reach a little farther, never by a pass's worth.
  EXPECT_LT(double(m.kernels[kPasses - 1]), 1.1 * double(m.kernels[1])) << passes(m);
  expect_resident_flat(m);
}

}  // namespace
