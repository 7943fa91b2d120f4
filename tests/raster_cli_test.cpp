// The `potmap raster` command end to end. Skipped where the command was not built (it needs
// read_map from the map I/O part of the library).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "test_support.hpp"

namespace fs = std::filesystem;

namespace {

struct Result {
  int status = -1;
  std::string out, err;
};

Result run_cli(const std::string& dir, const std::string& args) {
  const std::string cmd =
      std::string("'") + POTMAP_CLI + "' " + args + " >'" + dir + "/stdout' 2>'" + dir + "/stderr'";
  const int rc = std::system(cmd.c_str());
  Result r;
  r.status = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  r.out = potmap::test::file_bytes(dir + "/stdout");
  r.err = potmap::test::file_bytes(dir + "/stderr");
  return r;
}

std::string write_map_csv(const std::string& dir) {
  const std::string path = dir + "/map.csv";
  std::ofstream(path) << "x,y,gamma,w_mean,w_var\n0.5,0.25,2.0,3.0,0.5\n";
  return path;
}

}  // namespace

TEST(RasterCli, WritesTheFourFiles) {
  if (std::string(POTMAP_CLI).empty() || !fs::exists(POTMAP_CLI))
    GTEST_SKIP() << "potmap command not built";
  const std::string dir = potmap::test::temp_dir("raster-cli");
  const std::string map = write_map_csv(dir);
  const Result r =
      run_cli(dir, "raster --map '" + map + "' --bounds -1,2,-1,1.5 --res 0.05 --out '" + dir +
                       "/w' --band-cells 100 --json");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("\"width\": 60"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"height\": 50"), std::string::npos) << r.out;
  for (const char* f : {"_prob.png", "_var.png", "_prob.npy", "_var.npy"})
    EXPECT_TRUE(fs::exists(dir + "/w" + f)) << f;
}

TEST(RasterCli, BadBoundsNameTheValue) {
  if (std::string(POTMAP_CLI).empty() || !fs::exists(POTMAP_CLI))
    GTEST_SKIP() << "potmap command not built";
  const std::string dir = potmap::test::temp_dir("raster-cli-bad");
  const std::string map = write_map_csv(dir);
  Result r = run_cli(
      dir, "raster --map '" + map + "' --bounds -1,2,oops,1 --res 0.1 --out '" + dir + "/w'");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("ymin 'oops'"), std::string::npos) << r.err;
  r = run_cli(dir, "raster --map '" + map + "' --bounds -1,2,1 --res 0.1 --out '" + dir + "/w'");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("expected 4"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir + "/w_prob.png"));
}

TEST(RasterCli, HeightBandOfA3DMap) {
  if (std::string(POTMAP_CLI).empty() || !fs::exists(POTMAP_CLI))
    GTEST_SKIP() << "potmap command not built";
  const std::string dir = potmap::test::temp_dir("raster-cli-band");
  const std::string map = dir + "/map3.csv";
  // One kernel 1 m up: a band from 0 to 2 m sees it; the slice at 0 barely does.
  std::ofstream(map) << "x,y,z,gamma,w_mean,w_var\n0.5,0.25,1.0,4.0,3.0,0.5\n";
  Result r = run_cli(dir, "raster --map '" + map +
                              "' --bounds -1,2,-1,1.5 --res 0.05 --band 0,2 --band-step 0.25 "
                              "--out '" +
                              dir + "/b' --json");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("\"levels\": 9"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"prob_max\": 0.9"), std::string::npos) << r.out;
  for (const char* f : {"_prob.png", "_var.png", "_prob.npy", "_var.npy"})
    EXPECT_TRUE(fs::exists(dir + "/b" + f)) << f;
  r = run_cli(dir, "raster --map '" + map + "' --bounds -1,2,-1,1.5 --res 0.05 --band 0 --out '" +
                       dir + "/c'");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("--band '0'"), std::string::npos) << r.err;
  r = run_cli(dir, "raster --map '" + write_map_csv(dir) +
                       "' --bounds -1,2,-1,1.5 --res 0.05 --band 0,2 --out '" + dir + "/d'");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("3D map"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir + "/d_prob.png"));
}
