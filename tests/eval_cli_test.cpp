// potmap eval run as a separate process, its JSON compared with the library in this process.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <array>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "potmap/data/labelled_points.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/map/metrics.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

using test::CliResult;

std::string q(const std::string& s) {
  return "'" + s + "'";
}

class EvalCli : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::string(POTMAP_CLI).empty()) GTEST_SKIP() << "potmap command not built";
  }
};

}  // namespace

TEST_F(EvalCli, JsonMatchesLibraryOnRealTown1) {
  const std::string map_path = test::shared_data("carla/npz/town1_abhm_map.npz");
  const std::string test_path = test::shared_data("carla/town1_test2k.csv");
  const std::string json_path = test::temp_dir("eval_cli") + "/scores.json";
  const CliResult r = test::run_cli(
      "eval --map " + q(map_path) + " --test " + q(test_path) + " --json " + q(json_path), "2>&1");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("auc"), std::string::npos) << r.out;
  std::ifstream in(json_path);
  const nlohmann::json j = nlohmann::json::parse(in);
  for (const char* key : {"acc", "auc", "nll", "n", "device", "map", "test"})
    EXPECT_TRUE(j.contains(key)) << key;
  const double acc = j["acc"], auc = j["auc"], nll = j["nll"];
  EXPECT_EQ(j["n"].get<std::size_t>(), 2000u);
  EXPECT_GE(acc, 0.0);
  EXPECT_LE(acc, 1.0);
  EXPECT_GE(auc, 0.5);  // a learned map must beat chance on its own town
  EXPECT_LE(auc, 1.0);
  EXPECT_GT(nll, 0.0);

  // The same computation in this process, on the same kind of device.
  const KernelMap map = read_map(map_path);
  const LabelledPoints pts = read_labelled_csv(test_path);
  MapEvaluator ev(test::context(), map);
  const Scores s = score(ev.evaluate(pts.position).prob, pts.label);
  EXPECT_NEAR(acc, s.acc, 1e-12);
  EXPECT_NEAR(auc, s.auc, 1e-12);
  EXPECT_NEAR(nll, s.nll, 1e-9);
}

TEST_F(EvalCli, JsonToStdoutIsPureAndReferenceMatchesExact) {
  // A 300-point subset keeps the exact (dense, double) evaluation fast.
  const std::string map_path = test::shared_data("carla/town1_abhm_map.csv");
  LabelledPoints all = read_labelled_csv(test::shared_data("carla/town1_test2k.csv"));
  LabelledPoints sub;
  for (std::size_t i = 0; i < all.size(); i += all.size() / 300) {
    sub.position.insert(sub.position.end(), all.position.begin() + 2 * i,
                        all.position.begin() + 2 * i + 2);
    sub.label.push_back(all.label[i]);
    sub.scan.push_back(all.scan[i]);
  }
  const std::string test_path = test::temp_dir("eval_cli_ref") + "/sub.csv";
  write_labelled_csv(sub, test_path);
  const CliResult r = test::run_cli(
      "eval --reference --json - --map " + q(map_path) + " --test " + q(test_path), "2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);  // throws if anything else is on stdout
  const KernelMap map = read_map(map_path);
  const Scores s = score(evaluate_exact(map, sub.position.data(), sub.size()).prob, sub.label);
  EXPECT_EQ(j["n"].get<std::size_t>(), sub.size());
  EXPECT_DOUBLE_EQ(j["acc"].get<double>(), s.acc);
  EXPECT_DOUBLE_EQ(j["auc"].get<double>(), s.auc);
  EXPECT_DOUBLE_EQ(j["nll"].get<double>(), s.nll);
}

TEST_F(EvalCli, DimensionMismatchAndMissingFileAreClearErrors) {
  const std::string dir = test::temp_dir("eval_cli_err");
  std::ofstream(dir + "/p3.csv") << "t,x,y,z,occupied\n0,1,2,3,1\n";
  const std::string map_path = test::shared_data("carla/npz/town1_abhm_map.npz");
  CliResult r = test::run_cli(
      "eval --reference --map " + q(map_path) + " --test " + q(dir + "/p3.csv"), "2>&1");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("2D"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("3D"), std::string::npos) << r.out;
  r = test::run_cli("eval --map " + q(dir + "/none.potmap") + " --test " + q(dir + "/p3.csv"),
                    "2>&1");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("none.potmap"), std::string::npos) << r.out;
}
