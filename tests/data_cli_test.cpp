// `potmap data info` and `potmap data simulate`, run as a user would.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "potmap/data/simulator.hpp"
#include "test_support.hpp"

namespace {

std::string run_data_cli(const std::string& args, int* rc) {
  std::string out;
  FILE* p = popen((std::string(POTMAP_CLI) + " " + args + " 2>&1").c_str(), "r");
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  *rc = pclose(p);
  return out;
}

}  // namespace

TEST(DataCli, InfoPrintsTheScanCount) {
  if (std::string(POTMAP_CLI).empty()) GTEST_SKIP() << "tools not built";
  int rc = 0;
  const std::string out =
      run_data_cli("data info " + potmap::test::shared_data("radish/aces-corrected.log.gz"), &rc);
  EXPECT_EQ(rc, 0) << out;
  EXPECT_NE(out.find("\nscans: 440\n"), std::string::npos) << out;
  EXPECT_NE(out.find("beams per scan: 180\n"), std::string::npos) << out;
}

TEST(DataCli, InfoOnBadFileFailsNamingIt) {
  if (std::string(POTMAP_CLI).empty()) GTEST_SKIP() << "tools not built";
  int rc = 0;
  const std::string out = run_data_cli("data info /nonexistent/x.log", &rc);
  EXPECT_NE(rc, 0);
  EXPECT_NE(out.find("/nonexistent/x.log"), std::string::npos) << out;
}

TEST(DataCli, SimulateWritesALogTheInfoCommandReads) {
  if (std::string(POTMAP_CLI).empty()) GTEST_SKIP() << "tools not built";
  const std::string dir = potmap::test::temp_dir("cli_sim");
  int rc = 0;
  std::string out =
      run_data_cli("data simulate --town town3 --seed 4 --scans 25 --out " + dir, &rc);
  ASSERT_EQ(rc, 0) << out;
  // The town under its title, above its legend: taller than the town's own 0.5 m pixels.
  const auto [town_w, town_h] = potmap::test::png_size(dir + "/town.png");
  const potmap::Town town = potmap::Town::builtin("town3", 4);
  EXPECT_GE(town_w, std::size_t(std::ceil(town.width() / 0.5))) << dir;
  EXPECT_GT(town_h, std::size_t(std::ceil(town.height() / 0.5)) + 60) << dir;
  out = run_data_cli("data info " + dir + "/scans.log", &rc);
  EXPECT_NE(out.find("\nscans: 25\n"), std::string::npos) << out;
  EXPECT_NE(out.find("beams per scan: 360\n"), std::string::npos) << out;
}
