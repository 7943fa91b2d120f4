// potmap dict build | merge | info: the dictionary of atoms (SPEC section 4, step 1).
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>

#include "commands.hpp"
#include "dataset_samples.hpp"
#include "default_dictionary.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/error.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/learn/bhm_joint.hpp"
#include "potmap/pot/atom_index.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/dictionary_io.hpp"
#include "progress.hpp"

namespace potmap::cli {

namespace {

// Scans per build_dictionary call when building: small enough for a smooth progress line.
constexpr std::size_t kChunk = 16;

struct Spread {
  std::size_t min = 0, max = 0;
  double mean = 0, median = 0;
};

Spread spread(std::vector<std::size_t> v) {
  Spread s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  s.min = v.front();
  s.max = v.back();
  double sum = 0;
  for (auto x : v) sum += double(x);
  s.mean = sum / v.size();
  s.median = v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  return s;
}

nlohmann::json summary_json(const Dictionary& d) {
  std::vector<std::size_t> kernels, hits, free;
  std::vector<std::size_t> per_sector(static_cast<std::size_t>(std::max(d.sectors, 1)), 0);
  std::map<std::string, std::size_t> sources;
  std::map<std::string, std::pair<std::int64_t, std::int64_t>> source_scans;
  std::size_t no_hits = 0, no_free = 0, total_kernels = 0;
  std::int64_t scan_lo = 0, scan_hi = 0;
  for (std::size_t i = 0; i < d.size(); ++i) {
    const Atom& a = d.atoms[i];
    kernels.push_back(a.kernels.size());
    hits.push_back(a.sector.num_hits());
    free.push_back(a.sector.num_free());
    total_kernels += a.kernels.size();
    no_hits += a.sector.num_hits() == 0;
    no_free += a.sector.num_free() == 0;
    if (a.sector.index >= 0 && a.sector.index < d.sectors) ++per_sector[a.sector.index];
    if (!sources[a.source]++) source_scans[a.source] = {a.scan_index, a.scan_index};
    auto& range = source_scans[a.source];
    range.first = std::min(range.first, a.scan_index);
    range.second = std::max(range.second, a.scan_index);
    scan_lo = i ? std::min(scan_lo, a.scan_index) : a.scan_index;
    scan_hi = i ? std::max(scan_hi, a.scan_index) : a.scan_index;
  }
  auto js = [](const Spread& s) {
    return nlohmann::json{{"min", s.min}, {"median", s.median}, {"mean", s.mean}, {"max", s.max}};
  };
  nlohmann::json src = nlohmann::json::object();
  for (const auto& [k, v] : sources)
    src[k] = {{"atoms", v},
              {"scan_index", {{"min", source_scans[k].first}, {"max", source_scans[k].second}}}};
  return {{"dim", d.dim},
          {"scale", d.scale},
          {"max_range", d.max_range},
          {"sectors", d.sectors},
          {"atoms", d.size()},
          {"kernels", total_kernels},
          {"kernels_per_atom", js(spread(kernels))},
          {"hits_per_atom", js(spread(hits))},
          {"free_per_atom", js(spread(free))},
          {"atoms_without_hits", no_hits},
          {"atoms_without_free", no_free},
          {"atoms_per_sector", per_sector},
          {"scan_index", {{"min", scan_lo}, {"max", scan_hi}}},
          {"sources", src},
          {"memory_bytes_per_atom",
           d.empty() ? 0.0 : double(dictionary_memory_bytes(d)) / double(d.size())}};
}

void print_summary(const nlohmann::json& j, std::ostream& out) {
  auto line = [&](const char* name, const nlohmann::json& s) {
    out << std::left << std::setw(18) << name << "min " << s["min"].get<std::size_t>()
        << "  median " << s["median"].get<double>() << "  mean " << std::fixed
        << std::setprecision(1) << s["mean"].get<double>() << "  max "
        << s["max"].get<std::size_t>() << "\n";
    out.unsetf(std::ios::floatfield);
    out << std::setprecision(6);
  };
  out << "dimension         " << j["dim"] << "\n"
      << "scale             " << j["scale"].get<double>() << "\n"
      << "max range (m)     " << j["max_range"].get<double>() << "\n"
      << "sectors per scan  " << j["sectors"] << "\n"
      << "atoms             " << j["atoms"] << "\n"
      << "kernels           " << j["kernels"] << "\n";
  if (j["atoms"].get<std::size_t>() == 0) return;
  line("kernels per atom", j["kernels_per_atom"]);
  line("hits per atom", j["hits_per_atom"]);
  line("free per atom", j["free_per_atom"]);
  out << "without hits      " << j["atoms_without_hits"] << " atoms\n"
      << "without free      " << j["atoms_without_free"] << " atoms\n"
      << "atoms per sector  ";
  for (const auto& n : j["atoms_per_sector"]) out << n << " ";
  out << "\nsource scans      " << j["scan_index"]["min"] << " to " << j["scan_index"]["max"]
      << "\n";
  out << "memory per atom   " << std::fixed << std::setprecision(0)
      << j["memory_bytes_per_atom"].get<double>() << " bytes\n";
  out.unsetf(std::ios::floatfield);
  out << std::setprecision(6);
  out << "coverage          " << j["sources"].size() << " sources\n";
  for (const auto& [k, v] : j["sources"].items())
    out << "source            " << (k.empty() ? "(none)" : k) << ": " << v["atoms"]
        << " atoms, scans " << v["scan_index"]["min"] << " to " << v["scan_index"]["max"] << "\n";
}

void emit_json(const nlohmann::json& j, const std::string& where) {
  if (where.empty()) return;
  if (where == "-")
    std::cout << j.dump(2) << "\n";
  else
    write_text_atomically(where, j.dump(2) + "\n");
}

struct BuildArgs {
  std::string scans, map, out, source, json;
  DictionaryOptions opt;
  std::size_t first = 0, limit = 0;
  double range_cut = 0;
  BagOptions bag;
  bool kernels_at_samples_given = false, max_weight_var_given = false;
};

// Without --map: the experiments' source map (PotSetup::atom_bhm, a joint BHM without bias) of
// the scans used, and their atom settings where the flags leave them.
KernelMap learn_source_map(const std::vector<Scan>& scans, BuildArgs& a) {
  const experiment::PotSetup setup;
  LabelledPoints unused;
  LabelOptions lo = setup.dictionary.labels;
  lo.seed = a.opt.labels.seed;
  const experiment::MapTask task = experiment::make_task(scans, lo, unused);
  std::cerr << "potmap: learning the source map (joint BHM) of " << scans.size() << " scans, "
            << task.train.size() << " samples\n";
  const KernelMap map =
      experiment::learn_bhm(nullptr, setup.atom_bhm, task.dim, task.lo, task.hi, task.train);
  if (!a.kernels_at_samples_given) a.opt.kernels_at_samples = setup.dictionary.kernels_at_samples;
  if (!a.max_weight_var_given) a.opt.max_weight_variance = 0.5 * JointBhmOptions{}.prior_var;
  return map;
}

int run_build(BuildArgs& a) {
  const auto t0 = std::chrono::steady_clock::now();
  std::ostream& human = a.json == "-" ? std::cerr : std::cout;
  Dataset ds;
  ds.scans = read_scans(a.scans, a.range_cut, a.bag);
  if (a.first >= ds.scans.size())
    throw ArgumentError("--first " + std::to_string(a.first) + ": " + a.scans + " has only " +
                        std::to_string(ds.scans.size()) + " scans");
  const std::size_t end = a.limit ? std::min(ds.scans.size(), a.first + a.limit) : ds.scans.size();
  const KernelMap map =
      a.map.empty() ? learn_source_map(
                          std::vector<Scan>(ds.scans.begin() + a.first, ds.scans.begin() + end), a)
                    : read_map(a.map);
  if (ds.scans[a.first].dim != map.dim)
    throw ArgumentError("the scans of " + a.scans + " are " +
                        std::to_string(ds.scans[a.first].dim) + "D but the map " + a.map + " is " +
                        std::to_string(map.dim) + "D");
  const std::string map_name =
      a.map.empty() ? "joint BHM" : std::filesystem::path(a.map).filename().string();
  a.opt.source = a.source.empty()
                     ? std::filesystem::path(a.scans).filename().string() + " + " + map_name
                     : a.source;
  std::cerr << "potmap: dictionary from scans " << a.first << " to " << end - 1 << " of " << a.scans
            << " and " << map.size() << " kernels of " << map_name << "\n";
  // Built in chunks for the progress line; atoms carry their scan's index in the dataset.
  auto progress = terminal_progress("dict build");
  Dictionary dict;
  for (std::size_t s = a.first; s < end; s += kChunk) {
    const std::size_t e = std::min(end, s + kChunk);
    const std::vector<Scan> chunk(std::make_move_iterator(ds.scans.begin() + s),
                                  std::make_move_iterator(ds.scans.begin() + e));
    const std::size_t before = dict.size();
    DictionaryOptions o = a.opt;
    o.labels.seed = a.opt.labels.seed + s;  // a different free-sample draw for every chunk
    build_dictionary(chunk, map, o, dict);
    for (std::size_t i = before; i < dict.size(); ++i)
      dict.atoms[i].scan_index += static_cast<std::int64_t>(s);
    if (progress) progress(double(e - a.first) / double(end - a.first));
  }
  write_dictionary(dict, a.out);
  const double secs = seconds_since(t0);
  nlohmann::json j = summary_json(dict);
  j["file"] = a.out;
  j["seconds"] = secs;
  print_summary(j, human);
  human << "wrote             " << a.out << " (" << std::fixed << std::setprecision(2) << secs
        << " s)\n";
  emit_json(j, a.json);
  return 0;
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

int run_info(const std::string& file, const std::string& json) {
  auto t0 = std::chrono::steady_clock::now();
  const Dictionary dict = read_dictionary(file);
  const double load_ms = ms_since(t0);
  t0 = std::chrono::steady_clock::now();
  const AtomIndex index(dict);
  const double index_ms = ms_since(t0);
  std::ostream& human = json == "-" ? std::cerr : std::cout;
  nlohmann::json j = summary_json(dict);
  j["file"] = file;
  j["bytes"] = std::filesystem::file_size(file);
  j["load_ms"] = load_ms;
  j["index_ms"] = index_ms;
  j["index_bytes_per_atom"] = index.bytes_per_atom();
  human << "file              " << file << " (" << j["bytes"] << " bytes, read in " << std::fixed
        << std::setprecision(1) << load_ms << " ms)\n";
  human << "index             " << index.bytes_per_atom() << " bytes per atom, built in "
        << index_ms << " ms\n";
  human.unsetf(std::ios::floatfield);
  human << std::setprecision(6);
  print_summary(j, human);
  emit_json(j, json);
  return 0;
}

int run_merge(const std::vector<std::string>& inputs, const std::string& out,
              const std::string& json) {
  const auto t0 = std::chrono::steady_clock::now();
  std::ostream& human = json == "-" ? std::cerr : std::cout;
  Dictionary merged;
  for (const std::string& in : inputs) {
    const Dictionary d = read_dictionary(in);
    try {
      merge_dictionary(d, merged);
    } catch (const ArgumentError& e) {
      throw ArgumentError(in + ": " + e.what());
    }
  }
  write_dictionary(merged, out);
  nlohmann::json j = summary_json(merged);
  j["file"] = out;
  j["inputs"] = inputs;
  j["seconds"] = ms_since(t0) / 1e3;
  print_summary(j, human);
  human << "wrote             " << out << " (" << inputs.size() << " dictionaries)\n";
  emit_json(j, json);
  return 0;
}

}  // namespace

void register_dict(CLI::App& app, Runner& runner) {
  CLI::App* dict = app.add_subcommand("dict", "Build and inspect dictionaries of atoms");
  dict->require_subcommand(1);

  CLI::App* build = dict->add_subcommand(
      "build", "Cut source scans into sectors and keep each with the map's kernels inside it");
  auto b = std::make_shared<BuildArgs>();
  build->add_option("--scans", b->scans, "Source scans: any file `potmap data info` reads")
      ->required();
  build->add_option("--map", b->map,
                    "Map learned over the same place (.csv, .npz, .potmap); default: a joint BHM "
                    "of the scans used, learned here with the experiments' settings (PotSetup: "
                    "then --kernels-at-samples 0.5 and --max-weight-var 5 unless given)");
  build
      ->add_option("--range-cut", b->range_cut,
                   "Returns farther than this (metres) become no-returns (0: none)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  add_bag_options(build, b->bag);
  build->add_option("--out", b->out, "Dictionary file to write (.potdict)")->required();
  build->add_option("--sectors", b->opt.sectors.sectors, "Sectors per scan")->capture_default_str();
  build
      ->add_option("--scale", b->opt.sectors.scale,
                   "Scale s applied to centred coordinates (authors: 1/50 at 20 m)")
      ->capture_default_str();
  build->add_option("--max-range", b->opt.sectors.max_range,
                    "Sector radius, metres (default 0: each scan's own max range)");
  build
      ->add_option("--min-samples", b->opt.sectors.min_samples,
                   "Sectors with fewer samples are dropped")
      ->capture_default_str();
  build
      ->add_option("--kernels-at-samples", b->opt.kernels_at_samples,
                   "Atoms hold kernels at their own samples thinned to cells of this edge, "
                   "metres, weighted to reproduce the map there (0: the map's own kernels; 0.5 "
                   "suits a joint-BHM map of a building)")
      ->capture_default_str();
  build
      ->add_option("--max-weight-var", b->opt.max_weight_variance,
                   "Kernels (or samples) whose weight variance is above this carry no shape and "
                   "are left out (a joint BHM's prior is 10: use 5)")
      ->capture_default_str();
  build->add_option("--min-kernels", b->opt.min_kernels, "Atoms with fewer kernels are skipped")
      ->capture_default_str();
  build->add_option("--seed", b->opt.labels.seed, "Seed of the free samples")
      ->capture_default_str();
  build->add_option("--first", b->first, "Index of the first scan used")->capture_default_str();
  build->add_option("--scans-limit", b->limit, "Use at most this many scans (default 0: all)");
  build->add_option("--source", b->source,
                    "Provenance stored on every atom (default: the two file names)");
  build->add_option("--json", b->json, "Also write the summary as JSON to this file; '-': stdout");
  build->callback([&runner, b, build] {
    b->kernels_at_samples_given = build->count("--kernels-at-samples") > 0;
    b->max_weight_var_given = build->count("--max-weight-var") > 0;
    runner.action = [b] { return run_build(*b); };
  });

  CLI::App* def = dict->add_subcommand(
      "default",
      "The built-in default dictionary (" + default_dictionary_recipe() +
          "; with --3d: " + default_dictionary_recipe(3) +
          "): built once, cached in the user's cache folder, used by `map` and `mapping` "
          "without --dict");
  auto def_out = std::make_shared<std::string>();
  auto def_json = std::make_shared<std::string>();
  auto def_3d = std::make_shared<bool>(false);
  def->add_option("--out", *def_out, "Also copy it to this file");
  def->add_option("--json", *def_json, "Also write the summary as JSON to this file; '-': stdout");
  def->add_flag("--3d", *def_3d,
                "The 3D dictionary (`potmap mapping DRIVE --method repot` uses it)");
  def->callback([&runner, def_out, def_json, def_3d] {
    runner.action = [def_out, def_json, def_3d] {
      const int dim = *def_3d ? 3 : 2;
      std::string where;
      const Dictionary d = default_dictionary(&where, dim);
      std::ostream& human = *def_json == "-" ? std::cerr : std::cout;
      human << "default           " << default_dictionary_recipe(dim) << "\n"
            << "cached in         " << (where.empty() ? "(no cache folder)" : where) << "\n";
      nlohmann::json j = summary_json(d);
      j["file"] = where;
      j["version"] = dim == 3 ? kDefaultDictionary3dVersion : kDefaultDictionaryVersion;
      print_summary(j, human);
      if (!def_out->empty()) {
        write_dictionary(d, *def_out);
        human << "wrote             " << *def_out << "\n";
      }
      emit_json(j, *def_json);
      return 0;
    };
  });

  CLI::App* merge = dict->add_subcommand(
      "merge", "Join dictionaries of several places (same dimension, scale and radius) into one");
  auto inputs = std::make_shared<std::vector<std::string>>();
  auto merged = std::make_shared<std::string>();
  auto merge_json = std::make_shared<std::string>();
  merge->add_option("DICTS", *inputs, "Dictionary files, in the order their atoms are kept")
      ->required()
      ->expected(1, -1);
  merge->add_option("--out", *merged, "Dictionary file to write (.potdict)")->required();
  merge->add_option("--json", *merge_json,
                    "Also write the summary as JSON to this file; '-': stdout");
  merge->callback([&runner, inputs, merged, merge_json] {
    runner.action = [inputs, merged, merge_json] {
      return run_merge(*inputs, *merged, *merge_json);
    };
  });

  CLI::App* info = dict->add_subcommand("info", "Summarise a dictionary file");
  auto file = std::make_shared<std::string>();
  auto json = std::make_shared<std::string>();
  info->add_option("DICT", *file, "Dictionary file")->required();
  info->add_option("--json", *json, "Also write the summary as JSON to this file; '-': stdout");
  info->callback(
      [&runner, file, json] { runner.action = [file, json] { return run_info(*file, *json); }; });
}

}  // namespace potmap::cli
