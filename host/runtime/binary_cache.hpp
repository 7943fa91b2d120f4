#pragma once
// On-disk cache of compiled OpenCL program binaries. A missing entry, or one written by another
// version of the format, is a quiet miss; a corrupt or truncated entry (checksum, lengths or key
// wrong) is a miss with one warning naming the file, and is removed so that the rebuild replaces
// it. A folder that cannot be made, read or written disables the cache with one warning. Never
// throws.
//
// Entry layout (native byte order: the cache belongs to one machine's driver):
//   "POTMAP-CL-BINARY-2\n", u64 key length, key, u64 binary length, u64 FNV-1a of the binary,
//   binary.

#include <optional>
#include <string>
#include <vector>

namespace potmap::detail {

class BinaryCache {
 public:
  explicit BinaryCache(std::string dir);
  bool enabled() const { return enabled_; }
  /// The binary stored under `key`, if any (the stored key must match exactly and the checksum
  /// must hold). A damaged entry warns on stderr and is removed.
  std::optional<std::vector<unsigned char>> load(const std::string& key) const;
  /// Stores atomically (temporary file, fsync, rename). Failure disables the cache.
  void store(const std::string& key, const std::vector<unsigned char>& binary);
  /// Removes the entry of `key` after the driver rejected it (clCreateProgramWithBinary or
  /// clBuildProgram failed), with a warning naming the file and `why`.
  void reject(const std::string& key, const std::string& why);
  /// The file that holds (or would hold) the entry of `key`.
  std::string path_for(const std::string& key) const;

 private:
  std::string dir_;
  bool enabled_ = false;
};

}  // namespace potmap::detail
