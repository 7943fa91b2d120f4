// One hour of driving at 10 scans per second through the overall map: prints
// kernels and memory against scans driven and writes the curve as JSON.
//
// POT is not needed to measure the map's growth: each scan's instantaneous map is taken as the
// kernels of a BHM map of the simulated town within max_range of the sensor (the shape of what
// POT transfers), with each kernel's position jittered by --jitter metres (normal, per axis)
// and its gamma by a factor exp(N(0, 0.1)), as successive transports of one place differ.
//
// Usage: overall_map_drive [--scans 36000] [--jitter 0.05] [--town town1] [--seed 0]
//                          [--max-kernels 0] [--out overall_map_drive.json]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "potmap/data/labelling.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/learn/bhm.hpp"
#include "potmap/pot/overall_map.hpp"
#include "potmap/runtime/context.hpp"

using namespace potmap;

namespace {

struct DriveArgs {
  std::size_t scans = 36000, max_kernels = 0;
  double jitter = 0.05;
  std::string town = "town1", out = "overall_map_drive.json";
  std::uint64_t seed = 0;
};

// Returns false (after naming the option) on an unknown one.
bool parse_args(int argc, char** argv, DriveArgs& a) {
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--scans")
      a.scans = std::stoul(v);
    else if (k == "--jitter")
      a.jitter = std::stod(v);
    else if (k == "--town")
      a.town = v;
    else if (k == "--seed")
      a.seed = std::stoull(v);
    else if (k == "--max-kernels")
      a.max_kernels = std::stoul(v);
    else if (k == "--out")
      a.out = v;
    else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      return false;
    }
  }
  return true;
}

// The learned map: BHM over a survey drive of the whole town.
KernelMap learn_town(const Town& town, std::uint64_t seed) {
  SimOptions survey;
  survey.scans = 600;
  survey.spacing = 2.0;
  survey.step_deg = 2;
  survey.seed = seed;
  const Simulation s0 = simulate(town, survey);
  LabelOptions lo;
  lo.holdout_fraction = 0;
  lo.free_per_metre = 0.5;
  const LabelledPoints train = label_scans(s0.scans, lo).train;
  const double lo_[3] = {0, 0, 0}, hi[3] = {town.width(), town.height(), 0};
  KernelMap learned = bhm_grid_prior(2, lo_, hi, 1.0, 8.0);
  Context ctx;
  BhmOptions bo;
  bo.em_iterations = 2;
  bhm_update(ctx, learned, train, bo);
  std::fprintf(stderr, "learned map: %zu kernels over %.0f x %.0f m from %zu samples\n",
               learned.size(), town.width(), town.height(), train.size());
  return learned;
}

// The learned map's kernels within r_max of (x, y), jittered as successive transports of one
// place differ; kernels are bucketed by 1 m cell for the range query.
class Neighbourhood {
 public:
  Neighbourhood(const KernelMap& map, const Town& town) : map_(map) {
    gx_ = static_cast<int>(std::ceil(town.width())) + 1;
    gy_ = static_cast<int>(std::ceil(town.height())) + 1;
    cells_.resize(std::size_t(gx_) * gy_);
    for (std::size_t k = 0; k < map.size(); ++k) {
      const int cx = std::clamp(static_cast<int>(map.position[2 * k]), 0, gx_ - 1);
      const int cy = std::clamp(static_cast<int>(map.position[2 * k + 1]), 0, gy_ - 1);
      cells_[std::size_t(cy) * gx_ + cx].push_back(static_cast<std::uint32_t>(k));
    }
  }
  // `g` is the drive's one distribution (it keeps a spare draw between calls).
  KernelMap around(double x, double y, double r_max, double jitter, std::mt19937_64& rng,
                   std::normal_distribution<double>& g) const {
    KernelMap inst;
    for (int cy = std::max(0, int(y - r_max)); cy <= std::min(gy_ - 1, int(y + r_max)); ++cy)
      for (int cx = std::max(0, int(x - r_max)); cx <= std::min(gx_ - 1, int(x + r_max)); ++cx)
        for (std::uint32_t k : cells_[std::size_t(cy) * gx_ + cx]) {
          const double dx = map_.position[2 * k] - x, dy = map_.position[2 * k + 1] - y;
          if (dx * dx + dy * dy > r_max * r_max) continue;
          const double p[2] = {map_.position[2 * k] + jitter * g(rng),
                               map_.position[2 * k + 1] + jitter * g(rng)};
          inst.push_back(p, map_.gamma[k] * std::exp(0.1 * g(rng)), map_.w_mean[k], map_.w_var[k]);
        }
    return inst;
  }

 private:
  const KernelMap& map_;
  int gx_ = 0, gy_ = 0;
  std::vector<std::vector<std::uint32_t>> cells_;
};

struct CurvePoint {
  std::size_t scans = 0, kernels = 0, bytes = 0;
  double ms_per_add = 0;
};

void write_json(const DriveArgs& a, const KernelMap& learned, const OverallMapOptions& oo,
                std::size_t in_kernels, std::size_t merged, double add_s, double total_s,
                const std::vector<CurvePoint>& curve) {
  std::ofstream f(a.out);
  f << "{\n  \"town\": \"" << a.town << "\", \"scans\": " << a.scans
    << ", \"jitter_m\": " << a.jitter << ", \"max_kernels\": " << a.max_kernels
    << ", \"learned_kernels\": " << learned.size() << ", \"merge_radius\": " << oo.merge_radius
    << ", \"gamma_ratio\": " << oo.gamma_ratio << ",\n  \"input_kernels\": " << in_kernels
    << ", \"merged\": " << merged << ", \"add_seconds\": " << add_s
    << ", \"total_seconds\": " << total_s << ",\n  \"curve\": [";
  for (std::size_t i = 0; i < curve.size(); ++i)
    f << (i ? ",\n    " : "\n    ") << "{\"scans\": " << curve[i].scans
      << ", \"kernels\": " << curve[i].kernels << ", \"memory_bytes\": " << curve[i].bytes
      << ", \"ms_per_add\": " << curve[i].ms_per_add << "}";
  f << "\n  ]\n}\n";
}

}  // namespace

int main(int argc, char** argv) {
  DriveArgs a;
  if (!parse_args(argc, argv, a)) return 2;
  const Town town = Town::builtin(a.town, a.seed);
  const KernelMap learned = learn_town(town, a.seed);

  // The drive: only the poses matter, so the sensor casts few beams.
  SimOptions drive;
  drive.scans = a.scans;
  drive.spacing = 1.0;  // 10 m/s at 10 scans/s
  drive.step_deg = 90;
  drive.seed = a.seed + 1;
  const Simulation sim = simulate(town, drive);
  const Neighbourhood near(learned, town);

  OverallMapOptions oo;
  oo.max_kernels = a.max_kernels;
  OverallMap overall(2, oo);
  std::mt19937_64 rng(a.seed + 7);
  std::normal_distribution<double> g(0, 1);
  std::vector<CurvePoint> curve;
  std::size_t in_kernels = 0, merged = 0;
  double add_s = 0;
  const auto t0 = std::chrono::steady_clock::now();
  std::printf("%10s %12s %12s %12s %10s %14s\n", "scans", "kernels", "memory_MB", "input_kern",
              "merged_%", "us_per_add");
  for (std::size_t i = 0; i < sim.scans.size(); ++i) {
    const KernelMap inst =
        near.around(sim.route[2 * i], sim.route[2 * i + 1], drive.max_range, a.jitter, rng, g);
    const auto a0 = std::chrono::steady_clock::now();
    const OverallMapAddStats st = overall.add(inst);
    add_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - a0).count();
    in_kernels += inst.size();
    merged += st.merged;
    if ((i + 1) % 1800 == 0 || i + 1 == sim.scans.size() || i + 1 == 100 || i + 1 == 600) {
      curve.push_back({i + 1, overall.size(), overall.memory_bytes(), 1e3 * add_s / double(i + 1)});
      std::printf("%10zu %12zu %12.2f %12zu %10.1f %14.1f\n", i + 1, overall.size(),
                  curve.back().bytes / 1e6, in_kernels,
                  100.0 * merged / std::max<std::size_t>(1, in_kernels),
                  1e6 * add_s / double(i + 1));
      std::fflush(stdout);
    }
  }
  const double total_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  write_json(a, learned, oo, in_kernels, merged, add_s, total_s, curve);
  std::printf("learned map %zu kernels; wrote %s\n", learned.size(), a.out.c_str());
  return 0;
}
