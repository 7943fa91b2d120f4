#pragma once
// `potmap map --checkpoint`: what a checkpoint holds besides the mapper's state (saved with it by
// Mapper::save_state as its extra bytes, so that one atomic file holds both): a record of the run
// (the input files' fingerprints and every option that changes the map, as JSON) and the totals
// the summary is computed from (every held-out sample so far with its instantaneous
// probability, the timing sums).
#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "potmap/data/labelled_points.hpp"
#include "potmap/pot/transfer.hpp"

namespace potmap::cli {

/// The per-scan totals of a mapping run (map_pipeline.cpp): what a resumed run needs to end
/// with the summary of an uninterrupted one.
struct MapRunTotals {
  std::vector<float> inst_prob;      ///< held-out samples on their instantaneous maps
  std::vector<std::uint8_t> labels;  ///< their labels
  LabelledPoints test;               ///< the held-out samples, scored on the overall map
  PotTiming timing;                  ///< sums over the scans
  double wall_ms = 0, max_wall_ms = 0;
  std::size_t kernels = 0;  ///< instantaneous kernels, summed
  std::size_t scans = 0;
  double seconds = 0;  ///< wall-clock time of the earlier stretches of the run (resumed ones)
};

/// The extra bytes of a checkpoint: `run` (the run's record) and the totals, with `seconds` the
/// wall-clock time of the whole run so far in place of totals.seconds.
std::string encode_checkpoint(const nlohmann::json& run, const MapRunTotals& totals,
                              double seconds);

/// Reads what encode_checkpoint() wrote; throws InputError naming `path` when it is malformed.
void decode_checkpoint(const std::string& bytes, const std::string& path, nlohmann::json& run,
                       MapRunTotals& totals);

/// Removes what runs killed while writing the checkpoint at `path` left: its temporary files
/// (PATH.tmp-PID-*, io/atomic_file.hpp) of processes that no longer run. Returns how many.
std::size_t remove_stale_temporaries(const std::string& path);

/// Throws ArgumentError naming `path` and every entry of the run record that differs ("--sectors:
/// the checkpoint has 5, this run 7") when `saved` is not `run`.
void check_same_run(const std::string& path, const nlohmann::json& saved,
                    const nlohmann::json& run);

}  // namespace potmap::cli
