// `potmap experiment frames`: single 3D frames (sensor at the origin, no poses), BHM on the
// frame's own training beams against POT and RePOT with atoms from other frames (simulated 3D
// towns, other real frames), all scored on the frame's held-out beams (experiment_frames.hpp).
#include <nlohmann/json.hpp>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <thread>
#include <vector>

#include "commands.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"
#include "potmap/experiments/experiment_frames.hpp"
#include "potmap/version.hpp"
#include "progress.hpp"

namespace potmap::cli {

namespace {

namespace fs = std::filesystem;
using experiment::FrameSource;

struct FramesSettings {
  std::vector<std::string> targets;
  std::vector<std::string> sources{"sim3d:town1+town2+town3"};
  std::vector<std::uint64_t> seeds{0};
  std::string methods = "bhm,pot,repot";
  std::size_t sim_scans = 20;    ///< scans of each simulated source drive
  double sim_spacing = 4;        ///< metres between them
  std::size_t target_scan = 10;  ///< sim3d targets: the scan of the drive taken as the frame
  experiment::FrameSetup setup = experiment::frame_setup_3d();
  std::string json, figures;
  std::size_t figure_pixels = 400;
  bool cpu = false;
  std::string device;
};

bool is_sim(const std::string& spec) {
  return spec.rfind("sim3d:", 0) == 0;
}

std::string label(const std::string& spec) {
  if (is_sim(spec)) return spec;
  std::string stem = fs::path(spec).filename().string();
  for (const char* ext : {".gz", ".bin"})
    if (stem.size() > std::strlen(ext) && stem.substr(stem.size() - std::strlen(ext)) == ext)
      stem.resize(stem.size() - std::strlen(ext));
  return stem;
}

std::vector<Scan> read_frames(const std::string& path) {
  Dataset ds = read_dataset(path);
  if (ds.scans.empty()) throw InputError(path + ": no scans");
  for (const Scan& s : ds.scans)
    if (s.dim != 3) throw InputError(path + ": not a 3D dataset");
  return std::move(ds.scans);
}

// sim3d:TOWN[+TOWN...]: one place per town, each a drive of sim_scans scans.
std::vector<std::vector<Scan>> sim_places(const std::string& spec, const FramesSettings& s,
                                          std::size_t scans, std::uint64_t seed) {
  std::vector<std::vector<Scan>> places;
  for (const std::string& town : split_list(spec.substr(6), '+'))
    places.push_back(
        simulate(Town::builtin(town, 0), experiment::sim_options_3d(scans, seed, s.sim_spacing))
            .scans);
  return places;
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown";
}

int run_frames(const FramesSettings& s) {
  std::unique_ptr<Context> ctx;
  if (!s.cpu) ctx = std::make_unique<Context>(make_context(s.device));
  const std::vector<std::string> methods = split_list(s.methods, ',');
  if (!s.figures.empty()) fs::create_directories(s.figures);
  auto cache = std::make_shared<experiment::AtomCache>();
  nlohmann::json runs = nlohmann::json::array();
  std::ostringstream table;
  char buf[512];
  std::snprintf(buf, sizeof buf, "%-38s %-28s %-6s %6s %6s %6s %9s %8s\n", "frame", "source",
                "method", "ACC", "AUC", "NLL", "fit s", "kernels");
  table << buf;
  bool warm = !ctx;
  for (std::uint64_t seed : s.seeds)
    for (const std::string& tspec : s.targets) {
      // The frame: a real file's first scan, or scan target_scan of a simulated 3D drive.
      Scan frame;
      if (is_sim(tspec)) {
        const auto p = sim_places(tspec, s, s.target_scan + 1, seed + 1000);
        if (p.size() != 1 || p[0].size() <= s.target_scan)
          throw ArgumentError(tspec + ": one town, at least --target-scan + 1 scans");
        frame = p[0][s.target_scan];
      } else {
        frame = read_frames(tspec).front();
      }
      std::vector<FrameSource> sources;
      for (const std::string& sspec : s.sources) {
        if (sspec == tspec) continue;  // never a frame's own atoms
        FrameSource src;
        src.label = label(sspec);
        if (is_sim(sspec)) {
          // A simulated target town is left out of its own source.
          std::vector<std::string> towns;
          for (const std::string& t : split_list(sspec.substr(6), '+'))
            if (!is_sim(tspec) || tspec.substr(6) != t) towns.push_back(t);
          if (towns.empty()) continue;
          std::string spec = "sim3d:";
          for (std::size_t i = 0; i < towns.size(); ++i) spec += (i ? "+" : "") + towns[i];
          src.label = spec;
          src.places = sim_places(spec, s, s.sim_scans, seed);
        } else {
          src.places = {read_frames(sspec)};
        }
        sources.push_back(std::move(src));
      }
      if (!warm) {
        // Build the OpenCL programs (Sinkhorn, evaluator) before anything is timed: POT with one
        // rotation and atoms of one source scan (BHM runs on the host).
        experiment::FrameSetup w = s.setup;
        w.rotations = 1;
        w.pot.atom_scans = 1;
        std::vector<FrameSource> ws;
        if (!sources.empty()) ws.push_back({"warm-up", {{sources.front().places.front().front()}}});
        experiment::evaluate_frame(ctx.get(), frame, ws, w, seed, {"pot"}, nullptr);
        warm = true;
      }
      const auto e =
          experiment::evaluate_frame(ctx.get(), frame, sources, s.setup, seed, methods, cache);
      std::cerr << "potmap: frames " << label(tspec) << " seed " << seed << ": "
                << e.task.train.size() << " training and " << e.test.size()
                << " held-out samples\n";
      for (const auto& r : e.results) {
        std::snprintf(buf, sizeof buf, "%-38s %-28s %-6s %6.3f %6.3f %6.3f %9.2f %8.0f\n",
                      label(tspec).c_str(), r.source.empty() ? "-" : r.source.c_str(),
                      r.method.c_str(), r.scores.acc, r.scores.auc, r.scores.nll, r.fit_s,
                      r.info.count("kernels") ? r.info.at("kernels") : 0.0);
        std::cerr << "potmap:   " << buf;
        table << buf;
        nlohmann::json x;
        x["frame"] = label(tspec);
        x["source"] = r.source;
        x["method"] = r.method;
        x["seed"] = seed;
        x["acc"] = r.scores.acc;
        x["auc"] = r.scores.auc;
        x["nll"] = r.scores.nll;
        x["n_test"] = r.scores.n;
        x["fit_s"] = r.fit_s;
        x["query_s"] = r.query_s;
        x["info"] = r.info;
        runs.push_back(x);
      }
      if (!s.figures.empty() && seed == s.seeds.front()) {
        // The slice at the sensor's height.
        const double z = frame.origin()[2];
        const std::string prefix = (fs::path(s.figures) / ("frames_" + label(tspec))).string();
        experiment::write_frame_figures(e, frame, z, 0.25, prefix, s.figure_pixels);
      }
    }
  std::cout << table.str() << std::flush;
  if (!s.json.empty()) {
    nlohmann::json j;
    j["experiment"] = "frames";
    j["version"] = POTMAP_VERSION_STRING;
    j["machine"] = {{"cpu", cpu_model()},
                    {"hardware_threads", std::thread::hardware_concurrency()}};
    j["device"] = ctx ? ctx->info().summary() : std::string("CPU reference (no OpenCL)");
    j["settings"] = {{"max_range", s.setup.max_range},
                     {"holdout", s.setup.labels.holdout_fraction},
                     {"free_per_metre", s.setup.labels.free_per_metre},
                     {"bhm_spacing", s.setup.bhm.spacing},
                     {"bhm_gamma", s.setup.bhm.gamma},
                     {"rotations", s.setup.rotations},
                     {"sim_scans", s.sim_scans},
                     {"atom_scans", s.setup.pot.atom_scans},
                     {"sources", s.sources}};
    j["runs"] = runs;
    if (s.json == "-")
      std::cout << j.dump(1) << "\n";
    else
      write_text_atomically(s.json, j.dump(1) + "\n");
  }
  return 0;
}

}  // namespace

void register_experiment_frames(CLI::App& app, Runner& runner) {
  CLI::App* ex = app.get_subcommand("experiment");
  CLI::App* c = ex->add_subcommand(
      "frames",
      "Single 3D frames (sensor at the origin): BHM on the frame's training beams, POT and RePOT "
      "with atoms from other frames, scored on the frame's held-out beams (20 %)");
  auto s = std::make_shared<FramesSettings>();
  c->add_option("FRAMES", s->targets,
                "Target frames: 3D files any reader takes (KITTI .bin, nuScenes .bin) or "
                "sim3d:TOWN (scan --target-scan of a simulated 3D drive)")
      ->required()
      ->expected(1, -1);
  c->add_option("--sources", s->sources,
                "Atom sources: sim3d:TOWN[+TOWN] or 3D files (a target is never its own source; "
                "a simulated target town is left out of a simulated source)")
      ->expected(1, -1)
      ->capture_default_str();
  c->add_option("--seeds", s->seeds, "Seeds of the beam split and simulated drives")
      ->expected(1, -1)
      ->capture_default_str();
  c->add_option("--methods", s->methods, "Comma-separated: bhm, pot, repot")->capture_default_str();
  c->add_option("--sim-scans", s->sim_scans, "Scans of each simulated source drive")
      ->capture_default_str();
  c->add_option("--sim-spacing", s->sim_spacing, "Metres between simulated scans")
      ->capture_default_str();
  c->add_option("--target-scan", s->target_scan, "sim3d targets: the scan taken as the frame")
      ->capture_default_str();
  c->add_option("--atom-scans", s->setup.pot.atom_scans,
                "Source scans per place cut into atoms (0: all)")
      ->capture_default_str();
  c->add_option("--max-range", s->setup.max_range, "Horizontal range cut, metres")
      ->capture_default_str();
  c->add_option("--free-per-metre", s->setup.labels.free_per_metre,
                "Free samples per metre of beam (target and atoms)")
      ->capture_default_str();
  c->add_option("--bhm-spacing", s->setup.bhm.spacing, "BHM (and RePOT's map) kernel spacing, m")
      ->capture_default_str();
  c->add_option("--bhm-gamma", s->setup.bhm.gamma, "BHM kernel width, 1/m^2 (0: from spacing)")
      ->capture_default_str();
  c->add_option("--bhm-prior-var", s->setup.bhm.prior_var, "BHM prior variance (0: default)")
      ->capture_default_str();
  c->add_option("--atom-spacing", s->setup.pot.atom_bhm.spacing, "Source map kernel spacing, m")
      ->capture_default_str();
  c->add_option("--atom-kernels-at-samples", s->setup.pot.dictionary.kernels_at_samples,
                "Atoms' kernels at their samples thinned to this cell, m (0: map kernels)")
      ->capture_default_str();
  c->add_option("--pot-wall-clearance", s->setup.pot.pot.wall_clearance,
                "Wall clearance of transported kernels, m (0: off)")
      ->capture_default_str();
  c->add_option("--repot-seed-var", s->setup.pot.seed_min_variance,
                "RePOT: least prior variance of a seeded kernel")
      ->capture_default_str();
  c->add_option("--rotations", s->setup.rotations, "Rotations per atom")->capture_default_str();
  c->add_option("--sectors", s->setup.pot.pot.sectors, "Sectors per frame")->capture_default_str();
  c->add_option("--json", s->json, "Write the runs as JSON ('-': stdout)");
  c->add_option("--figures", s->figures,
                "Folder for PNGs: the frame's hits at sensor height and each map's slice there");
  c->add_option("--figure-pixels", s->figure_pixels, "Longer side of a figure")
      ->capture_default_str();
  c->add_flag("--cpu", s->cpu, "CPU references instead of OpenCL");
  c->add_option("--device", s->device, "OpenCL device (substring of its name)");
  c->callback([&runner, s] {
    runner.action = [s] {
      // Spacing options follow the BHM's unless set apart.
      experiment::FrameSetup& f = s->setup;
      f.pot.target_bhm.spacing = f.bhm.spacing;
      f.pot.target_bhm.gamma = f.bhm.gamma;
      f.pot.target_bhm.prior_var = f.bhm.prior_var;
      f.pot.dictionary.labels.free_per_metre = f.labels.free_per_metre;
      return run_frames(*s);
    };
  });
}

}  // namespace potmap::cli
