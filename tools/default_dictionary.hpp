#pragma once
// The built-in default dictionary of `potmap map` and `potmap mapping` without --dict: atoms
// cut from drives through the three built-in towns, built once and cached in the user's cache
// folder.
#include <functional>
#include <string>

#include "potmap/pot/atoms.hpp"

namespace potmap::cli {

/// Version of the recipe below; the cached file is named after it, so a new recipe never reads
/// an old file. Bump it whenever the towns, the drives or the atom settings change.
constexpr int kDefaultDictionaryVersion = 2;  // 2: atoms take the source map's bias (PotSetup)

/// What the default dictionary is made of, in words (stored as every atom's source).
std::string default_dictionary_recipe();

/// The default dictionary built from scratch: towns town1, town2 and town3 (seed 0), each
/// driven for `scans` scans 2 m apart (route seed 0), scans cut at 20 m, the experiments'
/// atoms (experiment::build_atoms with PotSetup's defaults, seed 0): a joint BHM of each town,
/// atoms from 10 scans of each. Deterministic: no device is used. `progress`, when set, is
/// called with the fraction done (0 to 1) after each town (the build takes about a minute).
Dictionary build_default_dictionary(std::size_t scans = 200,
                                    const std::function<void(double)>& progress = {});

/// The cached file (user_cache_dir("dictionaries")/default-vN.potdict); empty without a cache
/// folder.
std::string default_dictionary_path();

/// The default dictionary: read from the cache, or built (a note on stderr, about a minute) and
/// written there when missing or unreadable. `where` receives the file it came from ("" when
/// built without a cache folder).
Dictionary default_dictionary(std::string* where = nullptr);

}  // namespace potmap::cli
