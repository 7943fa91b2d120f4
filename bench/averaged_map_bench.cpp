// The averaged overall map's cost per scan (AveragedMap::add) on 360-beam scans: what POT's
// merge adds beside the next scan's transfer. Each instantaneous map has the shape POT's
// placement on the target's samples gives it: kernels on the scan's training samples thinned to
// 0.5 m (hits and free samples apart), the experiments' BHM atom width (gamma 6.64 per m^2),
// wall evidence +2 and free-space evidence -2.
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <unordered_set>

#include "potmap/data/labelling.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/pot/averaged_map.hpp"

using namespace potmap;

namespace {

std::vector<KernelMap> instantaneous_maps() {
  SimOptions so;
  so.scans = 40;
  const Simulation sim = simulate(Town::builtin("town2"), so);
  std::vector<KernelMap> out;
  for (std::size_t i = 0; i < sim.scans.size(); ++i) {
    LabelledSplit sp;
    label_scan(sim.scans[i], static_cast<std::int64_t>(i), LabelOptions{}, sp);
    KernelMap k;
    k.dim = 2;
    std::unordered_set<std::int64_t> seen;
    for (std::size_t j = 0; j < sp.train.size(); ++j) {
      const double* p = &sp.train.position[2 * j];
      const std::int64_t key =
          (std::int64_t(std::floor(p[0] / 0.5)) * 1000003 + std::int64_t(std::floor(p[1] / 0.5))) *
              2 +
          sp.train.label[j];
      if (!seen.insert(key).second) continue;
      k.push_back(p, 6.643, sp.train.label[j] ? 2.0 : -2.0, 1.0);
    }
    out.push_back(std::move(k));
  }
  return out;
}

void BM_AveragedMapAdd(benchmark::State& state) {
  static const std::vector<KernelMap> maps = instantaneous_maps();
  AveragedMap avg(2);
  std::size_t i = 0, kernels = 0;
  for (auto _ : state) {
    avg.add(maps[i % maps.size()]);
    kernels += maps[i % maps.size()].size();
    ++i;
  }
  state.counters["kernels_per_scan"] = double(kernels) / double(i);
  state.counters["map_kernels"] = double(avg.map().size());
}

}  // namespace

BENCHMARK(BM_AveragedMapAdd)->Unit(benchmark::kMillisecond)->Iterations(40);
