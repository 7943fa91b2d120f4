// What an embedder's Mapper costs a scan: potmap::Mapper::add_scan, one scan at a
// time as a ROS node or SLAM front end calls it, with the merge into the overall map done before
// add_scan returns (the default) and behind it (MapperOptions::async_merge), alternated on the
// same scans in the same run. The map is read once at the end, as a planner reading it now and
// then would; both runs' overall maps are compared bit for bit. A third run, merge before
// add_scan returns, uses a context without the host helper (ContextOptions::host_helper), so
// that what the helper buys is measured beside it; its map must be the same too.
//
// The dictionary is a file (pot_scale's cached pool, e.g. town2_first10_200.potdict); the scans
// are a built-in town's (simulated as pot_scale does, 360 beams) or a log's, cut at 20 m. The
// mapper's settings are `potmap map`'s defaults (averaged overall map for POT, RePOT's
// persistent map, indexed ranking, wall clearance 0.5 m).
//
// Usage: mapper_latency --dict FILE [--target town2 | --log PATH] [--first 10] [--scans 100]
//                       [--repeat 2] [--method both|pot|repot] [--out mapper_latency.json]
#include <nlohmann/json.hpp>

#include <sys/resource.h>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "option_pairs.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/dictionary_io.hpp"
#include "potmap/pot/mapper.hpp"
#include "potmap/runtime/context.hpp"

using namespace potmap;
namespace ex = potmap::experiment;
using Clock = std::chrono::steady_clock;

namespace {

struct Args {
  std::string dict, target = "town2", log, out = "mapper_latency.json";
  std::string method = "both";
  std::size_t first = 10, scans = 100, repeat = 2;
};

bool parse_args(int argc, char** argv, Args& a) {
  if (!bench::parse_option_pairs(
          argc, argv, "mapper_latency",
          {
              {"--dict", [&](const std::string& v) { a.dict = v; }},
              {"--target", [&](const std::string& v) { a.target = v; }},
              {"--log", [&](const std::string& v) { a.log = v; }},
              {"--first", [&](const std::string& v) { a.first = std::stoul(v); }},
              {"--scans", [&](const std::string& v) { a.scans = std::stoul(v); }},
              {"--repeat", [&](const std::string& v) { a.repeat = std::stoul(v); }},
              {"--out", [&](const std::string& v) { a.out = v; }},
              {"--method", [&](const std::string& v) { a.method = v; }},
          }))
    return false;
  if (a.dict.empty() || argc % 2 == 0 || a.repeat == 0 ||
      (a.method != "both" && a.method != "pot" && a.method != "repot")) {
    std::fprintf(stderr,
                 "usage: mapper_latency --dict FILE [--target town2 | --log PATH] [--first N]\n"
                 "       [--scans N] [--repeat N] [--method both|pot|repot] [--out F]\n");
    return false;
  }
  return true;
}

std::vector<Scan> target_scans(const Args& a) {
  std::vector<Scan> all;
  if (a.log.empty()) {
    SimOptions so;
    so.scans = a.first + a.scans;
    all = simulate(Town::builtin(a.target), so).scans;
  } else {
    all = read_dataset(a.log).scans;
  }
  std::vector<Scan> out;
  for (std::size_t i = a.first; i < all.size() && out.size() < a.scans; ++i)
    out.push_back(ex::limit_range(all[i], 20.0));
  return out;
}

// CPU time of every thread of the process (the host's and PoCL's), milliseconds.
double cpu_ms() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return 1e3 * double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-3 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// to += weight * t, stage by stage (the transfer's stages; RePOT's refinement is in the merge).
void add_stages(PotTiming& to, const PotTiming& t, double weight) {
  to.prepare_ms += weight * t.prepare_ms;
  to.ranking_ms += weight * t.ranking_ms;
  to.transport_ms += weight * t.transport_ms;
  to.placement_ms += weight * t.placement_ms;
}

struct Run {
  double ms_per_scan = 0, merge_ms = 0, cpu_ms_per_scan = 0;
  PotTiming stages;  // the transfer's stages, ms a scan (sync runs)
  KernelMap map;
};

Run run(Context& ctx, const std::shared_ptr<const Dictionary>& dict, const std::vector<Scan>& scans,
        MapperOptions o, bool async) {
  o.async_merge = async;
  Mapper m(&ctx, dict, o);
  Run r;
  const auto t0 = Clock::now();
  const double c0 = cpu_ms();
  for (const Scan& s : scans) {
    m.add_scan(s);
    if (async) continue;
    const PotTiming& t = m.last().transfer.timing;
    r.merge_ms += m.last_merge().merge_ms + t.refine_ms;
    add_stages(r.stages, t, 1.0 / double(scans.size()));
  }
  r.map = m.overall_map();  // waits for the last merge
  r.cpu_ms_per_scan = (cpu_ms() - c0) / double(scans.size());
  r.ms_per_scan =
      std::chrono::duration<double, std::milli>(Clock::now() - t0).count() / double(scans.size());
  r.merge_ms /= double(scans.size());
  return r;
}

bool same(const KernelMap& a, const KernelMap& b) {
  return a.position == b.position && a.gamma == b.gamma && a.w_mean == b.w_mean &&
         a.w_var == b.w_var && a.bias_mean == b.bias_mean && a.bias_var == b.bias_var;
}

}  // namespace

int main(int argc, char** argv) {
  pin_pocl_workers();  // before anything loads PoCL (potmap/runtime/context.hpp)
  Args a;
  if (!parse_args(argc, argv, a)) return 2;
  try {
    Context ctx;
    // The same scans with the host helper off (ContextOptions::host_helper), alternated with
    // the runs above: what the helper buys one scan at a time.
    ContextOptions serial_options;
    serial_options.host_helper = false;
    Context serial(serial_options);
    auto dict = std::make_shared<const Dictionary>(read_dictionary(a.dict));
    const std::vector<Scan> scans = target_scans(a);
    nlohmann::json rows = nlohmann::json::array();
    std::printf("%-6s %6s %5s %13s %13s %14s %9s %12s %12s %9s\n", "method", "atoms", "scans",
                "sync ms/scan", "no helper", "async ms/scan", "merge ms", "transfer ms",
                "sync cpu ms", "same map");
    for (const bool refine : {false, true}) {
      if (a.method != "both" && refine != (a.method == "repot")) continue;
      MapperOptions o;
      o.pot.refine = refine;
      o.pot.ranking = PotRanking::indexed;
      o.pot.wall_clearance = 0.5;
      o.average_overall = true;
      o.pot.placement = auto_placement(o);
      o.seed_displacement_variance = 0;  // potmap map's seeds
      std::vector<double> sync_ms, async_ms, serial_ms;
      double merge_ms = 0, sync_cpu_ms = 0;
      PotTiming stages;  // sync runs, averaged over the repeats
      bool identical = true;
      for (std::size_t rep = 0; rep < a.repeat; ++rep) {
        const Run s = run(ctx, dict, scans, o, false);
        const Run as = run(ctx, dict, scans, o, true);
        const Run one = run(serial, dict, scans, o, false);
        serial_ms.push_back(one.ms_per_scan);
        sync_ms.push_back(s.ms_per_scan);
        async_ms.push_back(as.ms_per_scan);
        merge_ms += s.merge_ms / double(a.repeat);
        sync_cpu_ms += s.cpu_ms_per_scan / double(a.repeat);
        add_stages(stages, s.stages, 1.0 / double(a.repeat));
        identical = identical && same(s.map, as.map) && same(s.map, one.map);
      }
      const double sm = *std::min_element(sync_ms.begin(), sync_ms.end());
      const double am = *std::min_element(async_ms.begin(), async_ms.end());
      const double om = *std::min_element(serial_ms.begin(), serial_ms.end());
      const char* method = refine ? "RePOT" : "POT";
      // The instantaneous map's latency: the sync runs' stages before the merge.
      const double transfer_ms = stages.total_ms();
      std::printf("%-6s %6zu %5zu %13.2f %13.2f %14.2f %9.2f %12.2f %12.2f %9s\n", method,
                  dict->size(), scans.size(), sm, om, am, merge_ms, transfer_ms, sync_cpu_ms,
                  identical ? "yes" : "NO");
      std::printf(
          "       sync stages, ms a scan: prepare %.2f, ranking %.2f, transport %.2f, "
          "placement %.2f, merge %.2f\n",
          stages.prepare_ms, stages.ranking_ms, stages.transport_ms, stages.placement_ms, merge_ms);
      std::fflush(stdout);
      rows.push_back(nlohmann::json{{"method", method},
                                    {"atoms", dict->size()},
                                    {"scans", scans.size()},
                                    {"sync_ms_per_scan", sync_ms},
                                    {"async_ms_per_scan", async_ms},
                                    {"sync_no_helper_ms_per_scan", serial_ms},
                                    {"sync_no_helper_best", om},
                                    {"transfer_ms_per_scan", transfer_ms},
                                    {"sync_best", sm},
                                    {"async_best", am},
                                    {"merge_ms", merge_ms},
                                    {"sync_cpu_ms_per_scan", sync_cpu_ms},
                                    {"sync_stages_ms",
                                     {{"prepare", stages.prepare_ms},
                                      {"ranking", stages.ranking_ms},
                                      {"transport", stages.transport_ms},
                                      {"placement", stages.placement_ms},
                                      {"merge", merge_ms}}},
                                    {"same_map", identical}});
      if (!identical) {
        std::fprintf(stderr,
                     "mapper_latency: %s: the asynchronous merge or the host helper changed the "
                     "map\n",
                     method);
        return 1;
      }
    }
    nlohmann::json out = {
        {"device", ctx.info().summary()},
        {"pocl_affinity", std::getenv("POCL_AFFINITY") ? std::getenv("POCL_AFFINITY") : ""},
        {"dictionary", a.dict},
        {"target", a.log.empty() ? a.target : a.log},
        {"first", a.first},
        {"rows", rows}};
    std::ofstream(a.out) << out.dump(2) << "\n";
    std::printf("device: %s; wrote %s\n", ctx.info().summary().c_str(), a.out.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mapper_latency: %s\n", e.what());
    return 1;
  }
}
