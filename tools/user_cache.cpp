#include "user_cache.hpp"

#include <cstdlib>

namespace potmap::cli {

namespace {

std::string env(const char* name) {
  const char* v = std::getenv(name);
  return v ? std::string(v) : std::string();
}

}  // namespace

std::string kernel_cache_dir() {
  const std::string own = env("POTMAP_CACHE_DIR");
  return own.empty() ? user_cache_dir("kernels") : own;
}

}  // namespace potmap::cli
