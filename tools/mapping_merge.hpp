#pragma once
// `mpirun -n N potmap mapping LOG` for a 2D log: each rank maps its contiguous part of the scans
// (map_pipeline.hpp, MapJob::start_at), then every rank sends its overall map and its run's
// totals (held-out samples, timings) to rank 0, which merges the maps (RePOT's persistent maps
// in information form, POT's averaged maps by their sums) and scores the merged map on every
// scan's held-out samples, as one process scores its map (docs/mapping-ranks.md).
#include "map_pipeline.hpp"
#include "mapping_ranks.hpp"

namespace potmap::cli {

/// Throws ArgumentError when a mapper with these options makes a map that cannot be merged
/// (POT's summed kernels, --preset paper): checked before the ranks map anything.
void check_rank_mergeable(const MapperOptions& options);

/// On rank 0: receives the other ranks' maps and totals, merges them with `r`'s into
/// r.merged, and sets r's scans, timings, scores and totals to the whole run's; returns true.
/// On the other ranks: sends this rank's map and totals to rank 0 and returns false (nothing
/// is left for them to do). `part` is this rank's.
bool merge_rank_maps(MappingRanks& ranks, Context* ctx, const RankPart& part, MapJobResult& r);

}  // namespace potmap::cli
