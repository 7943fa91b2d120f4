#pragma once
// Scans mapped by POT or RePOT, the part of the mapping job (job/mapping_job.hpp) that `potmap
// map` and `potmap demo` also run on scans of their own: stream scans through map_scans(),
// accumulate the overall map (POT's OverallMap, or RePOT's persistent RepotMap), score
// instantaneous and overall maps on the scans' held-out samples, report per-scan timing; write
// checkpoints of the run and continue one.
#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "potmap/export.h"
#include "potmap/learn/bhm_joint.hpp"
#include "potmap/map/metrics.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/averaged_map.hpp"
#include "potmap/pot/map_run.hpp"
#include "potmap/pot/mapper.hpp"
#include "potmap/pot/overall_map.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap::job {

/// Checkpoints of a mapping run (`potmap map --checkpoint`): the mapper's state and the run's
/// totals in one file, replaced atomically, so that a run killed at any moment can continue.
struct MapCheckpointing {
  std::string path;          ///< checkpoint file (empty: none written, none resumed)
  std::size_t every = 0;     ///< after every this many scans (0: not by count)
  double every_seconds = 0;  ///< or when this long has passed since the last one (0: not)
  bool resume = false;       ///< continue from `path` when it exists
  /// The run's record, a JSON object (the inputs' fingerprints and every option that changes
  /// the map): a resumed checkpoint must hold the same.
  std::string run = "{}";
};

struct MapJob {
  MapperOptions mapper;
  /// Index of the first scan of `scans` to map (those before it are skipped): an MPI rank's
  /// part of a run, labelled as in the whole run (Mapper::start_at).
  std::size_t start_at = 0;
  OverallMapOptions overall;
  std::string instantaneous_dir;  ///< write each instantaneous map here (empty: don't)
  /// Look-ahead (default false; RePOT's persistent map): each scan's held-out samples on the
  /// map before the scan joins it (map_scored(), MapRunTotals::ahead_*).
  bool lookahead = false;
  MapCheckpointing checkpoint;
  /// After each scan: its index in `scans`, the scans done and in all of this run, and a line
  /// on it (sectors, kernels, time). May throw to stop the run.
  std::function<void(std::size_t index, std::size_t done, std::size_t total,
                     const std::string& line)>
      after_scan;
  /// Lines of the run's account (a checkpoint resumed or replaced).
  std::function<void(const std::string& line)> note;
};

/// The overall maps of a run's parts (MPI ranks) merged into one (job/mapping_merge.hpp).
struct MergedOverall;

struct MapJobResult {
  /// The overall map: POT's merged map, or RePOT's persistent map (persistent_refine()).
  std::unique_ptr<Mapper> mapper;
  /// Set on rank 0 of an MPI run once the ranks' maps are merged: then the overall map.
  std::shared_ptr<const MergedOverall> merged;
  const KernelMap& overall_map() const;
  std::size_t overall_kernels() const;
  std::size_t overall_memory_bytes() const;
  bool persistent() const { return mapper->repot() != nullptr; }
  /// Writes the overall map with what merging needs (write_mapper_map, or the merged form).
  void write_overall_map(const std::string& path) const;
  MapRunTotals totals;            ///< the run's held-out samples and sums (a rank's: its part's)
  std::size_t resumed_at = 0;     ///< scans a checkpoint held when the run began (0: none)
  std::size_t checkpoints = 0;    ///< checkpoints written by this stretch of the run
  double checkpoint_seconds = 0;  ///< wall-clock time they took
  Scores instantaneous;           ///< every scan's held-out samples on its own instantaneous map
  Scores overall_scores;          ///< every scan's held-out samples on the final overall map
  /// MapJob::lookahead: the held-out samples on the map before their scan joined it, all and
  /// beyond every earlier sample's reach (n 0 and NaN without).
  Scores lookahead{NAN, NAN, NAN, 0}, lookahead_beyond{NAN, NAN, NAN, 0};
  std::size_t scans = 0;
  PotTiming mean_timing;     ///< per scan
  double mean_wall_ms = 0;   ///< per scan, solve to callback
  double total_seconds = 0;  ///< whole run, preparation included
  double max_wall_ms = 0;
  std::size_t kernels_per_scan = 0;
  /// The run as a JSON object's text (scores.json's part on the mapping).
  std::string to_json() const;
};

/// Fills `r`'s scans, timings and scores from `totals`, the overall map (r.overall_map()) scored
/// on every held-out sample of `totals` on `ctx`'s device.
void summarise(MapJobResult& r, const MapRunTotals& totals, Context* ctx);

MapJobResult run_map_job(Context* ctx, const Dictionary& dict, const std::vector<Scan>& scans,
                         const MapJob& job);

}  // namespace potmap::job
POTMAP_CXX_API_END
