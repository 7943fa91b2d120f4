#pragma once
// The mapping job for a 3D drive (a SLAM keyframe folder, a KITTI sequence, a ROS bag of point
// clouds): keyframes read one at a time into the joint BHM at the drive defaults
// (mapping/drive_mapper.hpp), with progress and checkpoints, then the map and what robotics
// stacks load from it (drive_outputs.hpp) and the scores on held-out beams.
#include <string>

#include "potmap/job/mapping_job.hpp"

namespace potmap::job {

/// run_mapping_job() for the drive at `drive`; `options` has its range cut and method set,
/// `ranks` the processes sharing the job (hooks.ranks, or this one alone). On several ranks each
/// maps its part of the keyframes and rank 0 merges their maps (drive_ranks.hpp) and writes the
/// outputs.
MappingJobResult run_drive_job(Context& ctx, const std::string& drive,
                               const MappingJobOptions& options, const MappingJobHooks& hooks,
                               JobRanks& ranks);

}  // namespace potmap::job
