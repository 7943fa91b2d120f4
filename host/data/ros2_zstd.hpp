#pragma once
// rosbag2's zstd compression undone: whole .db3.zstd files (FILE mode) into a temporary file
// that SQLite can open, and single messages (MESSAGE mode) in memory.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace potmap::data {

/// A file under the system's temporary folder, removed when this goes.
class TempFile {
 public:
  explicit TempFile(const std::string& stem);
  ~TempFile();
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

/// Decompresses the zstd file `from` into `to` (streamed: a bag's file may be larger than
/// memory). Throws InputError naming `from` when it is not zstd or is cut short.
void zstd_decompress_file(const std::string& from, const std::string& to);

/// One zstd frame (or several) in memory. Throws InputError naming `where`.
std::vector<std::uint8_t> zstd_decompress(const std::uint8_t* data, std::size_t size,
                                          const std::string& where);

}  // namespace potmap::data
