#include "demo_pot.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/experiments/figure_panels.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/job/map_job.hpp"
#include "potmap/job/map_pictures.hpp"
#include "potmap/learn/bhm.hpp"
#include "potmap/pot/atoms.hpp"
#include "progress.hpp"
#include "town_picture.hpp"

namespace fs = std::filesystem;

namespace potmap::cli {

using job::MapJob;
using job::MapJobResult;
using job::MapPictures;

namespace {

// The source town's map: BHM over the source scans' samples, kernels every metre (the
// dictionary needs a learned map of the place its atoms come from).
KernelMap learn_source_map(Context& ctx, const std::vector<Scan>& scans) {
  LabelOptions lo;
  lo.holdout_fraction = 0;
  const LabelledSplit s = label_scans(scans, lo);
  double lo3[3] = {HUGE_VAL, HUGE_VAL, 0}, hi3[3] = {-HUGE_VAL, -HUGE_VAL, 0};
  for (std::size_t i = 0; i < s.train.size(); ++i)
    for (int d = 0; d < 2; ++d) {
      lo3[d] = std::min(lo3[d], s.train.position[2 * i + d]);
      hi3[d] = std::max(hi3[d], s.train.position[2 * i + d]);
    }
  KernelMap map = bhm_grid_prior(2, lo3, hi3, 1.0, 4.0);
  bhm_update_sequential(&ctx, map, s.train);
  return map;
}

// A method's finished map, for the comparison figure.
struct DemoMap {
  std::string name;
  KernelMap map;
};

// The device builds its programs at their first launch (a few hundred milliseconds on PoCL):
// the first two scans mapped once and thrown away, so that no scan's time counts it.
void build_programs(Context& ctx, const Dictionary& dict, const std::vector<Scan>& scans,
                    const MapJob& job, std::FILE* human) {
  const auto tb = std::chrono::steady_clock::now();
  const std::vector<Scan> first(scans.begin(),
                                scans.begin() + std::min<std::size_t>(2, scans.size()));
  potmap::job::run_map_job(&ctx, dict, first, job);
  std::fprintf(human, "device         %s; kernels built in %.1f s (counted in no scan)\n",
               ctx.info().summary().c_str(), seconds_since(tb));
}

// The true town beside each estimate's probability, one window and scale: the last map's
// kernels and 5 m around them, within the town; each panel titled, one legend below.
void write_compare(Context& ctx, const Town& town, const std::string& name,
                   const std::vector<double>& route, const std::vector<DemoMap>& maps,
                   const std::string& path) {
  double lo[3], hi[3];
  maps.back().map.bounds(lo, hi);
  lo[0] = std::max(0.0, lo[0] - 5), lo[1] = std::max(0.0, lo[1] - 5), lo[2] = 0;
  hi[0] = std::min(town.width(), hi[0] + 5), hi[1] = std::min(town.height(), hi[1] + 5), hi[2] = 0;
  std::vector<experiment::Picture> panels = {town_picture(town, route, lo, hi, 1200)};
  std::vector<std::string> titles = {"TRUE TOWN " + name};
  for (const DemoMap& m : maps) {
    const auto fitted =
        experiment::kernel_fitted_map(&ctx, std::make_shared<const KernelMap>(m.map));
    panels.push_back(experiment::probability_picture(fitted, 2, lo, hi, 1200));
    titles.push_back(m.name + ": P(OCCUPIED)");
  }
  panels.front().metres_per_pixel = panels.back().metres_per_pixel;
  std::vector<const experiment::Picture*> ptrs;
  for (const auto& pic : panels) ptrs.push_back(&pic);
  experiment::write_comparison(ptrs, titles, path, town_swatches());
}

}  // namespace

int run_pot_demo(const PotDemoArgs& a, const std::string& device) {
  if (a.method != "pot" && a.method != "repot" && a.method != "both")
    throw ArgumentError("demo: --method must be pot, repot or both, not '" + a.method + "'");
  Context ctx = make_context(device);
  std::FILE* human = a.json == "-" ? stderr : stdout;
  const std::string prefix = a.out.empty() ? "out/demo/pot" : a.out;
  const fs::path parent = fs::path(prefix).parent_path();
  fs::create_directories(parent.empty() ? fs::path(".") : parent);

  auto t0 = std::chrono::steady_clock::now();
  SimOptions so;
  so.scans = a.source_scans;
  so.spacing = 3;
  so.seed = 1;
  const Town src = Town::builtin(a.source);
  const Simulation source = simulate(src, so);
  const KernelMap source_map = learn_source_map(ctx, source.scans);
  Dictionary dict;
  DictionaryOptions dopt;
  dopt.source = a.source;
  build_dictionary(source.scans, source_map, dopt, dict);
  if (dict.empty()) throw Error("demo: the source scans gave no atoms");
  std::fprintf(human,
               "dictionary     %zu atoms from %zu scans of %s (BHM source map, %zu kernels; "
               "%.1f s)\n",
               dict.size(), source.scans.size(), a.source.c_str(), source_map.size(),
               seconds_since(t0));

  SimOptions to;
  to.scans = a.target_scans;
  to.spacing = a.spacing;
  to.seed = 7;
  const Town tgt = Town::builtin(a.target);
  const Simulation target = simulate(tgt, to);
  write_true_town(tgt, a.target, target.route, prefix + "_town.png");
  std::fprintf(human, "target         %zu scans of %s, 20 %% of every scan's beams held out\n",
               target.scans.size(), a.target.c_str());

  nlohmann::json j = {{"source", a.source},
                      {"target", a.target},
                      {"atoms", dict.size()},
                      {"source_scans", source.scans.size()},
                      {"target_scans", target.scans.size()},
                      {"device", ctx.info().summary()}};
  std::vector<std::string> files = {prefix + "_town.png"};
  auto make_job = [&a](bool refine) {
    MapJob job;
    // `potmap map`'s defaults (the library's, the settings that map the real logs, with
    // potmap map's seeds: no displacement variance), or the authors' rules.
    job.mapper = a.map_defaults ? MapperOptions{} : MapperOptions::paper();
    if (a.map_defaults) job.mapper.seed_displacement_variance = 0;
    job.mapper.pot.refine = refine;
    job.mapper.pot.rotations = evenly_spaced_rotations(a.rotations);
    print_scans(job, false, "potmap demo");
    return job;
  };
  build_programs(ctx, dict, target.scans, make_job(a.method != "pot"), human);
  std::vector<DemoMap> maps;
  for (const bool refine : {false, true}) {
    if ((refine && a.method == "pot") || (!refine && a.method == "repot")) continue;
    const std::string name = refine ? "RePOT" : "POT";
    const MapJobResult r = potmap::job::run_map_job(&ctx, dict, target.scans, make_job(refine));
    std::fprintf(human,
                 "%-6s overall  ACC %.4f  AUC %.4f  NLL %.4f   instantaneous  ACC %.4f  AUC %.4f  "
                 "NLL %.4f\n",
                 name.c_str(), r.overall_scores.acc, r.overall_scores.auc, r.overall_scores.nll,
                 r.instantaneous.acc, r.instantaneous.auc, r.instantaneous.nll);
    std::fprintf(human,
                 "       %zu kernels; %.1f ms per scan (ranking %.1f, transport %.1f, placement "
                 "%.1f, refine %.1f)\n",
                 r.overall_kernels(), r.mean_wall_ms, r.mean_timing.ranking_ms,
                 r.mean_timing.transport_ms, r.mean_timing.placement_ms, r.mean_timing.refine_ms);
    j[refine ? "repot" : "pot"] = nlohmann::json::parse(r.to_json());

    maps.push_back({name, r.overall_map()});
    // Pictures of the last method run (RePOT when both): probability, variance, kernels.
    if (refine || a.method == "pot") {
      const std::string p = prefix + (refine ? "_repot" : "_pot");
      write_map(r.overall_map(), p + ".potmap");
      // Readable whatever the town's size: 1200 pixels along the long side unless --res.
      const double res =
          a.res > 0 ? a.res : potmap::job::picture_resolution(r.overall_map(), 5, 1200);
      const MapPictures mp = potmap::job::write_map_pictures(ctx, r.overall_map(), p, res);
      files.insert(files.end(), mp.files.begin(), mp.files.end());
      files.push_back(p + ".potmap");
      j["picture_pixels"] = {mp.width, mp.height};
      write_compare(ctx, tgt, a.target, target.route, maps, p + "_compare.png");
      files.push_back(p + "_compare.png");
      j["kernel_length_m"] = {mp.min_length, mp.max_length};
    }
  }
  std::fprintf(human, "files:\n");
  for (const auto& f : files) std::fprintf(human, "               %s\n", f.c_str());
  j["files"] = files;
  j["seconds"] = seconds_since(t0);
  if (a.json == "-")
    std::cout << j.dump(1) << "\n";
  else if (!a.json.empty())
    write_text_atomically(a.json, j.dump(1) + "\n");
  return 0;
}

}  // namespace potmap::cli
