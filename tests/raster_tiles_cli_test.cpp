// `potmap raster ... OUT.tif` end to end: a job killed with SIGKILL mid-way and started again
// with the same arguments skips the tiles it finished and writes the same file as a job that
// ran through.
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <thread>

#include "potmap/map/raster_tiles.hpp"
#include "test_support.hpp"

extern char** environ;
namespace fs = std::filesystem;
using potmap::test::quoted;

namespace {

std::size_t tiles_in(const std::string& dir) {
  std::size_t n = 0;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec))
    n += it->path().extension() == ".bin";
  return n;
}

// The Town 1 map, a 200 m x 200 m window at 0.25 m in 64-cell tiles: 169 tiles, a few seconds.
std::string job_args(const std::string& out) {
  return "raster --map " + quoted(potmap::test::shared_data("carla/town1_abhm_map.csv")) +
         " --bounds -300,-100,0,200 --res 0.25 --tile 64 --out " + quoted(out);
}

}  // namespace

TEST(RasterTilesCli, AJobKilledMidwayResumesToTheSameFile) {
  if (!potmap::test::cli_built()) GTEST_SKIP() << "potmap command not built";
  if (!potmap::geotiff_supported()) GTEST_SKIP() << "built without GDAL";
  const std::string map = potmap::test::shared_data("carla/town1_abhm_map.csv");
  ASSERT_TRUE(fs::exists(map)) << map;
  const std::string dir = potmap::test::temp_dir("raster-tiles-kill");

  const auto whole = potmap::test::run_cli(job_args(dir + "/whole.tif") + " --json", "2>/dev/null");
  ASSERT_EQ(whole.status, 0) << whole.out;
  ASSERT_NE(whole.out.find("\"tiles\": 169"), std::string::npos) << whole.out;

  // Start the same job elsewhere and kill it once a few tiles are done.
  const std::string out = dir + "/killed.tif";
  const std::string cmd = "exec " + quoted(POTMAP_CLI) + " " + job_args(out) + " >/dev/null 2>&1";
  const char* argv[] = {"/bin/sh", "-c", cmd.c_str(), nullptr};
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, "/bin/sh", nullptr, nullptr, const_cast<char**>(argv), environ), 0);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (tiles_in(out + ".tiles") < 10 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_EQ(kill(pid, SIGKILL), 0);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the job ended before it was killed";
  const std::size_t done = tiles_in(out + ".tiles");
  EXPECT_GE(done, 10u);
  EXPECT_LT(done, 169u);
  EXPECT_FALSE(fs::exists(out));

  const auto resumed = potmap::test::run_cli(job_args(out) + " --json", "2>/dev/null");
  ASSERT_EQ(resumed.status, 0) << resumed.out;
  // Every tile written before the kill is whole (atomic rename) and reused.
  EXPECT_NE(resumed.out.find("\"reused\": " + std::to_string(done)), std::string::npos)
      << resumed.out;
  EXPECT_NE(resumed.out.find("\"stale\": 0"), std::string::npos) << resumed.out;
  EXPECT_EQ(potmap::test::file_bytes(out), potmap::test::file_bytes(dir + "/whole.tif"));
  EXPECT_FALSE(fs::exists(out + ".tiles"));
}

TEST(RasterTilesCli, HelpNamesTheGeoTiffOptions) {
  if (!potmap::test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const auto r = potmap::test::run_cli("raster --help");
  ASSERT_EQ(r.status, 0);
  for (const char* opt : {"--tile", "--work-dir", "--keep-tiles", "--crs", "--no-overviews",
                          "--compress", "--compress-level", "--band", "--band-step"})
    EXPECT_NE(r.out.find(opt), std::string::npos) << opt;
}

// --compress-level reaches the blocks (the tiles record it, so a job at another level
// recomputes them), and a level the codec has not is refused before any tile, naming it.
TEST(RasterTilesCli, CompressLevelReachesTheFileAndABadOneIsNamed) {
  if (!potmap::test::cli_built()) GTEST_SKIP() << "potmap command not built";
  if (!potmap::geotiff_supported()) GTEST_SKIP() << "built without GDAL";
  const std::string dir = potmap::test::temp_dir("raster-cli-level");
  const std::string out = dir + "/map.tif";
  const std::string args =
      "raster --map " + quoted(potmap::test::shared_data("carla/town1_abhm_map.csv")) +
      " --bounds -300,-200,0,100 --res 0.5 --tile 128 --keep-tiles --json --out " + quoted(out);
  const auto fast = potmap::test::run_cli(args, "2>/dev/null");
  ASSERT_EQ(fast.status, 0) << fast.out;
  const std::string fast_bytes = potmap::test::file_bytes(out);
  const auto small = potmap::test::run_cli(args + " --compress-level 19", "2>/dev/null");
  ASSERT_EQ(small.status, 0) << small.out;
  EXPECT_NE(small.out.find("\"reused\": 0"), std::string::npos) << small.out;
  EXPECT_LT(potmap::test::file_bytes(out).size(), fast_bytes.size());

  const auto bad = potmap::test::run_cli(args + " --compress lzw --compress-level 5", "2>&1");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.out.find("level 5 for LZW"), std::string::npos) << bad.out;
  const auto bad2 = potmap::test::run_cli(args + " --compress-level 23", "2>&1");
  EXPECT_NE(bad2.status, 0);
  EXPECT_NE(bad2.out.find("level 23 for ZSTD"), std::string::npos) << bad2.out;
}
