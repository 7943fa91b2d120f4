// Memory over a long drive: the overall map's kernels and bytes and the
// process's resident memory against scans mapped, for POT or RePOT over every scan of a real
// log, looped. Writes the curve as JSON (bench/memory_curve.py runs the committed rows and draws
// the PNG).
//
// The dictionary is the intra-domain one of the experiments (atoms of the log's first --first
// scans, PotSetup's defaults); the mapper is potmap::Mapper with the experiments' transfer
// settings, so what is measured is what `potmap map` keeps. Scans are cut at 20 m, as there.
//
// Usage: memory_curve --log PATH [--method pot|repot] [--loops 1] [--first 10]
//                     [--ranking indexed|exhaustive] [--every 50] [--max-scans 0]
//                     [--out memory_curve.json]
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "option_pairs.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/pot/mapper.hpp"
#include "potmap/runtime/context.hpp"

using namespace potmap;
namespace ex = potmap::experiment;
using Clock = std::chrono::steady_clock;

namespace {

struct CurveArgs {
  std::string log, method = "pot", ranking = "indexed", out = "memory_curve.json";
  std::size_t loops = 1, first = 10, every = 50, max_scans = 0;
};

bool parse_args(int argc, char** argv, CurveArgs& a) {
  if (!bench::parse_option_pairs(
          argc, argv, "memory_curve",
          {
              {"--log", [&](const std::string& v) { a.log = v; }},
              {"--method", [&](const std::string& v) { a.method = v; }},
              {"--ranking", [&](const std::string& v) { a.ranking = v; }},
              {"--out", [&](const std::string& v) { a.out = v; }},
              {"--loops", [&](const std::string& v) { a.loops = std::stoul(v); }},
              {"--first", [&](const std::string& v) { a.first = std::stoul(v); }},
              {"--every", [&](const std::string& v) { a.every = std::stoul(v); }},
              {"--max-scans", [&](const std::string& v) { a.max_scans = std::stoul(v); }},
          }))
    return false;
  if (a.log.empty() || (a.method != "pot" && a.method != "repot") ||
      (a.ranking != "indexed" && a.ranking != "exhaustive") || a.every == 0 || a.loops == 0) {
    std::fprintf(stderr,
                 "usage: memory_curve --log PATH [--method pot|repot] [--loops N] [--first N]\n"
                 "       [--ranking indexed|exhaustive] [--every N] [--max-scans N] [--out F]\n");
    return false;
  }
  return true;
}

// Resident set of this process (bytes), from /proc/self/statm's second field.
std::size_t resident_bytes() {
  std::ifstream f("/proc/self/statm");
  std::size_t total = 0, resident = 0;
  f >> total >> resident;
  return resident * static_cast<std::size_t>(::sysconf(_SC_PAGESIZE));
}

}  // namespace

int main(int argc, char** argv) {
  CurveArgs a;
  if (!parse_args(argc, argv, a)) return 2;
  try {
    std::vector<Scan> scans;
    for (const Scan& s : read_dataset(a.log).scans) scans.push_back(ex::limit_range(s, 20.0));
    if (a.max_scans && scans.size() > a.max_scans) scans.resize(a.max_scans);
    if (scans.size() <= a.first) throw Error("memory_curve: " + a.log + " has too few scans");
    Context ctx;
    ex::PotSetup setup;
    setup.dictionary.source = a.log;
    const std::vector<Scan> head(scans.begin(), scans.begin() + a.first);
    auto dict = std::make_shared<const Dictionary>(ex::build_atoms(&ctx, {head}, setup, 0));

    MapperOptions mo;
    mo.pot = setup.pot;
    mo.pot.refine = a.method == "repot";
    mo.pot.ranking = a.ranking == "indexed" ? PotRanking::indexed : PotRanking::exhaustive;
    mo.seed_min_variance = setup.seed_min_variance;
    // RePOT's seeds placed as the scans' kernels are (the curves committed in docs/).
    mo.seed_placement = mo.pot.placement;
    mo.seed_displacement_variance = mo.pot.displacement_variance;
    Mapper mapper(&ctx, dict, mo);

    nlohmann::json curve = nlohmann::json::array();
    const auto t0 = Clock::now();
    const std::size_t per_loop = scans.size() - a.first;
    const std::size_t total = per_loop * a.loops;
    std::size_t done = 0;
    for (std::size_t loop = 0; loop < a.loops; ++loop) {
      for (std::size_t i = a.first; i < scans.size(); ++i) {
        mapper.add_scan(scans[i]);
        ++done;
        if (done % a.every != 0 && done != total) continue;
        const double s = std::chrono::duration<double>(Clock::now() - t0).count();
        curve.push_back({{"scans", done},
                         {"loop", loop},
                         {"kernels", mapper.overall_kernels()},
                         {"map_bytes", mapper.overall_memory_bytes()},
                         {"rss_bytes", resident_bytes()},
                         {"seconds", s}});
        if (done % (a.every * 20) == 0 || done == total)
          std::fprintf(stderr,
                       "memory_curve: %zu/%zu scans, %zu kernels, map %.1f MB, rss %.1f MB\n", done,
                       total, mapper.overall_kernels(), mapper.overall_memory_bytes() / 1048576.0,
                       resident_bytes() / 1048576.0);
      }
    }
    nlohmann::json out = {{"log", a.log},
                          {"method", a.method},
                          {"ranking", a.ranking},
                          {"loops", a.loops},
                          {"scans_per_loop", per_loop},
                          {"atoms", dict->size()},
                          {"device", ctx.info().summary()},
                          {"curve", curve}};
    std::ofstream(a.out) << out.dump(1) << "\n";
    std::fprintf(stderr, "memory_curve: wrote %s\n", a.out.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "memory_curve: %s\n", e.what());
    return 1;
  }
  return 0;
}
