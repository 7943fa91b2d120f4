// `potmap bench`: sweeps the launch settings of each routine on one device and reports them;
// `potmap tune`: the same sweep, its best settings written to the device's tuning file.
#include <iostream>

#include "bench_report.hpp"
#include "commands.hpp"
#include "potmap/error.hpp"
#include "potmap/experiments/bench_sweep.hpp"
#include "potmap/runtime/tuning_file.hpp"
#include "progress.hpp"

namespace potmap::cli {

using experiment::RoutineSweep;
using experiment::SweepOptions;
using experiment::SweepPoint;

namespace {

struct BenchArgs {
  std::string device;
  SweepOptions sweep;
  std::string routines;
  std::string out;
};

void add_sweep_options(CLI::App* cmd, BenchArgs& a) {
  cmd->add_option("--device", a.device,
                  "OpenCL device: substring of the platform's name or vendor or the device's name "
                  "(default: POTMAP_DEVICE, "
                  "else first GPU, else first CPU)");
  cmd->add_flag("--quick", a.sweep.quick,
                "fewer settings and smaller inputs (under a minute on a 2-core CPU)");
  cmd->add_option("--repeats", a.sweep.repeats,
                  "timed runs per setting after one warm-up (default 3 with --quick, else 5)")
      ->check(CLI::Range(1, 1000));
  cmd->add_option(
      "--routines", a.routines,
      "comma-separated routines to sweep: map_eval, map_eval_query, map_eval_device, raster, "
      "sinkhorn, sinkhorn_groups, pot, bhm, abhm (default all)");
  cmd->add_option("--map", a.sweep.map_path,
                  "kernel map for map_eval and raster (default: ../shared/data/carla/"
                  "town1_abhm_map.csv when present, else the built-in synthetic scene)");
}

// The sweep starts from the built-in defaults (not a tuning file already there), so that the
// ratios are against what an untuned library does and tuning twice does not compound.
Context bench_context(const BenchArgs& a) {
  ContextOptions o;
  o.device = a.device;
  o.tuning_file = false;
  Context ctx(o);
  std::cerr << "potmap: device: " << ctx.info().summary() << "\n";
  return ctx;
}

std::vector<RoutineSweep> sweep(Context& ctx, BenchArgs& a) {
  a.sweep.routines = split_list(a.routines, ',');
  a.sweep.note = [](const std::string& line) { std::cerr << "potmap: " << line << "\n"; };
  return experiment::run_sweeps(ctx, a.sweep);
}

void write_outputs(const Context& ctx, const BenchArgs& a, const std::vector<RoutineSweep>& s) {
  if (a.out.empty()) return;
  write_text_atomically(a.out + ".json", sweep_json(ctx, a.sweep, s).dump(1) + "\n");
  write_sweep_plot(s, a.out + ".png");
  std::cout << "wrote " << a.out << ".json and " << a.out << ".png\n";
}

int run_tune(const BenchArgs& a_in, const std::string& dir_in, double min_gain) {
  BenchArgs a = a_in;
  Context ctx = bench_context(a);
  const std::vector<RoutineSweep> sweeps = sweep(ctx, a);
  print_sweep_table(std::cout, sweeps);
  write_outputs(ctx, a, sweeps);
  // A routine's fields move only when its best point beats the default by more than the noise
  // allowance; the rest keep the defaults.
  Tuning t = ctx.tuning();
  for (const RoutineSweep& r : sweeps) {
    const double gain = r.points[r.best].throughput / r.points[r.baseline].throughput;
    const bool take = gain > 1 + min_gain;
    std::cout << r.name << ": best " << r.points[r.best].setting << ", " << gain
              << " x the default: " << (take ? "taken" : "default kept") << "\n";
    if (r.name == "pot") {
      // Its lines are sinkhorn.work_group on POT's own problems, but the file's Sinkhorn fields
      // come from the sinkhorn sweeps (one source per field); scans in flight is not a tuning.
      std::cout << "  (not written: scans in flight is MapperOptions::pipeline, "
                << (r.best_pipeline ? "on" : "off")
                << " at the best point; set it in code. The file's sinkhorn fields come from "
                   "the sinkhorn sweeps)\n";
      continue;
    }
    if (!take) continue;
    // Each routine writes only the fields it swept.
    const Tuning& b = r.best_tuning;
    if (r.name == "map_eval") {
      t.map_eval.vector_width = b.map_eval.vector_width;
      t.map_eval.work_group = b.map_eval.work_group;
    }
    if (r.name == "map_eval_query") t.map_eval.chunks_per_query = b.map_eval.chunks_per_query;
    if (r.name == "map_eval_device") t.map_eval.cells_work_group = b.map_eval.cells_work_group;
    if (r.name == "raster") t.raster.rows_per_item = b.raster.rows_per_item;
    // After raster: its rows are measured with the tile they were measured at.
    if (r.name == "raster_tile") t.raster = b.raster;
    // The last sinkhorn_N sweep has the most points a side, nearest POT's problems.
    if (r.name.rfind("sinkhorn_", 0) == 0 && r.name != "sinkhorn_groups") {
      t.sinkhorn.work_group = b.sinkhorn.work_group;
      t.sinkhorn.chunk_slots = b.sinkhorn.chunk_slots;
    }
    if (r.name == "sinkhorn_groups")
      t.sinkhorn.groups_per_compute_unit = b.sinkhorn.groups_per_compute_unit;
    if (r.name == "bhm") t.learn.bhm_work_group = b.learn.bhm_work_group;
    if (r.name == "abhm") t.learn.abhm_work_group = b.learn.abhm_work_group;
    if (r.name == "raster")
      std::cout << "  (the band, " << r.best_band
                << " cells, is EvalOptions::cells_per_launch, not a tuning: set it in code)\n";
  }
  const std::string dir = dir_in.empty() ? default_tuning_dir() : dir_in;
  if (dir.empty())
    throw ArgumentError(
        "tune: no folder for the tuning file: give --dir, or set "
        "POTMAP_CACHE_DIR, XDG_CACHE_HOME or HOME");
  const std::string path = tuning_file_path(dir, ctx.info());
  write_tuning_file(path, ctx.info(), t);
  std::cout << "wrote " << path << ": " << to_string(t) << "\n";
  return 0;
}

}  // namespace

void register_bench(CLI::App& app, Runner& runner) {
  auto a = std::make_shared<BenchArgs>();
  a->out = "potmap-bench";
  CLI::App* cmd = app.add_subcommand(
      "bench",
      "Time each routine under a sweep of batch sizes and work-group sizes on one device: a "
      "table, a JSON record and a PNG plot, the best setting per routine named");
  add_sweep_options(cmd, *a);
  cmd->add_option("--out", a->out,
                  "prefix of the JSON record and the PNG plot (PREFIX.json, PREFIX.png; default "
                  "potmap-bench; empty: neither)");
  cmd->callback([&runner, a] {
    runner.action = [a] {
      Context ctx = bench_context(*a);
      const std::vector<RoutineSweep> sweeps = sweep(ctx, *a);
      print_sweep_table(std::cout, sweeps);
      write_outputs(ctx, *a, sweeps);
      return 0;
    };
  });
}

void register_tune(CLI::App& app, Runner& runner) {
  auto a = std::make_shared<BenchArgs>();
  auto dir = std::make_shared<std::string>();
  auto min_gain = std::make_shared<double>(0.05);
  CLI::App* cmd = app.add_subcommand(
      "tune",
      "Run the sweep of `potmap bench` and write the best settings to this device's tuning "
      "file, which every later Context on the device reads in place of the built-in defaults");
  add_sweep_options(cmd, *a);
  cmd->add_option("--dir", *dir,
                  "folder of the tuning file (default: POTMAP_CACHE_DIR, else "
                  "$XDG_CACHE_HOME/potmap, else ~/.cache/potmap)");
  cmd->add_option("--min-gain", *min_gain,
                  "a routine's best setting replaces the default only when it is this much "
                  "faster (fraction; default 0.05: timing noise on a shared CPU)")
      ->check(CLI::Range(0.0, 10.0));
  cmd->add_option("--out", a->out, "also write PREFIX.json and PREFIX.png as `bench` does");
  cmd->callback([&runner, a, dir, min_gain] {
    runner.action = [a, dir, min_gain] { return run_tune(*a, *dir, *min_gain); };
  });
}

}  // namespace potmap::cli
