#pragma once
// The user's cache folder of the potmap command (compiled kernels, the default dictionary).
#include <string>

#include "potmap/experiments/default_dictionary.hpp"

namespace potmap::cli {

/// `sub` under the user's cache root (potmap/experiments/default_dictionary.hpp).
using experiment::user_cache_dir;

/// Where the command's compiled kernels go: POTMAP_CACHE_DIR when set (the library reads it
/// itself), else user_cache_dir("kernels"), so that a second run skips the OpenCL compiler.
std::string kernel_cache_dir();

}  // namespace potmap::cli
