// POT and RePOT per-scan latency: ranking, high-quality transport, placement and
// refinement, against the number of atoms and rotations, on 360-beam scans of a built-in town
// mapped with a dictionary from another. Every row also scores the instantaneous maps on the
// scans' held-out samples, so the batched OpenCL path and the one-problem-at-a-time CPU
// reference (BM_PotReference) can be compared for quality as well as time.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "potmap/data/labelling.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/learn/bhm.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/metrics.hpp"
#include "potmap/pot/atom_descriptor.hpp"
#include "potmap/pot/atom_index.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/mapper.hpp"
#include "potmap/pot/transfer.hpp"
#include "potmap/runtime/context.hpp"

using namespace potmap;

namespace {

constexpr double kPi = 3.14159265358979323846;

struct Fixture {
  Context ctx;
  Dictionary all;  // every atom of the source scans, most hits first
  std::vector<Scan> targets;
  std::vector<LabelledSplit> splits;
};

// `scans` scans of a built-in town, `spacing` metres apart along its route.
Simulation drive(const char* town, std::size_t scans, double spacing, std::uint64_t seed) {
  SimOptions o;
  o.scans = scans;
  o.spacing = spacing;
  o.seed = seed;
  return simulate(Town::builtin(town), o);
}

Fixture& fixture() {
  static std::unique_ptr<Fixture> f = [] {
    auto x = std::make_unique<Fixture>();
    const Simulation src = drive("town1", 40, 3, 1);
    LabelOptions lo;
    lo.holdout_fraction = 0;
    const LabelledSplit s = label_scans(src.scans, lo);
    double lo3[3], hi3[3];
    s.train.bounds(lo3, hi3);
    KernelMap map = bhm_grid_prior(2, lo3, hi3, 1.0, 4.0);
    bhm_update_sequential(&x->ctx, map, s.train);
    build_dictionary(src.scans, map, {}, x->all);
    std::stable_sort(x->all.atoms.begin(), x->all.atoms.end(), [](const Atom& a, const Atom& b) {
      return a.sector.num_hits() > b.sector.num_hits();
    });
    x->targets = drive("town2", 8, 5, 7).scans;
    for (std::size_t i = 0; i < x->targets.size(); ++i) {
      LabelledSplit sp;
      label_scan(x->targets[i], static_cast<std::int64_t>(i), LabelOptions{}, sp);
      x->splits.push_back(std::move(sp));
    }
    return x;
  }();
  return *f;
}

Dictionary first_atoms(std::size_t n) {
  Dictionary d = fixture().all;
  if (d.atoms.size() > n) d.atoms.resize(n);
  return d;
}

std::vector<double> rotations(int n) {
  std::vector<double> r;
  for (int i = 0; i < n; ++i) r.push_back(2 * kPi * i / n);
  return r;
}

// Args: atoms, rotations, refine (0/1), candidates (descriptor pre-selection, 0: every atom),
// ranking (0: exhaustive, 1: indexed). `device` false: the CPU reference.
void run_pot(benchmark::State& state, bool device) {
  Fixture& f = fixture();
  const Dictionary dict = first_atoms(static_cast<std::size_t>(state.range(0)));
  PotOptions o;
  o.rotations = rotations(static_cast<int>(state.range(1)));
  o.refine = state.range(2) != 0;
  o.candidates = static_cast<std::size_t>(state.range(3));
  if (o.candidates > 0) o.preselector = std::make_shared<const AtomPreselector>(dict);
  if (state.range(4) != 0) {
    o.ranking = PotRanking::indexed;
    o.index = std::make_shared<const AtomIndex>(dict);
  }
  Context* ctx = device ? &f.ctx : nullptr;
  if (device) {  // build the programs outside the timing
    transfer_scan(ctx, dict, f.splits[0].train, f.targets[0].origin(), scan_heading(f.targets[0]),
                  0, o);
  }
  PotTiming sum;
  std::vector<double> totals;  // per scan, for the median and 90th percentile
  std::size_t scans = 0, kernels = 0;
  std::vector<float> prob;
  std::vector<std::uint8_t> label;
  std::vector<long> warm;  // the previous scan's atoms (PotOptions::warm_candidates)
  for (auto _ : state) {
    const std::size_t i = scans % f.targets.size();
    ScanTransfer t = finish_transfer(
        ctx, dict,
        prepare_transfer(dict, f.splits[i].train, f.targets[i].origin(), scan_heading(f.targets[i]),
                         static_cast<std::int64_t>(i), o, warm),
        o);
    warm = chosen_atoms(t);
    state.PauseTiming();
    sum.prepare_ms += t.timing.prepare_ms;
    sum.ranking_ms += t.timing.ranking_ms;
    sum.transport_ms += t.timing.transport_ms;
    sum.placement_ms += t.timing.placement_ms;
    sum.refine_ms += t.timing.refine_ms;
    totals.push_back(t.timing.total_ms());
    kernels += t.map.size();
    if (scans < f.targets.size()) {  // score each scan once
      const LabelledPoints& test = f.splits[i].test;
      const MapValuesExact v = evaluate_exact(t.map, test.position.data(), test.size());
      for (std::size_t j = 0; j < test.size(); ++j) {
        prob.push_back(static_cast<float>(v.prob[j]));
        label.push_back(test.label[j]);
      }
    }
    ++scans;
    state.ResumeTiming();
  }
  const double n = static_cast<double>(scans);
  state.counters["prepare_ms"] = sum.prepare_ms / n;
  state.counters["ranking_ms"] = sum.ranking_ms / n;
  state.counters["transport_ms"] = sum.transport_ms / n;
  state.counters["placement_ms"] = sum.placement_ms / n;
  state.counters["refine_ms"] = sum.refine_ms / n;
  state.counters["total_ms"] = sum.total_ms() / n;
  // Scans on a shared 2-core machine see other work: the median says what a scan costs, the
  // 90th percentile how bad the tail is.
  std::sort(totals.begin(), totals.end());
  if (!totals.empty()) {
    state.counters["total_ms_median"] = totals[totals.size() / 2];
    state.counters["total_ms_p90"] = totals[std::min(totals.size() - 1, totals.size() * 9 / 10)];
  }
  state.counters["kernels"] = static_cast<double>(kernels) / n;
  const Scores sc = score(prob, label);
  state.counters["acc"] = sc.acc;
  state.counters["auc"] = sc.auc;
  state.counters["nll"] = sc.nll;
  state.counters["scored_scans"] = static_cast<double>(std::min(scans, f.targets.size()));
  state.SetLabel(device ? f.ctx.info().summary() : "CPU reference (Eigen, double)");
}

void BM_PotOpenCL(benchmark::State& state) {
  run_pot(state, true);
}
void BM_PotReference(benchmark::State& state) {
  run_pot(state, false);
}

// The setting: 5 sectors, 6 atoms, 8 rotations, POT and RePOT; then scaling.
BENCHMARK(BM_PotOpenCL)
    ->ArgNames({"atoms", "rotations", "refine", "candidates", "indexed"})
    ->Args({6, 8, 0, 0, 0})
    ->Args({6, 8, 1, 0, 0})
    ->Args({6, 4, 0, 0, 0})
    ->Args({24, 8, 0, 0, 0})
    ->Args({96, 8, 0, 0, 0})
    ->Args({200, 8, 0, 0, 0})
    ->Args({200, 8, 0, 24, 0})
    ->Args({6, 8, 0, 0, 1})
    ->Args({50, 8, 0, 0, 1})
    ->Args({200, 8, 0, 0, 1})
    ->Args({200, 8, 1, 0, 1})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(32);  // every target scan four times
BENCHMARK(BM_PotReference)
    ->ArgNames({"atoms", "rotations", "refine", "candidates", "indexed"})
    ->Args({6, 8, 0, 0, 0})
    ->Args({6, 8, 1, 0, 0})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(8);

// Streaming: map_scans over the target scans, next scan prepared while the current one solves.
void BM_PotStream(benchmark::State& state) {
  Fixture& f = fixture();
  const Dictionary dict = first_atoms(6);
  MapperOptions mo;
  mo.pipeline = state.range(0) != 0;
  for (auto _ : state) {
    std::size_t kernels = 0;
    map_scans(&f.ctx, dict, f.targets, mo,
              [&](MappedScan&& m) { kernels += m.transfer.map.size(); });
    benchmark::DoNotOptimize(kernels);
  }
  state.counters["scans"] = static_cast<double>(f.targets.size());
  state.SetLabel(f.ctx.info().summary());
}
// Wall time of the whole stream (divide by `scans` for the time per scan).
BENCHMARK(BM_PotStream)
    ->ArgName("pipeline")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(2);

}  // namespace
