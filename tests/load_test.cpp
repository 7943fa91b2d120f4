// Load: many mappers on one Context, and many Contexts on one device, at once on threads. Each
// must give exactly (bitwise) what it gives alone: a Context serialises its program builds and
// shares its queue, mappers share a dictionary they never change, and nothing else is shared.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <exception>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "potmap/data/simulator.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/mapper.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

constexpr int kMappers = 6;

// The suite's small options, each mapper with a seed of its own.
MapperOptions load_options(bool refine, std::uint64_t seed) {
  MapperOptions o = test::small_mapper_options(refine);
  o.labels.seed = o.pot.seed = seed;
  return o;
}

// One drive: the dictionary from its first two scans, then two scans for each mapper.
struct Drive {
  Simulation sim;
  std::shared_ptr<Dictionary> dict = std::make_shared<Dictionary>();
  Drive() {
    SimOptions so;
    so.scans = 2 + 2 * kMappers;
    so.spacing = 3;
    so.step_deg = 2;
    sim = simulate(Town::builtin("town1"), so);
    build_dictionary({sim.scans[0], sim.scans[1]}, test::grid_around(sim.scans[0].origin(), 24), {},
                     *dict);
  }
  std::vector<Scan> scans_of(int mapper) const {
    return {sim.scans[2 + mapper], sim.scans[2 + kMappers + mapper]};
  }
};

const Drive& drive() {
  static const Drive d;
  return d;
}

// Mapper `k`'s overall map on `ctx`: POT for even k, RePOT for odd, each with its own seed.
KernelMap map_alone(Context& ctx, int k) {
  Mapper m(&ctx, drive().dict, load_options(k % 2 == 1, 11 + k));
  for (const Scan& s : drive().scans_of(k)) m.add_scan(s);
  return m.overall_map();
}

void expect_bitwise(const KernelMap& a, const KernelMap& b, const std::string& what) {
  EXPECT_GT(a.size(), 0u) << what;
  ASSERT_EQ(a.size(), b.size()) << what;
  EXPECT_EQ(a.position, b.position) << what;
  EXPECT_EQ(a.gamma, b.gamma) << what;
  EXPECT_EQ(a.w_mean, b.w_mean) << what;
  EXPECT_EQ(a.w_var, b.w_var) << what;
  EXPECT_EQ(a.has_bias, b.has_bias) << what;
}

// Runs `work(k)` for k in [0, n) on n threads at once; an exception in one is rethrown here.
template <class F>
void on_threads(int n, F work) {
  std::vector<std::exception_ptr> errors(n);
  std::vector<std::thread> threads;
  for (int k = 0; k < n; ++k)
    threads.emplace_back([&, k] {
      try {
        work(k);
      } catch (...) {
        errors[k] = std::current_exception();
      }
    });
  for (std::thread& t : threads) t.join();
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
}

std::vector<double> query_points() {
  std::vector<double> pts;
  const std::array<double, 3> c = drive().sim.scans[2].origin();
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) {
      pts.push_back(c[0] - 20 + i);
      pts.push_back(c[1] - 20 + j);
    }
  return pts;
}

}  // namespace

TEST(Load, ManyMappersOnOneContextGiveWhatEachGivesAlone) {
  Context& ctx = test::context();
  std::vector<KernelMap> alone(kMappers), together(kMappers);
  for (int k = 0; k < kMappers; ++k) alone[k] = map_alone(ctx, k);
  on_threads(kMappers, [&](int k) { together[k] = map_alone(ctx, k); });
  for (int k = 0; k < kMappers; ++k)
    expect_bitwise(together[k], alone[k], "mapper " + std::to_string(k));
}

TEST(Load, ManyContextsOnOneDeviceGiveWhatEachGivesAlone) {
  constexpr int kContexts = 4;
  const std::vector<double> pts = query_points();
  // Alone: one Context at a time, each evaluating a map and mapping its scans.
  std::vector<KernelMap> want_map(kContexts), got_map(kContexts);
  std::vector<MapValues> want_eval(kContexts), got_eval(kContexts);
  auto work = [&](int k, std::vector<KernelMap>& maps, std::vector<MapValues>& evals) {
    Context ctx;  // the device POTMAP_DEVICE names, as test::context()
    maps[k] = map_alone(ctx, k);
    MapEvaluator ev(ctx, maps[k]);
    evals[k] = ev.evaluate(pts);
  };
  for (int k = 0; k < kContexts; ++k) work(k, want_map, want_eval);
  on_threads(kContexts, [&](int k) { work(k, got_map, got_eval); });
  for (int k = 0; k < kContexts; ++k) {
    const std::string what = "context " + std::to_string(k);
    expect_bitwise(got_map[k], want_map[k], what);
    EXPECT_EQ(got_eval[k].prob, want_eval[k].prob) << what;
    EXPECT_EQ(got_eval[k].var, want_eval[k].var) << what;
    EXPECT_EQ(got_eval[k].mean, want_eval[k].mean) << what;
  }
}
