// `potmap demo`, the README's main job, run as a process.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>

#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace potmap;

namespace {

nlohmann::json demo(const std::string& extra, const std::string& out) {
  const test::CliResult r =
      test::run_cli("demo --authors-map --json - --out " + test::quoted(out) + " " + extra, "2>/dev/null");
  EXPECT_EQ(r.status, 0) << r.out;
  return nlohmann::json::parse(r.out);
}

}  // namespace

TEST(DemoCli, RealTown1ScoresAndPictures) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  ASSERT_TRUE(fs::exists(test::shared_data("carla/town1_test2k.csv")));
  const std::string out = test::temp_dir("demo-town1") + "/t1";
  const nlohmann::json j = demo("--data " + test::quoted(test::shared_data("")) + " --res 2", out);
  EXPECT_EQ(j["map"], "town1");
  EXPECT_EQ(j["kernels"], 92372);
  EXPECT_EQ(j["points"], 2000);
  // The authors' map separates its own test points well above chance.
  EXPECT_GT(j["auc"].get<double>(), 0.8);
  EXPECT_GT(j["acc"].get<double>(), 0.7);
  EXPECT_LT(j["max_abs_dp"].get<double>(), 1e-6);
  for (const char* f : {"_prob.png", "_var.png", "_prob.npy", "_var.npy"})
    EXPECT_GT(fs::file_size(out + f), 1000u) << f;
}

TEST(DemoCli, SyntheticSceneWithoutData) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string out = test::temp_dir("demo-synthetic") + "/s";
  const nlohmann::json j = demo("--data /nonexistent-folder", out);
  EXPECT_EQ(j["map"], "synthetic");
  EXPECT_GT(j["auc"].get<double>(), 0.95);
  EXPECT_LT(j["nll"].get<double>(), 0.3);
  EXPECT_LT(j["max_abs_dp"].get<double>(), 1e-6);
  EXPECT_TRUE(fs::exists(out + "_prob.png"));
}
