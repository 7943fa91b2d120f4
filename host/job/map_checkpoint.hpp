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

#include "potmap/pot/map_run.hpp"

namespace potmap::job {

/// The per-scan totals of a mapping run (potmap/pot/map_run.hpp).
using MapRunTotals = potmap::MapRunTotals;

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

}  // namespace potmap::job
