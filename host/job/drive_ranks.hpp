#pragma once
// `mpirun -n N potmap mapping DRIVE`: each rank maps a contiguous part of the keyframes into
// its own joint BHM (every tile kept, so that its map carries the information form), then
// sends its map, held-out samples and run totals to rank 0, which merges the maps exactly in
// information form (learn/bhm_joint_merge.hpp) and scores the merged map on every keyframe's
// held-out samples, as one process scores its map (docs/mapping-ranks.md).
#include <nlohmann/json.hpp>

#include <functional>
#include <optional>
#include <string>

#include "drive_checkpoint.hpp"
#include "potmap/job/job_ranks.hpp"
#include "potmap/learn/bhm_joint.hpp"
#include "potmap/mapping/drive_mapper.hpp"

namespace potmap::job {

/// The ranks' maps merged, with what one process would have of its run.
struct DriveMerged {
  std::optional<JointBhm> joint;
  KernelMap map;            ///< joint->map()
  LabelledPoints held_out;  ///< every rank's, in keyframe order
  DriveRun run;             ///< every rank's keyframes, in order
  nlohmann::json record;    ///< the parts and the merge, for scores.json
};

/// On rank 0: receives the other ranks' maps and runs and merges them with `mapper`'s and
/// `run`'s. On the other ranks: sends this rank's and returns std::nullopt (nothing is left
/// for them to do). `part` is this rank's keyframes; `note` gets the merge's account.
std::optional<DriveMerged> merge_drive_ranks(JobRanks& ranks, const RankPart& part,
                                             const DriveMapper& mapper, const DriveRun& run,
                                             const std::function<void(const std::string&)>& note);

}  // namespace potmap::job
