// The commands chained as a user would: simulate a drive, learn maps from its labelled samples,
// score them on the held-out beams.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>

#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace potmap;

TEST(PipelineCli, SimulateLearnEvaluate) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string dir = test::temp_dir("pipeline");
  const std::string q = test::quoted(dir);
  test::CliResult r =
      test::run_cli("data simulate --town town2 --seed 3 --scans 20 --out " + q, "2>&1");
  ASSERT_EQ(r.status, 0) << r.out;
  ASSERT_TRUE(fs::exists(dir + "/train.csv"));
  ASSERT_TRUE(fs::exists(dir + "/test.csv"));

  r = test::run_cli(
      "learn bhm " + test::quoted(dir + "/train.csv") + " -o " + test::quoted(dir + "/bhm.potmap"),
      "2>&1");
  ASSERT_EQ(r.status, 0) << r.out;
  r = test::run_cli("eval --map " + test::quoted(dir + "/bhm.potmap") + " --test " +
                        test::quoted(dir + "/test.csv") + " --json -",
                    "2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json bhm = nlohmann::json::parse(r.out);
  // Held-out beams of a simulated town: BHM must separate hits from free space well.
  EXPECT_GT(bhm["auc"].get<double>(), 0.95);
  EXPECT_GT(bhm["acc"].get<double>(), 0.9);

  r = test::run_cli("learn abhm " + test::quoted(dir + "/train.csv") + " -o " +
                        test::quoted(dir + "/abhm.csv") + " --steps 150 --report 50",
                    "2>&1");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("ELBO"), std::string::npos) << r.out;
  r = test::run_cli("eval --map " + test::quoted(dir + "/abhm.csv") + " --test " +
                        test::quoted(dir + "/test.csv") + " --json -",
                    "2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json abhm = nlohmann::json::parse(r.out);
  // 150 steps are far from convergence: ask only that it learned something.
  EXPECT_GT(abhm["auc"].get<double>(), 0.7);
}
