#pragma once
// Labelled samples from any dataset potmap reads, for the commands that learn or build: scans
// (CARMEN, KITTI, nuScenes) are labelled here with the experiments' options, labelled files
// (.csv, .npz) pass through.
#include <CLI/CLI.hpp>

#include <string>
#include <vector>

#include "potmap/data/bag_options.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"

namespace potmap::cli {

struct LabelArgs {
  LabelOptions labels;   ///< free samples per metre, hold-out fraction, seed (labelling.hpp)
  double range_cut = 0;  ///< metres; returns beyond it become no-returns (0: none)
  BagOptions bag;        ///< ROS bags: topic, fixed frame, pose topic (add_bag_options)
};

/// Adds --topic, --fixed-frame, --pose-topic and --keyframe-distance (ROS bags) to `cmd`.
void add_bag_options(CLI::App* cmd, BagOptions& o);

/// Adds --free-per-metre, --holdout, --range-cut, the bag options and the seed option (named `seed_flag`: the
/// learners have a --seed of their own) to `cmd`, writing into `a`; the defaults shown are a's.
void add_label_options(CLI::App* cmd, LabelArgs& a, const std::string& seed_flag);

/// Whether `path` names labelled samples (.csv, .npz) rather than scans.
bool is_labelled_file(const std::string& path);

/// The scans of any dataset (read_dataset), each cut at `range_cut` metres when it is > 0 (the
/// experiments' limit_range). Throws InputError naming the file when it holds no scans.
std::vector<Scan> read_scans(const std::string& path, double range_cut,
                             const BagOptions& bag = {});

/// Labelled samples of `path`: a labelled file's samples as they are (all in train: its beams
/// are unknown, so nothing can be held out by beam), or the labelled scans (label_scans).
LabelledSplit read_samples(const std::string& path, const LabelArgs& a);

}  // namespace potmap::cli
