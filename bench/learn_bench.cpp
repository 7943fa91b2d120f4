// Learner timings: BHM update per scan against the number of kernels; ABHM time per step and per
// epoch for 1k, 10k and 50k kernels (the SPEC's 2450 steps to convergence follow by
// multiplication: a full run is too long for the default benchmark set).
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>

#include "potmap/learn/abhm.hpp"
#include "potmap/learn/bhm.hpp"
#include "potmap/runtime/context.hpp"

using namespace potmap;

namespace {

Context& learn_context() {
  static Context ctx;
  return ctx;
}

// Samples of one LIDAR-sized scan (about 10k: hits and free samples) spread over a square.
LabelledPoints scan_samples(std::size_t n, double side, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, side);
  LabelledPoints s;
  s.dim = 2;
  for (std::size_t i = 0; i < n; ++i) {
    const double x = u(rng), y = u(rng);
    s.position.insert(s.position.end(), {x, y});
    // A striped world: occupied bands 1 m wide every 6 m.
    s.label.push_back(std::fmod(x, 6.0) < 1.0);
    s.scan.push_back(0);
  }
  return s;
}

void BM_BhmUpdate(benchmark::State& state) {
  const std::size_t m = static_cast<std::size_t>(state.range(0));
  const bool device = state.range(1) != 0;
  const double side = std::sqrt(double(m));  // 1 m spacing
  const LabelledPoints scan = scan_samples(10000, side, 3);
  const double lo[3] = {0, 0, 0}, hi[3] = {side - 1, side - 1, 0};
  const KernelMap prior = bhm_grid_prior(2, lo, hi, 1.0, 2.0);
  if (device) {  // build the OpenCL program outside the timing
    KernelMap warm = prior;
    bhm_update(learn_context(), warm, scan);
  }
  for (auto _ : state) {
    KernelMap map = prior;
    if (device)
      bhm_update(learn_context(), map, scan);
    else
      bhm_update_reference(map, scan);
    benchmark::DoNotOptimize(map.w_mean.data());
  }
  state.counters["kernels"] = double(prior.size());
  state.counters["samples"] = double(scan.size());
}
BENCHMARK(BM_BhmUpdate)
    ->ArgsProduct({{1000, 10000, 50000}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_AbhmStep(benchmark::State& state) {
  const std::size_t m = static_cast<std::size_t>(state.range(0));
  const double side = std::sqrt(double(m));
  const LabelledPoints data = scan_samples(20000, side, 5);
  const double lo[3] = {0, 0, 0}, hi[3] = {side, side, 0};
  AbhmParams p = abhm_init_halton(2, lo, hi, m, 2.0);
  AbhmOptions o;
  o.batch = 1024;
  o.device = &learn_context();
  o.steps = 1;
  abhm_train(p, data, o);  // build the OpenCL program outside the timing
  // Without a checkpoint every call is one fresh step: the cost of one step
  for (auto _ : state) abhm_train(p, data, o);
  const double epoch_steps = double(data.size()) / double(o.batch);
  state.counters["kernels"] = double(m);
  state.counters["s_per_epoch"] =
      benchmark::Counter(double(state.iterations()) / epoch_steps,
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.counters["s_2450_steps"] =
      benchmark::Counter(double(state.iterations()) / 2450.0,
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_AbhmStep)
    ->Arg(1000)
    ->Arg(10000)
    ->Arg(50000)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// A whole training run, measured rather than extrapolated from one step: the SPEC's 2450 Adam
// steps, with the minibatch ELBO recorded along the way. `elbo_change_last_10pct` is the
// relative change of the (100-step averaged) ELBO over the last tenth of the run: near zero
// means the run has converged at that step count.
void BM_AbhmTrain(benchmark::State& state) {
  const std::size_t m = static_cast<std::size_t>(state.range(0));
  const double side = std::sqrt(double(m));
  const LabelledPoints data = scan_samples(20000, side, 5);
  const double lo[3] = {0, 0, 0}, hi[3] = {side, side, 0};
  AbhmOptions o;
  o.batch = 1024;
  o.device = &learn_context();
  o.report_every = 1;
  std::vector<double> elbo;
  o.progress = [&](std::size_t, double e) { elbo.push_back(e); };
  {
    AbhmParams warm = abhm_init_halton(2, lo, hi, m, 2.0);
    AbhmOptions w = o;
    w.steps = 1;
    w.progress = nullptr;
    abhm_train(warm, data, w);  // build the OpenCL program outside the timing
  }
  for (auto _ : state) {
    elbo.clear();
    AbhmParams p = abhm_init_halton(2, lo, hi, m, 2.0);
    abhm_train(p, data, o);
  }
  auto mean = [&](std::size_t a, std::size_t b) {
    double s = 0;
    for (std::size_t i = a; i < b; ++i) s += elbo[i];
    return s / double(b - a);
  };
  const std::size_t n = elbo.size();
  if (n >= 1000) {
    const double end = mean(n - 100, n), before = mean(n - n / 10 - 100, n - n / 10);
    state.counters["elbo_final"] = end;
    state.counters["elbo_change_last_10pct"] = (end - before) / std::abs(before);
  }
  state.counters["kernels"] = double(m);
  state.counters["steps"] = double(o.steps);
  state.counters["epochs"] = double(o.steps) * double(o.batch) / double(data.size());
}
BENCHMARK(BM_AbhmTrain)
    ->Arg(1000)
    ->Arg(10000)
    ->Arg(50000)
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(1);

}  // namespace
