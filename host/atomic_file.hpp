#pragma once
// Writing a file so that readers never see it half-written: the bytes go to a temporary file in
// the destination's folder (same file system, so the final rename is atomic on POSIX), and the
// temporary replaces the destination only once everything was written and flushed.

#include <cstddef>
#include <cstdio>
#include <string>

namespace potmap::detail {

class AtomicFile {
 public:
  /// Creates the temporary file next to `path`. Throws potmap::Error if it cannot.
  explicit AtomicFile(const std::string& path);
  /// Removes the temporary file unless commit() succeeded.
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  /// Appends bytes. Throws potmap::Error on a write error (disk full, ...).
  void write(const void* data, std::size_t size);
  void write(const std::string& s) { write(s.data(), s.size()); }
  /// Flushes, closes and renames the temporary file onto the destination.
  void commit();

  const std::string& path() const { return path_; }

 private:
  [[noreturn]] void fail(const std::string& what);

  std::string path_;
  std::string temp_;
  std::FILE* file_ = nullptr;
  bool committed_ = false;
};

/// Writes `bytes` to `path` atomically.
void write_file_atomically(const std::string& path, const std::string& bytes);

/// The whole content of a file. Throws InputError naming the path if it cannot be read.
std::string read_whole_file(const std::string& path);

}  // namespace potmap::detail
