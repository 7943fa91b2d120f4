// POT and RePOT in the experiments: atoms from the source places, target scans transferred in
// order from the task's training samples, instantaneous maps merged into an overall map.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <memory>

#include "potmap/data/labelling.hpp"
#include "potmap/error.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/experiments/lookahead.hpp"
#include "potmap/learn/bhm_joint.hpp"
#include "potmap/map/evaluate.hpp"

namespace potmap::experiment {

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The source map of one place, learned on every beam of its scans.
KernelMap source_map(Context* ctx, const std::vector<Scan>& scans, const PotSetup& setup,
                     std::uint64_t seed) {
  LabelOptions lo = setup.dictionary.labels;
  lo.seed = seed;
  const LabelledSplit s = label_scans(scans, lo);
  const int d = scans.front().dim;
  double lo3[3] = {0, 0, 0}, hi3[3] = {0, 0, 0};
  for (int k = 0; k < d; ++k) {
    lo3[k] = HUGE_VAL;
    hi3[k] = -HUGE_VAL;
  }
  for (std::size_t i = 0; i < s.train.size(); ++i)
    for (int k = 0; k < d; ++k) {
      lo3[k] = std::min(lo3[k], s.train.position[i * d + k]);
      hi3[k] = std::max(hi3[k], s.train.position[i * d + k]);
    }
  if (s.train.empty()) throw InputError("POT: a source place gave no labelled samples");
  if (setup.atom_map == "bhm") {
    return learn_bhm(ctx, setup.atom_bhm, d, lo3, hi3, s.train);
  }
  if (setup.atom_map == "abhm") {
    const AbhmSetup& a = setup.atom_abhm;
    AbhmParams p = abhm_init_halton(d, lo3, hi3, a.count, a.gamma0);
    AbhmOptions o;
    o.steps = a.steps;
    o.batch = a.batch;
    o.seed = seed * 7919 + 3;
    o.report_every = 0;
    o.device = ctx;
    abhm_train(p, s.train, o);
    return p.to_map();
  }
  throw ArgumentError("POT: atom map must be bhm or abhm, not '" + setup.atom_map + "'");
}

// Offsets of each scan's samples in task.train (label_scan appends scan by scan).
std::vector<std::size_t> scan_offsets(const MapTask& task) {
  const std::size_t n = task.train_scans.size();
  std::vector<std::size_t> off(n + 1, 0);
  const auto& t = task.train.scan;
  std::size_t j = 0;
  for (std::size_t i = 0; i < n; ++i) {
    off[i] = j;
    const std::int64_t idx = task.first_index + std::int64_t(i);
    while (j < t.size() && t[j] == idx) ++j;
  }
  off[n] = j;
  if (j != t.size()) throw ArgumentError("POT: the task's training samples are not in scan order");
  return off;
}

LabelledPoints samples_of(const MapTask& task, std::size_t a, std::size_t b,
                          const std::array<double, 3>& sensor, double range) {
  const int d = task.dim;
  LabelledPoints out;
  out.dim = d;
  const double r2 = range * range;
  for (std::size_t k = a; k < b; ++k) {
    const double* p = &task.train.position[k * d];
    const double dx = p[0] - sensor[0], dy = p[1] - sensor[1];
    if (range > 0 && dx * dx + dy * dy > r2) continue;
    out.position.insert(out.position.end(), p, p + d);
    out.label.push_back(task.train.label[k]);
    out.scan.push_back(task.train.scan[k]);
  }
  return out;
}

}  // namespace

Dictionary build_atoms(Context* ctx, const std::vector<std::vector<Scan>>& places,
                       const PotSetup& setup, std::uint64_t seed, std::size_t* map_kernels) {
  Dictionary dict;
  std::size_t kernels = 0;
  for (const std::vector<Scan>& scans : places) {
    if (scans.empty()) continue;
    const KernelMap map = source_map(ctx, scans, setup, seed);
    kernels += map.size();
    std::vector<Scan> chosen;
    const std::size_t n = scans.size();
    const std::size_t m = setup.atom_scans == 0 ? n : std::min(n, setup.atom_scans);
    for (std::size_t k = 0; k < m; ++k) chosen.push_back(scans[k * n / m]);
    DictionaryOptions o = setup.dictionary;
    o.labels.seed = seed;
    if (setup.atom_map == "bhm" && setup.atom_bhm.joint) {
      // The joint BHM's prior variance is small (10): a kernel no sample reached keeps it, one
      // near the data ends far below it.
      const double prior =
          setup.atom_bhm.prior_var > 0 ? setup.atom_bhm.prior_var : JointBhmOptions{}.prior_var;
      o.max_weight_variance = std::min(o.max_weight_variance, 0.5 * prior);
    }
    build_dictionary(chosen, map, o, dict);
  }
  if (map_kernels) *map_kernels = kernels;
  return dict;
}

LabelledPoints scan_training_samples(const MapTask& task, std::size_t i, double range) {
  if (i >= task.train_scans.size()) throw ArgumentError("scan_training_samples: no such scan");
  const auto off = scan_offsets(task);
  return samples_of(task, off[i], off[i + 1], task.train_scans[i].origin(), range);
}

namespace {

// The dictionary of the task's source places, built once per source_key: the experiments fit
// several methods and tasks on the same source.
std::shared_ptr<const Dictionary> source_dictionary(Context* ctx, const MapTask& task,
                                                    const PotSetup& setup, AtomCache& cache,
                                                    double& atoms_s) {
  auto hit =
      task.source_key.empty() ? cache.dictionaries.end() : cache.dictionaries.find(task.source_key);
  if (hit != cache.dictionaries.end()) {
    atoms_s = cache.build_seconds[task.source_key];
    return hit->second;
  }
  const auto t0 = std::chrono::steady_clock::now();
  auto dict = std::make_shared<const Dictionary>(build_atoms(ctx, task.source, setup, task.seed));
  atoms_s = seconds_since(t0);
  if (!task.source_key.empty()) {
    cache.dictionaries[task.source_key] = dict;
    cache.build_seconds[task.source_key] = atoms_s;
  }
  return dict;
}

// The transfer's options for the task. With RePOT's persistent map, also that map (into
// learner), which then does the refinement in place of the per-scan one.
PotOptions task_pot_options(const PotSetup& setup, const MapTask& task, const Dictionary& dict,
                            std::unique_ptr<JointBhm>& learner) {
  PotOptions po = setup.pot;
  po.seed = task.seed;
  if (po.ranking == PotRanking::indexed && !po.index)
    po.index = std::make_shared<const AtomIndex>(dict);
  if (po.refine && setup.persistent_refine) {
    po.refine = false;
    po.placement = setup.seed_placement;
    po.displacement_variance = setup.seed_displacement_variance;
    JointBhmOptions jo = joint_bhm_options(setup.target_bhm);
    jo.seeds_yield = setup.seeds_yield;
    jo.seeds_yield_fully = setup.seeds_yield_fully;
    learner = std::make_unique<JointBhm>(task.dim, task.lo, task.hi, jo);
  }
  return po;
}

// What mapping a task's scans came to.
struct PotRun {
  std::shared_ptr<KernelMap> map;
  PotTiming timing;  // summed over the scans
  std::size_t sectors = 0, inst_kernels = 0;
  double combine_ms = 0;
  double seconds = 0;
};

// The overall map as it stands at n points (the look-ahead): the persistent learner's, else
// the averaged or summed map (p = 0.5 before it has a kernel).
void query_overall(Context* ctx, const JointBhm* learner, const KernelMap& map, const double* pts,
                   std::size_t n, double* prob) {
  if (learner) {
    std::vector<double> var(n);
    learner->predict(pts, n, prob, var.data(), ctx);
    for (std::size_t i = 0; i < n; ++i) prob[i] = probit_probability(prob[i], var[i]);
    return;
  }
  if (map.empty()) {
    std::fill(prob, prob + n, 0.5);
    return;
  }
  if (ctx) {
    MapEvaluator ev(*ctx, map);
    std::vector<float> p(n);
    ev.evaluate(pts, n, nullptr, nullptr, p.data());
    std::copy(p.begin(), p.end(), prob);
    return;
  }
  const MapValuesExact e = evaluate_exact(map, pts, n);
  std::copy(e.prob.begin(), e.prob.end(), prob);
}

// Transfers the task's scans one after another and combines them into the overall map (the
// persistent learner's when there is one), with the stages of consecutive scans overlapped.
// `ahead`: each scan's look-ahead, scored on the overall map before the scan joins it.
PotRun map_task_scans(Context* ctx, const MapTask& task, const PotSetup& setup,
                      const Dictionary& dict, const PotOptions& po, JointBhm* learner, double range,
                      LookAheadScorer& ahead) {
  const auto off = scan_offsets(task);
  // A scan's samples gathered per voxel of the BHM's edge (BhmSetup::voxel; 3D drives: 0.5 m),
  // as the BHM learns them, for the transport and the persistent map alike: their cost follows
  // the space a scan covers, not the sensor's point count.
  const double voxel = setup.target_bhm.voxel;
  auto scan_samples = [&](std::size_t i, const std::array<double, 3>& sensor, double r) {
    LabelledPoints s = samples_of(task, off[i], off[i + 1], sensor, r);
    return voxel > 0 ? aggregate_voxels(s, voxel) : s;
  };
  // warm: the atoms of the last scan finished (PotOptions::warm_candidates).
  auto prepare = [&](std::size_t i, std::vector<long> warm) {
    const Scan& s = task.train_scans[i];
    const auto sensor = s.origin();
    return prepare_transfer(dict, scan_samples(i, sensor, range), sensor, scan_heading(s),
                            task.first_index + std::int64_t(i), po, warm, ctx);
  };

  const auto t0 = std::chrono::steady_clock::now();
  OverallMap overall(task.dim, setup.overall);
  AveragedMap averaged(task.dim, setup.averaged);
  const bool average = setup.combine == PotSetup::Combine::average;
  const auto launch = setup.pipeline ? std::launch::async : std::launch::deferred;
  const std::size_t n = task.train_scans.size();
  std::vector<long> warm;
  std::future<PreparedTransfer> next = std::async(launch, prepare, std::size_t{0}, warm);
  PotRun run;
  double refine_ms = 0;
  // What a scan adds to the overall map (RePOT's update, POT's averaged or summed map) runs
  // beside the next scan's transfer: the transfer never reads the overall map, which takes
  // the scans in order, so the maps are those of a serial run.
  std::future<void> merging;
  auto merge = [&](std::size_t i, KernelMap transported) {
    const auto c0 = std::chrono::steady_clock::now();
    if (learner) {
      learner->seed_unreached(transported, setup.seed_min_variance);
      learner->update(scan_samples(i, {0, 0, 0}, 0), ctx);
      refine_ms += 1e3 * seconds_since(c0);
      return;
    }
    if (transported.empty()) return;
    if (average)
      averaged.add(transported);
    else
      overall.add(transported);
    run.combine_ms += 1e3 * seconds_since(c0);
  };
  auto finish_scan = [&](std::size_t i, ScanTransfer t) {
    if (setup.on_scan) setup.on_scan(i, t);
    run.sectors += t.sectors.size();
    run.inst_kernels += t.map.size();
    run.timing.prepare_ms += t.timing.prepare_ms;
    run.timing.ranking_ms += t.timing.ranking_ms;
    run.timing.transport_ms += t.timing.transport_ms;
    run.timing.placement_ms += t.timing.placement_ms;
    run.timing.refine_ms += t.timing.refine_ms;
    if (merging.valid()) merging.get();
    ahead.before(task.first_index + std::int64_t(i),
                 [&](const double* pts, std::size_t n, double* prob) {
                   const KernelMap none;
                   const KernelMap& now = learner ? none : average ? averaged.map() : overall.map();
                   query_overall(ctx, learner, now, pts, n, prob);
                 });
    merging = std::async(launch, merge, i, std::move(t.map));
  };
  // A scan's kernels are placed (host) beside the next scan's ranking and transport (device),
  // as map_scans() does; not with the per-scan refinement, which uses the device too.
  const bool overlap = setup.pipeline && !po.refine;
  std::future<ScanTransfer> placing;
  for (std::size_t i = 0; i < n; ++i) {
    PreparedTransfer cur = next.get();
    if (i + 1 < n) next = std::async(launch, prepare, i + 1, warm);
    SolvedTransfer solved = solve_transfer(ctx, dict, std::move(cur), po);
    warm = chosen_atoms(solved);
    auto place = [ctx, &dict, &po](SolvedTransfer s) {
      return place_transfer(ctx, dict, std::move(s), po);
    };
    if (!overlap) {
      finish_scan(i, place(std::move(solved)));
      continue;
    }
    std::future<ScanTransfer> placed = std::async(std::launch::async, place, std::move(solved));
    if (placing.valid()) finish_scan(i - 1, placing.get());
    placing = std::move(placed);
  }
  if (placing.valid()) finish_scan(n - 1, placing.get());
  if (merging.valid()) merging.get();
  run.timing.refine_ms += refine_ms;
  run.seconds = seconds_since(t0);
  run.map = std::make_shared<KernelMap>(learner   ? learner->map(ctx)
                                        : average ? averaged.map()
                                                  : overall.map());
  return run;
}

}  // namespace

Method pot_method(const PotSetup& setup, const std::string& name,
                  std::shared_ptr<AtomCache> cache) {
  Method m;
  m.name = m.group = name;
  m.uses_source = true;
  if (!cache) cache = std::make_shared<AtomCache>();
  m.fit = [setup, cache](Context* ctx, const MapTask& task) {
    if (task.source.empty()) throw ArgumentError("POT: the task has no source scans");
    double atoms_s = 0;
    const std::shared_ptr<const Dictionary> dict =
        source_dictionary(ctx, task, setup, *cache, atoms_s);
    if (dict->empty()) throw InputError("POT: the source gave no atoms");
    std::unique_ptr<JointBhm> learner;
    const PotOptions po = task_pot_options(setup, task, *dict, learner);
    const double range = po.max_range > 0 ? po.max_range : dict->max_range;
    LookAheadScorer ahead(task);
    const PotRun run = map_task_scans(ctx, task, setup, *dict, po, learner.get(), range, ahead);

    FittedMap f = kernel_fitted_map(ctx, run.map);
    f.fit_seconds = run.seconds - ahead.seconds();
    if (ahead.active()) f.lookahead = ahead.take();
    const double dn = double(std::max<std::size_t>(task.train_scans.size(), 1));
    f.info["kernels"] = double(run.map->size());
    f.info["atoms"] = double(dict->size());
    f.info["atoms_s"] = atoms_s;
    f.info["sectors_per_scan"] = double(run.sectors) / dn;
    f.info["kernels_per_scan"] = double(run.inst_kernels) / dn;
    f.info["prepare_ms"] = run.timing.prepare_ms / dn;
    f.info["ranking_ms"] = run.timing.ranking_ms / dn;
    f.info["transport_ms"] = run.timing.transport_ms / dn;
    f.info["placement_ms"] = run.timing.placement_ms / dn;
    f.info["refine_ms"] = run.timing.refine_ms / dn;
    f.info["combine_ms"] = run.combine_ms / dn;
    f.info["range_m"] = range;
    f.info["atom_map_abhm"] = setup.atom_map == "abhm" ? 1.0 : 0.0;
    return f;
  };
  return m;
}

}  // namespace potmap::experiment
