#pragma once
// Rasterising a large window in tiles: each tile is evaluated on its own and kept as a small
// checksummed file in a work folder, so that a job killed at any point resumes where it stopped,
// several processes (MPI ranks) can share one job, and memory stays bounded by the tile size
// whatever the window. When every tile is there, they are assembled into one Cloud-Optimized
// GeoTIFF (through GDAL) with internal tiles and overviews: band 1 probability, band 2
// variance, float32, georeferenced by the window (RasterSpec's orientation and cell centres).
//
// A tile's values depend only on the map, the window, the tile size and the evaluator options,
// never on which process computed it or in what order, so a resumed job, a job split over ranks
// and an uninterrupted one write the same file.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "potmap/export.h"
#include "potmap/map/kernel_map.hpp"
#include "potmap/map/raster.hpp"
#include "potmap/runtime/context.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// How a tiled job cuts and writes the window.
struct TiledRasterOptions {
  /// Tile edge in cells, a multiple of 64 (the evaluator's tile and a GeoTIFF block size);
  /// default 512: 2 MiB of float32 per band and tile, the block size COG readers expect.
  std::size_t tile_cells = 512;
  /// Folder of the finished tiles; default OUT + ".tiles". Reused by a later run with the same
  /// arguments (resume); tiles of another job (another map, window or tile size) found there
  /// are recomputed.
  std::string work_dir;
  /// Remove the work folder once the GeoTIFF is in place; default true (the tiles are the
  /// GeoTIFF's content, kept only to resume).
  bool remove_tiles = true;
  /// Coordinate reference system of the map frame ("EPSG:32633", a WKT or PROJ string, as GDAL
  /// reads it). Empty (default): a local engineering frame in metres, since most robot maps
  /// have no geographic anchor.
  std::string crs;
  /// Reduced-resolution copies for zoomed-out views (averages, halving until one block);
  /// default true, as the COG layout expects.
  bool overviews = true;
  /// Codec of the GeoTIFF's blocks, as GDAL names it: "ZSTD", "DEFLATE", "LZW" or "NONE".
  /// Default "ZSTD" (floating-point predictor): about the size of DEFLATE on float32 maps for a
  /// fraction of its time, so on a CPU the job is not the compressor's (measured in
  /// docs/raster-scale.md). GDAL, QGIS, rasterio and libtiff 4.0.10 and later read it; give
  /// "DEFLATE" for a reader without ZSTD, "NONE" for the fastest job and the largest file
  /// (tiled, directories first, but GDAL 3.6 writes no COG header for an uncompressed file).
  std::string compression = "ZSTD";
  /// The codec's level: ZSTD -20 to -1 (fast levels) or 1 to 22, DEFLATE 1 to 9; LZW and NONE
  /// have none. 0 (default): ZSTD -1, DEFLATE 1: a job's compression is most of its host work
  /// beside the kernel; ZSTD -1 is about 10 % faster than level 1 on a dense map for 3 % more
  /// bytes, where -3 costs half as many bytes again on a sparse drive map for no time, and
  /// higher levels buy a few per cent of bytes for several times the time. Readers do not
  /// depend on the level.
  int compression_level = 0;
  EvalOptions eval;  ///< options of the device evaluator; defaults as EvalOptions
};

/// One tile of the job: its position in the grid of tiles (row 0 at the top of the picture) and
/// the image pixels it covers.
struct RasterTile {
  std::size_t row = 0, col = 0;       ///< in the grid of tiles
  std::size_t x0 = 0, y0 = 0;         ///< first image column and row (row 0 = highest y)
  std::size_t width = 0, height = 0;  ///< pixels (smaller at the right and bottom edges)
  std::size_t index = 0;              ///< row * columns + col
};

/// Counts of a tiled run.
struct TiledRasterSummary {
  std::size_t width = 0, height = 0;  ///< pixels of the whole window
  std::size_t tiles = 0;              ///< tiles in the job
  std::size_t computed = 0;           ///< tiles this run evaluated
  std::size_t reused = 0;             ///< tiles found complete in the work folder (resume)
  std::size_t stale = 0;              ///< tiles found there but of another job or corrupt
  std::size_t levels = 0;             ///< heights of the height band sampled; 0 for a slice
  double level_spacing = 0;           ///< metres between those heights; 0 for fewer than 2
  double seconds = 0;                 ///< wall time of this run, seconds
  std::string output;                 ///< the GeoTIFF written (empty if not assembled)
  std::string manifest;               ///< OUT + ".manifest.json": the tiles and their CRC-32
  /// Where this run's time went, seconds of wall time: evaluating tiles on the device, the
  /// writer compressing and storing them (beside the evaluation), the evaluation waiting for
  /// the writer, and the assembly of the GeoTIFF. Zero where the caller ran the steps itself.
  double evaluate_seconds = 0, store_seconds = 0, store_wait_seconds = 0, assemble_seconds = 0;
};

/// A tiled rasterisation job over one map and window, writing `output` (a .tif path). Cheap to
/// construct: it validates the spec and the options, fingerprints the job and creates the work
/// folder. Several processes may hold the same job at once if each computes different tiles.
class TiledRaster {
 public:
  TiledRaster(Context& ctx, const KernelMap& map, const RasterSpec& spec, std::string output,
              TiledRasterOptions options = {});
  ~TiledRaster();
  TiledRaster(const TiledRaster&) = delete;
  TiledRaster& operator=(const TiledRaster&) = delete;

  const std::vector<RasterTile>& tiles() const;
  std::size_t width() const;
  std::size_t height() const;
  /// 64-bit fingerprint of the job (map, window, tile size, evaluator options), stored in each
  /// tile file.
  std::uint64_t fingerprint() const;
  const std::string& work_dir() const;

  /// Whether the tile's file is in the work folder, of this job, and its checksum holds.
  /// `stale` (may be null) is set when a file is there but is not a valid tile of this job.
  bool complete(const RasterTile& tile, bool* stale = nullptr) const;
  /// Evaluates the tile into probability and variance, image order (row 0 = top), each
  /// tile.width * tile.height floats.
  void evaluate(const RasterTile& tile, std::vector<float>& prob, std::vector<float>& var);
  /// Writes the tile's file atomically (temporary name, then rename).
  void store(const RasterTile& tile, const std::vector<float>& prob,
             const std::vector<float>& var) const;
  /// Reads a complete tile back (throws InputError naming the file if it is not).
  void load(const RasterTile& tile, std::vector<float>& prob, std::vector<float>& var) const;

  /// Assembles every tile into the GeoTIFF (written to a temporary name and renamed) and its
  /// manifest, then removes the work folder if the options say so. Throws potmap::Error naming
  /// the first missing or corrupt tile. `progress` (may be empty) gets the fraction of tiles
  /// copied.
  TiledRasterSummary assemble(const std::function<void(double)>& progress = {});

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Computes the tiles that `next()` hands out (an index into job.tiles(); job.tiles().size()
/// or more when there are none left) and are not complete on disk: each is evaluated on this
/// thread and stored by a writer thread while the next one is evaluated (two sets of buffers
/// take turns), so the device does not wait for compression and disk. Used by
/// rasterize_tiled() (every tile in order) and by MPI ranks (tiles claimed from a shared
/// counter). `done` (may be empty) gets each handed-out index once its tile is evaluated or
/// found complete. Returns the counts and the phases' seconds (assemble_seconds 0; the rest of
/// the summary empty). A failed write is rethrown at the next tile or at the end.
TiledRasterSummary compute_tiles(TiledRaster& job, const std::function<std::size_t()>& next,
                                 const std::function<void(std::size_t)>& done = {});

/// Runs a whole job in this process: computes every tile not yet complete (evaluation of one
/// tile overlaps the writing of the previous one), then assembles. `progress` (may be empty)
/// gets the fraction of tiles done, including reused ones. An exception thrown from it stops
/// the job; the tiles already written stay for a later run.
TiledRasterSummary rasterize_tiled(Context& ctx, const KernelMap& map, const RasterSpec& spec,
                                   const std::string& output,
                                   const TiledRasterOptions& options = {},
                                   const std::function<void(double)>& progress = {});

/// Whether this build writes GeoTIFFs (GDAL was found when it was configured).
bool geotiff_supported();

}  // namespace potmap
POTMAP_CXX_API_END
