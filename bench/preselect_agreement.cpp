// How often descriptor pre-selection (atom_descriptor.hpp) keeps the atom the full Sinkhorn
// ranking chooses, and the ranking time it saves: a dictionary from one simulated town, target
// scans from another. Prints a table and writes JSON.
//
// Pre-selection is emulated: for every target sector the dictionary is cut down to its k
// pre-selected atoms and the scan transferred with that; the sector's chosen atom is compared
// with the one chosen from the whole dictionary. Subsampling is switched off (rank caps above
// the sector sizes, few free samples per metre) so that both runs rank the same points: the
// only difference is the candidate set, as in transfer_scan with PotOptions::candidates.
//
// Usage: preselect_agreement [--source-scans 80] [--targets 8] [--k 8,32,128]
//                            [--out preselect_agreement.json]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "potmap/data/labelling.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/learn/bhm.hpp"
#include "potmap/pot/atom_descriptor.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/transfer.hpp"
#include "potmap/runtime/context.hpp"

using namespace potmap;
using Clock = std::chrono::steady_clock;

static double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

int main(int argc, char** argv) {
  std::size_t source_scans = 80, targets = 8;
  std::vector<std::size_t> ks = {8, 32, 128};
  std::string out = "preselect_agreement.json";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--source-scans")
      source_scans = std::stoul(v);
    else if (k == "--targets")
      targets = std::stoul(v);
    else if (k == "--out")
      out = v;
    else if (k == "--k") {
      ks.clear();
      std::stringstream ss(v);
      for (std::string t; std::getline(ss, t, ',');) ks.push_back(std::stoul(t));
    } else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      return 2;
    }
  }
  Context ctx;
  LabelOptions lo;
  lo.free_per_metre = 0.05;  // about 50 free samples a sector: no subsampling below
  lo.holdout_fraction = 0;

  // Source: town1, a BHM map over its drive, atoms from every scan.
  SimOptions so;
  so.scans = source_scans;
  so.spacing = 3.0;
  so.seed = 1;
  const Simulation src = simulate(Town::builtin("town1", 1), so);
  LabelOptions learn_lo;
  learn_lo.holdout_fraction = 0;
  const LabelledPoints train = label_scans(src.scans, learn_lo).train;
  double blo[3], bhi[3];
  train.bounds(blo, bhi);
  KernelMap map = bhm_grid_prior(2, blo, bhi, 1.0, 8.0);
  bhm_update(ctx, map, train);
  DictionaryOptions dopt;
  dopt.labels = lo;
  Dictionary dict;
  build_dictionary(src.scans, map, dopt, dict);
  std::fprintf(stderr, "dictionary: %zu atoms from %zu town1 scans (map %zu kernels)\n",
               dict.size(), src.scans.size(), map.size());

  // Targets: town2.
  SimOptions to;
  to.scans = targets;
  to.spacing = 7.0;
  to.seed = 2;
  const Simulation tgt = simulate(Town::builtin("town2", 2), to);
  PotOptions po;
  po.rank_hits = 100000;
  po.rank_free = 100000;
  const AtomPreselector pre(dict);

  std::vector<std::size_t> agree(ks.size(), 0), top_contains(ks.size(), 0);
  std::vector<double> ms_pre(ks.size(), 0), ms_rank_sub(ks.size(), 0);
  double ms_full = 0;
  std::size_t sectors_total = 0;
  for (std::size_t t = 0; t < tgt.scans.size(); ++t) {
    LabelledSplit split;
    label_scan(tgt.scans[t], static_cast<std::int64_t>(t), lo, split);
    const auto sensor = tgt.scans[t].origin();
    const double heading = scan_heading(tgt.scans[t]);
    const ScanTransfer full = transfer_scan(&ctx, dict, split.train, sensor, heading, t, po);
    ms_full += full.timing.ranking_ms + full.timing.prepare_ms;
    SectorOptions sopt;
    sopt.sectors = po.sectors;
    sopt.max_range = dict.max_range;
    sopt.scale = dict.scale;
    const std::vector<Sector> secs = cut_sectors(split.train, sensor, heading, sopt);
    for (std::size_t s = 0; s < secs.size(); ++s) {
      const SectorTransfer& fs = full.sectors[s];
      if (fs.atom < 0) continue;
      ++sectors_total;
      for (std::size_t ki = 0; ki < ks.size(); ++ki) {
        auto t0 = Clock::now();
        const std::vector<std::size_t> chosen = pre.select(secs[s], ks[ki]);
        ms_pre[ki] += ms_since(t0);
        top_contains[ki] +=
            std::find(chosen.begin(), chosen.end(), std::size_t(fs.atom)) != chosen.end();
        Dictionary sub;
        sub.dim = dict.dim;
        sub.scale = dict.scale;
        sub.max_range = dict.max_range;
        sub.sectors = dict.sectors;
        for (std::size_t a : chosen) sub.atoms.push_back(dict.atoms[a]);
        const ScanTransfer part = transfer_scan(&ctx, sub, split.train, sensor, heading, t, po);
        // Ranking time of this sector's share: the sub-dictionary run ranks every sector.
        ms_rank_sub[ki] += (part.timing.ranking_ms + part.timing.prepare_ms) / secs.size();
        const long a = part.sectors[s].atom;
        agree[ki] += a >= 0 && chosen[a] == std::size_t(fs.atom);
      }
    }
    std::fprintf(stderr, "target scan %zu/%zu done\n", t + 1, tgt.scans.size());
  }
  std::printf("dictionary %zu atoms, %zu target sectors, full ranking %.1f ms per scan\n",
              dict.size(), sectors_total, ms_full / tgt.scans.size());
  std::printf("%8s %12s %14s %16s %18s\n", "k", "same_atom", "in_top_k", "preselect_ms/sec",
              "rank_ms/scan(est)");
  std::ofstream f(out);
  f << "{\n  \"device\": \"" << ctx.info().name << "\", \"atoms\": " << dict.size()
    << ", \"target_sectors\": " << sectors_total
    << ", \"full_rank_ms_per_scan\": " << ms_full / tgt.scans.size() << ",\n  \"rows\": [";
  for (std::size_t ki = 0; ki < ks.size(); ++ki) {
    const double same = double(agree[ki]) / sectors_total;
    const double inside = double(top_contains[ki]) / sectors_total;
    const double per_sector = ms_pre[ki] / sectors_total;
    const double rank_scan = ms_rank_sub[ki] / tgt.scans.size();
    std::printf("%8zu %12.3f %14.3f %16.3f %18.1f\n", ks[ki], same, inside, per_sector, rank_scan);
    f << (ki ? ",\n    " : "\n    ") << "{\"k\": " << ks[ki] << ", \"same_atom\": " << same
      << ", \"in_top_k\": " << inside << ", \"preselect_ms_per_sector\": " << per_sector
      << ", \"rank_ms_per_scan\": " << rank_scan << "}";
  }
  f << "\n  ]\n}\n";
  return 0;
}
