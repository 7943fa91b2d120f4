#pragma once
// Cloud-Optimized GeoTIFF output: float32 bands in internal tiles, with overviews, compressed
// with the floating-point predictor, in the layout of GDAL's COG driver.
//
// Two writers of the same file: write_cog_encoded() takes blocks already compressed (by
// encode_block(), as a tiled raster job stores them) and lays the file out around their bytes,
// compressing only the overviews; write_cog() stages the bands uncompressed and has GDAL's COG
// driver copy them (each block compressed there). For the same values and options both write
// the same bytes (tested), except uncompressed files, where GDAL 3.6 writes no COG header and
// write_cog_encoded() does. Memory stays bounded whatever the image size: a block, a bounded
// GDAL block cache, and write_cog_encoded()'s overviews up to GeoTiffSpec::overview_memory
// (in a staging file past it).
//
// In a shared build geotiff_writer.cpp is a module of its own, libpotmap_gdal.so beside
// libpotmap, which geotiff_module.cpp loads on the first call: processes that write no GeoTIFF
// do not load GDAL. The functions below are the same either way.

#include <cmath>
#include <cstddef>
#include <cstdint>
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
  /// The codec's level; 0: its default (default_level()).
  int level = 0;
  /// Bytes up to which write_cog_encoded() computes the overviews in memory rather than in a
  /// staging file; default 512 MiB: the overviews of about 400 M cells of two bands (a
  /// quarter of the image and a third of that again), where a file costs a second of writing
  /// and reading back at 64 M cells.
  std::size_t overview_memory = std::size_t(512) << 20;
  std::vector<std::pair<std::string, std::string>> metadata;  ///< dataset metadata items
};

/// ZSTD's default level: the fast level -1 writes a dense float32 map (with the predictor)
/// about 10 % faster end to end than level 1 for 3 % more bytes, and a sparse drive map (most
/// of the window far from any kernel) in the same time for 3 % more; faster levels gain little
/// more time on dense maps and cost half as many bytes again on sparse ones
/// (docs/raster-scale.md).
constexpr int kZstdDefaultLevel = -1;

/// The level `compression` compresses at for a requested `level`: `level` itself unless 0, the
/// codec's default then (ZSTD kZstdDefaultLevel, DEFLATE 1: the fastest of zlib's, about the
/// size of its default on these maps); 0 for LZW and NONE, which have no level.
inline int default_level(const std::string& compression, int level = 0) {
  if (compression == "ZSTD") return level ? level : kZstdDefaultLevel;
  if (compression == "DEFLATE") return level ? level : 1;
  return 0;
}

/// Throws ArgumentError naming `path` and the value unless `compression` is a codec write_cog
/// takes (ZSTD, DEFLATE, LZW or NONE, upper case as GDAL names them).
inline void check_compression(const std::string& compression, const std::string& path) {
  for (const char* ok : {"ZSTD", "DEFLATE", "LZW", "NONE"})
    if (compression == ok) return;
  throw ArgumentError(path + ": GeoTIFF compression '" + compression +
                      "': expected zstd, deflate, lzw or none");
}

/// Throws ArgumentError naming `path` and the value unless `level` is 0 (the codec's default) or
/// a level of `compression`: ZSTD -20 to -1 (its fast levels) and 1 to 22, DEFLATE 1 to 9;
/// LZW and NONE have none.
inline void check_level(const std::string& compression, int level, const std::string& path) {
  if (level == 0) return;
  const bool ok = compression == "ZSTD"      ? level >= -20 && level <= 22
                  : compression == "DEFLATE" ? level >= 1 && level <= 9
                                             : false;
  if (ok) return;
  const std::string range = compression == "ZSTD"      ? "-20 to -1 or 1 to 22"
                            : compression == "DEFLATE" ? "1 to 9"
                                                       : "none (" + compression + " has no level)";
  throw ArgumentError(path + ": GeoTIFF compression level " + std::to_string(level) + " for " +
                      compression + ": expected " + range);
}

/// Fills one block: `bands[b]` receives width * height floats of band b, row-major, for the
/// block at pixel (x0, y0) of size width x height.
using BlockFill = std::function<void(std::size_t x0, std::size_t y0, std::size_t width,
                                     std::size_t height, std::vector<float*>& bands)>;

/// Writes the GeoTIFF at `path` through GDAL's COG driver (a temporary name in the same folder,
/// renamed when complete; nothing is left behind on failure). Blocks are requested in row-major
/// order. Throws potmap::Error naming the file and GDAL's message.
void write_cog(const std::string& path, const GeoTiffSpec& spec, const BlockFill& fill,
               const std::function<void(double)>& progress = {});

/// The first overview of a w x h block of one band (row-major): each cell the mean of the 2 x 2
/// cells it covers that are numbers (NaN, the nodata value, where none is), as GDAL's AVERAGE;
/// (w + 1) / 2 x (h + 1) / 2 cells, those past an odd edge covering one row or column.
inline void average_halves(const float* in, std::size_t w, std::size_t h, float* out) {
  const std::size_t hw = (w + 1) / 2, hh = (h + 1) / 2;
  // Whole 2 x 2 squares without branches, so that the compiler vectorises them (a tiled job
  // halves every tile on its writer thread, beside the kernel): a NaN adds 0 where the loop
  // below skips it, the same sum bit for bit, since the sum starts at +0.
  for (std::size_t r = 0; r < h / 2; ++r) {
    const float* a = in + 2 * r * w;
    const float* b = a + w;
    float* o = out + r * hw;
    for (std::size_t c = 0; c < w / 2; ++c) {
      const float v[4] = {a[2 * c], a[2 * c + 1], b[2 * c], b[2 * c + 1]};
      double sum = 0;
      int n = 0;
      for (float x : v) {
        const bool number = !std::isnan(x);
        sum += number ? double(x) : 0.0;
        n += number;
      }
      o[c] = n ? float(sum / n) : std::nanf("");
    }
  }
  for (std::size_t r = 0; r < hh; ++r)
    for (std::size_t c = r < h / 2 ? w / 2 : 0; c < hw; ++c) {  // the odd edges
      double sum = 0;
      int n = 0;
      for (std::size_t dr = 0; dr < 2 && 2 * r + dr < h; ++dr)
        for (std::size_t dc = 0; dc < 2 && 2 * c + dc < w; ++dc) {
          const float v = in[(2 * r + dr) * w + 2 * c + dc];
          if (!std::isnan(v)) {
            sum += v;
            ++n;
          }
        }
      out[r * hw + c] = n ? float(sum / n) : std::nanf("");
    }
}

/// One block as the COG stores it: the bands (`bands[b]`: width * height floats, row-major)
/// pixel-interleaved into a spec.block x spec.block tile (zeros past the image edge, as GDAL
/// pads), the floating-point predictor unless spec.compression is NONE, then the codec through
/// libtiff: the bytes GDAL writes for the same block. `path` names the file in errors.
std::string encode_block(const std::string& path, const GeoTiffSpec& spec,
                         const std::vector<const float*>& bands, std::size_t width,
                         std::size_t height);

/// The inverse of encode_block(): `bands[b]` receives width * height floats. Throws
/// potmap::Error naming `path` if the bytes do not decode to a block of this spec.
void decode_block(const std::string& path, const GeoTiffSpec& spec, const std::string& bytes,
                  std::size_t width, std::size_t height, const std::vector<float*>& bands);

/// Where a full-resolution block's compressed bytes (encode_block()) are: `size` bytes at
/// `offset` in `file`.
struct EncodedBlock {
  std::string file;
  std::uint64_t offset = 0, size = 0;
};

/// Gives the full-resolution block at block row `row`, column `col` (pixels x0 = col * block,
/// y0 = row * block): fills `halves` (one pointer a band, room for (w + 1) / 2 x (h + 1) / 2
/// floats; empty when spec.overviews is false) with its first overview level (average_halves)
/// and returns where its compressed bytes are. Called once a block, in row-major order.
using EncodedBlockSource = std::function<EncodedBlock(std::size_t row, std::size_t col,
                                                      const std::vector<float*>& halves)>;

/// Writes the COG at `path` from blocks compressed beforehand: the coarser overviews computed
/// from the first level (halved here where a level's source has even sides, by GDAL's
/// resampler from the first odd one), the overviews compressed here, the blocks' bytes copied
/// as they are. A temporary name in the same folder, synced and renamed when complete; nothing is
/// left behind on failure. Throws potmap::Error naming the file.
void write_cog_encoded(const std::string& path, const GeoTiffSpec& spec,
                       const EncodedBlockSource& source,
                       const std::function<void(double)>& progress = {});

/// Reads band `band` (1-based) of a GeoTIFF whole, with its size and geotransform: for tests
/// and tools that check what was written.
struct GeoTiffImage {
  std::size_t width = 0, height = 0, bands = 0, block_x = 0, block_y = 0, overviews = 0;
  double geotransform[6] = {0, 0, 0, 0, 0, 0};
  std::string crs_wkt;
  std::string compression;  ///< GDAL's name of the codec ("ZSTD", ...); empty: uncompressed
  std::string layout;       ///< GDAL's IMAGE_STRUCTURE LAYOUT: "COG" for a valid COG layout
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
