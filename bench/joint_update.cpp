// The joint BHM's update per scan (RePOT's refine stage, BHM's whole cost), replayed
// on a real log away from POT's ranking and transport, so that its time can be compared between
// builds without the noise of the rest of the pipeline. Prints ms per scan by stage and writes
// the final maps (means, variances, scores) to compare builds' results.
//
// Target: a Radish log or a built-in town (town2: simulated, 360 beams), scans [first, first +
// scans) cut at 20 m, 20 % of every scan's beams held out (as bench/pot_scale and `potmap
// experiment intra`). POT runs once (the atoms of the
// first `first` scans) and its transported maps are kept; then, `reps` times each:
//   BHM:   a fresh joint BHM (the experiments' BhmSetup), update() per scan, then map();
//   RePOT: a fresh joint BHM (pot_method's persistent map), seed_unreached() with the scan's
//          transported map, then update() per scan, then map().
// Times are the median over the repetitions of each stage's total, over the scans.
//
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "potmap/data/scan.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/learn/bhm_joint.hpp"
#include "potmap/runtime/context.hpp"

using namespace potmap;
namespace ex = potmap::experiment;
using Clock = std::chrono::steady_clock;

namespace {

constexpr const char* kUsage =
    "Usage: joint_update [--data ../shared/data/radish] [--target intel] [--first 10]\n"
    "                    [--scans 100] [--reps 5] [--cg-tol 1e-5] [--em 3] [--repot-em 3]\n"
    "                    [--team both|on|off] [--dump FILE] [--compare FILE]\n"
    "  --target: a Radish log's name (intel, fr079, ...) or a built-in town (town2)\n"
    "  --cg-tol: JointBhmOptions::cg_tolerance (another tolerance shows how far the results\n"
    "            move within the solver's tolerance: the scale to judge a build's differences)\n"
    "  --em: EM iterations per scan of both models; --repot-em: of RePOT's alone\n"
    "  --team: both (default): every repetition runs the update on this thread alone, then on\n"
    "          a Context's host team (the maps are the same bit for bit; the dump holds the\n"
    "          team's); on or off: one of them\n"
    "  --dump: the final maps' means and variances (binary doubles, BHM then RePOT)\n"
    "  --compare: the largest differences from a dump of another build\n";

double ms_since(Clock::time_point t) {
  return 1e3 * std::chrono::duration<double>(Clock::now() - t).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

struct Replay {
  double seed_ms = 0, update_ms = 0, map_ms = 0;
  double cg_its = 0, active = 0, samples = 0;
  KernelMap map;
};

Replay replay(const ex::MapTask& task, const JointBhmOptions& o,
              const std::vector<KernelMap>* seeds, double seed_min_var, Context* team) {
  JointBhm learner(task.dim, task.lo, task.hi, o);
  Replay r;
  const std::size_t n = task.train_scans.size();
  std::vector<LabelledPoints> samples(n);
  for (std::size_t i = 0; i < n; ++i) samples[i] = ex::scan_training_samples(task, i, 0);
  for (std::size_t i = 0; i < n; ++i) {
    if (seeds) {
      const auto t0 = Clock::now();
      learner.seed_unreached((*seeds)[i], seed_min_var);
      r.seed_ms += ms_since(t0);
    }
    const auto t1 = Clock::now();
    learner.update(samples[i], team);
    r.update_ms += ms_since(t1);
    r.cg_its += double(learner.last_stats().cg_iterations);
    r.active += double(learner.last_stats().active);
    r.samples += double(learner.last_stats().samples);
  }
  const auto t2 = Clock::now();
  r.map = learner.map();
  r.map_ms = ms_since(t2);
  for (double* v : {&r.seed_ms, &r.update_ms, &r.map_ms, &r.cg_its, &r.active, &r.samples})
    *v /= double(n);
  return r;
}

std::vector<double> flatten(const KernelMap& m) {
  std::vector<double> v;
  for (std::size_t k = 0; k < m.size(); ++k) v.push_back(m.w_mean[k]);
  for (std::size_t k = 0; k < m.size(); ++k) v.push_back(m.w_var[k]);
  v.push_back(m.bias_mean);
  v.push_back(m.bias_var);
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  std::string data = "../shared/data/radish", target = "intel", dump, compare, team = "both";
  std::size_t first = 10, scans = 100, reps = 5;
  double cg_tol = 0;
  int em = 0, repot_em = 0;
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h") {
      std::printf("%s", kUsage);
      return 0;
    }
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--data")
      data = v;
    else if (k == "--target")
      target = v;
    else if (k == "--first")
      first = std::stoul(v);
    else if (k == "--scans")
      scans = std::stoul(v);
    else if (k == "--reps")
      reps = std::stoul(v);
    else if (k == "--cg-tol")
      cg_tol = std::stod(v);
    else if (k == "--em")
      em = std::stoi(v);
    else if (k == "--repot-em")
      repot_em = std::stoi(v);
    else if (k == "--dump")
      dump = v;
    else if (k == "--compare")
      compare = v;
    else if (k == "--team" && (v == "both" || v == "on" || v == "off"))
      team = v;
    else {
      std::fprintf(stderr, "joint_update: unknown option %s\n", k.c_str());
      return 2;
    }
  }
  // A built-in town is simulated as bench/pot_scale and bench/mapper_latency do (360 beams).
  std::vector<Scan> all;
  if (target.rfind("town", 0) == 0) {
    SimOptions so;
    so.scans = first + scans;
    all = simulate(Town::builtin(target), so).scans;
  } else {
    all = read_dataset(data + "/" + target + "-corrected.log.gz").scans;
  }
  std::vector<Scan> src, dst;
  for (std::size_t i = 0; i < all.size() && i < first + scans; ++i)
    (i < first ? src : dst).push_back(ex::limit_range(all[i], 20.0));
  LabelOptions lo;
  LabelledPoints test;
  ex::MapTask task = ex::make_task(dst, lo, test, 5.0, std::int64_t(first));
  task.source = {src};
  Context ctx;

  // The transported maps, once.
  ex::PotSetup setup;
  std::vector<KernelMap> seeds(task.train_scans.size());
  setup.on_scan = [&seeds](std::size_t i, const ScanTransfer& t) { seeds[i] = t.map; };
  ex::pot_method(setup, "POT").fit(&ctx, task);

  JointBhmOptions bhm = ex::joint_bhm_options(ex::BhmSetup{});
  JointBhmOptions repot = ex::joint_bhm_options(setup.target_bhm);
  repot.seeds_yield = setup.seeds_yield;
  if (cg_tol > 0) bhm.cg_tolerance = repot.cg_tolerance = cg_tol;
  if (em > 0) bhm.em_iterations = repot.em_iterations = em;
  if (repot_em > 0) repot.em_iterations = repot_em;

  // Per mode (0: this thread alone, 1: the host team), alternated within each repetition.
  struct Times {
    std::vector<double> bu, bm, rs, ru, rf, rm;
  } times[2];
  const bool modes[2] = {team != "on", team != "off"};
  Replay lb, lr;
  for (std::size_t k = 0; k < reps; ++k)
    for (int mode = 0; mode < 2; ++mode) {
      if (!modes[mode]) continue;
      Context* t = mode == 1 ? &ctx : nullptr;
      lb = replay(task, bhm, nullptr, 0, t);
      lr = replay(task, repot, &seeds, setup.seed_min_variance, t);
      Times& m = times[mode];
      m.bu.push_back(lb.update_ms);
      m.bm.push_back(lb.map_ms);
      m.rs.push_back(lr.seed_ms);
      m.ru.push_back(lr.update_ms);
      m.rf.push_back(lr.seed_ms + lr.update_ms);
      m.rm.push_back(lr.map_ms);
    }
  auto score = [&](const KernelMap& m) {
    return ex::score_map(ex::kernel_fitted_map(&ctx, std::make_shared<KernelMap>(m)), test);
  };
  const Scores sb = score(lb.map), sr = score(lr.map);
  std::printf("%s, %zu scans, %zu reps (median ms per scan)\n", target.c_str(),
              task.train_scans.size(), reps);
  for (int mode = 0; mode < 2; ++mode) {
    if (!modes[mode]) continue;
    const Times& m = times[mode];
    std::printf("%s\n",
                mode == 0 ? "one thread:" : "host team (two parts on this thread and the helper):");
    std::printf(
        "BHM   update %.3f  map %.3f  (per scan: %.0f samples, %.0f active, %.1f CG its)"
        "  AUC %.5f NLL %.5f ACC %.5f\n",
        median(m.bu), median(m.bm), lb.samples, lb.active, lb.cg_its, sb.auc, sb.nll, sb.acc);
    std::printf(
        "RePOT seed %.3f  update %.3f  refine %.3f  map %.3f  (per scan: %.0f active, "
        "%.1f CG its)  AUC %.5f NLL %.5f ACC %.5f\n",
        median(m.rs), median(m.ru), median(m.rf), median(m.rm), lr.active, lr.cg_its, sr.auc,
        sr.nll, sr.acc);
  }

  std::vector<double> v = flatten(lb.map), w = flatten(lr.map);
  v.insert(v.end(), w.begin(), w.end());
  if (!dump.empty()) {
    std::ofstream f(dump, std::ios::binary);
    f.write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * sizeof(double)));
  }
  if (!compare.empty()) {
    std::ifstream f(compare, std::ios::binary);
    std::vector<double> u(v.size());
    f.read(reinterpret_cast<char*>(u.data()), std::streamsize(u.size() * sizeof(double)));
    if (!f || f.peek() != EOF) {
      std::printf("compare: %s holds another number of values\n", compare.c_str());
      return 1;
    }
    // Means then variances, per map: the largest absolute difference of each, and the
    // largest value, for scale.
    const std::size_t nb = lb.map.size(), nr = lr.map.size();
    auto report = [&](const char* name, std::size_t a, std::size_t n) {
      double d = 0, top = 0, ss = 0;
      for (std::size_t k = a; k < a + n; ++k) {
        d = std::max(d, std::abs(u[k] - v[k]));
        top = std::max(top, std::abs(u[k]));
        ss += (u[k] - v[k]) * (u[k] - v[k]);
      }
      std::printf(" %s %.3g (rms %.3g, largest %.3g)", name, d, std::sqrt(ss / double(n)), top);
    };
    const std::size_t r0 = 2 * nb + 2;
    std::printf("compare:\n  BHM  ");
    report("means", 0, nb);
    report("vars", nb, nb);
    report("bias", 2 * nb, 1);
    std::printf("\n  RePOT");
    report("means", r0, nr);
    report("vars", r0 + nr, nr);
    report("bias", r0 + 2 * nr, 1);
    std::printf("\n");
  }
  return 0;
}
