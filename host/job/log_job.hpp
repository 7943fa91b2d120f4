#pragma once
// The mapping job for a 2D log: its scans mapped by RePOT (or POT) with the default
// dictionary (job/map_job.hpp), then the map, its pictures, a ROS map and the scores.
#include <string>

#include "potmap/job/mapping_job.hpp"

namespace potmap::job {

/// run_mapping_job() for the 2D log at `log`; `options` has its range cut and method set,
/// `ranks` the processes sharing the job (hooks.ranks, or this one alone).
MappingJobResult run_log_job(Context& ctx, const std::string& log, const MappingJobOptions& options,
                             const MappingJobHooks& hooks, JobRanks& ranks);

}  // namespace potmap::job
