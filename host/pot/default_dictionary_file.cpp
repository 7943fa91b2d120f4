#include "potmap/pot/default_dictionary_file.hpp"

#include <cstdlib>
#include <filesystem>

namespace potmap {

namespace {

std::string env(const char* name) {
  const char* v = std::getenv(name);
  return v ? std::string(v) : std::string();
}

}  // namespace

std::string default_dictionary_recipe(int dim) {
  if (dim == 3)
    return "potmap 3D default dictionary v" + std::to_string(kDefaultDictionary3dVersion) +
           ": town1+town2+town3 (seed 0), 32-ring LIDAR drives 4 m apart, 20 m, joint BHM atoms "
           "(frame_setup_3d)";
  return "potmap default dictionary v" + std::to_string(kDefaultDictionaryVersion) +
         ": town1+town2+town3 (seed 0), drives 2 m apart, 20 m, joint BHM atoms (PotSetup)";
}

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

std::string default_dictionary_path(int dim) {
  const std::string dir = user_cache_dir("dictionaries");
  if (dir.empty()) return {};
  const std::string name = dim == 3 ? "default-3d-v" + std::to_string(kDefaultDictionary3dVersion)
                                    : "default-v" + std::to_string(kDefaultDictionaryVersion);
  return (std::filesystem::path(dir) / (name + ".potdict")).string();
}

}  // namespace potmap
