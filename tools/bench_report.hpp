#pragma once
// What `potmap bench` shows of a sweep: a table on stdout, a JSON record of every point, and a
// PNG plot of throughput against batch size, one panel per routine.

#include <nlohmann/json.hpp>

#include <ostream>
#include <string>
#include <vector>

#include "potmap/experiments/bench_sweep.hpp"

namespace potmap::cli {

using experiment::RoutineSweep;
using experiment::SweepOptions;
using experiment::SweepPoint;

/// Every point as a row (setting, median, spread, throughput), the default marked `*`, then the
/// best setting per routine and its ratio to the default.
void print_sweep_table(std::ostream& out, const std::vector<RoutineSweep>& sweeps);

/// The device, driver, potmap version, tuning source, options and every point of every routine.
nlohmann::json sweep_json(const Context& ctx, const SweepOptions& options,
                          const std::vector<RoutineSweep>& sweeps);

/// One panel per routine, left to right: x the batch size (log2 scale, evenly spaced values),
/// y the median throughput from 0 to the panel's largest, one line per series value coloured
/// viridis from dark (smallest) to bright, a vertical bar from the slowest to the fastest
/// repetition, the best point ringed black and the default point boxed red. Throws
/// potmap::Error naming the file if it cannot be written.
void write_sweep_plot(const std::vector<RoutineSweep>& sweeps, const std::string& path);

}  // namespace potmap::cli
