#include "potmap/experiments/bench_sweep.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <memory>
#include <random>
#include <sstream>

#include <boost/compute/container/vector.hpp>

#include "potmap/data/labelling.hpp"
#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/learn/abhm.hpp"
#include "potmap/learn/bhm.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/synthetic.hpp"
#include "potmap/ot/sinkhorn.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/mapper.hpp"

namespace potmap::experiment {

namespace {

const std::array<const char*, 10> kRoutines = {"map_eval",
                                               "map_eval_query",
                                               "map_eval_device",
                                               "raster",
                                               "raster_tile",
                                               "sinkhorn",
                                               "sinkhorn_groups",
                                               "pot",
                                               "bhm",
                                               "abhm"};

constexpr const char* kTown1 = "../shared/data/carla/town1_abhm_map.csv";

struct MapInput {
  KernelMap map;
  std::string label;
};

MapInput load_map(const SweepOptions& o) {
  std::string path = o.map_path;
  std::error_code ec;
  if (path.empty() && std::filesystem::exists(kTown1, ec)) path = kTown1;
  if (!path.empty()) {
    MapInput in{read_map(path), ""};
    if (in.map.dim != 2) throw ArgumentError("bench: map '" + path + "' is not 2D");
    in.label = path + " (" + std::to_string(in.map.size()) + " kernels)";
    return in;
  }
  SyntheticScene scene = make_synthetic_scene(1, 0.5, 10);
  return {scene.map, "synthetic scene (" + std::to_string(scene.map.size()) + " kernels)"};
}

// One warm-up call (builds the kernels, fills caches), then `repeats` timed calls.
SweepPoint time_point(const std::function<void()>& run, int repeats, double work) {
  run();
  SweepPoint p;
  for (int r = 0; r < repeats; ++r) {
    const auto t0 = std::chrono::steady_clock::now();
    run();
    p.seconds.push_back(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  std::vector<double> s = p.seconds;
  std::sort(s.begin(), s.end());
  p.median_s = s.size() % 2 ? s[s.size() / 2] : 0.5 * (s[s.size() / 2 - 1] + s[s.size() / 2]);
  p.min_s = s.front();
  p.max_s = s.back();
  p.throughput = work / p.median_s;
  return p;
}

void finish(RoutineSweep& r) {
  for (std::size_t i = 0; i < r.points.size(); ++i) {
    if (r.points[i].throughput > r.points[r.best].throughput) r.best = i;
    if (r.points[i].is_default) r.baseline = i;
  }
}

void progress(const SweepOptions& o, const RoutineSweep& r, const SweepPoint& p) {
  if (!o.note) return;
  std::ostringstream line;
  line << "bench " << r.name << " " << p.setting << ": " << p.throughput << " " << r.unit;
  o.note(line.str());
}

std::vector<double> random_points(const KernelMap& map, std::size_t n) {
  double lo[3], hi[3];
  map.bounds(lo, hi);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> ux(lo[0], hi[0]), uy(lo[1], hi[1]);
  std::vector<std::array<double, 2>> xy(n);
  for (auto& p : xy) p = {ux(rng), uy(rng)};
  // In rows of 2 m, each along x, as a scan or a picture's rows arrive: a chunk's points lie
  // together, as they do in use (random order would time the kernel lists, not the launch).
  std::sort(xy.begin(), xy.end(), [](const auto& a, const auto& b) {
    const double ra = std::floor(a[1] / 2), rb = std::floor(b[1] / 2);
    return ra != rb ? ra < rb : a[0] < b[0];
  });
  std::vector<double> pts(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    pts[2 * i] = xy[i][0];
    pts[2 * i + 1] = xy[i][1];
  }
  return pts;
}

RoutineSweep sweep_map_eval(Context& ctx, const MapInput& in, const SweepOptions& o, int reps) {
  const Tuning base = ctx.tuning();
  const std::size_t n = o.quick ? std::size_t{1} << 17 : std::size_t{1} << 19;
  const std::vector<double> pts = random_points(in.map, n);
  RoutineSweep r;
  r.start = to_string(base);
  r.name = "map_eval";
  r.unit = "points/s";
  r.x_label = "points per chunk (vector_width x work_group)";
  r.series_label = "map_eval.vector_width";
  r.input = in.label + ", " + std::to_string(n) + " random points in rows of 2 m";
  const std::vector<int> widths = o.quick ? std::vector<int>{8, 16} : std::vector<int>{4, 8, 16};
  const std::vector<int> groups =
      o.quick ? std::vector<int>{4, 8, 16, 32} : std::vector<int>{2, 4, 8, 16, 32, 64};
  std::vector<float> mean(n), var(n), prob(n);
  for (int vw : widths)
    for (int wg : groups) {
      Tuning t = base;
      t.map_eval.vector_width = vw;
      t.map_eval.work_group = wg;
      ctx.set_tuning(t);
      MapEvaluator ev(ctx, in.map);
      SweepPoint p =
          time_point([&] { ev.evaluate(pts.data(), n, mean.data(), var.data(), prob.data()); },
                     reps, double(n));
      p.x = static_cast<long long>(vw) * wg;
      p.series = vw;
      p.setting = "map_eval.vector_width=" + std::to_string(vw) +
                  ",map_eval.work_group=" + std::to_string(wg);
      p.is_default = vw == base.map_eval.vector_width && wg == base.map_eval.work_group;
      progress(o, r, p);
      r.points.push_back(std::move(p));
    }
  finish(r);
  const SweepPoint& b = r.points[r.best];
  r.best_tuning = base;
  r.best_tuning.map_eval.vector_width = static_cast<int>(b.series);
  r.best_tuning.map_eval.work_group = static_cast<int>(b.x / b.series);
  return r;
}

// The raster routines' grid over the map's extent: about 2^20 cells (quick) or 2^22 whatever
// the extent, so that the time per point stays bounded on any map.
GridSpec raster_grid(const MapInput& in, const SweepOptions& o) {
  double lo[3], hi[3];
  in.map.bounds(lo, hi);
  const double cells = o.quick ? double(1 << 20) : double(1 << 22);
  const double res = std::sqrt((hi[0] - lo[0]) * (hi[1] - lo[1]) / cells);
  return GridSpec::covering(2, lo, hi, res);
}

// A raster routine's sweep, before its points: cells per second against raster.rows_per_item.
RoutineSweep raster_sweep(const Tuning& base, const MapInput& in, const GridSpec& grid,
                          const char* name, const char* x_label) {
  RoutineSweep r;
  r.start = to_string(base);
  r.name = name;
  r.unit = "cells/s";
  r.x_label = x_label;
  r.series_label = "raster.rows_per_item";
  r.input = in.label + ", grid " + std::to_string(grid.count[0]) + " x " +
            std::to_string(grid.count[1]) + " cells";
  return r;
}

RoutineSweep sweep_raster(Context& ctx, const MapInput& in, const SweepOptions& o, int reps) {
  const Tuning base = ctx.tuning();
  const GridSpec grid = raster_grid(in, o);
  RoutineSweep r = raster_sweep(base, in, grid, "raster", "cells per launch (band)");
  const std::vector<long long> bands =
      o.quick ? std::vector<long long>{1 << 16, 1 << 18, 1 << 20, 1 << 22}
              : std::vector<long long>{1 << 14, 1 << 16, 1 << 18, 1 << 20, 1 << 22};
  const long long default_band = static_cast<long long>(EvalOptions{}.cells_per_launch);
  std::vector<float> mean(grid.cells()), var(grid.cells()), prob(grid.cells());
  for (int rows : {4, 8, 16})
    for (long long band : bands) {
      Tuning t = base;
      t.raster.rows_per_item = rows;
      ctx.set_tuning(t);
      EvalOptions eo;
      eo.cells_per_launch = static_cast<std::size_t>(band);
      MapEvaluator ev(ctx, in.map, eo);
      SweepPoint p =
          time_point([&] { ev.evaluate_grid(grid, mean.data(), var.data(), prob.data()); }, reps,
                     double(grid.cells()));
      p.x = band;
      p.series = rows;
      p.setting = "raster.rows_per_item=" + std::to_string(rows) + ",band=" + std::to_string(band);
      p.is_default = rows == base.raster.rows_per_item && band == default_band;
      progress(o, r, p);
      r.points.push_back(std::move(p));
    }
  finish(r);
  r.best_tuning = base;
  r.best_tuning.raster.rows_per_item = static_cast<int>(r.points[r.best].series);
  r.best_band = r.points[r.best].x;
  return r;
}

// raster.tile by raster.rows_per_item, on the raster sweep's grid at the default band.
RoutineSweep sweep_raster_tile(Context& ctx, const MapInput& in, const SweepOptions& o, int reps) {
  const Tuning base = ctx.tuning();
  const GridSpec grid = raster_grid(in, o);
  RoutineSweep r = raster_sweep(base, in, grid, "raster_tile", "tile edge, cells (raster.tile)");
  std::vector<float> mean(grid.cells()), var(grid.cells()), prob(grid.cells());
  const std::vector<int> rows = o.quick ? std::vector<int>{8, 16} : std::vector<int>{4, 8, 16};
  for (int rpi : rows)
    for (int tile : {16, 32, 64}) {
      Tuning t = base;
      t.raster.rows_per_item = rpi;
      t.raster.tile = tile;
      ctx.set_tuning(t);
      MapEvaluator ev(ctx, in.map);
      SweepPoint p =
          time_point([&] { ev.evaluate_grid(grid, mean.data(), var.data(), prob.data()); }, reps,
                     double(grid.cells()));
      p.x = tile;
      p.series = rpi;
      p.setting =
          "raster.rows_per_item=" + std::to_string(rpi) + ",raster.tile=" + std::to_string(tile);
      p.is_default = rpi == base.raster.rows_per_item && tile == base.raster.tile;
      progress(o, r, p);
      r.points.push_back(std::move(p));
    }
  finish(r);
  r.best_tuning = base;
  r.best_tuning.raster.rows_per_item = static_cast<int>(r.points[r.best].series);
  r.best_tuning.raster.tile = static_cast<int>(r.points[r.best].x);
  return r;
}

SinkhornBatch sinkhorn_batch(std::size_t problems, int side) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  SinkhornBatch batch;
  for (std::size_t p = 0; p < problems; ++p) {
    SinkhornProblem q;
    q.source = Eigen::MatrixXd::NullaryExpr(side, 2, [&] { return u(rng); });
    q.target = Eigen::MatrixXd::NullaryExpr(side, 2, [&] { return u(rng); });
    q.epsilon = 0.05;
    q.tolerance = 1e-5;
    q.max_iterations = 2000;
    batch.add(q);
  }
  return batch;
}

// One sweep per points-per-side: problems per launch on the axis, work-group per line.
RoutineSweep sweep_sinkhorn(Context& ctx, int side, const SweepOptions& o, int reps) {
  const Tuning base = ctx.tuning();
  // Enough problems that one run takes tens of milliseconds on a CPU: shorter runs time the
  // machine's noise.
  const std::size_t problems = 1024;
  const SinkhornBatch batch = sinkhorn_batch(problems, side);
  // The batch pads each side by at most 16 (sinkhorn.cpp's chunking): chunk_slots of k times
  // this gives launches of exactly k problems.
  const std::size_t slots_per_problem = 2 * (static_cast<std::size_t>(side) + 16);
  RoutineSweep r;
  r.start = to_string(base);
  r.name = "sinkhorn_" + std::to_string(side);
  r.unit = "problems/s";
  r.x_label = "problems per launch";
  r.series_label = "sinkhorn.work_group";
  r.input = std::to_string(problems) + " random 2D problems, " + std::to_string(side) +
            " points a side, epsilon 0.05, tolerance 1e-5";
  const std::vector<long long> per_launch = {16, 64, 256, static_cast<long long>(problems)};
  const std::size_t default_per_launch =
      std::min(problems, (base.sinkhorn.chunk_slots + slots_per_problem - 1) / slots_per_problem);
  const std::vector<int> groups =
      o.quick ? std::vector<int>{1, 2, 4, 8} : std::vector<int>{1, 2, 4, 8, 16, 32};
  for (int wg : groups)
    for (long long k : per_launch) {
      Tuning t = base;
      t.sinkhorn.work_group = wg;
      t.sinkhorn.chunk_slots = static_cast<std::size_t>(k) * slots_per_problem;
      // The whole batch in one launch is the default's behaviour: record the default's value.
      if (static_cast<std::size_t>(k) == problems)
        t.sinkhorn.chunk_slots = std::max(t.sinkhorn.chunk_slots, base.sinkhorn.chunk_slots);
      ctx.set_tuning(t);
      SweepPoint p = time_point([&] { batch.run(ctx); }, reps, double(problems));
      p.x = k;
      p.series = wg;
      p.setting = "sinkhorn.work_group=" + std::to_string(wg) +
                  ",sinkhorn.chunk_slots=" + std::to_string(t.sinkhorn.chunk_slots);
      p.is_default =
          wg == base.sinkhorn.work_group && static_cast<std::size_t>(k) == default_per_launch;
      progress(o, r, p);
      r.points.push_back(std::move(p));
    }
  finish(r);
  r.best_tuning = base;
  r.best_tuning.sinkhorn.work_group = static_cast<int>(r.points[r.best].series);
  // The whole batch in one launch is what the default chunk already gives: keep the default
  // then, so that the file does not cap larger batches at this sweep's size.
  if (static_cast<std::size_t>(r.points[r.best].x) < problems)
    r.best_tuning.sinkhorn.chunk_slots =
        static_cast<std::size_t>(r.points[r.best].x) * slots_per_problem;
  return r;
}

// The simulated source of the pot and learn sweeps, as `potmap demo` builds it: 6 scans of the
// built-in town1 3 m apart, every beam labelled, and a BHM map over them with kernels every
// metre (gamma 4 / m^2).
struct SimSource {
  Simulation sim;
  LabelledPoints train;
  double lo[3] = {HUGE_VAL, HUGE_VAL, 0}, hi[3] = {-HUGE_VAL, -HUGE_VAL, 0};
};

SimSource sim_source() {
  SimSource src;
  SimOptions so;
  so.scans = 6;
  so.spacing = 3;
  so.seed = 1;
  src.sim = simulate(Town::builtin("town1"), so);
  LabelOptions lo;
  lo.holdout_fraction = 0;
  src.train = label_scans(src.sim.scans, lo).train;
  for (std::size_t i = 0; i < src.train.size(); ++i)
    for (int d = 0; d < 2; ++d) {
      src.lo[d] = std::min(src.lo[d], src.train.position[2 * i + d]);
      src.hi[d] = std::max(src.hi[d], src.train.position[2 * i + d]);
    }
  return src;
}

// POT on a fixed simulated drive: a dictionary from the simulated source (sim_source), then 8
// (quick) or 16 scans of town2, 3 m apart, mapped with the default PotOptions (exhaustive
// ranking, 8 rotations). The axis is the number of scans in flight: 1 with
// MapperOptions::pipeline off (prepare, then solve, one scan at a time), 2 with it on (the next
// scan prepared, and the last one placed, on other threads while this one is solved). The lines are
// sinkhorn.work_group, which every ranking and transport solve of POT reads.
RoutineSweep sweep_pot(Context& ctx, const SimSource& src, const SweepOptions& o, int reps) {
  const Tuning base = ctx.tuning();
  KernelMap source_map = bhm_grid_prior(2, src.lo, src.hi, 1.0, 4.0);
  bhm_update_sequential(&ctx, source_map, src.train);
  Dictionary dict;
  build_dictionary(src.sim.scans, source_map, {}, dict);
  if (dict.empty()) throw Error("bench: the simulated source scans gave no atoms");
  SimOptions to;
  to.scans = o.quick ? 8 : 16;
  to.spacing = 3;
  to.seed = 7;
  const std::vector<Scan> scans = simulate(Town::builtin("town2"), to).scans;

  RoutineSweep r;
  r.start = to_string(base);
  r.name = "pot";
  r.unit = "scans/s";
  r.x_label = "scans in flight (1: pipeline off, 2: on)";
  r.series_label = "sinkhorn.work_group";
  r.input = "simulated: " + std::to_string(dict.size()) + " atoms from 6 scans of town1, " +
            std::to_string(scans.size()) + " scans of town2 3 m apart, default PotOptions";
  const MapperOptions defaults;
  const std::vector<int> groups =
      o.quick ? std::vector<int>{1, 2, 4} : std::vector<int>{1, 2, 4, 8, 16};
  for (int wg : groups)
    for (const bool pipeline : {false, true}) {
      Tuning t = base;
      t.sinkhorn.work_group = wg;
      ctx.set_tuning(t);
      MapperOptions mo;
      mo.pipeline = pipeline;
      std::size_t mapped = 0;
      SweepPoint p =
          time_point([&] { map_scans(&ctx, dict, scans, mo, [&](MappedScan&&) { ++mapped; }); },
                     reps, double(scans.size()));
      if (mapped != scans.size() * static_cast<std::size_t>(reps + 1))
        throw Error("bench: pot mapped " + std::to_string(mapped) + " scans, expected " +
                    std::to_string(scans.size() * static_cast<std::size_t>(reps + 1)));
      p.x = pipeline ? 2 : 1;
      p.series = wg;
      p.setting =
          "sinkhorn.work_group=" + std::to_string(wg) + ",pipeline=" + (pipeline ? "on" : "off");
      p.is_default = wg == base.sinkhorn.work_group && pipeline == defaults.pipeline;
      progress(o, r, p);
      r.points.push_back(std::move(p));
    }
  finish(r);
  r.best_tuning = base;
  r.best_tuning.sinkhorn.work_group = static_cast<int>(r.points[r.best].series);
  r.best_pipeline = r.points[r.best].x == 2;
  return r;
}

// A sweep of one integer field of the tuning: `values` on the axis, one line. `run` does the
// work of one repetition under the context's current tuning; `make` is called once per point
// after the tuning is set (objects that read the tuning when they are built).
struct OneField {
  std::string routine, field, unit, x_label, input;
  std::vector<int> values;
  int* (*get)(Tuning&);
  double work = 0;
};

RoutineSweep sweep_field(Context& ctx, const OneField& f, const SweepOptions& o, int reps,
                         const std::function<std::function<void()>()>& make) {
  const Tuning base = ctx.tuning();
  RoutineSweep r;
  r.start = to_string(base);
  r.name = f.routine;
  r.unit = f.unit;
  r.x_label = f.x_label;
  r.series_label = f.field;
  r.input = f.input;
  Tuning copy = base;
  const int def = *f.get(copy);
  for (int v : f.values) {
    Tuning t = base;
    *f.get(t) = v;
    ctx.set_tuning(t);
    const std::function<void()> run = make();
    SweepPoint p = time_point(run, reps, f.work);
    p.x = v;
    p.series = 0;  // one line: the field is on the axis
    p.setting = f.field + "=" + std::to_string(v);
    p.is_default = v == def;
    progress(o, r, p);
    r.points.push_back(std::move(p));
  }
  finish(r);
  r.best_tuning = base;
  *f.get(r.best_tuning) = static_cast<int>(r.points[r.best].x);
  return r;
}

// map_eval.chunks_per_query: chunks of the batch path sharing one kernel-index walk on the host,
// at the default vector width and work-group, on map_eval's points.
RoutineSweep sweep_map_query(Context& ctx, const MapInput& in, const SweepOptions& o, int reps) {
  const std::size_t n = o.quick ? std::size_t{1} << 17 : std::size_t{1} << 19;
  const std::vector<double> pts = random_points(in.map, n);
  std::vector<float> mean(n), var(n), prob(n);
  OneField f{"map_eval_query",
             "map_eval.chunks_per_query",
             "points/s",
             "chunks per kernel-index query",
             in.label + ", " + std::to_string(n) + " random points in rows of 2 m",
             o.quick ? std::vector<int>{4, 16, 64} : std::vector<int>{1, 4, 16, 64, 256},
             [](Tuning& t) { return &t.map_eval.chunks_per_query; },
             double(n)};
  std::unique_ptr<MapEvaluator> ev;
  return sweep_field(ctx, f, o, reps, [&]() -> std::function<void()> {
    ev = std::make_unique<MapEvaluator>(ctx, in.map);
    return [&] { ev->evaluate(pts.data(), n, mean.data(), var.data(), prob.data()); };
  });
}

// map_eval.cells_work_group: the device-buffer path (evaluate_device, points already on the
// device, in any order), on map_eval's points uploaded once.
RoutineSweep sweep_map_device(Context& ctx, const MapInput& in, const SweepOptions& o, int reps) {
  const std::size_t n = o.quick ? std::size_t{1} << 17 : std::size_t{1} << 19;
  const std::vector<double> pts = random_points(in.map, n);
  double lo[3], hi[3];
  in.map.bounds(lo, hi);
  const double origin[2] = {std::round(0.5 * (lo[0] + hi[0])), std::round(0.5 * (lo[1] + hi[1]))};
  std::vector<float> rel(2 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (int d = 0; d < 2; ++d) rel[2 * i + d] = static_cast<float>(pts[2 * i + d] - origin[d]);
  boost::compute::vector<float> d_pts(rel.begin(), rel.end(), ctx.queue());
  boost::compute::buffer d_mean(ctx.context(), n * 4), d_var(ctx.context(), n * 4),
      d_prob(ctx.context(), n * 4);
  OneField f{"map_eval_device",
             "map_eval.cells_work_group",
             "points/s",
             "work-items per work-group (evaluate_device)",
             in.label + ", " + std::to_string(n) + " random points on the device",
             o.quick ? std::vector<int>{8, 16, 32} : std::vector<int>{4, 8, 16, 32, 64, 128},
             [](Tuning& t) { return &t.map_eval.cells_work_group; },
             double(n)};
  std::unique_ptr<MapEvaluator> ev;
  return sweep_field(ctx, f, o, reps, [&]() -> std::function<void()> {
    ev = std::make_unique<MapEvaluator>(ctx, in.map);
    return [&] {
      ev->evaluate_device(d_pts.get_buffer(), n, origin, &d_mean, &d_var, &d_prob).wait();
    };
  });
}

// sinkhorn.groups_per_compute_unit: resident work-groups of the stabilised scheme, on
// sinkhorn_32's problems at the default work-group.
RoutineSweep sweep_sinkhorn_groups(Context& ctx, const SweepOptions& o, int reps) {
  const std::size_t problems = 1024;
  const SinkhornBatch batch = sinkhorn_batch(problems, 32);
  OneField f{"sinkhorn_groups",
             "sinkhorn.groups_per_compute_unit",
             "problems/s",
             "resident work-groups per compute unit",
             std::to_string(problems) +
                 " random 2D problems, 32 points a side, epsilon 0.05, tolerance 1e-5",
             o.quick ? std::vector<int>{1, 4, 16} : std::vector<int>{1, 2, 4, 8, 16},
             [](Tuning& t) { return &t.sinkhorn.groups_per_compute_unit; },
             double(problems)};
  return sweep_field(ctx, f, o, reps,
                     [&]() -> std::function<void()> { return [&] { batch.run(ctx); }; });
}

// learn.bhm_work_group and learn.abhm_work_group: one BHM update (3 EM iterations) and one
// ABHM loss-and-gradient evaluation on the simulated source's samples, kernels every metre.
RoutineSweep sweep_bhm(Context& ctx, const SimSource& src, const SweepOptions& o, int reps) {
  const KernelMap prior = bhm_grid_prior(2, src.lo, src.hi, 1.0, 4.0);
  OneField f{"bhm",
             "learn.bhm_work_group",
             "samples/s",
             "work-items per work-group (bhm_update.cl)",
             "simulated: " + std::to_string(src.train.size()) + " samples of 6 scans of town1, " +
                 std::to_string(prior.size()) + " kernels 1 m apart, 3 EM iterations",
             o.quick ? std::vector<int>{16, 64, 256} : std::vector<int>{8, 16, 32, 64, 128, 256},
             [](Tuning& t) { return &t.learn.bhm_work_group; },
             double(src.train.size())};
  return sweep_field(ctx, f, o, reps, [&]() -> std::function<void()> {
    return [&] {
      KernelMap m = prior;
      bhm_update(ctx, m, src.train);
    };
  });
}

RoutineSweep sweep_abhm(Context& ctx, const SimSource& src, const SweepOptions& o, int reps) {
  const AbhmParams params = abhm_init_grid(2, src.lo, src.hi, 1.0, 4.0);
  AbhmNoise noise;
  std::mt19937 rng(13);
  std::normal_distribution<double> z;
  noise.w.resize(params.size());
  noise.g.resize(params.size());
  noise.h.resize(params.h_loc.size());
  for (auto* v : {&noise.w, &noise.g, &noise.h})
    for (double& x : *v) x = z(rng);
  OneField f{"abhm",
             "learn.abhm_work_group",
             "samples/s",
             "work-items per work-group (abhm_grad.cl)",
             "simulated: " + std::to_string(src.train.size()) + " samples of 6 scans of town1, " +
                 std::to_string(params.size()) + " kernels 1 m apart, loss and gradient",
             o.quick ? std::vector<int>{16, 64, 256} : std::vector<int>{8, 16, 32, 64, 128, 256},
             [](Tuning& t) { return &t.learn.abhm_work_group; },
             double(src.train.size())};
  std::vector<double> grad;
  return sweep_field(ctx, f, o, reps, [&]() -> std::function<void()> {
    return [&] { abhm_loss_device(ctx, params, AbhmPrior{}, src.train, 1.0, noise, &grad); };
  });
}

bool wanted(const SweepOptions& o, const std::string& name) {
  return o.routines.empty() ||
         std::find(o.routines.begin(), o.routines.end(), name) != o.routines.end();
}

}  // namespace

std::vector<RoutineSweep> run_sweeps(Context& ctx, const SweepOptions& o) {
  for (const std::string& name : o.routines)
    if (std::find(kRoutines.begin(), kRoutines.end(), name) == kRoutines.end()) {
      std::string known;
      for (const char* k : kRoutines) known += std::string(known.empty() ? "" : ", ") + k;
      throw ArgumentError("bench: no routine named '" + name + "' (routines: " + known + ")");
    }
  const int reps = o.repeats > 0 ? o.repeats : (o.quick ? 3 : 5);
  const Tuning saved = ctx.tuning();
  std::vector<RoutineSweep> out;
  // Each sweep starts from the saved tuning: its default point is the context's, not the last
  // point of the sweep before.
  const auto add = [&](RoutineSweep r) {
    out.push_back(std::move(r));
    ctx.set_tuning(saved);
  };
  try {
    if (wanted(o, "map_eval") || wanted(o, "map_eval_query") || wanted(o, "map_eval_device") ||
        wanted(o, "raster") || wanted(o, "raster_tile")) {
      const MapInput in = load_map(o);
      if (wanted(o, "map_eval")) add(sweep_map_eval(ctx, in, o, reps));
      if (wanted(o, "map_eval_query")) add(sweep_map_query(ctx, in, o, reps));
      if (wanted(o, "map_eval_device")) add(sweep_map_device(ctx, in, o, reps));
      if (wanted(o, "raster")) add(sweep_raster(ctx, in, o, reps));
      if (wanted(o, "raster_tile")) add(sweep_raster_tile(ctx, in, o, reps));
    }
    if (wanted(o, "sinkhorn")) {
      add(sweep_sinkhorn(ctx, 32, o, reps));
      if (!o.quick) add(sweep_sinkhorn(ctx, 96, o, reps));
    }
    if (wanted(o, "sinkhorn_groups")) add(sweep_sinkhorn_groups(ctx, o, reps));
    if (wanted(o, "pot") || wanted(o, "bhm") || wanted(o, "abhm")) {
      const SimSource src = sim_source();
      if (wanted(o, "pot")) add(sweep_pot(ctx, src, o, reps));
      if (wanted(o, "bhm")) add(sweep_bhm(ctx, src, o, reps));
      if (wanted(o, "abhm")) add(sweep_abhm(ctx, src, o, reps));
    }
  } catch (...) {
    ctx.set_tuning(saved);
    throw;
  }
  ctx.set_tuning(saved);
  return out;
}

}  // namespace potmap::experiment
