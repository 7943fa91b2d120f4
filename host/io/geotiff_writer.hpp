#pragma once
// Cloud-Optimized GeoTIFF output through GDAL: float32 bands written block by block into a
// tiled staging file, then copied by GDAL's COG driver into the final layout (internal tiles,
// overviews, compressed with the floating-point predictor). Memory stays bounded by a block
// and a bounded GDAL block cache, whatever the image size.
//
// In a shared build geotiff_writer.cpp is a module of its own, libpotmap_gdal.so beside
// libpotmap, which geotiff_module.cpp loads on the first call: processes that write no GeoTIFF
// do not load GDAL. The functions below are the same either way.

#include <cstddef>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "potmap/error.hpp"

namespace potmap::detail {

struct GeoTiffSpec {
  std::size_t width = 0, height = 0;  ///< pixels
  std::size_t block = 512;            ///< internal tile edge, pixels (a multiple of 16)
  /// Geotransform: the top-left corner of pixel (0, 0) and the pixel edge, metres (north up).
  double left = 0, top = 0, pixel = 1;
  std::string crs;                      ///< as GDAL reads it; empty: a local frame in metres
  bool overviews = true;                ///< averaged overviews down to one block
  std::vector<std::string> band_names;  ///< one per band
  /// Codec of the blocks, as GDAL names it: ZSTD, DEFLATE, LZW or NONE (TiledRasterOptions
  /// says why ZSTD).
  std::string compression = "ZSTD";
  std::vector<std::pair<std::string, std::string>> metadata;  ///< dataset metadata items
};

/// Throws ArgumentError naming `path` and the value unless `compression` is a codec write_cog
/// takes (ZSTD, DEFLATE, LZW or NONE, upper case as GDAL names them).
inline void check_compression(const std::string& compression, const std::string& path) {
  for (const char* ok : {"ZSTD", "DEFLATE", "LZW", "NONE"})
    if (compression == ok) return;
  throw ArgumentError(path + ": GeoTIFF compression '" + compression +
                      "': expected zstd, deflate, lzw or none");
}

/// Fills one block: `bands[b]` receives width * height floats of band b, row-major, for the
/// block at pixel (x0, y0) of size width x height.
using BlockFill = std::function<void(std::size_t x0, std::size_t y0, std::size_t width,
                                     std::size_t height, std::vector<float*>& bands)>;

/// Writes the GeoTIFF at `path` (a temporary name in the same folder, renamed when complete;
/// nothing is left behind on failure). Blocks are requested in row-major order. Throws
/// potmap::Error naming the file and GDAL's message.
void write_cog(const std::string& path, const GeoTiffSpec& spec, const BlockFill& fill,
               const std::function<void(double)>& progress = {});

/// Reads band `band` (1-based) of a GeoTIFF whole, with its size and geotransform: for tests
/// and tools that check what was written.
struct GeoTiffImage {
  std::size_t width = 0, height = 0, bands = 0, block_x = 0, block_y = 0, overviews = 0;
  double geotransform[6] = {0, 0, 0, 0, 0, 0};
  std::string crs_wkt;
  std::string compression;  ///< GDAL's name of the codec ("ZSTD", ...); empty: uncompressed
  std::vector<float> values;
  /// The first (finest) overview of the band, when there is one: its size and values.
  std::size_t overview_width = 0, overview_height = 0;
  std::vector<float> overview_values;
};
GeoTiffImage read_geotiff_band(const std::string& path, int band);

/// Throws ArgumentError naming `crs` and `path` unless GDAL reads it (empty is the local frame).
void check_crs(const std::string& crs, const std::string& path);

/// Whether this build has GDAL.
bool geotiff_available();

}  // namespace potmap::detail
