#pragma once
// potmap raster with a .tif output: the tiled, resumable job, on one process or MPI ranks.
#include <chrono>
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

/// Seconds between laps (the phases the --json summary reports: reading the map, opening the
/// device).
class PhaseClock {
 public:
  double lap() {
    const auto now = std::chrono::steady_clock::now();
    const double s = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    return s;
  }

 private:
  std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

/// Runs the job and prints its summary (rank 0); returns the exit status.
int run_tiled_raster(const TiledRunArgs& args);

}  // namespace potmap::cli
