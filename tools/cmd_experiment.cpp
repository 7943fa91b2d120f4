// `potmap experiment intra|inter|sim2real|dynamic|per-time`: the paper's comparisons (Sec. IV,
// Tables III to VI) on any dataset a reader takes, every method scored on the same held-out beams.
#include <algorithm>
#include <cmath>
#include <functional>
#include <iostream>
#include <memory>
#include <vector>

#include "commands.hpp"
#include "potmap/data/drive.hpp"
#include "potmap/error.hpp"
#include "potmap/experiments/experiment_runner.hpp"
#include "potmap/mapping/drive_mapper.hpp"

namespace potmap::cli {

namespace {

namespace exp = experiment::runner;
using exp::Harness;
using exp::Settings;

// The wavemap peer's settings (used by builds with wavemap; accepted by every build).
void add_wavemap_options(CLI::App* cmd, std::vector<double>& cells, experiment::WavemapSetup& w) {
  cmd->add_option("--wavemap-cells", cells, "wavemap: smallest cell sizes, metres, one run each")
      ->expected(1, -1)
      ->capture_default_str();
  cmd->add_option("--wavemap-pitch", w.azimuth_pitch_deg,
                  "wavemap: the range image's azimuth pixel, degrees (the field of view is the "
                  "keyframes')")
      ->capture_default_str();
  cmd->add_option("--wavemap-elevation-pitch", w.elevation_pitch_deg,
                  "wavemap: the range image's elevation pixel, degrees")
      ->capture_default_str();
  cmd->add_option("--wavemap-angle-sigma", w.options.angle_sigma_deg,
                  "wavemap: the continuous beam model's angular sigma, degrees")
      ->capture_default_str();
  cmd->add_option("--wavemap-min-range", w.options.min_range,
                  "wavemap: no update closer than this, metres")
      ->capture_default_str();
}

// Which seeds, scans and methods a comparison runs.
void add_run_options(CLI::App* cmd, Settings& s) {
  cmd->add_option(
         "--seeds", s.seeds,
         "Seeds of the beam split, free samples, simulated routes and ABHM (default 0 1 2)")
      ->expected(1, -1);
  cmd->add_option("--scans", s.scans, "Use at most this many scans of each dataset (0: all)");
  cmd->add_option("--methods", s.methods,
                  "Comma-separated: ogm, bhm, abhm, pot, repot; wavemap in builds with it "
                  "(-DPOTMAP_WAVEMAP_DIR)")
      ->capture_default_str();
  cmd->add_option("--ogm-cells", s.ogm_cells, "OGM cell sizes, metres; the best by AUC is reported")
      ->expected(1, -1)
      ->capture_default_str();
  add_wavemap_options(cmd, s.wavemap_cells, s.wavemap);
  cmd->add_flag(
      "--lookahead", s.lookahead,
      "Also score each scan's held-out samples on every method's map before the scan "
      "is learned (the sequences of intra, inter, sim2real and per-time), all of them and those "
      "beyond every earlier sample's reach: what a planner reads of the space ahead, "
      "and what a transferred prior is for (docs/transfer.md)");
  cmd->add_option("--lookahead-reach", s.lookahead_reach,
                  "Look-ahead: a held-out sample with no earlier training sample within this "
                  "many metres is beyond reach (0: twice the BHM's spacing)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
}

// The BHM and ABHM methods' settings.
void add_learner_options(CLI::App* cmd, Settings& s) {
  cmd->add_option("--bhm-joint", s.bhm.joint,
                  "BHM posterior: true = joint (overlapping kernels, sparse precision), false = "
                  "diagonal (narrow disjoint kernels)")
      ->capture_default_str();
  cmd->add_option("--bhm-spacing", s.bhm.spacing, "BHM kernel grid spacing, metres")
      ->capture_default_str();
  cmd->add_option("--bhm-gamma", s.bhm.gamma,
                  "BHM kernel width, 1/m^2 (0: the model's default for the spacing)")
      ->capture_default_str();
  cmd->add_option("--bhm-prior-var", s.bhm.prior_var,
                  "BHM prior weight variance (0: the model's default, joint 10, diagonal 1e4)")
      ->capture_default_str();
  cmd->add_option("--bhm-voxel", s.bhm.voxel,
                  "Joint BHM: each scan's samples gathered per voxel of this edge, metres, one "
                  "weighted sample each (0: every sample on its own)")
      ->capture_default_str();
  cmd->add_option("--bhm-tau", s.bhm.tau,
                  "Joint BHM: feature cut-off exponent gamma d^2 (0: the learner's default, 6)")
      ->capture_default_str();
  cmd->add_option("--bhm-margin", s.bhm.solve_margin,
                  "Joint BHM: rings of kernels solved around those a scan reaches (-1: the "
                  "learner's default, 4)")
      ->capture_default_str();
  cmd->add_option("--bhm-cg-tol", s.bhm.cg_tolerance,
                  "Joint BHM: relative residual that ends a scan's solve (0: the learner's "
                  "default, 1e-5)")
      ->capture_default_str();
  cmd->add_option("--bhm-em", s.bhm.options.em_iterations, "BHM E-steps per scan")
      ->capture_default_str();
  cmd->add_option("--bhm-bias", s.bhm.bias, "BHM bias weight (true/false)")->capture_default_str();
  cmd->add_option("--abhm-kernels", s.abhm.count, "ABHM kernels (Halton over the area)")
      ->capture_default_str();
  cmd->add_option("--abhm-steps", s.abhm.steps, "ABHM Adam steps")->capture_default_str();
  cmd->add_option("--abhm-gamma0", s.abhm.gamma0, "ABHM starting kernel width, 1/m^2")
      ->capture_default_str();
}

// POT and RePOT: the atoms and the transfer of a scan.
void add_pot_transfer_options(CLI::App* cmd, Settings& s) {
  cmd->add_option("--atom-map", s.pot.atom_map,
                  "POT/RePOT: map the atoms' kernels come from, learned on the source: bhm "
                  "(fast) or abhm (the paper's, varied widths)")
      ->capture_default_str();
  cmd->add_option_function<std::string>(
         "--ranking",
         [&s](const std::string& v) {
           s.pot.pot.ranking = v == "indexed" ? PotRanking::indexed : PotRanking::exhaustive;
         },
         "POT/RePOT: exhaustive (every atom at every rotation) or indexed (nearest atoms at "
         "estimated rotations, coarse to fine; default indexed)")
      ->check(CLI::IsMember({"exhaustive", "indexed"}));
  cmd->add_option("--pot-pipeline", s.pot.pipeline,
                  "POT/RePOT: prepare the next scan, and run RePOT's update, beside the current "
                  "scan's transfer on other threads (false: one scan at a time; same maps)")
      ->capture_default_str();
  cmd->add_option("--index-neighbours", s.pot.pot.index_neighbours,
                  "POT/RePOT with --ranking indexed: atoms taken from the index per sector")
      ->capture_default_str();
  cmd->add_option("--fine-candidates", s.pot.pot.fine_candidates,
                  "POT/RePOT with --ranking indexed: best coarse candidates per sector solved "
                  "again at the ranking's caps (0: the coarse stage decides)")
      ->capture_default_str();
  cmd->add_option("--coarse-tolerance", s.pot.pot.coarse_tolerance,
                  "POT/RePOT with --ranking indexed: the coarse stage's tolerance on the "
                  "plan's marginal error (from 1e-6 up solved in single-precision sums)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--free-tolerance", s.pot.pot.transport_free_tolerance,
                  "POT/RePOT: the free samples' transport's tolerance on the plan's marginal error")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--free-points", s.pot.pot.transport_free_points,
                  "POT/RePOT: free samples a side in the high-quality transport, thinned evenly")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--transport-points", s.pot.pot.transport_points,
                  "POT/RePOT: hits a side in the high-quality transport, thinned evenly")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option("--atom-scans", s.pot.atom_scans,
                  "POT/RePOT: source scans per place cut into atoms, evenly spaced (0: all)")
      ->capture_default_str();
  cmd->add_option("--atom-abhm-kernels", s.pot.atom_abhm.count,
                  "POT/RePOT with --atom-map abhm: ABHM kernels per source place")
      ->capture_default_str();
  cmd->add_option("--atom-sample-distance", s.pot.dictionary.max_sample_distance,
                  "POT/RePOT: atoms keep only kernels within this many metres of their own "
                  "samples (0: no limit)")
      ->capture_default_str();
  cmd->add_option("--atom-kernels-at-samples", s.pot.dictionary.kernels_at_samples,
                  "POT/RePOT: atoms hold kernels at their own samples thinned to this cell, "
                  "metres (0: the source map's kernels)")
      ->capture_default_str();
}

// POT and RePOT: where transported kernels go and how the scans' maps combine.
void add_pot_map_options(CLI::App* cmd, Settings& s) {
  cmd->add_option("--pot-wall-clearance", s.pot.pot.wall_clearance,
                  "POT/RePOT, barycentric kernels: drop free-space kernels landing this close to "
                  "the target's hits and wall kernels landing farther, metres (0: off)")
      ->capture_default_str();
  cmd->add_option_function<std::string>(
         "--pot-placement",
         [&s](const std::string& v) {
           s.pot.pot.placement =
               v == "barycentric" ? PotPlacement::barycentric : PotPlacement::target_samples;
         },
         "POT: kernels on the target's own samples, carrying the atom's logit pulled back "
         "through the plan (target_samples, default), or at the barycentric images of the "
         "atom's kernels (barycentric, the authors' rule)")
      ->check(CLI::IsMember({"target_samples", "barycentric"}));
  cmd->add_option("--pot-anchor-spacing", s.pot.pot.anchor_spacing,
                  "POT with --pot-placement target_samples: one kernel per cell of this edge of "
                  "the target's hits and free samples, metres")
      ->capture_default_str();
  cmd->add_option("--pot-anchor-clearance", s.pot.pot.anchor_clearance,
                  "POT with --pot-placement target_samples: drop free-sample anchors this close "
                  "to the target's hits, metres (0: off)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--pot-anchor-sweeps", s.pot.pot.anchor_sweeps,
                  "POT with --pot-placement target_samples: sweeps solving the anchors' weights "
                  "together, walls and free space (0: each class's partition alone)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--pot-logit-gain", s.pot.pot.logit_gain,
                  "POT with --pot-placement target_samples: the transported logits are "
                  "multiplied by this (1: the atoms' own)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  cmd->add_option_function<std::string>(
         "--pot-combine",
         [&s](const std::string& v) {
           s.pot.combine = v == "sum" ? experiment::PotSetup::Combine::sum
                                      : experiment::PotSetup::Combine::average;
         },
         "POT: overall map as the support-weighted average of the instantaneous maps "
         "(average, default) or their kernels summed with merging (sum, the authors' rule)")
      ->check(CLI::IsMember({"average", "sum"}));
  cmd->add_option("--pot-average-spacing", s.pot.averaged.spacing,
                  "POT with --pot-combine average: anchor grid of the averaged map, metres")
      ->capture_default_str();
  cmd->add_option("--pot-displacement-var", s.pot.pot.displacement_variance,
                  "POT/RePOT: weight variance added per m^2 a kernel was moved beyond the "
                  "candidate's rotation")
      ->capture_default_str();
  cmd->add_option("--repot-seed-var", s.pot.seed_min_variance,
                  "RePOT: least prior variance of a kernel seeded from transported kernels")
      ->capture_default_str();
  cmd->add_option("--repot-seeds-yield", s.pot.seeds_yield,
                  "RePOT: a seeded kernel returns to the plain prior when a sample first "
                  "reaches it (false: the seed stays its prior under the data)")
      ->capture_default_str();
  cmd->add_option("--repot-seeds-yield-fully", s.pot.seeds_yield_fully,
                  "RePOT: a seed yields when its kernel enters a scan's solve (within the solve "
                  "margin of the data), its mean too, so RePOT is BHM there (false: when a "
                  "sample reaches it, its mean starting that scan's bound)")
      ->capture_default_str();
  cmd->add_option("--repot-persistent", s.pot.persistent_refine,
                  "RePOT: one persistent joint BHM seeded by the transported kernels (true) or "
                  "per-scan refinement merged as POT's map (false)")
      ->capture_default_str();
  cmd->add_option("--pot-sample-distance", s.pot.pot.max_sample_distance,
                  "POT/RePOT: transported kernels farther than this many metres from the target "
                  "scan's samples are dropped (0: no limit)")
      ->capture_default_str();
  cmd->add_option("--rotations", s.rotations, "POT/RePOT: rotations tried per atom")
      ->capture_default_str();
  cmd->add_option("--sectors", s.pot.pot.sectors, "POT/RePOT: sectors per target scan")
      ->capture_default_str();
  cmd->add_option("--merge-radius", s.pot.overall.merge_radius,
                  "POT/RePOT: overall map merge radius (d^2 * gamma; 0: no merging)")
      ->capture_default_str();
}

// The scans' range, the simulated drives, the device and what is written.
void add_data_and_output_options(CLI::App* cmd, Settings& s) {
  cmd->add_option("--max-range", s.max_range,
                  "Cut every scan at this range, metres, for every method (POT's sector "
                  "radius; 0: each scan's own)")
      ->capture_default_str();
  cmd->add_option("--sim-scans", s.sim_scans, "Scans of each simulated drive (sim:TOWN)")
      ->capture_default_str();
  cmd->add_option("--sim-spacing", s.sim_spacing, "Metres between simulated scans")
      ->capture_default_str();
  cmd->add_option("--free-per-metre", s.free_per_metre, "Free samples per metre of beam")
      ->capture_default_str();
  cmd->add_option("--json", s.json, "Write the results as JSON to this file ('-': stdout)");
  cmd->add_option("--figures", s.figures,
                  "Folder for PNG figures (probability, variance, kernels by width) of the "
                  "first seed");
  cmd->add_option("--figure-pixels", s.figure_pixels, "Longer side of a figure, pixels")
      ->capture_default_str();
  cmd->add_flag("--cpu", s.cpu, "CPU references instead of OpenCL for the kernel maps");
  cmd->add_option("--device", s.device, "OpenCL device (substring of its name)");
}

// In the order --help lists them.
void add_common(CLI::App* cmd, Settings& s) {
  // The harness writes where the command prints, on the device it opens.
  s.out = &std::cout;
  s.err = &std::cerr;
  s.open_device = [](const std::string& device) { return make_context(device); };
  add_run_options(cmd, s);
  add_learner_options(cmd, s);
  add_pot_transfer_options(cmd, s);
  add_pot_map_options(cmd, s);
  add_data_and_output_options(cmd, s);
}

constexpr const char* kDatasetHelp =
    "Datasets: files any reader takes (CARMEN .log[.gz], ...), 3D drive folders, or "
    "sim:TOWN[+TOWN] for built-in simulated towns (town1, town2, town3; sim3d:TOWN driven with "
    "a 32-ring 3D sensor)";

std::vector<Scan> slice(const std::vector<Scan>& v, std::size_t a, std::size_t b) {
  a = std::min(a, v.size());
  b = std::min(b, v.size());
  return std::vector<Scan>(v.begin() + a, v.begin() + b);
}

// Per-time-unit: the kernel count at which a learner's time per scan matches the budget.
// At most `probes` probes, kernel counts within [16, max_count]. Every probe is a full fit of the
// real task (first seed), so the matched time is measured, not extrapolated: secant steps on log
// time against log kernels (time is about a power of the count), until within `tolerance` of the
// budget or out of probes; the probe closest to the budget wins. `measured_ms` receives its time.
std::size_t match_budget(const std::function<double(std::size_t)>& ms_per_scan, std::size_t start,
                         double budget_ms, double* measured_ms, double max_count,
                         int* probes_made = nullptr, double tolerance = 0.15, int probes = 4) {
  if (!(max_count >= 16)) throw ArgumentError("--max-kernels: at least 16");
  auto clampc = [max_count](double c) { return std::size_t(std::clamp(c, 16.0, max_count)); };
  std::vector<std::pair<std::size_t, double>> seen;
  std::size_t c = clampc(double(start));
  double slope = 1;
  for (int k = 0; k < probes; ++k) {
    const double t = ms_per_scan(c);
    std::cerr << "potmap:   calibration: " << c << " kernels " << t << " ms/scan (budget "
              << budget_ms << ")\n";
    seen.emplace_back(c, t);
    if (std::abs(t - budget_ms) <= tolerance * budget_ms) break;
    if (seen.size() >= 2) {
      const auto& [ca, ta] = seen[seen.size() - 2];
      const double sl = std::log(t / ta) / std::log(double(c) / double(ca));
      if (std::isfinite(sl)) slope = std::clamp(sl, 0.2, 2.0);
    }
    const std::size_t nc = clampc(c * std::pow(budget_ms / std::max(t, 1e-6), 1.0 / slope));
    if (nc == c) break;  // at the cap or the floor
    c = nc;
  }
  const auto best = std::min_element(seen.begin(), seen.end(), [&](auto& x, auto& y) {
    return std::abs(std::log(x.second / budget_ms)) < std::abs(std::log(y.second / budget_ms));
  });
  if (measured_ms) *measured_ms = best->second;
  if (probes_made) *probes_made = int(seen.size());
  return best->first;
}

// Adds the budget to what a method reports.
experiment::Method with_budget(experiment::Method m, double budget_ms, double calibrated_ms,
                               int probes) {
  auto fit = m.fit;
  m.fit = [fit, budget_ms, calibrated_ms, probes](Context* ctx, const experiment::MapTask& task) {
    experiment::FittedMap f = fit(ctx, task);
    f.info["budget_ms"] = budget_ms;
    f.info["calibrated_ms"] = calibrated_ms;
    f.info["calibration_probes"] = probes;
    return f;
  };
  return m;
}

// BHM with as many kernels (at a fixed width) as fit the time budget per scan.
experiment::Method matched_bhm(Harness& h, const Settings& s, const experiment::MapTask& full,
                               double budget, std::size_t max_kernels) {
  // A fixed width (the default grid's) so that more kernels cost more time.
  experiment::BhmSetup b = s.bhm;
  b.gamma = b.gamma > 0 ? b.gamma : 8.0 / (b.spacing * b.spacing);
  double vol = 1;
  for (int k = 0; k < full.dim; ++k) vol *= full.hi[k] - full.lo[k];
  const std::size_t start = std::max<std::size_t>(16, std::size_t(vol / (b.spacing * b.spacing)));
  double got = 0;
  int probes = 0;
  b.count = match_budget(
      [&](std::size_t n) {
        experiment::BhmSetup x = b;
        x.count = n;
        const auto f = experiment::bhm_method(x).fit(h.context(), full);
        return 1e3 * f.fit_seconds / double(full.train_scans.size());
      },
      start, budget, &got, double(max_kernels), &probes);
  return with_budget(experiment::bhm_method(b, "BHM (budget)"), budget, got, probes);
}

// ABHM with as many kernels as fit the time budget per scan.
experiment::Method matched_abhm(Harness& h, const Settings& s, const experiment::MapTask& full,
                                double budget, std::size_t max_kernels) {
  experiment::AbhmSetup a = s.abhm;
  double got = 0;
  int probes = 0;
  a.count = match_budget(
      [&](std::size_t n) {
        experiment::AbhmSetup x = a;
        x.count = n;
        const auto f = experiment::abhm_method(x).fit(h.context(), full);
        return 1e3 * f.fit_seconds / double(full.train_scans.size());
      },
      s.abhm.count, budget, &got, double(max_kernels), &probes);
  return with_budget(experiment::abhm_method(a, "ABHM (budget)"), budget, got, probes);
}

// The per-time runner: every method at its defaults, then BHM and ABHM with kernel counts
// matched to the budget (POT's mean time per scan unless --budget-ms).
int run_per_time(const Settings& s, const std::vector<std::string>& data, std::size_t max_kernels) {
  Harness h("per-time-unit", s);
  const auto base = h.methods();
  const std::string list = "," + s.methods + ",";
  const bool want_bhm = list.find(",bhm,") != std::string::npos;
  const bool want_abhm = list.find(",abhm,") != std::string::npos;
  const bool want_pot = list.find(",pot,") != std::string::npos;
  const bool want_transfer = want_pot || list.find(",repot,") != std::string::npos;
  if (s.budget_ms <= 0 && !want_pot)
    throw ArgumentError("per-time: --budget-ms 0 takes POT's time: add pot to --methods");
  for (const std::string& d : data) {
    const std::uint64_t seed0 = s.seeds.front();
    const auto scans0 = h.load(d, seed0);
    h.warm_up(scans0);
    // POT's source: --source, or every other target (leave one out).
    std::vector<std::string> srcs;
    if (!s.source.empty())
      srcs.push_back(s.source);
    else
      for (const std::string& o : data)
        if (o != d) srcs.push_back(o);
    if (want_transfer && srcs.empty())
      throw ArgumentError("per-time: POT needs --source when there is one target");
    std::string src_label;
    for (const std::string& o : srcs)
      src_label += (src_label.empty() ? "" : "+") + Harness::label(o);
    auto places = [&](std::uint64_t seed) {
      std::vector<std::vector<Scan>> p;
      for (const std::string& o : srcs)
        for (auto& pl : h.load_places(o, seed)) p.push_back(std::move(pl));
      return p;
    };
    // Every method at its defaults first, POT and RePOT included; POT's mean time per
    // scan over the seeds is then the budget (its time varies several-fold between
    // seeds, mostly in the high-quality transport).
    for (std::uint64_t seed : s.seeds)
      h.run_case(want_transfer ? src_label : "",
                 want_transfer ? places(seed) : std::vector<std::vector<Scan>>{}, Harness::label(d),
                 h.load(d, seed), 0, seed, base);
    std::vector<experiment::Method> methods;
    LabelOptions lo;
    lo.seed = seed0;
    lo.free_per_metre = s.free_per_metre;
    lo.holdout_fraction = s.holdout;
    LabelledPoints test;
    experiment::MapTask full = experiment::make_task(scans0, lo, test);
    full.seed = seed0;
    double budget = s.budget_ms;
    if (budget <= 0) {
      budget = h.mean_ms_per_scan(Harness::label(d), "POT");
      std::cerr << "potmap: per-time-unit " << Harness::label(d) << ": POT took " << budget
                << " ms per scan (mean over the seeds): the budget\n";
    }
    std::cerr << "potmap: per-time-unit " << Harness::label(d) << ": matching " << budget
              << " ms per scan\n";
    if (want_bhm) methods.push_back(matched_bhm(h, s, full, budget, max_kernels));
    if (want_abhm) methods.push_back(matched_abhm(h, s, full, budget, max_kernels));
    for (std::uint64_t seed : s.seeds)
      h.run_case(want_transfer ? src_label : "",
                 want_transfer ? places(seed) : std::vector<std::vector<Scan>>{}, Harness::label(d),
                 h.load(d, seed), 0, seed, methods);
  }
  h.finish("seeds");
  return 0;
}

// The intra-domain runner: per log and seed, its first scans are the source of the rest.
int run_intra(const Settings& settings, const std::vector<std::string>& data) {
  Harness h("intra-domain", settings);
  const auto methods = h.methods();
  bool warm = false;
  for (const std::string& d : data)
    for (std::uint64_t seed : settings.seeds) {
      const auto scans = h.load(d, seed);
      if (scans.size() <= settings.source_scans)
        throw InputError(d + ": " + std::to_string(scans.size()) + " scans, need more than " +
                         std::to_string(settings.source_scans));
      if (!warm) h.warm_up(scans), warm = true;
      const std::string l = Harness::label(d);
      h.run_case(l, {slice(scans, 0, settings.source_scans)}, l,
                 slice(scans, settings.source_scans, scans.size()),
                 std::int64_t(settings.source_scans), seed, methods);
    }
  h.finish("seeds");
  return 0;
}

// The inter-domain runner: every ordered pair of different datasets, per seed.
int run_inter(const Settings& settings, const std::vector<std::string>& data) {
  Harness h("inter-domain", settings);
  const auto methods = h.methods();
  bool warm = false;
  for (std::uint64_t seed : settings.seeds)
    for (const std::string& a : data)
      for (const std::string& b : data) {
        if (a == b) continue;
        const auto src = h.load_places(a, seed);
        const auto dst = h.load(b, seed);
        if (!warm) h.warm_up(dst), warm = true;
        h.run_case(Harness::label(a), src, Harness::label(b), dst, 0, seed, methods);
      }
  h.finish("seeds");
  return 0;
}

// The sim-to-real runner: the simulated towns as one source of every real log, per seed.
int run_sim2real(const Settings& settings, const std::vector<std::string>& data,
                 const std::string& towns) {
  Harness h("sim-to-real", settings);
  const auto methods = h.methods();
  bool warm = false;
  for (std::uint64_t seed : settings.seeds) {
    // 3D targets (drives) take the towns driven with the 3D sensor.
    const bool three_d =
        std::any_of(data.begin(), data.end(), [](const std::string& d) { return is_drive(d); });
    const std::string src_spec = (three_d ? "sim3d:" : "sim:") + towns;
    const auto src = h.load_places(src_spec, seed);
    for (const std::string& b : data) {
      const auto dst = h.load(b, seed);
      if (!warm) h.warm_up(dst), warm = true;
      h.run_case(src_spec, src, Harness::label(b), dst, 0, seed, methods);
    }
  }
  h.finish("seeds");
  return 0;
}

// The dynamic runner: every scan of each target mapped on its own from each source.
int run_dynamic(const Settings& settings, std::vector<std::string> data,
                const std::vector<std::string>& sources) {
  if (data.empty()) data.push_back("simdyn:town1");
  if (settings.lookahead)
    throw ArgumentError(
        "experiment dynamic: --lookahead scores a sequence's scans before they are learned; "
        "dynamic maps every scan on its own");
  Harness h("dynamic", settings);
  const auto methods = h.methods();
  bool warm = false;
  for (std::uint64_t seed : settings.seeds)
    for (const std::string& b : data) {
      const auto dst = h.load(b, seed);
      if (!warm) h.warm_up(dst), warm = true;
      for (const std::string& a : sources)
        h.run_instantaneous(Harness::label(a), h.load_places(a, seed), Harness::label(b), dst, seed,
                            methods);
    }
  h.finish("scans and seeds");
  return 0;
}

// A 3D drive among the datasets: the joint BHM, the labelling and POT's transport take the
// drive defaults (learn/drive_mapper.hpp, as `potmap mapping DRIVE` maps) wherever the command
// line leaves them; the 2D defaults cost a drive's keyframe ten times OctoMap's time for the
// same scores. POT's averaged map takes 0.5 m anchors (0.25 m, the 2D grid, is 8 times the
// cells in 3D): on riverside-a at 20 m, with 500 hits a side in the transport, POT took 79 ms
// a keyframe for AUC / NLL 0.977 / 0.132, against 439 ms for 0.978 / 0.124 with the 2D
// settings (OctoMap at 0.2 m: 224-249 ms). The anchors' clearance is half the BHM's spacing, as
// the 2D default is half the 2D spacing: on riverside-a at 40 m (keyframes 10-29), 0.5 m scored
// POT 0.963 / 0.166 against 0.955 / 0.186 at 0.25 m (gain 1).
void use_drive_defaults(const CLI::App& app, Settings& s, const std::vector<std::string>& data) {
  if (std::none_of(data.begin(), data.end(), [](const std::string& d) { return is_drive(d); }))
    return;
  const DriveMapperOptions d;
  auto unset = [&app](const char* name) { return app.count(name) == 0; };
  if (unset("--bhm-spacing")) s.bhm.spacing = d.bhm.spacing;
  if (unset("--free-per-metre")) s.free_per_metre = d.labels.free_per_metre;
  if (unset("--bhm-voxel")) s.bhm.voxel = d.voxel;
  if (unset("--bhm-tau")) s.bhm.tau = d.bhm.tau;
  if (unset("--bhm-margin")) s.bhm.solve_margin = d.bhm.solve_margin;
  if (unset("--bhm-em")) s.bhm.options.em_iterations = d.bhm.em_iterations;
  if (unset("--bhm-cg-tol")) s.bhm.cg_tolerance = d.bhm.cg_tolerance;
  if (unset("--transport-points")) s.pot.pot.transport_points = d.pot.transport_points;
  if (unset("--pot-average-spacing")) s.pot.averaged.spacing = 0.5;
  if (unset("--pot-anchor-clearance")) s.pot.pot.anchor_clearance = 0.5 * s.bhm.spacing;
}

// A runner's subcommand, with the settings and datasets its options fill and its action reads.
struct RunnerCommand {
  CLI::App* app;
  std::shared_ptr<Settings> s = std::make_shared<Settings>();
  std::shared_ptr<std::vector<std::string>> data = std::make_shared<std::vector<std::string>>();
};

RunnerCommand runner_command(CLI::App* ex, const char* name, const char* help) {
  return {ex->add_subcommand(name, help)};
}

// Adds the options every runner shares (after its own, so that --help lists those first) and
// the action to run when the subcommand is chosen.
void on_run(const RunnerCommand& c, Runner& runner, std::function<int()> action) {
  add_common(c.app, *c.s);
  c.app->callback([&runner, action, app = c.app, s = c.s, data = c.data] {
    use_drive_defaults(*app, *s, *data);
    runner.action = action;
  });
}

// `experiment intra`: the first scans of each log are the source, the rest the target.
void add_intra(CLI::App* ex, Runner& runner) {
  RunnerCommand c = runner_command(
      ex, "intra",
      "Intra-domain: the first --source-scans scans are the source, the rest the target");
  c.app->add_option("DATASETS", *c.data, kDatasetHelp)->required()->expected(1, -1);
  c.app->add_option("--source-scans", c.s->source_scans, "Scans forming the source")
      ->capture_default_str();
  on_run(c, runner, [s = c.s, data = c.data] { return run_intra(*s, *data); });
}

// `experiment inter`: every ordered pair of the datasets.
void add_inter(CLI::App* ex, Runner& runner) {
  RunnerCommand c = runner_command(
      ex, "inter", "Inter-domain: source A, target B, for every ordered pair of the datasets");
  c.app->add_option("DATASETS", *c.data, kDatasetHelp)->required()->expected(2, -1);
  on_run(c, runner, [s = c.s, data = c.data] { return run_inter(*s, *data); });
}

// `experiment sim2real`: the simulated towns as the source of real logs.
void add_sim2real(CLI::App* ex, Runner& runner) {
  RunnerCommand c = runner_command(
      ex, "sim2real",
      "Sim-to-real: source the built-in simulated towns (driven with the 3D frames' 32-ring "
      "sensor when a target is a 3D drive), target real logs");
  auto towns = std::make_shared<std::string>("town1+town2+town3");
  c.app->add_option("TARGETS", *c.data, "Real logs (any reader's format)")
      ->required()
      ->expected(1, -1);
  c.app->add_option("--towns", *towns, "Simulated source towns, joined by +")
      ->capture_default_str();
  on_run(c, runner, [s = c.s, data = c.data, towns] { return run_sim2real(*s, *data, *towns); });
}

// `experiment dynamic`: instantaneous maps of single scans (Table V).
void add_dynamic(CLI::App* ex, Runner& runner) {
  RunnerCommand c = runner_command(
      ex, "dynamic",
      "Instantaneous maps in a dynamic scene (Table V): each scan mapped on its own, mean and "
      "sd over scans (and seeds)");
  c.s->sim_scans = 50;
  auto sources = std::make_shared<std::vector<std::string>>(
      std::vector<std::string>{"sim:town1", "sim:town2", "sim:town3"});
  c.app->add_option("TARGETS", *c.data,
                    "Target scenes (default simdyn:town1, Town 1 with traffic)");
  c.app->add_option("--sources", *sources, "Source datasets, one table row each")
      ->expected(1, -1)
      ->capture_default_str();
  c.app->add_option("--moving", c.s->moving, "Moving vehicles in simdyn: scenes")
      ->capture_default_str();
  on_run(c, runner, [s = c.s, data = c.data, sources] { return run_dynamic(*s, *data, *sources); });
}

// `experiment per-time`: BHM and ABHM matched to POT's time per scan (Table VI).
void add_per_time(CLI::App* ex, Runner& runner) {
  RunnerCommand c = runner_command(
      ex, "per-time",
      "Per time unit (Table VI): BHM and ABHM with kernel counts matched to POT's time per "
      "scan, beside their defaults, POT, RePOT and OGM");
  c.app->add_option("TARGETS", *c.data, kDatasetHelp)->required()->expected(1, -1);
  c.app
      ->add_option("--budget-ms", c.s->budget_ms,
                   "Time per scan the matched BHM and ABHM may take, milliseconds (0: POT's, "
                   "measured on the first seed, as the paper)")
      ->capture_default_str();
  auto max_kernels = std::make_shared<std::size_t>(400000);
  c.app->add_option("--max-kernels", *max_kernels, "Most kernels the matched BHM and ABHM may get")
      ->capture_default_str();
  c.app->add_option("--source", c.s->source,
                    "POT's source dataset (default: the other targets, each a place of its own)");
  on_run(c, runner,
         [s = c.s, data = c.data, max_kernels] { return run_per_time(*s, *data, *max_kernels); });
}

}  // namespace

void register_experiment(CLI::App& app, Runner& runner) {
  CLI::App* ex = app.add_subcommand(
      "experiment",
      "The paper's experiments: OGM (OctoMap), BHM, ABHM, POT and RePOT scored on the same "
      "held-out beams (20 % per scan), tables of ACC, AUC, NLL and time per scan, JSON and "
      "figures");
  ex->require_subcommand(1);
  add_intra(ex, runner);
  add_inter(ex, runner);
  add_sim2real(ex, runner);
  add_dynamic(ex, runner);
  add_per_time(ex, runner);
}

}  // namespace potmap::cli
