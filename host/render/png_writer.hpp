#pragma once
// Streaming 8-bit PNG writer, RGB or indexed colour (a palette of up to 256 colours): rows are
// compressed as they arrive, so memory stays at one row whatever the image size. The file
// appears atomically (see atomic_file.hpp).
//
// Compression: RGB pictures (figures, small) use zlib level 6 with libpng's adaptive filters,
// the smallest files. Indexed pictures (rasters, up to 10^12 pixels) are written for speed:
// the Up filter on every row and zlib level 1 with run-length matching (Z_RLE). On an index
// image of a smooth field neighbouring rows hold nearly the same indices, so the Up-filtered
// rows are mostly runs of zeros: run-length matching (matches at distance 1 only) finds them
// for less time than zlib's full search, and here gives smaller files too. The adaptive choice
// (five trial filters a row) and higher levels cost far more time for files barely smaller.
// docs/raster-scale.md has the measurements.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "potmap/render/colormap.hpp"

namespace potmap::detail {

class PngWriter {
 public:
  /// Starts `path` (width x height pixels, both > 0). Throws potmap::Error naming the file.
  PngWriter(const std::string& path, std::size_t width, std::size_t height);
  /// Starts an indexed-colour picture: each pixel is one byte, an index into `palette` (1 to
  /// 256 colours). Throws potmap::Error naming the file.
  PngWriter(const std::string& path, std::size_t width, std::size_t height,
            const std::vector<Rgb>& palette);
  ~PngWriter();
  PngWriter(const PngWriter&) = delete;
  PngWriter& operator=(const PngWriter&) = delete;

  /// Appends the next row, top first: width * 3 bytes (R, G, B), or width palette indices for
  /// an indexed picture (an index past the palette makes the file invalid: the caller's duty).
  void write_row(const std::uint8_t* row);
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
