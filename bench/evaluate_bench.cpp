// Throughput of map evaluation: OpenCL evaluator against the exact CPU reference.
#include <benchmark/benchmark.h>

#include <random>

#include "potmap/map/evaluate.hpp"
#include "potmap/runtime/context.hpp"

using namespace potmap;

namespace {

Context& bench_context() {
  static Context ctx;
  return ctx;
}

KernelMap random_map(std::size_t m, double extent, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(0, extent), lg(std::log(0.01), std::log(1.0)),
      w(-10, 10), v(0, 100);
  KernelMap map;
  map.dim = 2;
  for (std::size_t k = 0; k < m; ++k) {
    const double p[2] = {pos(rng), pos(rng)};
    map.push_back(p, std::exp(lg(rng)), w(rng), v(rng));
  }
  return map;
}

std::vector<double> random_points(std::size_t n, double extent, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(0, extent);
  std::vector<double> p(2 * n);
  for (double& x : p) x = pos(rng);
  return p;
}

// Kernels spaced as in Town 1 (about 0.58 per square metre).
double extent_for(std::size_t kernels) {
  return std::sqrt(kernels / 0.58);
}

void BM_EvalPointsOpenCL(benchmark::State& state) {
  const std::size_t m = state.range(0), n = state.range(1);
  const double extent = extent_for(m);
  KernelMap map = random_map(m, extent, 1);
  MapEvaluator ev(bench_context(), map);
  const std::vector<double> pts = random_points(n, extent, 2);
  std::vector<float> prob(n);
  ev.evaluate(pts.data(), n, nullptr, nullptr, prob.data());  // warm-up: program build
  std::size_t pairs = 0;
  for (auto _ : state) {
    ev.evaluate(pts.data(), n, nullptr, nullptr, prob.data());
    pairs += ev.last_pairs();
  }
  state.counters["queries_per_s"] =
      benchmark::Counter(double(n) * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["kernel_evals_per_s"] =
      benchmark::Counter(double(pairs), benchmark::Counter::kIsRate);
  state.SetLabel(bench_context().info().name);
}
BENCHMARK(BM_EvalPointsOpenCL)
    ->ArgsProduct({{1000, 10000, 100000}, {10000, 100000, 1000000, 10000000}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_EvalPointsReference(benchmark::State& state) {
  const std::size_t m = state.range(0), n = state.range(1);
  const double extent = extent_for(m);
  KernelMap map = random_map(m, extent, 1);
  const std::vector<double> pts = random_points(n, extent, 2);
  for (auto _ : state) benchmark::DoNotOptimize(evaluate_exact(map, pts.data(), n));
  state.SetLabel("CPU reference (Eigen, double, OpenMP)");
  state.counters["queries_per_s"] =
      benchmark::Counter(double(n) * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["kernel_evals_per_s"] =
      benchmark::Counter(double(n) * m * state.iterations(), benchmark::Counter::kIsRate);
}
// The reference is dense (every kernel for every query): 2,000 queries are enough to time it.
BENCHMARK(BM_EvalPointsReference)
    ->ArgsProduct({{1000, 10000, 100000}, {2000}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
