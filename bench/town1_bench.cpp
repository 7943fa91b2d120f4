// The real Town 1 map (92,372 kernels) on a 0.25 m grid over its whole extent: the issue's
// headline number. The reference is timed on a sample of cells and scaled per query.
#include <benchmark/benchmark.h>

#include <filesystem>

#include "potmap/io/map_io.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/runtime/context.hpp"

using namespace potmap;

namespace {

const std::string kTown1 =
    std::string(POTMAP_SOURCE_DIR) + "/../shared/data/carla/town1_abhm_map.csv";

Context& town1_context() {
  static Context ctx;
  return ctx;
}

GridSpec whole_town(const KernelMap& map, double res) {
  double lo[3], hi[3];
  map.bounds(lo, hi);
  return GridSpec::covering(2, lo, hi, res);
}

// The kernel alone on the whole town's grid at `res` metres: the reference of the raster job's
// end-to-end time (bench/raster_scale.py).
void town1_grid(benchmark::State& state, double res) {
  if (!std::filesystem::exists(kTown1)) {
    state.SkipWithError("../shared/data/carla not found");
    return;
  }
  const KernelMap map = read_map(kTown1);
  MapEvaluator ev(town1_context(), map);
  const GridSpec g = whole_town(map, res);
  std::vector<float> mean(g.cells()), var(g.cells()), prob(g.cells());
  ev.evaluate_grid(g, mean.data(), var.data(), prob.data());  // warm-up: program build
  double pairs = 0;
  for (auto _ : state) {
    ev.evaluate_grid(g, mean.data(), var.data(), prob.data());
    pairs += ev.last_pairs();
  }
  state.counters["queries_per_s"] =
      benchmark::Counter(double(g.cells()) * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["kernel_evals_per_s"] = benchmark::Counter(pairs, benchmark::Counter::kIsRate);
  state.counters["cells"] = double(g.cells());
  state.SetLabel(town1_context().info().name);
}

void BM_Town1GridOpenCL(benchmark::State& state) {
  town1_grid(state, 0.25);
}
BENCHMARK(BM_Town1GridOpenCL)->Unit(benchmark::kMillisecond)->UseRealTime();

// 0.05 m: 8692 x 7384 = 64 M cells (25x the cells; 770 MB of outputs).
void BM_Town1GridOpenCLFine(benchmark::State& state) {
  town1_grid(state, 0.05);
}
BENCHMARK(BM_Town1GridOpenCLFine)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

void BM_Town1PointsOpenCL(benchmark::State& state) {
  if (!std::filesystem::exists(kTown1)) {
    state.SkipWithError("../shared/data/carla not found");
    return;
  }
  // The same 2.5 million cell centres as arbitrary points: the general path, no separability.
  const KernelMap map = read_map(kTown1);
  MapEvaluator ev(town1_context(), map);
  const GridSpec g = whole_town(map, 0.25);
  std::vector<double> pts;
  pts.reserve(2 * g.cells());
  for (std::size_t j = 0; j < g.count[1]; ++j)
    for (std::size_t i = 0; i < g.count[0]; ++i) {
      pts.push_back(g.origin[0] + (i + 0.5) * g.resolution);
      pts.push_back(g.origin[1] + (j + 0.5) * g.resolution);
    }
  std::vector<float> prob(g.cells());
  ev.evaluate(pts.data(), g.cells(), nullptr, nullptr, prob.data());
  double pairs = 0;
  for (auto _ : state) {
    ev.evaluate(pts.data(), g.cells(), nullptr, nullptr, prob.data());
    pairs += ev.last_pairs();
  }
  state.counters["queries_per_s"] =
      benchmark::Counter(double(g.cells()) * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["kernel_evals_per_s"] = benchmark::Counter(pairs, benchmark::Counter::kIsRate);
  state.SetLabel(town1_context().info().name);
}
BENCHMARK(BM_Town1PointsOpenCL)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_Town1Reference(benchmark::State& state) {
  if (!std::filesystem::exists(kTown1)) {
    state.SkipWithError("../shared/data/carla not found");
    return;
  }
  const KernelMap map = read_map(kTown1);
  const GridSpec g = whole_town(map, 0.25);
  std::vector<double> pts;
  const std::size_t n = 500;  // every cell would take about an hour
  for (std::size_t s = 0; s < n; ++s) {
    const std::size_t i = (s * 7919u * 331u) % g.cells();
    pts.push_back(g.origin[0] + (i % g.count[0] + 0.5) * g.resolution);
    pts.push_back(g.origin[1] + (i / g.count[0] + 0.5) * g.resolution);
  }
  for (auto _ : state) benchmark::DoNotOptimize(evaluate_exact(map, pts.data(), n));
  state.counters["queries_per_s"] =
      benchmark::Counter(double(n) * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["kernel_evals_per_s"] =
      benchmark::Counter(double(n) * map.size() * state.iterations(), benchmark::Counter::kIsRate);
  state.SetLabel("CPU reference (Eigen, double, OpenMP)");
}
BENCHMARK(BM_Town1Reference)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
