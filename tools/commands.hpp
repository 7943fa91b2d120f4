#pragma once
// Registration of the potmap subcommands. Each register_* adds one subcommand to the app and
// stores the action to run in the Runner; main() runs it after parsing, so that errors from the
// action are reported uniformly.

#include <CLI/CLI.hpp>

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "potmap/experiments/experiment_runner.hpp"
#include "potmap/learn/bhm_joint.hpp"
#include "potmap/map/kernel_map.hpp"
#include "potmap/runtime/context.hpp"

namespace potmap::cli {

struct Runner {
  std::function<int()> action;
  int run() { return action ? action() : 0; }
};

/// Adds --device to a subcommand; returns the storage the option writes to.
std::shared_ptr<std::string> add_device_option(CLI::App* cmd);

/// RePOT's seed rule as a pair of flags, --seeds-yield-fully (default) and --seeds-keep-start,
/// into *yield_fully (JointBhmOptions::seeds_yield_fully).
void add_seed_rule_flag(CLI::App* cmd, bool* yield_fully);

/// --half-life into *half_life (JointBhmOptions::half_life, seconds; 0: never forget).
void add_half_life_option(CLI::App* cmd, double* half_life);

/// A Context on the device named (or POTMAP_DEVICE, or the default), announced on stderr.
Context make_context(const std::string& device, bool quiet = false);
/// Writes `map` to `path`: with the joint BHM's information form (for `potmap merge`) when
/// `learner` is given and the file is a .potmap, else the map alone (write_map()).
void write_learned_map(const JointBhm* learner, const KernelMap& map, const std::string& path);
using experiment::runner::split_list;  // "a,b,c" -> a, b, c

void register_devices(CLI::App& app, Runner& runner);
void register_eval(CLI::App& app, Runner& runner);
void register_raster(CLI::App& app, Runner& runner);
void register_demo(CLI::App& app, Runner& runner);
void register_learn(CLI::App& app, Runner& runner);
void register_data(CLI::App& app, Runner& runner);
void register_map(CLI::App& app, Runner& runner);
void register_mapping(CLI::App& app, Runner& runner);
void register_export(CLI::App& app, Runner& runner);
void register_merge(CLI::App& app, Runner& runner);
void register_dict(CLI::App& app, Runner& runner);
void register_experiment(CLI::App& app, Runner& runner);
void register_bench(CLI::App& app, Runner& runner);
void register_tune(CLI::App& app, Runner& runner);
/// `experiment frames` (single 3D frames); after register_experiment.
void register_experiment_frames(CLI::App& app, Runner& runner);

}  // namespace potmap::cli
