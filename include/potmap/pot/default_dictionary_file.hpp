#pragma once
// Where the built-in default dictionaries live and what they are made of: the file every run,
// command or program, reads (built once by potmap/experiments/default_dictionary.hpp, `potmap
// dict default` or Python's potmap.default_dictionary()), named after its recipe's version.
#include <string>

#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// Version of the 2D recipe; the cached file is named after it, so a new recipe never reads an
/// old file. Bumped whenever the towns, the drives or the atom settings change.
constexpr int kDefaultDictionaryVersion = 2;  // 2: atoms take the source map's bias (PotSetup)

/// Version of the 3D recipe (build_default_dictionary_3d), as kDefaultDictionaryVersion.
constexpr int kDefaultDictionary3dVersion = 1;

/// What the default dictionary of dimension `dim` (2 or 3) is made of, in words (stored as
/// every atom's source).
std::string default_dictionary_recipe(int dim = 2);

/// `sub` under the user's cache root, $XDG_CACHE_HOME/potmap, else $HOME/.cache/potmap (the
/// XDG base directory rule). Empty when neither variable is set (no cache). Nothing is created.
std::string user_cache_dir(const std::string& sub);

/// The cached file (user_cache_dir("dictionaries")/default-vN.potdict, 3D:
/// default-3d-vN.potdict); empty without a cache folder.
std::string default_dictionary_path(int dim = 2);

}  // namespace potmap
POTMAP_CXX_API_END
