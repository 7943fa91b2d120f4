#pragma once
// A file that appears under its final name only once it is complete: it is written to a
// temporary file in the same folder (so that rename() is atomic on POSIX file systems) and
// renamed by commit(). If commit() is never reached the temporary file is removed, so a failed
// write leaves nothing behind and never clobbers an existing file with half a result.

#include <cstddef>
#include <cstdio>
#include <string>

namespace potmap::detail {

/// Creates the folders above `path` that do not exist yet (an output file's folder), so that
/// every writer of the library writes into a folder named for the first time. Here rather than
/// in file_util because the experiments library carries its own copy of this file. Throws
/// potmap::Error naming the folder when one cannot be created.
void make_parent_folders(const std::string& path);

class AtomicFile {
 public:
  /// Creates the temporary file next to `path`, and the folders above it that do not exist yet
  /// (make_parent_folders). Throws potmap::Error naming `path` on failure.
  explicit AtomicFile(const std::string& path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  std::FILE* file() { return file_; }
  const std::string& path() const { return path_; }
  /// Writes `n` bytes; throws potmap::Error naming the file on a short write. Every
  /// kWritebackBytes the bytes written so far are handed to the disk (on Linux
  /// sync_file_range(SYNC_FILE_RANGE_WRITE), which starts the writeback and does not wait), so
  /// that sync() at the end waits for the last few MiB rather than the whole file. Bytes written
  /// through file() directly are not counted.
  void write(const void* data, std::size_t n);
  /// Flushes the temporary file and fsyncs it: a full disk shows here at the latest. A writer of
  /// several files syncs every one before committing any, so that a failure leaves all the
  /// previous files in place. Throws potmap::Error naming the file (the temporary file is then
  /// removed).
  void sync();
  /// Syncs (unless sync() already did), closes and renames the temporary file to its final
  /// name. Throws on failure (the temporary file is then removed and the previous file is left
  /// as it was). The folder is not synced: after a crash the name holds the previous file or
  /// the new one, both whole, and a folder fsync would add 4 to 9 ms a file here (ext4,
  /// measured), which a job writing hundreds of tiles would feel.
  void commit();
  /// Removes the temporary file now (also done by the destructor unless committed).
  void discard() noexcept;

 private:
  /// 8 MiB: large enough that the hint costs nothing beside the copy, small enough that the
  /// disk is kept busy while the writer computes the next bytes.
  static constexpr std::size_t kWritebackBytes = std::size_t(8) << 20;
  void start_writeback();

  std::string path_;
  std::string temp_;
  std::size_t written_ = 0, handed_over_ = 0;
  std::FILE* file_ = nullptr;
  bool synced_ = false;
  bool done_ = false;
};

}  // namespace potmap::detail
