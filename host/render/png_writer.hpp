#pragma once
// Streaming 8-bit RGB PNG writer: rows are compressed as they arrive, so memory stays at one row
// whatever the image size. The file appears atomically (see atomic_file.hpp).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace potmap::detail {

class PngWriter {
 public:
  /// Starts `path` (width x height pixels, both > 0). Throws potmap::Error naming the file.
  PngWriter(const std::string& path, std::size_t width, std::size_t height);
  ~PngWriter();
  PngWriter(const PngWriter&) = delete;
  PngWriter& operator=(const PngWriter&) = delete;

  /// Appends the next row, top first: `rgb` holds width * 3 bytes (R, G, B).
  void write_row(const std::uint8_t* rgb);
  /// Writes the end of the image and syncs the temporary file (AtomicFile::sync), so that a
  /// writer of several images meets a full disk before it renames any. Throws potmap::Error if
  /// rows are missing or the write fails; the temporary file is removed then.
  void complete();
  /// complete() (unless done) and renames the file into place. Throws as complete() does.
  void finish();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace potmap::detail
