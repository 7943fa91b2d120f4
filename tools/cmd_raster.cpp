// potmap raster: a window of a map as pictures (PNG) and arrays (.npy), or as a tiled,
// resumable Cloud-Optimized GeoTIFF (an output ending in .tif) on one process or MPI ranks.
#include <unistd.h>

#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "commands.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/map/raster.hpp"
#include "progress.hpp"
#include "raster_tiled.hpp"

namespace potmap::cli {

namespace {

struct RasterArgs {
  std::string map, bounds, out, prob_cmap = "viridis", var_cmap = "magma", band;
  double res = 0, z = 0, band_step = 0;
  std::size_t band_cells = RasterOptions{}.max_band_cells;
  bool no_png = false, no_npy = false, json = false;
  std::size_t tile = TiledRasterOptions{}.tile_cells;
  std::string work_dir, crs, compress = TiledRasterOptions{}.compression;
  int compress_level = 0;
  bool keep_tiles = false, no_overviews = false;
};

bool is_geotiff(const std::string& out) {
  auto ends = [&](const char* ext) {
    const std::string e(ext);
    if (out.size() < e.size()) return false;
    std::string tail = out.substr(out.size() - e.size());
    for (char& ch : tail) ch = char(std::tolower(static_cast<unsigned char>(ch)));
    return tail == e;
  };
  return ends(".tif") || ends(".tiff");
}

// "xmin,xmax,ymin,ymax" -> spec; names the value that is wrong.
void parse_bounds(const std::string& text, RasterSpec& spec) {
  const char* names[] = {"xmin", "xmax", "ymin", "ymax"};
  double* dest[] = {&spec.xmin, &spec.xmax, &spec.ymin, &spec.ymax};
  std::vector<std::string> parts;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) parts.push_back(item);
  if (!text.empty() && text.back() == ',') parts.push_back("");
  if (parts.size() != 4)
    throw ArgumentError("--bounds '" + text + "': expected 4 comma-separated values " +
                        "xmin,xmax,ymin,ymax, got " + std::to_string(parts.size()));
  for (int i = 0; i < 4; ++i) {
    std::size_t used = 0;
    double v = NAN;
    try {
      v = std::stod(parts[i], &used);
    } catch (const std::exception&) {
      used = 0;
    }
    while (used < parts[i].size() && std::isspace(static_cast<unsigned char>(parts[i][used])))
      ++used;
    if (used == 0 || used != parts[i].size() || !std::isfinite(v))
      throw ArgumentError(std::string("--bounds: ") + names[i] + " '" + parts[i] +
                          "' is not a finite number");
    *dest[i] = v;
  }
}

// "ZLO,ZHI" -> the spec's height band; names the value that is wrong.
void parse_height_band(const std::string& text, RasterSpec& spec) {
  const std::size_t comma = text.find(',');
  const std::string parts[2] = {text.substr(0, comma),
                                comma == std::string::npos ? "" : text.substr(comma + 1)};
  double* dest[2] = {&spec.band_lo, &spec.band_hi};
  for (int i = 0; i < 2; ++i) {
    std::size_t used = 0;
    double v = NAN;
    try {
      v = std::stod(parts[i], &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (comma == std::string::npos || used == 0 || used != parts[i].size() || !std::isfinite(v))
      throw ArgumentError("--band '" + text + "': expected ZLO,ZHI, two finite heights in metres");
    *dest[i] = v;
  }
}

// The options of the tiled GeoTIFF job (an output ending in .tif).
void add_geotiff_options(CLI::App* cmd, RasterArgs& a) {
  cmd->add_option("--tile", a.tile,
                  "GeoTIFF: tile edge in cells, a multiple of 64 (default 512); each tile is "
                  "computed and kept on its own")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--work-dir", a.work_dir,
                  "GeoTIFF: folder of the finished tiles (default OUT.tiles); a later run with "
                  "the same arguments skips the tiles found complete there");
  cmd->add_flag("--keep-tiles", a.keep_tiles, "GeoTIFF: keep the tile folder when done");
  cmd->add_option("--crs", a.crs,
                  "GeoTIFF: coordinate reference system of the map frame (EPSG:n, WKT or PROJ); "
                  "default a local frame in metres");
  cmd->add_flag("--no-overviews", a.no_overviews, "GeoTIFF: no reduced-resolution overviews");
  cmd->add_option("--compress", a.compress,
                  "GeoTIFF: codec of the blocks: zstd (default: about as small as deflate, "
                  "several times faster), deflate (for readers without ZSTD), lzw, none "
                  "(fastest, largest)");
  cmd->add_option("--compress-level", a.compress_level,
                  "GeoTIFF: the codec's level: zstd -20..-1 (fast) or 1..22, deflate 1..9; "
                  "default zstd -1 (faster than level 1 for 3 % more bytes), deflate 1");
}

}  // namespace

void register_raster(CLI::App& app, Runner& runner) {
  CLI::App* cmd = app.add_subcommand(
      "raster",
      "Write probability and variance of a map window as PNG pictures and .npy arrays, or (an "
      "output ending in .tif) as a tiled, resumable Cloud-Optimized GeoTIFF; under mpirun the "
      "tiles are shared by the ranks");
  auto a = std::make_shared<RasterArgs>();
  auto device = add_device_option(cmd);
  cmd->add_option("--map", a->map, "Map file (.csv, .npz, .potmap)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--bounds", a->bounds, "Window xmin,xmax,ymin,ymax in metres")->required();
  cmd->add_option("--res", a->res, "Cell edge in metres")->required()->check(CLI::PositiveNumber);
  cmd->add_option("--out", a->out,
                  "Output prefix: writes PREFIX_prob.png, PREFIX_var.png, PREFIX_prob.npy, "
                  "PREFIX_var.npy; or a .tif path: a Cloud-Optimized GeoTIFF (band 1 probability, "
                  "band 2 variance, float32) written in tiles, resumed if run again")
      ->required();
  cmd->add_option("--z", a->z, "Slice height for 3D maps, metres (default 0)");
  cmd->add_option("--band", a->band,
                  "3D maps: ZLO,ZHI in metres (map frame): instead of the slice at --z, each cell "
                  "holds the largest probability over the heights ZLO..ZHI and the variance at "
                  "that height (what stands between the ground and a vehicle's roof)");
  cmd->add_option("--band-step", a->band_step,
                  "Largest spacing of the band's heights, metres; both ends are sampled (default "
                  "0: the standard deviation of the map's narrowest kernel, 1/sqrt(2 gamma_max), "
                  "finer than which the map does not change)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--band-cells", a->band_cells,
                  "Most cells evaluated at once, in bands of whole rows (memory ~24 bytes per "
                  "cell; default 4194304)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--prob-cmap", a->prob_cmap, "Colour map of probability (viridis, magma)");
  cmd->add_option("--var-cmap", a->var_cmap, "Colour map of variance (viridis, magma)");
  cmd->add_flag("--no-png", a->no_png, "Do not write the PNG pictures");
  cmd->add_flag("--no-npy", a->no_npy, "Do not write the .npy arrays");
  cmd->add_flag("--json", a->json, "Print the summary as JSON on stdout");
  add_geotiff_options(cmd, *a);
  cmd->callback([&runner, a, device] {
    runner.action = [a, device] {
      RasterSpec spec;
      parse_bounds(a->bounds, spec);
      spec.resolution = a->res;
      spec.z = a->z;
      if (!a->band.empty()) parse_height_band(a->band, spec);
      spec.band_step = a->band_step;
      spec.validate();  // before reading a large map
      if (is_geotiff(a->out)) {
        TiledRunArgs t;
        t.map = a->map;
        t.out = a->out;
        t.device = *device;
        t.spec = spec;
        t.options.tile_cells = a->tile;
        t.options.work_dir = a->work_dir;
        t.options.remove_tiles = !a->keep_tiles;
        t.options.crs = a->crs;
        t.options.overviews = !a->no_overviews;
        t.options.compression = a->compress;
        t.options.compression_level = a->compress_level;
        t.options.eval = RasterOptions{}.eval;
        t.json = a->json;
        return run_tiled_raster(t);
      }
      RasterOptions opt;
      opt.max_band_cells = a->band_cells;
      opt.write_png = !a->no_png;
      opt.write_npy = !a->no_npy;
      opt.prob_colormap = parse_colormap(a->prob_cmap);
      opt.var_colormap = parse_colormap(a->var_cmap);
      opt.progress = terminal_progress("raster");
      RasterSetup setup = open_map_and_device(a->map, *device, a->json);
      const KernelMap& map = setup.map;
      Context& ctx = setup.ctx;
      const RasterSummary s = rasterize(ctx, map, spec, a->out, opt);
      if (a->json) {
        nlohmann::json j = {{"width", s.width},
                            {"height", s.height},
                            {"cells", s.cells},
                            {"bands", s.bands},
                            {"levels", s.levels},
                            {"level_spacing", s.level_spacing},
                            {"seconds", s.seconds},
                            {"read_seconds", setup.read_seconds},
                            {"device_seconds", setup.device_seconds},
                            {"setup_seconds", setup.setup_seconds},
                            {"prob_min", s.prob_min},
                            {"prob_max", s.prob_max},
                            {"var_min", s.var_min},
                            {"var_max", s.var_max},
                            {"files", s.files}};
        std::cout << j.dump(2) << "\n";
      } else {
        std::cout << s.width << " x " << s.height << " cells in " << s.bands << " band"
                  << (s.bands == 1 ? "" : "s") << ", " << s.seconds << " s; p in [" << s.prob_min
                  << ", " << s.prob_max << "], variance in [" << s.var_min << ", " << s.var_max
                  << "]\n";
        if (s.levels)
          std::cout << "height band: maximum over " << s.levels << " heights " << s.level_spacing
                    << " m apart\n";
        for (const std::string& f : s.files) std::cout << "wrote " << f << "\n";
      }
      return 0;
    };
  });
}

}  // namespace potmap::cli
