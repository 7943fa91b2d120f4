#pragma once
// The built-in default dictionaries of `potmap map` and `potmap mapping` without --dict: the
// library's (potmap/experiments/default_dictionary.hpp), with the command's notes on stderr and
// a progress bar on a terminal while one is built.
#include <string>

#include "potmap/experiments/default_dictionary.hpp"

namespace potmap::cli {

using experiment::build_default_dictionary;
using experiment::build_default_dictionary_3d;
using experiment::default_dictionary_path;
using experiment::default_dictionary_recipe;
using experiment::kDefaultDictionary3dVersion;
using experiment::kDefaultDictionaryVersion;

/// experiment::default_dictionary(dim, where) with its notes on stderr ("potmap: ...") and a
/// progress bar on a terminal while it builds.
Dictionary default_dictionary(std::string* where = nullptr, int dim = 2);

}  // namespace potmap::cli
