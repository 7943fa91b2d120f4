#pragma once
// potmap raster with a .tif output: the tiled, resumable job, on one process or MPI ranks.
#include <string>

#include "potmap/map/raster.hpp"
#include "potmap/map/raster_tiles.hpp"
#include "potmap/runtime/context.hpp"

namespace potmap::cli {

struct TiledRunArgs {
  std::string map, out, device;
  RasterSpec spec;
  TiledRasterOptions options;
  bool json = false;
};

/// The map and the device of a raster job, opened at once: reading the map is one core's work
/// and opening the device is mostly the OpenCL driver loading its libraries, so on two threads
/// they overlap. Seconds from the start until each was ready, and until both were.
struct RasterSetup {
  KernelMap map;
  Context ctx;
  double read_seconds = 0, device_seconds = 0, setup_seconds = 0;
};
/// Throws the map's error if reading it fails (whatever the device does), else the device's.
RasterSetup open_map_and_device(const std::string& map, const std::string& device, bool quiet);

/// Runs the job and prints its summary (rank 0); returns the exit status.
int run_tiled_raster(const TiledRunArgs& args);

}  // namespace potmap::cli
