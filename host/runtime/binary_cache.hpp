#pragma once
// On-disk cache of compiled OpenCL program binaries. A missing, unreadable or stale entry is a
// miss; an unwritable folder disables the cache with one warning. Never throws.

#include <optional>
#include <string>
#include <vector>

namespace potmap::detail {

class BinaryCache {
 public:
  explicit BinaryCache(std::string dir);
  bool enabled() const { return enabled_; }
  /// The binary stored under `key`, if any (the stored key must match exactly).
  std::optional<std::vector<unsigned char>> load(const std::string& key) const;
  /// Stores atomically (temporary file then rename). Failure disables the cache.
  void store(const std::string& key, const std::vector<unsigned char>& binary);
  /// Removes the entry of `key` (after it failed to load as a program).
  void forget(const std::string& key);

 private:
  std::string path_for(const std::string& key) const;
  std::string dir_;
  bool enabled_ = false;
};

}  // namespace potmap::detail
