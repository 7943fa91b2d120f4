#pragma once
// Streaming writer of a 2D NumPy .npy array of float32: shape (rows, cols), C order, '<f4'.
// Rows are appended as they come (bounded memory); the file appears atomically.

#include <cstddef>
#include <string>

#include "io/atomic_file.hpp"

namespace potmap::detail {

class NpyWriter {
 public:
  /// Starts `path` for a (rows, cols) array. Throws potmap::Error naming the file.
  NpyWriter(const std::string& path, std::size_t rows, std::size_t cols);
  /// Appends the next row of `cols` floats (stored little-endian whatever the host).
  void write_row(const float* values);
  /// Checks that every row came and syncs the temporary file (AtomicFile::sync), so that a
  /// writer of several arrays meets a full disk before it renames any. Throws potmap::Error if
  /// rows are missing or the write fails; the temporary file is removed then.
  void complete();
  /// complete() and renames the file into place; throws as complete() does.
  void finish();

  /// The header (magic, version 1.0, dictionary padded to a multiple of 64 bytes) for a
  /// (rows, cols) float32 array. Exposed for tests.
  static std::string header(std::size_t rows, std::size_t cols);

 private:
  AtomicFile out_;
  std::size_t rows_, cols_, written_ = 0;
};

}  // namespace potmap::detail
