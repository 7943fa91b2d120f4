// One hour of driving at 10 scans per second through the overall map (issue #6 item 3): prints
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

int main(int argc, char** argv) {
  std::size_t scans = 36000, max_kernels = 0;
  double jitter = 0.05;
  std::string town_name = "town1", out = "overall_map_drive.json";
  std::uint64_t seed = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--scans")
      scans = std::stoul(v);
    else if (k == "--jitter")
      jitter = std::stod(v);
    else if (k == "--town")
      town_name = v;
    else if (k == "--seed")
      seed = std::stoull(v);
    else if (k == "--max-kernels")
      max_kernels = std::stoul(v);
    else if (k == "--out")
      out = v;
    else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      return 2;
    }
  }
  const Town town = Town::builtin(town_name, seed);
  // The learned map: BHM over a survey drive of the whole town.
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
  {
    Context ctx;
    BhmOptions bo;
    bo.em_iterations = 2;
    bhm_update(ctx, learned, train, bo);
  }
  std::fprintf(stderr, "learned map: %zu kernels over %.0f x %.0f m from %zu samples\n",
               learned.size(), town.width(), town.height(), train.size());

  // The drive: only the poses matter, so the sensor casts few beams.
  SimOptions drive;
  drive.scans = scans;
  drive.spacing = 1.0;  // 10 m/s at 10 scans/s
  drive.step_deg = 90;
  drive.seed = seed + 1;
  const Simulation sim = simulate(town, drive);
  const double r_max = drive.max_range;

  // Kernels by 1 m cell for the range query.
  const int gx = static_cast<int>(std::ceil(town.width())) + 1;
  const int gy = static_cast<int>(std::ceil(town.height())) + 1;
  std::vector<std::vector<std::uint32_t>> cells(std::size_t(gx) * gy);
  for (std::size_t k = 0; k < learned.size(); ++k) {
    const int cx = std::clamp(static_cast<int>(learned.position[2 * k]), 0, gx - 1);
    const int cy = std::clamp(static_cast<int>(learned.position[2 * k + 1]), 0, gy - 1);
    cells[std::size_t(cy) * gx + cx].push_back(static_cast<std::uint32_t>(k));
  }

  OverallMapOptions oo;
  oo.max_kernels = max_kernels;
  OverallMap overall(2, oo);
  std::mt19937_64 rng(seed + 7);
  std::normal_distribution<double> g(0, 1);
  std::vector<std::size_t> at_scan, sizes, bytes;
  std::vector<double> ms_per_add;
  std::size_t in_kernels = 0, merged = 0;
  double add_s = 0;
  const auto t0 = std::chrono::steady_clock::now();
  std::printf("%10s %12s %12s %12s %10s %14s\n", "scans", "kernels", "memory_MB", "input_kern",
              "merged_%", "us_per_add");
  for (std::size_t i = 0; i < sim.scans.size(); ++i) {
    const double x = sim.route[2 * i], y = sim.route[2 * i + 1];
    KernelMap inst;
    for (int cy = std::max(0, int(y - r_max)); cy <= std::min(gy - 1, int(y + r_max)); ++cy)
      for (int cx = std::max(0, int(x - r_max)); cx <= std::min(gx - 1, int(x + r_max)); ++cx)
        for (std::uint32_t k : cells[std::size_t(cy) * gx + cx]) {
          const double dx = learned.position[2 * k] - x, dy = learned.position[2 * k + 1] - y;
          if (dx * dx + dy * dy > r_max * r_max) continue;
          const double p[2] = {learned.position[2 * k] + jitter * g(rng),
                               learned.position[2 * k + 1] + jitter * g(rng)};
          inst.push_back(p, learned.gamma[k] * std::exp(0.1 * g(rng)), learned.w_mean[k],
                         learned.w_var[k]);
        }
    const auto a0 = std::chrono::steady_clock::now();
    const OverallMapAddStats st = overall.add(inst);
    add_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - a0).count();
    in_kernels += inst.size();
    merged += st.merged;
    if ((i + 1) % 1800 == 0 || i + 1 == sim.scans.size() || i + 1 == 100 || i + 1 == 600) {
      at_scan.push_back(i + 1);
      sizes.push_back(overall.size());
      bytes.push_back(overall.memory_bytes());
      ms_per_add.push_back(1e3 * add_s / double(i + 1));
      std::printf("%10zu %12zu %12.2f %12zu %10.1f %14.1f\n", i + 1, overall.size(),
                  bytes.back() / 1e6, in_kernels,
                  100.0 * merged / std::max<std::size_t>(1, in_kernels),
                  1e6 * add_s / double(i + 1));
      std::fflush(stdout);
    }
  }
  const double total_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::ofstream f(out);
  f << "{\n  \"town\": \"" << town_name << "\", \"scans\": " << scans
    << ", \"jitter_m\": " << jitter << ", \"max_kernels\": " << max_kernels
    << ", \"learned_kernels\": " << learned.size() << ", \"merge_radius\": " << oo.merge_radius
    << ", \"gamma_ratio\": " << oo.gamma_ratio << ",\n  \"input_kernels\": " << in_kernels
    << ", \"merged\": " << merged << ", \"add_seconds\": " << add_s
    << ", \"total_seconds\": " << total_s << ",\n  \"curve\": [";
  for (std::size_t i = 0; i < at_scan.size(); ++i)
    f << (i ? ",\n    " : "\n    ") << "{\"scans\": " << at_scan[i] << ", \"kernels\": " << sizes[i]
      << ", \"memory_bytes\": " << bytes[i] << ", \"ms_per_add\": " << ms_per_add[i] << "}";
  f << "\n  ]\n}\n";
  std::printf("learned map %zu kernels; wrote %s\n", learned.size(), out.c_str());
  return 0;
}
