// Faults below the writers: every file potmap writes, overwritten while the disk fills up, must
// leave the previous file byte for byte, leave no temporary file behind and name the file in
// the error. The disk fills up for real as far as the writers can tell: RLIMIT_FSIZE makes the
// kernel fail every write past the limit (EFBIG, as ENOSPC would on a full disk), whichever
// library writes (stdio, libpng, GDAL), with no test hook in the writers themselves.
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include "potmap/data/simulator.hpp"
#include "potmap/error.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/io/ros_map.hpp"
#include "potmap/map/raster.hpp"
#include "potmap/map/raster_tiles.hpp"
#include "potmap/map/synthetic.hpp"
#include "potmap/pot/atoms.hpp"
#include "potmap/pot/dictionary_io.hpp"
#include "potmap/pot/mapper.hpp"
#include "potmap/runtime/tuning_file.hpp"
#include "test_support.hpp"

using namespace potmap;
namespace fs = std::filesystem;

namespace {

// Every file under `dir` (relative name -> bytes).
std::map<std::string, std::string> snapshot(const std::string& dir) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file())
      out[fs::relative(e.path(), dir).string()] = test::file_bytes(e.path().string());
  return out;
}

std::uintmax_t largest_file(const std::string& dir) {
  std::uintmax_t most = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) most = std::max(most, e.file_size());
  return most;
}

// `write(dir, version)` writes a writer's file(s) into `dir`: version 0 the previous content,
// version 1 a different, larger one. Version 1 is written once freely (to learn its size), then
// over version 0 with files limited to `limit` bytes (0: half its largest file): it must throw
// an Error naming `named` (a file name) and leave version 0's folder exactly as it was.
void expect_full_disk_keeps_previous(const std::string& name, const std::string& named,
                                     const std::function<void(const std::string&, int)>& write,
                                     std::uintmax_t limit = 0) {
  const std::string target = test::temp_dir(name + "-target");
  const std::string probe = test::temp_dir(name + "-probe");
  write(target, 0);
  write(probe, 1);
  const auto before = snapshot(target);
  ASSERT_FALSE(before.empty());
  ASSERT_NE(before, snapshot(probe)) << "the two versions must differ for the test to mean much";
  if (limit == 0) limit = largest_file(probe) / 2;
  ASSERT_GT(limit, 0u);
  std::string message;
  {
    test::FileSizeLimit full(limit);
    try {
      write(target, 1);
    } catch (const Error& e) {
      message = e.what();
    }
  }
  EXPECT_FALSE(message.empty()) << name << ": a write past " << limit << " bytes did not fail";
  EXPECT_NE(message.find(named), std::string::npos)
      << name << ": the error does not name " << named << ": " << message;
  EXPECT_EQ(snapshot(target), before)
      << name << ": the previous files changed or a temporary file was left behind";
}

KernelMap grid_map(int side) {
  KernelMap m;
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j) {
      const double p[2] = {0.5 * i, 0.5 * j};
      m.push_back(p, 4.0, (i * 7 + j * 3) % 5 - 2.0, 0.1 + 0.01 * j);
    }
  return m;
}

// The raster window of version v: 30 x 30 cells, then 250 x 250 (250 kB a .npy).
RasterSpec window(int v) {
  RasterSpec spec;
  spec.xmin = spec.ymin = -1;
  spec.xmax = spec.ymax = v ? 4.0 : 2.0;
  spec.resolution = v ? 0.02 : 0.1;
  return spec;
}

Dictionary small_dictionary(std::size_t atoms) {
  Dictionary d;
  d.dim = 2;
  d.scale = 0.25;
  d.max_range = 10;
  d.sectors = 4;
  for (std::size_t a = 0; a < atoms; ++a) {
    Atom at;
    at.sector.dim = 2;
    at.sector.index = static_cast<int>(a % 4);
    at.sector.scale = d.scale;
    at.sector.max_range = d.max_range;
    at.sector.hits = {0.1 * double(a), 0.2, 0.3, 0.4 + double(a)};
    at.sector.free = {0.05, 0.06 * double(a)};
    at.kernels = grid_map(3);
    at.scan_index = static_cast<std::int64_t>(a);
    d.atoms.push_back(std::move(at));
  }
  return d;
}

}  // namespace

TEST(WriteFaults, MapsInEveryFormat) {
  for (const char* ext : {".potmap", ".csv", ".npz"}) {
    expect_full_disk_keeps_previous(std::string("map") + (ext + 1), std::string("map") + ext,
                                    [&](const std::string& dir, int v) {
                                      write_map(grid_map(v ? 40 : 4), dir + "/map" + ext);
                                    });
  }
}

TEST(WriteFaults, Dictionary) {
  expect_full_disk_keeps_previous("dictionary", "atoms.potdict", [](const std::string& dir, int v) {
    write_dictionary(small_dictionary(v ? 200 : 2), dir + "/atoms.potdict");
  });
}

TEST(WriteFaults, RasterPngAndNpy) {
  const KernelMap map = grid_map(6);
  expect_full_disk_keeps_previous("raster", "map_", [&](const std::string& dir, int v) {
    rasterize(test::context(), map, window(v), dir + "/map", {});
  });
}

TEST(WriteFaults, RasterGeoTiffAndManifest) {
  if (!geotiff_supported()) GTEST_SKIP() << "built without GDAL";
  const KernelMap map = grid_map(6);
  const std::string work = test::temp_dir("geotiff-fault-tiles");
  expect_full_disk_keeps_previous("geotiff", "map.tif", [&](const std::string& dir, int v) {
    TiledRasterOptions o;
    o.tile_cells = 64;
    o.work_dir = work + "/" + fs::path(dir).filename().string() + std::to_string(v);
    rasterize_tiled(test::context(), map, window(v), dir + "/map.tif", o);
  });
}

// The tiles themselves (containers in the work folder, here inside the output's folder): the
// first tile cannot be written, so the job stops before the GeoTIFF, which stays as it was.
TEST(WriteFaults, RasterTiles) {
  if (!geotiff_supported()) GTEST_SKIP() << "built without GDAL";
  const KernelMap map = grid_map(6);
  expect_full_disk_keeps_previous(
      "tiles", "tile_",
      [&](const std::string& dir, int v) {
        TiledRasterOptions o;
        o.tile_cells = 64;
        o.work_dir = dir + "/tiles";
        rasterize_tiled(test::context(), map, window(v), dir + "/map.tif", o);
      },
      4096);  // a tile of 64 x 64 cells holds 32 kB
}

TEST(WriteFaults, RosMap) {
  const KernelMap map = grid_map(6);
  expect_full_disk_keeps_previous("rosmap", "map.", [&](const std::string& dir, int v) {
    RosMapOptions o;
    o.resolution = v ? 0.01 : 0.1;
    o.xmin = o.ymin = -1;
    o.xmax = o.ymax = 3;
    write_ros_map(nullptr, map, dir + "/map.yaml", o);
  });
}

TEST(WriteFaults, TuningFile) {
  expect_full_disk_keeps_previous("tuning", "tuning.txt", [](const std::string& dir, int v) {
    Tuning t = test::context().tuning();
    t.map_eval.work_group = v ? 16 : 8;
    write_tuning_file(dir + "/tuning.txt", test::context().info(), t);
  });
}

TEST(WriteFaults, SimulatedLog) {
  expect_full_disk_keeps_previous("simulation", "scans.log", [](const std::string& dir, int v) {
    SimOptions o;
    o.scans = v ? 20 : 2;
    write_simulation(simulate(Town::builtin("town1"), o), o, dir);
  });
}

// A mapper's checkpoint (`potmap map --checkpoint` stores this same file with its run record as
// the extra bytes): RePOT after one scan, then after four (its persistent map and caches grow).
TEST(WriteFaults, MapperCheckpoint) {
  SimOptions so;
  so.scans = 6;
  so.spacing = 3;
  const Simulation sim = simulate(Town::builtin("town1"), so);
  auto dict = std::make_shared<Dictionary>();
  build_dictionary({sim.scans[0], sim.scans[1]}, test::grid_around(sim.scans[0].origin(), 30), {},
                   *dict);
  const MapperOptions o = test::small_mapper_options(true);
  Mapper early(&test::context(), dict, o), later(&test::context(), dict, o);
  early.add_scan(sim.scans[2]);
  for (std::size_t i = 2; i < 6; ++i) later.add_scan(sim.scans[i]);
  expect_full_disk_keeps_previous("checkpoint", "run.ckpt", [&](const std::string& dir, int v) {
    (v ? later : early).save_state(dir + "/run.ckpt", "run record");
  });
}
