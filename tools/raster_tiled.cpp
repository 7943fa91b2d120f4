#include "raster_tiled.hpp"

#include <chrono>
#include <cstdlib>
#include <exception>
#include <functional>
#include <future>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <utility>
#include <vector>

#include "commands.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"
#include "progress.hpp"
#include "raster_ranks.hpp"

namespace potmap::cli {

namespace {

// With several ranks on a node, each takes its own device when there are several (unless the
// user named one).
std::string rank_device(const TiledRunArgs& a, const RasterRanks& ranks) {
  if (ranks.size() == 1 || !a.device.empty() || std::getenv("POTMAP_DEVICE")) return a.device;
  const auto devices = list_devices();
  if (devices.empty()) return a.device;
  return devices[std::size_t(ranks.local_rank()) % devices.size()].name;
}

// `setup`: this rank's seconds reading the map and opening the device.
void print_summary(const TiledRasterSummary& s, int ranks, std::size_t busy, bool json,
                   const RasterSetup& setup) {
  if (json) {
    nlohmann::json j = {{"width", s.width},
                        {"height", s.height},
                        {"tiles", s.tiles},
                        {"computed", s.computed},
                        {"reused", s.reused},
                        {"stale", s.stale},
                        {"levels", s.levels},
                        {"level_spacing", s.level_spacing},
                        {"ranks", ranks},
                        {"seconds", s.seconds},
                        {"evaluate_seconds", s.evaluate_seconds},
                        {"store_seconds", s.store_seconds},
                        {"store_wait_seconds", s.store_wait_seconds},
                        {"assemble_seconds", s.assemble_seconds},
                        {"read_seconds", setup.read_seconds},
                        {"device_seconds", setup.device_seconds},
                        {"setup_seconds", setup.setup_seconds},
                        {"output", s.output},
                        {"ranks_with_tiles", busy},
                        {"manifest", s.manifest}};
    std::cout << j.dump(2) << "\n";
    return;
  }
  std::cout << s.width << " x " << s.height << " cells in " << s.tiles << " tiles (" << s.computed
            << " computed, " << s.reused << " reused from an earlier run"
            << (s.stale ? ", " + std::to_string(s.stale) + " stale recomputed" : std::string())
            << ") on " << ranks << " rank" << (ranks == 1 ? "" : "s") << ", " << s.seconds
            << " s\n";
  if (s.levels)
    std::cout << "height band: maximum over " << s.levels << " heights " << s.level_spacing
              << " m apart\n";
  std::cout << "wrote " << s.output << "\nwrote " << s.manifest << "\n";
}

}  // namespace

RasterSetup open_map_and_device(const std::string& map, const std::string& device, bool quiet) {
  const auto t0 = std::chrono::steady_clock::now();
  auto reading = std::async(std::launch::async, [&map, t0] {
    KernelMap m = read_map(map);
    return std::make_pair(std::move(m), seconds_since(t0));
  });
  std::optional<Context> ctx;
  std::exception_ptr device_error;
  try {
    ctx.emplace(make_context(device, quiet));
  } catch (...) {
    device_error = std::current_exception();
  }
  const double device_s = seconds_since(t0);
  auto [m, read_s] = reading.get();  // the map's error first: it names the user's file
  if (device_error) std::rethrow_exception(device_error);
  return RasterSetup{std::move(m), std::move(*ctx), read_s, device_s, seconds_since(t0)};
}

int run_tiled_raster(const TiledRunArgs& a) {
  if (!geotiff_supported())
    throw Error(a.out +
                ": this potmap was built without GDAL; a .tif output needs it "
                "(install libgdal-dev, configure again), or give an output prefix for PNG/.npy");
  RasterRanks ranks;
  try {
    RasterSetup setup =
        open_map_and_device(a.map, rank_device(a, ranks), a.json || ranks.rank() > 0);
    const KernelMap& map = setup.map;
    Context& ctx = setup.ctx;
    if (ranks.size() == 1) {
      print_summary(
          rasterize_tiled(ctx, map, a.spec, a.out, a.options, terminal_progress("raster")), 1, 1,
          a.json, setup);
      return 0;
    }
    const auto t0 = std::chrono::steady_clock::now();
    TiledRaster job(ctx, map, a.spec, a.out, a.options);
    const std::size_t total = job.tiles().size();
    auto progress = ranks.rank() == 0 ? terminal_progress("raster") : std::function<void(double)>();
    ranks.all_ok(true);  // every rank has its device before the first claim
    // Each rank stores a tile while it evaluates the next it claims, as one process does.
    const TiledRasterSummary run = compute_tiles(
        job, [&] { return ranks.claim(total); },
        [&](std::size_t i) {
          if (progress) progress(0.9 * double(i + 1) / double(total));
        });
    const std::size_t busy = ranks.sum(run.computed + run.reused > 0 ? 1 : 0);
    const std::size_t computed = ranks.sum(run.computed);
    const std::size_t reused = ranks.sum(run.reused);
    const std::size_t stale = ranks.sum(run.stale);
    if (ranks.rank() == 0) {
      TiledRasterSummary s = job.assemble();
      s.computed = computed;
      s.reused = reused;
      s.stale = stale;
      s.seconds = seconds_since(t0);
      print_summary(s, ranks.size(), busy, a.json, setup);
    }
    return ranks.all_ok(true) ? 0 : 1;
  } catch (const std::exception& e) {
    if (ranks.size() == 1) throw;
    // The other ranks would wait for this one forever: end the job; tiles written stay.
    std::cerr << "potmap: rank " << ranks.rank() << ": error: " << e.what() << "\n";
    ranks.abort(1);
  }
}

}  // namespace potmap::cli
