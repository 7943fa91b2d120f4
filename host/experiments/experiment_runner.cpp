#include "potmap/experiments/experiment_runner.hpp"
#include "potmap/experiments/lookahead.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>
#include <thread>

#include "experiment_breakdown.hpp"
#include "job/job_text.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"
#include "potmap/experiments/experiment_frames.hpp"
#include "potmap/job/map_pictures.hpp"
#include "potmap/map/raster.hpp"
#include "potmap/render/kernel_picture.hpp"

namespace potmap::experiment::runner {

namespace fs = std::filesystem;
using experiment::FittedMap;
using experiment::MapTask;
using experiment::Method;

namespace {

std::string slug(const std::string& s) {
  std::string o;
  for (char c : s) o += std::isalnum(static_cast<unsigned char>(c)) || c == '.' ? c : '-';
  return o;
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("model name", 0) == 0) {
      const auto p = line.find(':');
      return p == std::string::npos ? line : line.substr(p + 2);
    }
  return "unknown";
}

std::string command_line() {
  std::ifstream in("/proc/self/cmdline", std::ios::binary);
  std::string all((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::string out;
  bool first = true;
  for (const std::string& a : split_list(all, '\0')) {
    std::string arg = first ? "potmap" : a;
    first = false;
    if (!out.empty()) out += ' ';
    out += arg;
  }
  return out;
}

struct Stat {
  double mean = NAN, sd = NAN;
  std::size_t n = 0;
};

Stat stat(const std::vector<double>& v) {
  Stat s;
  double sum = 0;
  for (double x : v)
    if (std::isfinite(x)) {
      sum += x;
      ++s.n;
    }
  if (s.n == 0) return s;
  s.mean = sum / s.n;
  double ss = 0;
  for (double x : v)
    if (std::isfinite(x)) ss += (x - s.mean) * (x - s.mean);
  s.sd = s.n > 1 ? std::sqrt(ss / (s.n - 1)) : 0.0;
  return s;
}

nlohmann::json to_json(const Stat& s) {
  nlohmann::json j;
  j["mean"] = std::isfinite(s.mean) ? nlohmann::json(s.mean) : nlohmann::json();
  j["sd"] = std::isfinite(s.sd) ? nlohmann::json(s.sd) : nlohmann::json();
  j["n"] = s.n;
  return j;
}

nlohmann::json finite_or_null(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json();
}

}  // namespace

std::ostream& Harness::out() {
  return s_.out ? *s_.out : nowhere_;
}

std::ostream& Harness::err() {
  return s_.err ? *s_.err : nowhere_;
}

Harness::Harness(std::string experiment, Settings settings)
    : experiment_(std::move(experiment)), s_(std::move(settings)) {
  if (s_.seeds.empty()) throw ArgumentError("--seeds: at least one seed");
  if (!s_.figures.empty()) fs::create_directories(s_.figures);
}

Harness::~Harness() = default;

Context* Harness::context() {
  if (!ctx_made_) {
    ctx_made_ = true;
    if (!s_.cpu)
      ctx_ = std::make_unique<Context>(s_.open_device ? s_.open_device(s_.device) : [&] {
        ContextOptions o;
        o.device = s_.device;
        return Context(o);
      }());
  }
  return ctx_.get();
}

std::string Harness::label(const std::string& spec) {
  if (spec.rfind("sim", 0) == 0 && spec.find(':') != std::string::npos) return spec;
  std::string stem = fs::path(spec).filename().string();
  for (const char* ext : {".gz", ".log", ".bin", ".npz"})
    if (stem.size() > std::strlen(ext) && stem.substr(stem.size() - std::strlen(ext)) == ext)
      stem.resize(stem.size() - std::strlen(ext));
  for (const char* suf : {"-corrected"})
    if (stem.size() > std::strlen(suf) && stem.substr(stem.size() - std::strlen(suf)) == suf)
      stem.resize(stem.size() - std::strlen(suf));
  return stem;
}

std::vector<Scan> Harness::load(const std::string& spec, std::uint64_t seed) {
  std::vector<Scan> scans;
  for (auto& place : load_places(spec, seed))
    for (Scan& sc : place) scans.push_back(std::move(sc));
  return scans;
}

std::vector<std::vector<Scan>> Harness::load_places(const std::string& spec, std::uint64_t seed) {
  std::vector<std::vector<Scan>> places;
  const auto colon = spec.find(':');
  const std::string kind = colon == std::string::npos ? "" : spec.substr(0, colon);
  if (kind == "sim" || kind == "simdyn" || kind == "sim3d") {
    for (const std::string& town : split_list(spec.substr(colon + 1), '+')) {
      // sim3d: the 32-ring sensor of the 3D frames (experiment_frames.hpp), the 3D towns.
      SimOptions o = kind == "sim3d"
                         ? experiment::sim_options_3d(s_.sim_scans, seed, s_.sim_spacing)
                         : SimOptions{};
      o.scans = s_.sim_scans;
      o.spacing = s_.sim_spacing;
      o.seed = seed;
      if (kind == "simdyn") o.moving_vehicles = s_.moving;
      if (s_.scans > 0) o.scans = std::min(o.scans, s_.scans);
      Simulation sim = simulate(Town::builtin(town, 0), o);
      places.emplace_back();
      for (Scan& sc : sim.scans) places.back().push_back(experiment::limit_range(sc, s_.max_range));
    }
    return places;
  }
  auto it = files_.find(spec);
  if (it == files_.end()) {
    Dataset ds = read_dataset(spec);
    if (ds.scans.empty()) throw InputError(spec + ": no scans");
    if (s_.scans > 0 && ds.scans.size() > s_.scans) ds.scans.resize(s_.scans);
    for (Scan& sc : ds.scans) sc = experiment::limit_range(sc, s_.max_range);
    it = files_.emplace(spec, std::move(ds.scans)).first;
  }
  places.push_back(it->second);
  return places;
}

void Harness::add_wavemap(std::vector<Method>& out) const {
#ifdef POTMAP_WITH_WAVEMAP
  for (double c : s_.wavemap_cells) {
    experiment::WavemapSetup w = s_.wavemap;
    w.options.cell = c;
    out.push_back(experiment::wavemap_method(w));
  }
#else
  (void)out;
  throw ArgumentError(
      "--methods wavemap: this potmap was built without wavemap (configure with "
      "-DPOTMAP_WAVEMAP_DIR=<wavemap's install prefix>; docs/drives-3d.md)");
#endif
}

std::vector<Method> Harness::methods() const {
  std::vector<Method> out;
  for (const std::string& m : split_list(s_.methods, ',')) {
    if (m == "ogm") {
      for (double c : s_.ogm_cells) out.push_back(experiment::ogm_method(c));
    } else if (m == "bhm") {
      out.push_back(experiment::bhm_method(s_.bhm));
    } else if (m == "abhm") {
      out.push_back(experiment::abhm_method(s_.abhm));
    } else if (m == "pot" || m == "repot") {
      out.push_back(
          experiment::pot_method(pot_setup(m == "repot"), m == "pot" ? "POT" : "RePOT", atoms_));
    } else if (m == "wavemap") {
      add_wavemap(out);
    } else {
      throw ArgumentError("--methods: unknown method '" + m +
                          "' (ogm, bhm, abhm, pot, repot, wavemap)");
    }
  }
  return out;
}

experiment::PotSetup Harness::pot_setup(bool refine) const {
  experiment::PotSetup p = s_.pot;
  p.pot.refine = refine;
  // RePOT refines the BHM it is compared with: its persistent map takes the --bhm-* settings.
  p.target_bhm = s_.bhm;
  if (s_.rotations < 1) throw ArgumentError("--rotations: at least 1");
  p.pot.rotations = evenly_spaced_rotations(int(s_.rotations));
  return p;
}

std::shared_ptr<const StructureReference> Harness::make_reference(const MapTask& task,
                                                                  bool picture) const {
  if (task.dim != 2) return nullptr;  // 3D: not scored (structure_reference)
  const auto t0 = std::chrono::steady_clock::now();
  auto ref = std::make_shared<StructureReference>();
  ref->grid = experiment::structure_grid(task.lo, task.hi, s_.structure_cell,
                                         s_.structure_tolerance, s_.structure_max_cells);
  const FittedMap ogm = experiment::structure_reference(task, ref->grid);
  ref->occupied = experiment::occupied_cells(ogm, task.dim, ref->grid);
  char name[64];
  std::snprintf(name, sizeof name, "OGM %g m (reference)", ref->grid.cell_m);
  ref->name = name;
  if (picture && !s_.figures.empty())
    ref->picture = std::make_shared<experiment::Picture>(
        experiment::probability_picture(ogm, task.dim, task.lo, task.hi, picture_view(task)));
  ref->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return ref;
}

experiment::PictureView Harness::picture_view(const MapTask& task) const {
  experiment::PictureView v;
  v.max_pixels = s_.figure_pixels;
  if (task.dim == 3 && !task.train_scans.empty()) {
    // Top down, what stands from a metre below the sensor to half a metre above it (the band
    // of `potmap mapping`'s drive pictures), about the sensors' mean height.
    double z = 0;
    for (const Scan& sc : task.train_scans) z += sc.origin()[2];
    z /= double(task.train_scans.size());
    v.band_lo = z - 1.0;
    v.band_hi = z + 0.5;
  }
  return v;
}

Record Harness::fit_and_score(const Method& m, const MapTask& task, const LabelledPoints& test,
                              bool figures, const std::string& case_label,
                              const StructureReference* reference,
                              const experiment::SamplePlaces* places,
                              const std::vector<std::uint8_t>* beyond) {
  FittedMap f = m.fit(context(), task);
  Record r;
  r.method = m.name;
  r.group = m.group.empty() ? m.name : m.group;
  r.seed = task.seed;
  r.scans = task.train_scans.size();
  r.fit_s = f.fit_seconds;
  r.per_scan_ms = r.scans ? 1e3 * f.fit_seconds / double(r.scans) : NAN;
  const std::vector<double> prob = experiment::query_map(f, test, &r.query_s);
  r.scores = potmap::score(prob, test.label);
  if (places) r.breakdown = experiment::score_breakdown(prob, test, *places);
  if (task.lookahead && f.lookahead.size() == test.size()) {
    std::vector<float> all, far;
    std::vector<std::uint8_t> all_y, far_y;
    for (std::size_t i = 0; i < test.size(); ++i) {
      if (!std::isfinite(f.lookahead[i])) continue;  // the first scan's
      all.push_back(f.lookahead[i]);
      all_y.push_back(test.label[i]);
      if (beyond && (*beyond)[i]) {
        far.push_back(f.lookahead[i]);
        far_y.push_back(test.label[i]);
      }
    }
    if (!all.empty()) r.lookahead = potmap::score(all, all_y);
    if (!far.empty()) r.lookahead_beyond = potmap::score(far, far_y);
  }
  r.info = f.info;
  if (reference) {
    const auto t0 = std::chrono::steady_clock::now();
    r.structure = experiment::score_structure(f, task.dim, reference->grid, reference->occupied);
    r.structure_cell_m = reference->grid.cell_m;
    r.structure_tolerance_m = reference->grid.tolerance_m;
    r.structure_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  if (figures && !s_.figures.empty()) {
    r.picture = std::make_shared<experiment::Picture>(
        experiment::probability_picture(f, task.dim, task.lo, task.hi, picture_view(task)));
    const std::string prefix =
        (fs::path(s_.figures) / slug(experiment_ + "_" + case_label + "_" + m.name)).string();
    r.figures =
        experiment::write_figures(f, task.dim, task.lo, task.hi, prefix, s_.figure_pixels, m.name);
    if (m.uses_source && f.kernels && !f.kernels->empty() && context()) {
      // Transported kernels coloured by width over the grey map (the paper's Fig. 3 and 9),
      // in place of the plain dots.
      RasterSpec spec;
      spec.xmin = task.lo[0];
      spec.xmax = task.hi[0];
      spec.ymin = task.lo[1];
      spec.ymax = task.hi[1];
      spec.resolution =
          std::max(task.hi[0] - task.lo[0], task.hi[1] - task.lo[1]) / double(s_.figure_pixels);
      const std::string path = prefix + "_kernels.png";
      job::write_kernel_legend_picture(*context(), *f.kernels, spec, path);
      if (std::find(r.figures.begin(), r.figures.end(), path) == r.figures.end())
        r.figures.push_back(path);
    }
  }
  return r;
}

void Harness::run_case(const std::string& source_label,
                       const std::vector<std::vector<Scan>>& source,
                       const std::string& target_label, const std::vector<Scan>& target,
                       std::int64_t first_index, std::uint64_t seed,
                       const std::vector<Method>& methods) {
  LabelOptions lo;
  lo.seed = seed;
  lo.free_per_metre = s_.free_per_metre;
  lo.holdout_fraction = s_.holdout;
  LabelledPoints test;
  MapTask task = experiment::make_task(target, lo, test, 5.0, first_index);
  task.seed = seed;
  task.source = source;
  task.source_key = source_label + "\n" + std::to_string(seed);
  std::vector<std::uint8_t> beyond;
  if (s_.lookahead) {
    task.lookahead = &test;
    const double reach = s_.lookahead_reach > 0 ? s_.lookahead_reach : 2 * s_.bhm.spacing;
    beyond = experiment::beyond_reach(test, task.train, reach);
  }
  const bool figs = seed == s_.seeds.front();
  err() << "potmap: " << experiment_ << " " << (source_label.empty() ? "" : source_label + " -> ")
        << target_label << " seed " << seed << ": " << target.size() << " scans, "
        << task.train.size() << " training and " << test.size() << " held-out samples\n";
  // One structural reference per (target, seed, first scan), for every method and source.
  const std::string ref_key =
      target_label + "\n" + std::to_string(seed) + "\n" + std::to_string(first_index);
  auto ref_it = references_.find(ref_key);
  if (ref_it == references_.end() ||
      (figs && ref_it->second && !ref_it->second->picture && !s_.figures.empty())) {
    ref_it = references_.insert_or_assign(ref_key, make_reference(task, figs)).first;
    if (const auto& nr = ref_it->second) {
      std::size_t occupied = 0;
      for (std::uint8_t o : nr->occupied) occupied += o;
      err() << job::format(
          "potmap:   structure reference %s: %zu x %zu cells, %zu occupied, %.2f s\n",
          nr->name.c_str(), nr->grid.width, nr->grid.height, occupied, nr->seconds);
    }
  }
  const std::shared_ptr<const StructureReference> ref = ref_it->second;
  if (figs) compare_refs_[{source_label, target_label}] = ref;
  // 3D tasks: where each held-out sample lies, for the scores' breakdown.
  std::unique_ptr<experiment::SamplePlaces> places;
  if (task.dim == 3)
    places = std::make_unique<experiment::SamplePlaces>(
        experiment::place_test_samples(target, lo, first_index, test));
  for (const Method& m : methods) {
    const std::string key = target_label + "\n" + std::to_string(seed) + "\n" + m.name;
    Record r;
    auto hit = cache_.find(key);
    if (!m.uses_source && hit != cache_.end()) {
      r = hit->second.front();
    } else {
      r = fit_and_score(m, task, test, figs,
                        m.uses_source ? source_label + "-" + target_label : target_label, ref.get(),
                        places.get(), s_.lookahead ? &beyond : nullptr);
      if (!m.uses_source) cache_[key] = {r};
      err() << job::format(
          "potmap:   %-12s ACC %.3f AUC %.3f NLL %.3f F1 %.3f chamfer %.2f m  %.1f "
          "ms/scan\n",
          m.name.c_str(), r.scores.acc, r.scores.auc, r.scores.nll, r.structure.f1,
          r.structure.chamfer_m, r.per_scan_ms);
      if (r.lookahead.n)
        err() << job::format(
            "potmap:   %-12s look-ahead AUC %.3f NLL %.3f; beyond reach (%zu) AUC %.3f NLL "
            "%.3f\n",
            "", r.lookahead.auc, r.lookahead.nll, r.lookahead_beyond.n, r.lookahead_beyond.auc,
            r.lookahead_beyond.nll);
    }
    r.source = source_label;
    r.target = target_label;
    records_.push_back(r);
  }
}

void Harness::run_instantaneous(const std::string& source_label,
                                const std::vector<std::vector<Scan>>& source,
                                const std::string& target_label, const std::vector<Scan>& target,
                                std::uint64_t seed, const std::vector<Method>& methods) {
  LabelOptions lo;
  lo.seed = seed;
  lo.free_per_metre = s_.free_per_metre;
  lo.holdout_fraction = s_.holdout;
  err() << "potmap: " << experiment_ << " " << source_label << " -> " << target_label << " seed "
        << seed << ": " << target.size() << " instantaneous maps\n";
  std::vector<MapTask> tasks(target.size());
  std::vector<LabelledPoints> tests(target.size());
  for (std::size_t i = 0; i < target.size(); ++i) {
    tasks[i] = experiment::make_task({target[i]}, lo, tests[i], 5.0, std::int64_t(i));
    tasks[i].seed = seed;
    tasks[i].source = source;
    tasks[i].source_key = source_label + "\n" + std::to_string(seed);
  }
  // Each scan's own structural reference, made when a method first needs it and kept for this
  // call only (one per scan; cheap to make again for the next source).
  const bool figs_seed = seed == s_.seeds.front();
  std::vector<std::shared_ptr<const StructureReference>> refs(target.size());
  std::vector<bool> made(target.size(), false);
  auto reference = [&](std::size_t i) {
    if (!made[i]) {
      refs[i] = make_reference(tasks[i], figs_seed && i == target.size() / 2);
      made[i] = true;
    }
    return refs[i];
  };
  if (figs_seed && !target.empty())
    compare_refs_[{source_label, target_label}] = reference(target.size() / 2);
  for (const Method& m : methods) {
    const std::string key = "inst\n" + target_label + "\n" + std::to_string(seed) + "\n" + m.name;
    auto hit = cache_.find(key);
    std::vector<Record> recs;
    if (!m.uses_source && hit != cache_.end()) {
      recs = hit->second;
    } else {
      for (std::size_t i = 0; i < target.size(); ++i) {
        // The figure is of the middle scan of the first seed.
        const bool figs = seed == s_.seeds.front() && i == target.size() / 2;
        Record r = fit_and_score(m, tasks[i], tests[i], figs,
                                 m.uses_source ? source_label + "-" + target_label : target_label,
                                 reference(i).get());
        r.scan = long(i);
        recs.push_back(std::move(r));
      }
      if (!m.uses_source) cache_[key] = recs;
      std::vector<double> auc, f1;
      for (const Record& r : recs) {
        auc.push_back(r.scores.auc);
        f1.push_back(r.structure.f1);
      }
      err() << job::format("potmap:   %-12s mean AUC %.3f F1 %.3f over %zu scans\n", m.name.c_str(),
                           stat(auc).mean, stat(f1).mean, recs.size());
    }
    for (Record& r : recs) {
      r.source = source_label;
      r.target = target_label;
      records_.push_back(std::move(r));
    }
  }
}

double Harness::mean_ms_per_scan(const std::string& target_label, const std::string& group) const {
  std::vector<double> v;
  for (const Record& r : records_)
    if (r.target == target_label && r.group == group) v.push_back(r.per_scan_ms);
  return stat(v).mean;
}

void Harness::warm_up(const std::vector<Scan>& scans) {
  // The first OpenCL launch of a program builds it (seconds on PoCL): do that before anything
  // is timed, on one scan, and throw the result away.
  if (scans.empty() || !context()) return;
  LabelOptions lo;
  LabelledPoints test;
  MapTask task = experiment::make_task({scans.front()}, lo, test);
  experiment::AbhmSetup a = s_.abhm;
  a.steps = 3;
  a.count = std::min<std::size_t>(a.count, 64);
  for (const Method& m : {experiment::bhm_method(s_.bhm), experiment::abhm_method(a)})
    experiment::score_map(m.fit(context(), task), test);
  // POT's Sinkhorn programs: atoms from the first scans, RePOT (which runs every stage).
  const std::string list = "," + s_.methods + ",";
  if (list.find(",pot,") != std::string::npos || list.find(",repot,") != std::string::npos) {
    task.source = {
        std::vector<Scan>(scans.begin(), scans.begin() + std::min<std::size_t>(2, scans.size()))};
    experiment::PotSetup w = pot_setup(true);
    w.atom_map = "bhm";
    experiment::score_map(experiment::pot_method(w, "warm-up").fit(context(), task), test);
  }
}

namespace {

using Case = std::pair<std::string, std::string>;  // (source, target)

// One (case, group) cell of the table: the statistics of the group's chosen member.
struct Cell {
  Stat acc, auc, nll, ms, f1, precision, recall, chamfer;
  Stat ahead_auc, ahead_nll, beyond_auc, beyond_nll, beyond_n;  // look-ahead
  std::string chosen;
  bool present = false;
};

// The records summarised: cases in first-seen order, groups in method order, a cell for each
// (case, group) that has records, the JSON table rows, and the figures of members not chosen.
struct Summary {
  std::vector<Case> cases;
  std::vector<std::string> groups;
  std::map<std::pair<std::size_t, std::size_t>, Cell> cells;
  nlohmann::json table = nlohmann::json::array();
  std::set<std::string> losing_figures;
};

std::string case_label(const Case& c, const char* arrow) {
  const auto& [src, dst] = c;
  return src.empty() || src == dst ? dst : src + arrow + dst;
}

// The member of a group (in `order`) that represents it: the best by mean AUC, then NLL, as the
// paper reports the best OGM cell size.
std::string choose_member(const std::vector<std::string>& order,
                          const std::map<std::string, std::vector<const Record*>>& members) {
  std::string best;
  double best_auc = -1, best_nll = HUGE_VAL;
  for (const std::string& name : order) {
    std::vector<double> a, n;
    for (const Record* r : members.at(name)) {
      a.push_back(r->scores.auc);
      n.push_back(r->scores.nll);
    }
    const double ma = stat(a).mean, mn = stat(n).mean;
    const double key_a = std::isfinite(ma) ? ma : -1;
    if (best.empty() || key_a > best_auc || (key_a == best_auc && mn < best_nll)) {
      best = name;
      best_auc = key_a;
      best_nll = mn;
    }
  }
  return best;
}

// The statistics of one member's records; `figures` receives their figures.
Cell member_cell(const std::vector<const Record*>& records, const std::string& name,
                 std::set<std::string>& figures) {
  std::vector<double> acc, auc, nll, ms, f1, precision, recall, chamfer;
  std::vector<double> ahead_auc, ahead_nll, beyond_auc, beyond_nll, beyond_n;
  for (const Record* r : records) {
    acc.push_back(r->scores.acc);
    auc.push_back(r->scores.auc);
    nll.push_back(r->scores.nll);
    ms.push_back(r->per_scan_ms);
    f1.push_back(r->structure.f1);
    precision.push_back(r->structure.precision);
    recall.push_back(r->structure.recall);
    chamfer.push_back(r->structure.chamfer_m);
    if (r->lookahead.n) {
      ahead_auc.push_back(r->lookahead.auc);
      ahead_nll.push_back(r->lookahead.nll);
      beyond_auc.push_back(r->lookahead_beyond.auc);
      beyond_nll.push_back(r->lookahead_beyond.nll);
      beyond_n.push_back(double(r->lookahead_beyond.n));
    }
    for (const std::string& f : r->figures) figures.insert(f);
  }
  Cell c;
  c.acc = stat(acc);
  c.auc = stat(auc);
  c.nll = stat(nll);
  c.ms = stat(ms);
  c.f1 = stat(f1);
  c.precision = stat(precision);
  c.recall = stat(recall);
  c.chamfer = stat(chamfer);
  c.ahead_auc = stat(ahead_auc);
  c.ahead_nll = stat(ahead_nll);
  c.beyond_auc = stat(beyond_auc);
  c.beyond_nll = stat(beyond_nll);
  c.beyond_n = stat(beyond_n);
  c.chosen = name;
  c.present = true;
  return c;
}

nlohmann::json cell_row(const Case& c, const std::string& group, const Cell& cell,
                        const std::set<std::string>& figures) {
  nlohmann::json row;
  row["source"] = c.first;
  row["target"] = c.second;
  row["method"] = group;
  row["chosen"] = cell.chosen;
  row["acc"] = to_json(cell.acc);
  row["auc"] = to_json(cell.auc);
  row["nll"] = to_json(cell.nll);
  row["ms_per_scan"] = to_json(cell.ms);
  row["f1"] = to_json(cell.f1);
  row["precision"] = to_json(cell.precision);
  row["recall"] = to_json(cell.recall);
  row["chamfer_m"] = to_json(cell.chamfer);
  if (cell.ahead_nll.n)
    row["lookahead"] = {{"auc", to_json(cell.ahead_auc)},
                        {"nll", to_json(cell.ahead_nll)},
                        {"beyond_auc", to_json(cell.beyond_auc)},
                        {"beyond_nll", to_json(cell.beyond_nll)},
                        {"beyond_n", to_json(cell.beyond_n)}};
  row["figures"] = std::vector<std::string>(figures.begin(), figures.end());
  return row;
}

Summary summarise(const std::vector<Record>& records) {
  Summary sum;
  for (const Record& r : records) {
    const Case c = std::make_pair(r.source, r.target);
    if (std::find(sum.cases.begin(), sum.cases.end(), c) == sum.cases.end()) sum.cases.push_back(c);
    if (std::find(sum.groups.begin(), sum.groups.end(), r.group) == sum.groups.end())
      sum.groups.push_back(r.group);
  }
  for (std::size_t ci = 0; ci < sum.cases.size(); ++ci)
    for (std::size_t gi = 0; gi < sum.groups.size(); ++gi) {
      std::map<std::string, std::vector<const Record*>> members;
      std::vector<std::string> order;
      for (const Record& r : records)
        if (r.source == sum.cases[ci].first && r.target == sum.cases[ci].second &&
            r.group == sum.groups[gi]) {
          if (!members.count(r.method)) order.push_back(r.method);
          members[r.method].push_back(&r);
        }
      if (members.empty()) continue;
      const std::string best = choose_member(order, members);
      for (const std::string& name : order)
        if (name != best)
          for (const Record* r : members[name])
            for (const std::string& f : r->figures) sum.losing_figures.insert(f);
      std::set<std::string> figs_of_best;
      Cell& cell = sum.cells[{ci, gi}];
      cell = member_cell(members[best], best, figs_of_best);
      for (const std::string& f : figs_of_best) sum.losing_figures.erase(f);
      sum.table.push_back(cell_row(sum.cases[ci], sum.groups[gi], cell, figs_of_best));
    }
  return sum;
}

// One text cell of the table: metric mi of a cell, "-" where the group has none.
std::string metric_text(const Summary& sum, std::size_t ci, std::size_t gi, int mi) {
  auto it = sum.cells.find({ci, gi});
  if (it == sum.cells.end()) return "-";
  const Cell& c = it->second;
  const Stat* stats[] = {&c.acc,        &c.auc,        &c.nll,       &c.f1,
                         &c.chamfer,    &c.ms,         &c.ahead_auc, &c.ahead_nll,
                         &c.beyond_auc, &c.beyond_nll, &c.beyond_n};
  const Stat& s = *stats[mi];
  if (mi >= 6 && s.n == 0) return "-";  // no look-ahead: a method that learns at once
  char buf[256];
  if (mi == 5 || mi == 10)
    std::snprintf(buf, sizeof buf, "%.1f±%.1f", s.mean, s.sd);
  else if (mi == 4)
    std::snprintf(buf, sizeof buf, "%.2f±%.2f", s.mean, s.sd);
  else
    std::snprintf(buf, sizeof buf, "%.3f±%.3f", s.mean, s.sd);
  return buf;
}

// The paper-style table: one block per metric, methods as rows, cases as columns.
std::string table_text(const std::string& experiment, const std::string& spread, const Summary& sum,
                       const Settings& s) {
  std::ostringstream out;
  out << experiment << " (mean ± sd over " << spread << "; held-out beams only)\n";
  // F1 and chamfer: occupied cells against the OGM reference (structure_score.hpp).
  const char* metric_names[] = {"ACC",    "AUC",    "NLL",     "F1",      "chamfer m", "ms/scan",
                                "LA AUC", "LA NLL", "far AUC", "far NLL", "far n"};
  char buf[256];
  for (int mi = 0; mi < (s.lookahead ? 11 : 6); ++mi) {
    std::snprintf(buf, sizeof buf, "%-9s %-16s", metric_names[mi], "method");
    out << buf;
    for (const Case& c : sum.cases) {
      std::snprintf(buf, sizeof buf, " %20s", case_label(c, "→").c_str());
      out << buf;
    }
    out << "\n";
    for (std::size_t gi = 0; gi < sum.groups.size(); ++gi) {
      std::snprintf(buf, sizeof buf, "%-9s %-16s", "", sum.groups[gi].c_str());
      out << buf;
      for (std::size_t ci = 0; ci < sum.cases.size(); ++ci) {
        std::snprintf(buf, sizeof buf, " %20s", metric_text(sum, ci, gi, mi).c_str());
        out << buf;
      }
      out << "\n";
    }
  }
  for (std::size_t ci = 0; ci < sum.cases.size(); ++ci)
    for (std::size_t gi = 0; gi < sum.groups.size(); ++gi) {
      auto it = sum.cells.find({ci, gi});
      if (it != sum.cells.end() && it->second.chosen != sum.groups[gi])
        out << case_label(sum.cases[ci], "→") << ": " << sum.groups[gi] << " is "
            << it->second.chosen << " (best mean AUC of its group)\n";
    }
  out << "F1, chamfer m: the map's occupied cells (p > 0.501) against those of an OGM at "
      << s.structure_cell << " m of the training scans (tolerance " << s.structure_tolerance
      << " m; mean nearest-cell distance); 2D tasks only\n";
  if (s.lookahead)
    out << "LA: look-ahead, each scan's held-out samples on the map before that scan was learned "
           "(every scan but the first; OGM's unknown cells p = 0.5); far: those with no earlier "
           "training sample within "
        << (s.lookahead_reach > 0 ? s.lookahead_reach : 2 * s.bhm.spacing)
        << " m, and how many (per seed)\n";
  return out.str();
}

nlohmann::json settings_json(const Settings& s) {
  return {
      {"seeds", s.seeds},
      {"scans_cap", s.scans},
      {"source_scans", s.source_scans},
      {"sim_scans", s.sim_scans},
      {"methods", s.methods},
      {"ogm_cells", s.ogm_cells},
      {"bhm_joint", s.bhm.joint},
      {"bhm_spacing", s.bhm.spacing},
      {"bhm_gamma", s.bhm.gamma},
      {"bhm_prior_var", s.bhm.prior_var},
      {"bhm_em", s.bhm.options.em_iterations},
      {"abhm_kernels", s.abhm.count},
      {"abhm_steps", s.abhm.steps},
      {"free_per_metre", s.free_per_metre},
      {"max_range", s.max_range},
      {"pot_atom_map", s.pot.atom_map},
      {"pot_atom_scans", s.pot.atom_scans},
      {"pot_rotations", s.rotations},
      {"pot_sectors", s.pot.pot.sectors},
      {"pot_ranking", s.pot.pot.ranking == PotRanking::indexed ? "indexed" : "exhaustive"},
      {"pot_index_neighbours", s.pot.pot.index_neighbours},
      {"pot_fine_candidates", s.pot.pot.fine_candidates},
      {"pot_coarse_tolerance", s.pot.pot.coarse_tolerance},
      {"pot_free_tolerance", s.pot.pot.transport_free_tolerance},
      {"pot_transport_points", s.pot.pot.transport_points},
      {"pot_free_points", s.pot.pot.transport_free_points},
      {"pot_merge_radius", s.pot.overall.merge_radius},
      {"pot_kernels_at_samples", s.pot.dictionary.kernels_at_samples},
      {"pot_wall_clearance", s.pot.pot.wall_clearance},
      {"pot_displacement_variance", s.pot.pot.displacement_variance},
      {"pot_placement",
       s.pot.pot.placement == PotPlacement::target_samples ? "target_samples" : "barycentric"},
      {"pot_anchor_spacing", s.pot.pot.anchor_spacing},
      {"pot_anchor_clearance", s.pot.pot.anchor_clearance},
      {"pot_anchor_sweeps", s.pot.pot.anchor_sweeps},
      {"pot_logit_gain", s.pot.pot.logit_gain},
      {"pot_combine", s.pot.combine == experiment::PotSetup::Combine::average ? "average" : "sum"},
      {"pot_average_spacing", s.pot.averaged.spacing},
      {"pot_average_ridge", s.pot.averaged.ridge},
      {"pot_average_min_support", s.pot.averaged.min_support},
      {"repot_seed_placement",
       s.pot.seed_placement == PotPlacement::target_samples ? "target_samples" : "barycentric"},
      {"repot_seed_displacement_variance", s.pot.seed_displacement_variance},
      {"pot_sample_distance", s.pot.pot.max_sample_distance},
      {"repot_persistent", s.pot.persistent_refine},
      {"repot_seed_min_variance", s.pot.seed_min_variance},
      {"repot_seeds_yield", s.pot.seeds_yield},
      {"repot_seeds_yield_fully", s.pot.seeds_yield_fully},
      {"holdout", s.holdout},
      {"budget_ms", s.budget_ms},
      {"lookahead", s.lookahead},
      {"lookahead_reach", s.lookahead_reach > 0 ? s.lookahead_reach : 2 * s.bhm.spacing},
      {"structure",
       {{"reference",
         "OGM of the training scans, cells with p >= 0.5 occupied, "
         "unknown free"},
        {"cell_m", s.structure_cell},
        {"tolerance_m", s.structure_tolerance},
        {"max_cells", s.structure_max_cells}}}};
}

nlohmann::json run_json(const Record& r) {
  nlohmann::json x;
  x["source"] = r.source;
  x["target"] = r.target;
  x["method"] = r.method;
  x["group"] = r.group;
  x["seed"] = r.seed;
  if (r.scan >= 0) x["scan"] = r.scan;
  x["acc"] = finite_or_null(r.scores.acc);
  x["auc"] = finite_or_null(r.scores.auc);
  x["nll"] = finite_or_null(r.scores.nll);
  x["n_test"] = r.scores.n;
  x["scans"] = r.scans;
  x["fit_s"] = r.fit_s;
  x["ms_per_scan"] = finite_or_null(r.per_scan_ms);
  x["query_s"] = r.query_s;
  x["precision"] = finite_or_null(r.structure.precision);
  x["recall"] = finite_or_null(r.structure.recall);
  x["f1"] = finite_or_null(r.structure.f1);
  x["chamfer_m"] = finite_or_null(r.structure.chamfer_m);
  x["map_cells"] = r.structure.map_cells;
  x["reference_cells"] = r.structure.reference_cells;
  x["structure_cell_m"] = finite_or_null(r.structure_cell_m);
  x["structure_tolerance_m"] = finite_or_null(r.structure_tolerance_m);
  x["structure_s"] = r.structure_s;
  x["info"] = r.info;
  if (!r.breakdown.empty()) x["breakdown"] = breakdown_json(r.breakdown);
  if (r.lookahead.n) {
    auto scores = [](const Scores& s) {
      return nlohmann::json{{"auc", finite_or_null(s.auc)},
                            {"nll", finite_or_null(s.nll)},
                            {"acc", finite_or_null(s.acc)},
                            {"n", s.n}};
    };
    x["lookahead"] = {{"all", scores(r.lookahead)}, {"beyond_reach", scores(r.lookahead_beyond)}};
  }
  return x;
}

}  // namespace

nlohmann::json Harness::write_compare_figures(const std::vector<Case>& cases,
                                              const std::vector<std::string>& groups,
                                              const std::vector<std::string>& chosen) const {
  // Per case with figures, the reference, then each group's representative (chosen[ci *
  // groups + gi], empty where the group has no cell).
  nlohmann::json compare = nlohmann::json::array();
  for (std::size_t ci = 0; ci < cases.size() && !s_.figures.empty(); ++ci) {
    const auto ref = compare_refs_.find(cases[ci]);
    std::vector<const experiment::Picture*> panels;
    std::vector<std::string> names;
    if (ref != compare_refs_.end() && ref->second && ref->second->picture) {
      panels.push_back(ref->second->picture.get());
      names.push_back(ref->second->name);
    }
    std::size_t methods_drawn = 0;
    for (std::size_t gi = 0; gi < groups.size(); ++gi) {
      const std::string& method = chosen[ci * groups.size() + gi];
      if (method.empty()) continue;
      for (const Record& r : records_)
        if (r.source == cases[ci].first && r.target == cases[ci].second && r.method == method &&
            r.picture) {
          panels.push_back(r.picture.get());
          names.push_back(r.method);
          ++methods_drawn;
          break;
        }
    }
    if (methods_drawn == 0) continue;
    const auto& [src, dst] = cases[ci];
    const std::string path =
        (fs::path(s_.figures) /
         (slug(experiment_ + "_" + case_label(cases[ci], "-") + "_compare") + "_prob.png"))
            .string();
    experiment::write_comparison(panels, names, path);
    compare.push_back({{"source", src}, {"target", dst}, {"file", path}, {"panels", names}});
  }
  return compare;
}

void Harness::finish(const std::string& spread) {
  const Summary sum = summarise(records_);
  for (const std::string& f : sum.losing_figures) fs::remove(f);
  std::vector<std::string> chosen(sum.cases.size() * sum.groups.size());
  for (const auto& [key, cell] : sum.cells)
    chosen[key.first * sum.groups.size() + key.second] = cell.chosen;
  const nlohmann::json compare = write_compare_figures(sum.cases, sum.groups, chosen);
  const std::string text = table_text(experiment_, spread, sum, s_);
  const std::string bins = breakdown_text(records_);
  // With the JSON on stdout the tables go to stderr, so that stdout parses.
  (s_.json == "-" ? err() : out()) << text << bins << std::flush;

  if (s_.json.empty()) return;
  nlohmann::json j;
  j["experiment"] = experiment_;
  j["command"] = command_line();
  j["spread"] = spread;
  j["machine"] = {{"cpu", cpu_model()}, {"hardware_threads", std::thread::hardware_concurrency()}};
  j["device"] = ctx_ ? ctx_->info().summary() : std::string("CPU reference (no OpenCL)");
  j["settings"] = settings_json(s_);
  j["table"] = sum.table;
  j["compare_figures"] = compare;
  nlohmann::json runs = nlohmann::json::array();
  for (const Record& r : records_) runs.push_back(run_json(r));
  j["runs"] = runs;
  j["table_text"] = text;
  j["breakdown_text"] = bins;
  if (s_.json == "-")
    out() << j.dump(1) << "\n";
  else
    job::write_text_atomically(s_.json, j.dump(1) + "\n");
}

std::vector<std::string> split_list(const std::string& s, char sep) {
  std::vector<std::string> out;
  std::string item;
  for (char c : s) {
    if (c != sep) {
      item += c;
    } else if (!item.empty()) {
      out.push_back(item);
      item.clear();
    }
  }
  if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace potmap::experiment::runner
