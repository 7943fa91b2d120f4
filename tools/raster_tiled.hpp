#pragma once
// potmap raster with a .tif output: the tiled, resumable job, on one process or MPI ranks.
#include <string>

#include "potmap/map/raster.hpp"
#include "potmap/map/raster_tiles.hpp"

namespace potmap::cli {

struct TiledRunArgs {
  std::string map, out, device;
  RasterSpec spec;
  TiledRasterOptions options;
  bool json = false;
};

/// Runs the job and prints its summary (rank 0); returns the exit status.
int run_tiled_raster(const TiledRunArgs& args);

}  // namespace potmap::cli
