#include "user_cache.hpp"

#include <cstdlib>
#include <filesystem>

namespace potmap::cli {

namespace {

std::string env(const char* name) {
  const char* v = std::getenv(name);
  return v ? std::string(v) : std::string();
}

}  // namespace

std::string user_cache_dir(const std::string& sub) {
  std::filesystem::path root;
  if (!env("XDG_CACHE_HOME").empty())
    root = std::filesystem::path(env("XDG_CACHE_HOME")) / "potmap";
  else if (!env("HOME").empty())
    root = std::filesystem::path(env("HOME")) / ".cache" / "potmap";
  else
    return {};
  return (root / sub).string();
}

std::string kernel_cache_dir() {
  const std::string own = env("POTMAP_CACHE_DIR");
  return own.empty() ? user_cache_dir("kernels") : own;
}

}  // namespace potmap::cli
