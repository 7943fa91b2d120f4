#pragma once
// The benchmark harness (`potmap bench`, `potmap tune`, and whoever picks batch sizes for their
// hardware from C++): each routine run on fixed synthetic (or Town 1)
// inputs under a grid of launch settings, every point repeated, its times kept. A point's
// setting is a Tuning (plus, for the raster, the band of cells per launch), so that the best
// point can be written to a tuning file as it was measured.

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "potmap/export.h"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap::experiment {

/// What to sweep and how hard.
struct SweepOptions {
  bool quick = false;  ///< fewer points, smaller inputs: under a minute on a 2-core CPU
  int repeats = 0;     ///< timed runs per point after one warm-up; 0: 3 quick, 5 otherwise
  /// Kernel map for the map routines; empty: Town 1 (../shared/data/carla) when present, else
  /// the built-in synthetic scene.
  std::string map_path;
  /// Routines to run (map_eval, raster, sinkhorn, pot); empty: all.
  std::vector<std::string> routines;
  /// A line for every point measured ("bench raster band=4096: 1.9e+07 cells/s"); none when
  /// empty.
  std::function<void(const std::string& line)> note;
};

/// One setting of one routine, timed.
struct SweepPoint {
  long long x = 0;  ///< the batch size on the plot's axis (routine's x_label)
  /// The second setting (routine's series_label): one line per value; 0 for a one-field sweep
  /// (its field on the axis, one line).
  long long series = 0;
  std::string setting;          ///< the full setting, `routine.field=value` pairs (and band=...)
  std::vector<double> seconds;  ///< every timed repetition
  double median_s = 0, min_s = 0, max_s = 0;
  double throughput = 0;    ///< work / median_s, in the routine's unit
  bool is_default = false;  ///< the setting the context had before the sweep
};

/// Every point of one routine and its input.
struct RoutineSweep {
  std::string name;          ///< map_eval, raster, sinkhorn_32, sinkhorn_96, pot
  std::string unit;          ///< of throughput, e.g. "points/s"
  std::string x_label;       ///< e.g. "points per chunk (vector_width x work_group)"
  std::string series_label;  ///< e.g. "vector_width"
  std::string input;         ///< what was run, e.g. "Town 1 map, 92372 kernels, 262144 points"
  std::string start;         ///< the tuning the sweep started from (to_string), for the record
  std::vector<SweepPoint> points;
  std::size_t best = 0;       ///< index of the highest median throughput
  std::size_t baseline = 0;   ///< index of the default point
  Tuning best_tuning;         ///< the context's tuning with the best point's fields
  long long best_band = 0;    ///< raster: cells per launch of the best point (else 0)
  bool best_pipeline = true;  ///< pot: MapperOptions::pipeline of the best point
};

/// Runs the sweeps on `ctx` (its tuning is restored afterwards), a note for every point.
std::vector<RoutineSweep> run_sweeps(Context& ctx, const SweepOptions& options);

}  // namespace potmap::experiment
POTMAP_CXX_API_END
