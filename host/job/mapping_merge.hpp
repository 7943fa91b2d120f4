#pragma once
// `mpirun -n N potmap mapping LOG` for a 2D log: each rank maps its contiguous part of the scans
// (job/map_job.hpp, MapJob::start_at), then every rank sends its overall map and its run's
// totals (held-out samples, timings) to rank 0, which merges the maps (RePOT's persistent maps
// in information form, POT's averaged maps by their sums) and scores the merged map on every
// scan's held-out samples, as one process scores its map (docs/mapping-ranks.md).
#include <nlohmann/json.hpp>

#include <optional>

#include "potmap/job/job_ranks.hpp"
#include "potmap/job/map_job.hpp"
#include "potmap/learn/bhm_joint.hpp"
#include "potmap/pot/averaged_map.hpp"

namespace potmap::job {

/// The overall maps of a run's parts (MPI ranks) merged into one: RePOT's persistent maps in
/// information form, or POT's averaged maps by their sums (learn/bhm_joint_merge.hpp).
struct MergedOverall {
  std::optional<JointBhm> joint;
  std::optional<AveragedMap> averaged;
  KernelMap map;          ///< the merged map's export
  nlohmann::json record;  ///< the parts and the merge, for scores.json
  std::size_t kernels() const { return joint ? joint->size() : averaged->size(); }
  std::size_t memory_bytes() const {
    return joint ? joint->memory_bytes() : averaged->memory_bytes();
  }
};

/// Throws ArgumentError when a mapper with these options makes a map that cannot be merged
/// (POT's summed kernels, --preset paper): checked before the ranks map anything.
void check_rank_mergeable(const MapperOptions& options);

/// On rank 0: receives the other ranks' maps and totals, merges them with `r`'s into
/// r.merged, and sets r's scans, timings, scores and totals to the whole run's; returns true.
/// On the other ranks: sends this rank's map and totals to rank 0 and returns false (nothing
/// is left for them to do). `part` is this rank's.
bool merge_rank_maps(JobRanks& ranks, Context* ctx, const RankPart& part, MapJobResult& r,
                     const std::function<void(const std::string&)>& note);

}  // namespace potmap::job
