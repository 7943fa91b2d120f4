// POT at dictionary scale: ms per scan by stage, held-out scores and the agreement of
// the chosen atoms, exhaustive against indexed ranking, against the number of atoms, beside
// BHM's time per scan on the same scans in the same run. Prints a table and writes JSON.
//
// Target: a Radish log (default intel; or a built-in town's 360-beam drive), scans [first, first +
// scans) cut at 20 m, 20 % of every scan's beams held out, mapped as `potmap experiment intra` maps
// it (PotSetup's defaults: the committed experiments' settings). Dictionaries: the first N atoms of
// a pool whose head is the atoms of the target log's first `first` scans (the intra-domain
// dictionary) and whose tail is other places, round robin: the other Radish logs and the three
// simulated towns. The pool is built once and cached as a .potdict in --cache (load time and memory
// per atom reported).
//
// The exhaustive ranking costs atoms x rotations per sector: at large N it runs on fewer scans
// (--exhaustive-scans); the indexed ranking runs on those scans too, for the same-scan
// comparison, and on every scan.
//
// Usage: pot_scale --help
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "potmap/data/scan.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/pot/atom_index.hpp"
#include "potmap/pot/dictionary_io.hpp"
#include "potmap/runtime/context.hpp"

using namespace potmap;
namespace ex = potmap::experiment;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

namespace {

double seconds_since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

std::vector<std::size_t> numbers(const std::string& s) {
  std::vector<std::size_t> v;
  std::stringstream ss(s);
  for (std::string t; std::getline(ss, t, ',');) v.push_back(std::stoul(t));
  return v;
}

bool is_town(const std::string& name) {
  return name.rfind("town", 0) == 0;
}

// Scans [first, first + count) of a Radish log (`name` under `data`) or of a drive through a
// built-in town (360-beam scans, 1 m apart, as `potmap data simulate` drives), cut at 20 m.
std::vector<Scan> read_log(const std::string& data, const std::string& name, std::size_t first,
                           std::size_t count) {
  std::vector<Scan> all;
  if (is_town(name)) {
    SimOptions so;
    so.scans = first + count;
    all = simulate(Town::builtin(name), so).scans;
  } else {
    all = read_dataset(data + "/" + name + "-corrected.log.gz").scans;
  }
  std::vector<Scan> out;
  for (std::size_t i = first; i < all.size() && out.size() < count; ++i)
    out.push_back(ex::limit_range(all[i], 20.0));
  return out;
}

// Atoms of one place: its map learned on every scan, atoms cut from `atom_scans` of them.
Dictionary place_atoms(Context* ctx, const std::vector<Scan>& scans, std::size_t atom_scans,
                       const std::string& name) {
  ex::PotSetup setup;
  setup.atom_scans = atom_scans;
  setup.dictionary.source = name;
  std::fprintf(stderr, "pool: %s, %zu scans, atoms from %zu\n", name.c_str(), scans.size(),
               atom_scans);
  return ex::build_atoms(ctx, {scans}, setup, 0);
}

// The pool: the target's first scans' atoms, then the other places round robin.
Dictionary build_pool(Context* ctx, const std::string& data, const std::string& target,
                      std::size_t first, std::size_t want) {
  Dictionary head = place_atoms(ctx, read_log(data, target, 0, first), first, target);
  std::vector<Dictionary> others;
  const std::size_t per_place = want > head.size() ? (want - head.size()) / 6 + 1 : 0;
  const std::size_t scans_each = per_place / 4 + 8;  // about 4-5 atoms a scan
  if (per_place > 0) {
    for (const char* log : {"intel", "aces", "csail", "freiburg-079"}) {
      if (log == target) continue;
      // Every few scans over the log, learned on the same scans.
      std::vector<Scan> all = read_log(data, log, 0, 100000);
      std::vector<Scan> pick;
      const std::size_t step = std::max<std::size_t>(1, all.size() / scans_each);
      for (std::size_t i = 0; i < all.size() && pick.size() < scans_each; i += step)
        pick.push_back(all[i]);
      others.push_back(place_atoms(ctx, pick, 0, log));
    }
    for (const char* town : {"town1", "town2", "town3"}) {
      if (town == target) continue;
      SimOptions so;
      so.scans = scans_each;
      so.spacing = 3;
      so.seed = 11;
      others.push_back(place_atoms(ctx, simulate(Town::builtin(town), so).scans, 0, town));
    }
  }
  Dictionary pool = head;
  std::vector<std::size_t> next(others.size(), 0);
  for (bool any = true; any && pool.size() < want;) {
    any = false;
    for (std::size_t p = 0; p < others.size() && pool.size() < want; ++p)
      if (next[p] < others[p].size()) {
        pool.atoms.push_back(others[p].atoms[next[p]++]);
        any = true;
      }
  }
  return pool;
}

struct Run {
  json row;
  std::map<std::pair<std::size_t, int>, std::pair<long, double>> chosen;  // (scan, sector)
};

// The indexed ranking's settings under test (--neighbours, --rotations-per-atom, --coarse,
// --fine; defaults: PotOptions').
PotOptions g_indexed;
// --pipeline 0: every scan prepared, solved, placed and merged before the next starts, so that
// ms a scan is the latency a mapper fed one scan at a time sees (default 1: the experiments'
// pipeline, whose ms a scan is throughput).
bool g_pipeline = true;
// --host-helper 0: the context's host helper off (ContextOptions::host_helper), every host
// stage on the scan's own thread.
bool g_host_helper = true;

Run run_method(Context& ctx, const std::shared_ptr<const Dictionary>& dict,
               const std::vector<Scan>& scans, std::size_t count, PotRanking ranking, bool refine,
               std::int64_t first_index) {
  std::vector<Scan> part(scans.begin(), scans.begin() + std::min(count, scans.size()));
  LabelOptions lo;  // 20 % of every scan's beams held out, seed 0
  LabelledPoints test;
  ex::MapTask task = ex::make_task(part, lo, test, 5.0, first_index);
  task.source = {{part.front()}};  // the dictionary comes from the cache below
  task.source_key = "pool";
  auto cache = std::make_shared<ex::AtomCache>();
  cache->dictionaries["pool"] = dict;
  cache->build_seconds["pool"] = 0;
  ex::PotSetup setup;
  setup.pot.ranking = ranking;
  setup.pot.refine = refine;
  setup.pot.index_neighbours = g_indexed.index_neighbours;
  setup.pot.index_rotations = g_indexed.index_rotations;
  setup.pot.coarse_hits = g_indexed.coarse_hits;
  setup.pot.coarse_free = g_indexed.coarse_free;
  setup.pot.coarse_tolerance = g_indexed.coarse_tolerance;
  setup.pot.transport_free_tolerance = g_indexed.transport_free_tolerance;
  setup.pot.transport_free_points = g_indexed.transport_free_points;
  setup.pot.transport_max_iterations = g_indexed.transport_max_iterations;
  setup.pot.fine_candidates = g_indexed.fine_candidates;
  setup.pot.warm_candidates = g_indexed.warm_candidates;
  setup.pot.snap_rotations = g_indexed.snap_rotations;
  setup.pot.index_anchors = g_indexed.index_anchors;
  setup.pipeline = g_pipeline;
  Run run;
  setup.on_scan = [&run](std::size_t i, const ScanTransfer& t) {
    for (const SectorTransfer& s : t.sectors) run.chosen[{i, s.sector}] = {s.atom, s.rotation};
  };
  const ex::FittedMap f = ex::pot_method(setup, refine ? "RePOT" : "POT", cache).fit(&ctx, task);
  const Scores sc = ex::score_map(f, test);
  const double n = double(task.train_scans.size());
  run.row = {{"method", refine ? "RePOT" : "POT"},
             {"ranking", ranking == PotRanking::indexed ? "indexed" : "exhaustive"},
             {"scans", task.train_scans.size()},
             {"ms_per_scan", 1e3 * f.fit_seconds / n},
             {"prepare_ms", f.info.at("prepare_ms")},
             {"ranking_ms", f.info.at("ranking_ms")},
             {"transport_ms", f.info.at("transport_ms")},
             {"placement_ms", f.info.at("placement_ms")},
             {"refine_ms", f.info.at("refine_ms")},
             {"combine_ms", f.info.at("combine_ms")},
             {"acc", sc.acc},
             {"auc", sc.auc},
             {"nll", sc.nll}};
  return run;
}

json bhm_row(Context& ctx, const std::vector<Scan>& scans, std::size_t count,
             std::int64_t first_index) {
  std::vector<Scan> part(scans.begin(), scans.begin() + std::min(count, scans.size()));
  LabelOptions lo;
  LabelledPoints test;
  const ex::MapTask task = ex::make_task(part, lo, test, 5.0, first_index);
  const ex::FittedMap f = ex::bhm_method(ex::BhmSetup{}).fit(&ctx, task);
  const Scores sc = ex::score_map(f, test);
  return {{"method", "BHM"},
          {"scans", task.train_scans.size()},
          {"ms_per_scan", 1e3 * f.fit_seconds / double(task.train_scans.size())},
          {"acc", sc.acc},
          {"auc", sc.auc},
          {"nll", sc.nll}};
}

// Fraction of the sectors both runs mapped where they chose the same atom, and the same atom
// at a rotation within 22.5 degrees.
std::pair<double, double> agreement(const Run& a, const Run& b) {
  std::size_t n = 0, same = 0, same_rot = 0;
  for (const auto& [k, va] : a.chosen) {
    auto it = b.chosen.find(k);
    if (it == b.chosen.end() || va.first < 0) continue;
    ++n;
    if (va.first != it->second.first) continue;
    ++same;
    double d = std::fmod(std::abs(va.second - it->second.second), 2 * M_PI);
    d = std::min(d, 2 * M_PI - d);
    same_rot += d <= M_PI / 8 + 1e-9;
  }
  return {n ? double(same) / n : 0, n ? double(same_rot) / n : 0};
}

}  // namespace

const char* const kUsage =
    "Usage: pot_scale [--data ../shared/data/radish] [--target intel|aces|csail|freiburg-079|\n"
    "                 town1|town2|town3] [--first 10] [--scans 100]\n"
    "                 [--atoms 6,50,200,1000,5000] [--exhaustive-scans 100,100,100,20,5 (0: "
    "none)]\n"
    "                 [--repot 1] [--cache pot_scale_cache] [--out pot_scale.json]\n"
    "                 [--pool N (atoms in the cached pool; default: the largest of --atoms)]\n"
    "                 [--neighbours N] [--rotations-per-atom N] [--coarse HITS,FREE]\n"
    "                 [--coarse-tolerance 1e-5] [--free-tolerance 1e-2] [--free-points 200] "
    "[--fine N]\n"
    "                 [--transport-max-iterations 2000]\n"
    "                 [--warm 0|1] [--snap 0|1] [--anchors 0|1] [--pipeline 0|1]\n"
    "                 [--host-helper 0|1]\n"
    "--pipeline 0: each scan finished (merge included) before the next starts: ms a scan is\n"
    "then a scan's latency, not the pipeline's throughput.\n"
    "A Radish log's scans have 180 beams; a town's (simulated, as `potmap data simulate`) 360.\n"
    "The indexed ranking's settings default to PotOptions'.\n";

struct ScaleArgs {
  std::string data = "../shared/data/radish", target = "intel", cache = "pot_scale_cache",
              out = "pot_scale.json";
  std::size_t first = 10, scans = 100;
  std::size_t pool = 0;  // atoms in the cached pool (0: the largest of --atoms)
  bool repot = true;
  std::vector<std::size_t> sizes = {6, 50, 200, 1000, 5000}, ex_scans = {100, 100, 100, 20, 5};
};

// Fills `a` and the indexed ranking's knobs; false (after naming the option) on an unknown one.
bool parse_args(int argc, char** argv, ScaleArgs& a) {
  for (int i = 1; i < argc; ++i)
    if (std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h") {
      std::printf("%s", kUsage);
      std::exit(0);
    }
  if (argc % 2 == 0) {
    std::fprintf(stderr, "pot_scale: %s has no value\n%s", argv[argc - 1], kUsage);
    return false;
  }
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    try {
      if (k == "--data")
        a.data = v;
      else if (k == "--target")
        a.target = v;
      else if (k == "--first")
        a.first = std::stoul(v);
      else if (k == "--scans")
        a.scans = std::stoul(v);
      else if (k == "--atoms")
        a.sizes = numbers(v);
      else if (k == "--pool")
        a.pool = std::stoul(v);
      else if (k == "--exhaustive-scans")
        a.ex_scans = numbers(v);
      else if (k == "--repot")
        a.repot = v != "0";
      else if (k == "--cache")
        a.cache = v;
      else if (k == "--neighbours")
        g_indexed.index_neighbours = std::stoul(v);
      else if (k == "--rotations-per-atom")
        g_indexed.index_rotations = std::stoi(v);
      else if (k == "--coarse") {
        const auto c = numbers(v);
        g_indexed.coarse_hits = c.at(0);
        g_indexed.coarse_free = c.at(1);
      } else if (k == "--coarse-tolerance")
        g_indexed.coarse_tolerance = std::stod(v);
      else if (k == "--free-tolerance")
        g_indexed.transport_free_tolerance = std::stod(v);
      else if (k == "--free-points")
        g_indexed.transport_free_points = std::stoul(v);
      else if (k == "--fine")
        g_indexed.fine_candidates = std::stoul(v);
      else if (k == "--transport-max-iterations")
        g_indexed.transport_max_iterations = std::stoi(v);
      else if (k == "--pipeline")
        g_pipeline = v != "0";
      else if (k == "--host-helper")
        g_host_helper = v != "0";
      else if (k == "--warm")
        g_indexed.warm_candidates = v != "0";
      else if (k == "--snap")
        g_indexed.snap_rotations = v != "0";
      else if (k == "--out")
        a.out = v;
      else {
        std::fprintf(stderr, "pot_scale: unknown option %s\n%s", k.c_str(), kUsage);
        return false;
      }
    } catch (const std::logic_error&) {  // std::stoul and friends, numbers()' .at()
      std::fprintf(stderr, "pot_scale: %s: not a valid value: '%s'\n", k.c_str(), v.c_str());
      return false;
    }
  }
  return true;
}

int run(int argc, char** argv) {
  ScaleArgs args;
  if (!parse_args(argc, argv, args)) return 2;
  const std::string &data = args.data, &target = args.target, &cache = args.cache, &out = args.out;
  const std::size_t first = args.first, scans = args.scans;
  const bool repot = args.repot;
  const std::vector<std::size_t>&sizes = args.sizes, &ex_scans = args.ex_scans;
  ContextOptions co;
  co.host_helper = g_host_helper;
  Context ctx(co);
  const std::size_t want = std::max(args.pool, *std::max_element(sizes.begin(), sizes.end()));
  std::filesystem::create_directories(cache);
  const std::string pool_file = cache + "/" + target + "_first" + std::to_string(first) + "_" +
                                std::to_string(want) + ".potdict";
  double build_s = 0;
  if (!std::filesystem::exists(pool_file)) {
    const auto t0 = Clock::now();
    write_dictionary(build_pool(&ctx, data, target, first, want), pool_file);
    build_s = seconds_since(t0);
  }
  auto t0 = Clock::now();
  const Dictionary pool = read_dictionary(pool_file);
  const double load_ms = 1e3 * seconds_since(t0);
  t0 = Clock::now();
  const AtomIndex pool_index(pool);
  const double index_ms = 1e3 * seconds_since(t0);
  std::map<std::string, std::size_t> sources;
  for (const Atom& a : pool.atoms) ++sources[a.source];
  json dj = {{"file", pool_file},
             {"atoms", pool.size()},
             {"file_bytes", std::filesystem::file_size(pool_file)},
             {"bytes_per_atom", double(dictionary_memory_bytes(pool)) / double(pool.size())},
             {"index_bytes_per_atom", pool_index.bytes_per_atom()},
             {"load_ms", load_ms},
             {"index_build_ms", index_ms},
             {"build_s", build_s},
             {"sources", sources}};
  std::fprintf(stderr, "pool: %zu atoms, %.0f bytes an atom (+%zu index), loaded in %.0f ms\n",
               pool.size(), dj["bytes_per_atom"].get<double>(), pool_index.bytes_per_atom(),
               load_ms);

  const std::vector<Scan> targets = read_log(data, target, first, scans);
  const std::int64_t first_index = static_cast<std::int64_t>(first);
  json rows = json::array();
  std::printf("%-6s %-6s %-10s %5s %8s %8s %9s %9s %9s %8s %6s %6s %6s %7s %7s\n", "atoms",
              "method", "ranking", "scans", "ms/scan", "ranking", "transport", "placement",
              "prepare", "xBHM", "AUC", "NLL", "ACC", "agree", "agreeR");
  for (std::size_t si = 0; si < sizes.size(); ++si) {
    const std::size_t n = std::min(sizes[si], pool.size());
    auto dict = std::make_shared<Dictionary>(pool);
    dict->atoms.resize(n);
    const std::size_t es = si < ex_scans.size() ? ex_scans[si] : ex_scans.back();
    // BHM on the same scans in the same run, for the ratio.
    const json bhm_all = bhm_row(ctx, targets, scans, first_index);
    // es 0: no comparison with the exhaustive ranking, the indexed one over every scan only.
    const json bhm_es = es > 0 && es < scans ? bhm_row(ctx, targets, es, first_index) : bhm_all;
    auto emit = [&](json row, const json& bhm, double agree, double agree_rot) {
      row["atoms"] = n;
      row["bhm_ms_per_scan"] = bhm["ms_per_scan"];
      row["bhm_auc"] = bhm["auc"];
      row["bhm_nll"] = bhm["nll"];
      row["over_bhm"] = row["ms_per_scan"].get<double>() / bhm["ms_per_scan"].get<double>();
      row["agreement"] = agree;
      row["agreement_rotation"] = agree_rot;
      std::printf(
          "%-6zu %-6s %-10s %5zu %8.1f %8.1f %9.1f %9.1f %9.1f %8.2f %6.3f %6.3f %6.3f %7.3f "
          "%7.3f\n",
          n, row["method"].get<std::string>().c_str(), row["ranking"].get<std::string>().c_str(),
          row["scans"].get<std::size_t>(), row["ms_per_scan"].get<double>(),
          row["ranking_ms"].get<double>(), row["transport_ms"].get<double>(),
          row["placement_ms"].get<double>(), row["prepare_ms"].get<double>(),
          row["over_bhm"].get<double>(), row["auc"].get<double>(), row["nll"].get<double>(),
          row["acc"].get<double>(), agree, agree_rot);
      std::fflush(stdout);
      rows.push_back(row);
    };
    for (bool refine : {false, true}) {
      if (refine && !repot) continue;
      // RePOT's exhaustive run only where it is affordable: the refinement does not depend on
      // the dictionary's size, its ranking is POT's.
      const bool exhaustive = es > 0 && (!refine || es >= scans);
      Run exr;
      if (exhaustive) {
        exr = run_method(ctx, dict, targets, es, PotRanking::exhaustive, refine, first_index);
        emit(exr.row, bhm_es, 1.0, 1.0);
      }
      if (es > 0) {
        Run same = run_method(ctx, dict, targets, es, PotRanking::indexed, refine, first_index);
        const auto ag = exhaustive ? agreement(exr, same) : std::pair<double, double>{-1, -1};
        emit(same.row, bhm_es, ag.first, ag.second);
      }
      if (es < scans) {
        Run all = run_method(ctx, dict, targets, scans, PotRanking::indexed, refine, first_index);
        emit(all.row, bhm_all, -1, -1);
      }
    }
    std::fprintf(stderr, "%zu atoms done\n", n);
  }
  json j = {{"device", ctx.info().summary()},
            {"pocl_affinity", std::getenv("POCL_AFFINITY") ? std::getenv("POCL_AFFINITY") : ""},
            {"indexed",
             {{"index_neighbours", g_indexed.index_neighbours},
              {"index_rotations", g_indexed.index_rotations},
              {"coarse_hits", g_indexed.coarse_hits},
              {"coarse_free", g_indexed.coarse_free},
              {"coarse_tolerance", g_indexed.coarse_tolerance},
              {"free_tolerance", g_indexed.transport_free_tolerance},
              {"free_points", g_indexed.transport_free_points},
              {"fine_candidates", g_indexed.fine_candidates},
              {"warm_candidates", g_indexed.warm_candidates},
              {"snap_rotations", g_indexed.snap_rotations},
              {"transport_max_iterations", g_indexed.transport_max_iterations},
              {"index_anchors", g_indexed.index_anchors}}},
            {"pipeline", g_pipeline},
            {"host_helper", g_host_helper},
            {"target", target},
            {"first", first},
            {"dictionary", dj},
            {"rows", rows}};
  std::ofstream(out) << j.dump(2) << "\n";
  std::printf("device: %s; wrote %s\n", ctx.info().summary().c_str(), out.c_str());
  return 0;
}

int main(int argc, char** argv) {
  pin_pocl_workers();  // before anything loads PoCL (potmap/runtime/context.hpp)
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    // Bad numbers in the options, unreadable logs, a full disk: said, not an abort.
    std::fprintf(stderr, "pot_scale: %s\n", e.what());
    return 1;
  }
}
