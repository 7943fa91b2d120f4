#pragma once
// `potmap mapping DRIVE` for a 3D drive (a SLAM keyframe folder or a KITTI sequence): keyframes
// read one at a time into the joint BHM at the drive defaults (learn/drive_mapper.hpp), with
// progress and checkpoints, then the map and what robotics stacks load from it
// (drive_outputs.hpp) and the scores on held-out beams.
#include <cstddef>
#include <cstdint>
#include <string>

#include "mapping_ranks.hpp"
#include "potmap/data/bag_options.hpp"

namespace potmap::cli {

struct DriveMappingArgs {
  std::string drive, out, json, poses = "odom";
  /// "bhm" (the joint BHM) or "repot" (seeded from `dict`: the built-in 3D dictionary when
  /// empty).
  std::string method = "bhm", dict;
  double range_cut = 40;  ///< metres
  std::size_t first = 0, max_keyframes = 0;
  std::uint64_t seed = 0;
  double band_low = -1.0, band_high = 0.5;  ///< metres about the sensor's height
  double picture_res = 0, voxel_out = 0.4;  ///< metres (0: automatic)
  std::size_t picture_pixels = 1200;        ///< along the longer side (as 2D mapping's pictures)
  /// A checkpoint after every N keyframes (0: not by count) and when this many seconds have
  /// passed since the last (0: not by time); with both 0 none. As `potmap map`'s: a drive
  /// mapper's state is 100-200 MB, so a count of keyframes alone would copy it every second
  /// on a drive mapped at 50 keyframes a second.
  std::size_t checkpoint_every = 0;
  double checkpoint_seconds = 30;
  /// Keyframes between exports of the map so far while the drive goes on (0: only at the end).
  std::size_t export_every = 0;
  std::size_t transfer_every = 4;  ///< RePOT: keyframes between transfers
  /// Where the joint BHM's features and sums run: "auto", "host" or "device" (JointBhmSums).
  std::string sums = "auto";
  BagOptions bag;  ///< ROS bags: topic, fixed frame, poses, keyframe spacing
  bool resume = false, keep_checkpoint = false, quiet = false;
  /// Never retire the learner's far tiles (DriveMapperOptions::retire_radius 0), so that
  /// map.potmap carries the joint BHM's information form (`potmap merge`).
  bool keep_tiles = false;
  /// Forgetting: the joint BHM's half-life, seconds of the keyframes' time (0: never).
  double half_life = 0;
};

/// Runs the job; prints a summary on stdout (stderr with --json -), returns the exit status.
/// On several MPI ranks each maps its part of the keyframes and rank 0 merges their maps
/// (drive_ranks.hpp) and writes the outputs.
int run_drive_mapping(const DriveMappingArgs& a, const std::string& device, MappingRanks& ranks);

}  // namespace potmap::cli
