#pragma once
// A 2D recording (any log potmap reads) mapped in one call, as `potmap mapping LOG` maps it:
// scans cut at 20 m, the default dictionary, RePOT with the library's defaults, every scan's
// held-out beams scored on its instantaneous map and on the overall map (pot/map_run.hpp).
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "potmap/data/scan.hpp"
#include "potmap/experiments/default_dictionary.hpp"
#include "potmap/export.h"
#include "potmap/pot/map_run.hpp"
#include "potmap/pot/mapper.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap::experiment {

/// How map_recording() maps.
struct RecordingOptions {
  /// The mapper's settings (default: the library's, RePOT: pot.refine true, as `potmap
  /// mapping`; MapperOptions::paper() for the authors' rules).
  MapperOptions mapper = [] {
    MapperOptions o;
    o.pot.refine = true;
    return o;
  }();
  /// Returns farther than this become no-returns, metres (default 20: the towns' range, which
  /// the default dictionary's atoms are cut at; 0: none).
  double range_cut = 20;
  std::size_t first = 0;      ///< scans skipped
  std::size_t max_scans = 0;  ///< at most this many mapped (0: all)
  std::string dictionary;     ///< a .potdict (empty: the default dictionary, default_dictionary())
};

/// The scans of a recording from scan `first`, at most `max_scans` of them (0: all), each cut at
/// `range_cut` metres when it is > 0 (limit_range). Throws InputError naming the file when it
/// holds no scans, ArgumentError when it holds no more than `first`.
std::vector<Scan> read_recording(const std::string& path, double range_cut, std::size_t first = 0,
                                 std::size_t max_scans = 0);

/// What map_recording() made.
struct RecordingMap {
  std::shared_ptr<Mapper> mapper;  ///< holds the overall map (Mapper::overall_map())
  MapRunSummary summary;           ///< held-out scores, timings
  std::string dictionary;          ///< the atoms' file ("" for a default one built uncached)
  std::size_t atoms = 0;
  double seconds = 0;  ///< wall-clock time of the mapping (reading and dictionary apart)
};

/// Maps the 2D recording at `path` (read_recording() with `options`) on `ctx` (null: the CPU
/// reference, slow) into one overall map and scores it on the held-out beams of every scan
/// (20 % by default, never used for transport). `notes` as for default_dictionary(), used when
/// the default dictionary has to be built. Throws ArgumentError for a 3D drive folder (map it
/// with DriveMapper, `potmap mapping`) or when the recording's dimension is not the
/// dictionary's.
RecordingMap map_recording(Context* ctx, const std::string& path,
                           const RecordingOptions& options = {},
                           const DefaultDictionaryNotes& notes = {});

}  // namespace potmap::experiment
POTMAP_CXX_API_END
