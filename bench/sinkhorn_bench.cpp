// Problems per second of the batched OpenCL Sinkhorn against batch size and problem size, and
// the double-precision CPU reference. bench/sinkhorn_table.py turns the JSON into a table and
// times PythonOT on the same point sets (same generator, see sinkhorn_point()).
//
// Settings (SPEC section 4): sizes up to 500 use the ranking setting (points in a 20 m square,
// scaled by 1/50, eps 0.005, tol 1e-7, at most 1000 iterations); 1500 the high-quality one
// (cost divided by its maximum, eps 0.0005, at most 2000 iterations, tol 1e-7).
#include <benchmark/benchmark.h>

#include <cstdint>

#include "potmap/ot/sinkhorn.hpp"
#include "potmap/runtime/context.hpp"

using namespace potmap;

namespace {

Context& bench_context() {
  static Context ctx;
  return ctx;
}

// Counter-based generator the Python script reproduces bit for bit: uniform in [-10, 10).
double sinkhorn_point(std::uint64_t problem, int side, std::uint64_t index, int coord) {
  std::uint64_t h = ((problem * 2 + side) * 100000 + index) * 4 + coord;
  h = h * 0x9E3779B97F4A7C15ull + 0x632BE59BD9B4E019ull;
  h ^= h >> 31;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 27;
  h *= 0x94D049BB133111EBull;
  h ^= h >> 31;
  return (static_cast<double>(h >> 11) / 9007199254740992.0) * 20.0 - 10.0;
}

SinkhornProblem bench_problem(std::uint64_t p, int n) {
  SinkhornProblem q;
  q.source.resize(n, 2);
  q.target.resize(n, 2);
  for (int i = 0; i < n; ++i)
    for (int d = 0; d < 2; ++d) {
      q.source(i, d) = sinkhorn_point(p, 0, i, d);
      q.target(i, d) = sinkhorn_point(p, 1, i, d);
    }
  q.tolerance = 1e-7;
  if (n >= 1500) {
    q.normalise_cost = true;
    q.epsilon = 0.0005;
    q.max_iterations = 2000;
  } else {
    q.scale = 1.0 / 50;
    q.epsilon = 0.005;
    q.max_iterations = 1000;
  }
  return q;
}

// Args: batch size, points a side, annealing (0: none; else epsilon_start = value / 1000),
// scheme (0: log domain, 1: stabilised).
void BM_SinkhornOpenCL(benchmark::State& state) {
  const int batch = static_cast<int>(state.range(0)), n = static_cast<int>(state.range(1));
  SinkhornBatch b;
  for (int p = 0; p < batch; ++p) b.add(bench_problem(p, n));
  SinkhornOptions o;
  o.epsilon_start = state.range(2) / 1000.0;
  o.stabilised = state.range(3) != 0;
  std::vector<SinkhornResult> r = b.run(bench_context(), o);  // warm-up: program build
  for (auto _ : state) r = b.run(bench_context(), o);
  double its = 0, conv = 0, err = 0;
  for (const auto& x : r) {
    its += x.iterations;
    conv += x.converged;
    err = std::max(err, x.marginal_error);
  }
  state.counters["problems_per_s"] =
      benchmark::Counter(double(batch) * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["iterations"] = its / batch;
  state.counters["converged_fraction"] = conv / batch;
  state.counters["max_marginal_error"] = err;
  state.counters["batch"] = batch;
  state.counters["n"] = n;
  state.SetLabel(bench_context().info().summary());
}
BENCHMARK(BM_SinkhornOpenCL)
    ->ArgsProduct({{1, 8, 36, 64, 128, 270, 512}, {50, 200}, {0}, {0, 1}})
    ->ArgsProduct({{1, 8, 36, 64}, {500}, {0}, {0, 1}})
    ->ArgsProduct({{1, 8}, {1500}, {0}, {0, 1}})
    ->ArgsProduct({{270}, {200}, {100}, {0, 1}})
    ->ArgsProduct({{1}, {1500}, {500}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// One POT scan (SPEC section 4, steps 3 and 4): the ranking batch of 5 sectors x 6 atoms x
// 8 rotations x {hits, free} = 480 problems (hits 40 to 72 points a side, free 30 to 50,
// eps 0.005, points scaled by 1/50, tol 1e-7, at most 1000 iterations, rotation about the
// origin by k * 45 degrees), and the transport batch of 5 high-quality problems (150 to 300
// points a side, max-normalised cost, eps 0.0005, at most 2000 iterations, annealed from 0.05).
// Sizes and points are reproduced by bench/sinkhorn_table.py for PythonOT.
int scan_size(std::uint64_t p) {
  return p % 2 == 0 ? 40 + static_cast<int>((p * 7919) % 33)
                    : 30 + static_cast<int>((p * 104729) % 21);
}

SinkhornProblem scan_problem(std::uint64_t p) {
  const int n = scan_size(p), m = scan_size(p + 1000003);
  SinkhornProblem q;
  q.source.resize(n, 2);
  q.target.resize(m, 2);
  for (int i = 0; i < n; ++i)
    for (int d = 0; d < 2; ++d) q.source(i, d) = sinkhorn_point(1000 + p, 0, i, d);
  for (int j = 0; j < m; ++j)
    for (int d = 0; d < 2; ++d) q.target(j, d) = sinkhorn_point(1000 + p, 1, j, d);
  q.angle = 0.78539816339744831 * static_cast<double>((p / 2) % 8);
  q.scale = 1.0 / 50;
  q.epsilon = 0.005;
  q.tolerance = 1e-7;
  q.max_iterations = 1000;
  return q;
}

SinkhornProblem transport_problem(std::uint64_t p) {
  const int n = 150 + static_cast<int>((p * 37) % 151), m = 150 + static_cast<int>((p * 53) % 151);
  SinkhornProblem q;
  q.source.resize(n, 2);
  q.target.resize(m, 2);
  for (int i = 0; i < n; ++i)
    for (int d = 0; d < 2; ++d) q.source(i, d) = sinkhorn_point(5000 + p, 0, i, d);
  for (int j = 0; j < m; ++j)
    for (int d = 0; d < 2; ++d) q.target(j, d) = sinkhorn_point(5000 + p, 1, j, d);
  q.normalise_cost = true;
  q.epsilon = 0.0005;
  q.tolerance = 1e-7;
  q.max_iterations = 2000;
  return q;
}

// Args: part (0: ranking batch of 480, 1: transport batch of 5, 2: both in one batch), scheme.
void BM_SinkhornScan(benchmark::State& state) {
  const int part = static_cast<int>(state.range(0));
  SinkhornBatch b;
  if (part != 1)
    for (int p = 0; p < 480; ++p) b.add(scan_problem(p));
  if (part != 0)
    for (int p = 0; p < 5; ++p) b.add(transport_problem(p));
  SinkhornOptions o;
  o.stabilised = state.range(1) != 0;
  if (part != 0) {
    o.epsilon_start = 0.05;
    o.epsilon_decay = 0.5;
  }
  std::vector<SinkhornResult> r = b.run(bench_context(), o);
  for (auto _ : state) r = b.run(bench_context(), o);
  double its = 0, conv = 0, err = 0;
  for (const auto& x : r) {
    its += x.iterations;
    conv += x.converged;
    err = std::max(err, x.marginal_error);
  }
  const double batch = static_cast<double>(b.size());
  state.counters["problems_per_s"] =
      benchmark::Counter(batch * state.iterations(), benchmark::Counter::kIsRate);
  state.counters["iterations"] = its / batch;
  state.counters["converged_fraction"] = conv / batch;
  state.counters["max_marginal_error"] = err;
  state.counters["batch"] = batch;
  state.counters["n"] = 0;
  state.counters["part"] = part;
  state.SetLabel(bench_context().info().summary());
}
BENCHMARK(BM_SinkhornScan)
    ->ArgsProduct({{0, 1, 2}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_SinkhornReference(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const SinkhornProblem q = bench_problem(0, n);
  SinkhornResult r;
  for (auto _ : state) r = sinkhorn_reference(q);
  state.counters["problems_per_s"] =
      benchmark::Counter(double(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["iterations"] = r.iterations;
  state.counters["converged_fraction"] = r.converged;
  state.counters["batch"] = 1;
  state.counters["n"] = n;
  state.SetLabel("CPU reference (Eigen, double, 1 thread)");
}
BENCHMARK(BM_SinkhornReference)->Arg(50)->Arg(200)->Arg(500)->Unit(benchmark::kMillisecond);

}  // namespace
