#pragma once
// The POT mapping job shared by `potmap map` and `potmap demo`: stream scans through
// map_scans(), accumulate the overall map (POT's OverallMap, or RePOT's persistent RepotMap), score
// instantaneous and overall maps on the scans' held-out samples, report per-scan timing.
#include <nlohmann/json.hpp>

#include <optional>
#include <string>
#include <vector>

#include "potmap/map/metrics.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/mapper.hpp"
#include "potmap/pot/overall_map.hpp"
#include "potmap/runtime/context.hpp"

namespace potmap::cli {

struct MapJob {
  MapperOptions mapper;
  OverallMapOptions overall;
  std::string instantaneous_dir;  ///< write each instantaneous map here (empty: don't)
  bool verbose = true;            ///< a line per scan on stderr (else a progress bar on a tty)
};

struct MapJobResult {
  OverallMap overall;             ///< POT's merged map (empty for RePOT's persistent map)
  std::optional<RepotMap> repot;  ///< RePOT's persistent map (persistent_refine(job.mapper))
  /// The overall map, whichever the kind.
  const KernelMap& overall_map() const { return repot ? repot->map() : overall.map(); }
  std::size_t overall_kernels() const { return repot ? repot->size() : overall.size(); }
  std::size_t overall_memory_bytes() const {
    return repot ? repot->memory_bytes() : overall.memory_bytes();
  }
  Scores instantaneous;   ///< every scan's held-out samples on its own instantaneous map
  Scores overall_scores;  ///< every scan's held-out samples on the final overall map
  std::size_t scans = 0;
  PotTiming mean_timing;     ///< per scan
  double mean_wall_ms = 0;   ///< per scan, solve to callback
  double total_seconds = 0;  ///< whole run, preparation included
  double max_wall_ms = 0;
  std::size_t kernels_per_scan = 0;
  nlohmann::json to_json() const;
};

MapJobResult run_map_job(Context* ctx, const Dictionary& dict, const std::vector<Scan>& scans,
                         const MapJob& job);

}  // namespace potmap::cli
