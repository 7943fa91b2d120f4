// The tiled, resumable Cloud-Optimized GeoTIFF job (rasterize_tiled), as `potmap raster
// ... OUT.tif` runs it.
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "potmap/map/raster_tiles.hpp"
#include "raster_window.hpp"

namespace py = pybind11;
using namespace pybind11::literals;

namespace potmap::python {

namespace {

py::dict geotiff_job(Context& ctx, const KernelMap& map, const std::vector<double>& bounds,
                     double res, const std::string& out, double z, const Band& band,
                     double band_step, const TiledRasterOptions& o) {
  const RasterSpec spec = window(bounds, res, z, band, band_step);
  TiledRasterSummary s;
  {
    py::gil_scoped_release release;
    s = rasterize_tiled(ctx, map, spec, out, o);
  }
  return py::dict(
      "width"_a = s.width, "height"_a = s.height, "tiles"_a = s.tiles, "computed"_a = s.computed,
      "reused"_a = s.reused, "stale"_a = s.stale, "levels"_a = s.levels, "seconds"_a = s.seconds,
      "output"_a = s.output, "manifest"_a = s.manifest, "evaluate_seconds"_a = s.evaluate_seconds,
      "store_seconds"_a = s.store_seconds, "store_wait_seconds"_a = s.store_wait_seconds,
      "assemble_seconds"_a = s.assemble_seconds);
}

}  // namespace

void bind_raster_tiles(py::module_& m) {
  m.def("geotiff_supported", &geotiff_supported,
        "Whether this build writes GeoTIFFs (GDAL was found when it was configured).");
  m.def(
      "rasterize_geotiff",
      [](Context& ctx, const KernelMap& map, const std::vector<double>& bounds, double res,
         const std::string& out, double z, const Band& band, double band_step, std::size_t tile,
         const std::string& work_dir, bool keep_tiles, const std::string& crs, bool overviews,
         const std::string& compress, int compress_level) {
        TiledRasterOptions o;
        o.tile_cells = tile;
        o.work_dir = work_dir;
        o.remove_tiles = !keep_tiles;
        o.crs = crs;
        o.overviews = overviews;
        o.compression = compress;
        o.compression_level = compress_level;
        return geotiff_job(ctx, map, bounds, res, out, z, band, band_step, o);
      },
      "ctx"_a, "map"_a, "bounds"_a, "res"_a, "out"_a, "z"_a = 0.0, "band"_a = py::none(),
      "band_step"_a = 0.0, "tile"_a = TiledRasterOptions{}.tile_cells, "work_dir"_a = "",
      "keep_tiles"_a = false, "crs"_a = "", "overviews"_a = true, "compress"_a = "zstd",
      "compress_level"_a = 0,
      "Writes the window as one Cloud-Optimized GeoTIFF at `out` (band 1 probability, band 2\n"
      "variance, float32), as `potmap raster ... OUT.tif`: computed in tiles of `tile` cells\n"
      "(a multiple of 64, default 512) kept in work_dir (default OUT.tiles), so that a job run\n"
      "again with the same arguments skips the tiles found complete; removed when done unless\n"
      "keep_tiles. band = (z_lo, z_hi): a 3D map's height-band maximum instead of the slice at\n"
      "z. crs: the map frame's reference system as GDAL reads it (default a local frame in\n"
      "metres); overviews: averaged reduced levels; compress: zstd (default), deflate, lzw or\n"
      "none; compress_level: zstd -20..-1 or 1..22, deflate 1..9, 0 the default (zstd -1,\n"
      "deflate 1). Returns a dict: width, height, tiles, computed, reused, stale, levels,\n"
      "seconds, output, manifest and the phases' seconds. ArgumentError for a bad option,\n"
      "Error if this build has no GDAL (geotiff_supported()).");
}

}  // namespace potmap::python
