#pragma once
// The user's cache folder of the potmap command (compiled kernels, the default dictionary).
#include <string>

namespace potmap::cli {

/// `sub` under the user's cache root, $XDG_CACHE_HOME/potmap, else $HOME/.cache/potmap (the XDG
/// base directory rule). Empty when neither variable is set (no cache). Nothing is created here.
std::string user_cache_dir(const std::string& sub);

/// Where the command's compiled kernels go: POTMAP_CACHE_DIR when set (the library reads it
/// itself), else user_cache_dir("kernels"), so that a second run skips the OpenCL compiler.
std::string kernel_cache_dir();

}  // namespace potmap::cli
