#pragma once
// The TIFF side of write_cog_encoded() (geotiff_writer.hpp), part of the GDAL module: the
// directories of a Cloud-Optimized GeoTIFF laid out as GDAL's COG driver lays them out (through
// libtiff, with deferred tile arrays), so that the file is GDAL's byte for byte.
//
// The file: the TIFF header; GDAL's "ghost" structural metadata (LAYOUT=IFDS_BEFORE_DATA,
// row-major blocks, each with its size before it and its last 4 bytes repeated after it); the
// directories, full resolution first, each followed by its values that do not fit in an
// entry; the tile offset and size arrays of every directory in that order; then the blocks,
// the coarsest overview first and the full resolution last.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "io/geotiff_writer.hpp"

namespace potmap::detail {

/// A TIFF field as written: its tag, TIFF type, count and value bytes (little-endian).
struct TiffField {
  std::uint16_t tag = 0, type = 0;
  std::uint64_t count = 0;
  std::string bytes;
};

/// One directory of the COG: an image level, its blocks' offsets and sizes (row-major).
struct CogLevel {
  std::size_t width = 0, height = 0;
  std::vector<std::uint64_t> offsets, sizes;
};

/// What every directory of the file shares.
struct CogFields {
  const GeoTiffSpec* spec = nullptr;
  bool bigtiff = false;
  /// Fields GDAL writes on the full resolution only (georeferencing, GDAL_METADATA), and on
  /// every level (GDAL_NODATA), in the order GDAL sets them.
  std::vector<TiffField> main, every;
};

/// The file's bytes up to the first block: header, ghost metadata, directories and tile
/// arrays, for `levels` (full resolution first). Its size does not depend on the offsets and
/// sizes, so it can be computed before any block is placed.
std::string cog_header(const CogFields& fields, const std::vector<CogLevel>& levels);

/// The fields of GDAL's own GTiff at `tiff` (a whole file in memory) from tag 33550 on
/// (georeferencing, GDAL_METADATA, GDAL_NODATA), in the order their values lie in the file.
/// Throws Error naming `path` if `tiff` is not a little-endian classic TIFF.
std::vector<TiffField> gdal_fields(const std::string& path, const std::string& tiff);

}  // namespace potmap::detail
