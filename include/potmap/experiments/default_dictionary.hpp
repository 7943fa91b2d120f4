#pragma once
// The built-in default dictionaries (what `potmap map`, `potmap mapping` and
// potmap.default_dictionary() use without a dictionary of their own): atoms cut from drives
// through the three built-in towns (2D: the towns' 2D laser; 3D: the 32-ring LIDAR of the 3D
// frames), built once and cached in the user's cache folder, so that every later run, command
// or program, reads the same file.
#include <cstddef>
#include <functional>
#include <string>

#include "potmap/export.h"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/default_dictionary_file.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap::experiment {

// Its file, recipe and version (potmap/pot/default_dictionary_file.hpp).
using potmap::default_dictionary_path;
using potmap::default_dictionary_recipe;
using potmap::kDefaultDictionary3dVersion;
using potmap::kDefaultDictionaryVersion;
using potmap::user_cache_dir;

/// The default dictionary built from scratch: towns town1, town2 and town3 (seed 0), each
/// driven for `scans` scans 2 m apart (route seed 0), scans cut at 20 m, the experiments'
/// atoms (build_atoms with PotSetup's defaults, seed 0): a joint BHM of each town, atoms from
/// 10 scans of each. Deterministic: no device is used. `progress`, when set, is called with
/// the fraction done (0 to 1) after each town (its time: docs/figures.json, dict.default.build).
Dictionary build_default_dictionary(std::size_t scans = 200,
                                    const std::function<void(double)>& progress = {});

/// The 3D default dictionary built from scratch: towns town1, town2 and town3 (seed 0), each
/// driven for `scans` scans 4 m apart with the 3D frames' sensor (sim_options_3d: 32 rings,
/// 20 m), atoms from 10 scans of each by frame_setup_3d()'s settings (kernels at the atoms'
/// samples thinned to 1 m, the drive BHM's spacing). Deterministic: no device is used.
/// `progress` as above (its time: docs/figures.json, dict.default3d.build).
Dictionary build_default_dictionary_3d(std::size_t scans = 20,
                                       const std::function<void(double)>& progress = {});

/// What default_dictionary() tells its caller while it works (each may be empty: silence).
struct DefaultDictionaryNotes {
  /// A line for the user: the build starting (long enough to announce), an unreadable cache
  /// rebuilt, a cache that could not be written, the build done.
  std::function<void(const std::string&)> note;
  /// Called once when a build starts; what it returns receives the fraction done.
  std::function<std::function<void(double)>()> start_progress;
};

/// The default dictionary of dimension `dim` (2 or 3): read from the cache, or built and
/// written there when missing or unreadable (concurrent callers, processes too, build it
/// once: the others wait on a lock beside the file, then read it). `where` receives the file
/// it came from ("" when built without a cache folder). Throws ArgumentError for another dim.
Dictionary default_dictionary(int dim = 2, std::string* where = nullptr,
                              const DefaultDictionaryNotes& notes = {});

}  // namespace potmap::experiment
POTMAP_CXX_API_END
