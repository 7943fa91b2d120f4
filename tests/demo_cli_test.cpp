// `potmap demo`, the README's main job, run as a process.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdint>
#include <filesystem>

#include "potmap/experiments/figure_panels.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace potmap;

namespace {

nlohmann::json demo(const std::string& extra, const std::string& out) {
  const test::CliResult r = test::run_cli(
      "demo --authors-map --json - --out " + test::quoted(out) + " " + extra, "2>/dev/null");
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

// The README's main job: dictionary from town1, town2 mapped by POT and RePOT with `potmap
// map`'s settings. Thresholds are set from measured values (6 target scans, 4 rotations: POT
// overall ACC 0.985 AUC 0.973 NLL 0.043, RePOT ACC 0.993 AUC 0.998 NLL 0.027, 0.017 with session
// 16's seed rule) with a margin.
TEST(DemoCli, PotDemoMapsAnotherTown) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string out = test::temp_dir("demo-pot") + "/p";
  const test::CliResult r = test::run_cli(
      "demo --scans 6 --rotations 4 --json - --res 1 --out " + test::quoted(out), "2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["source"], "town1");
  EXPECT_EQ(j["target"], "town2");
  EXPECT_EQ(j["target_scans"], 6);
  EXPECT_GT(j["atoms"].get<int>(), 10);
  for (const char* m : {"pot", "repot"}) {
    const auto& o = j[m]["overall"];
    EXPECT_GT(o["acc"].get<double>(), 0.95) << m;
    EXPECT_GT(o["auc"].get<double>(), 0.9) << m;
    EXPECT_LT(o["nll"].get<double>(), 0.3) << m;
    EXPECT_GT(o["points"].get<int>(), 5000) << m;
    EXPECT_EQ(j[m]["scans"], 6);
    EXPECT_GT(j[m]["overall_kernels"].get<int>(), 1000) << m;
  }
  // RePOT refines with the scans' own training beams: its held-out NLL is not worse.
  EXPECT_LE(j["repot"]["overall"]["nll"].get<double>(), j["pot"]["overall"]["nll"].get<double>());
  for (const char* f : {"_town.png", "_repot_prob.png", "_repot_var.png", "_repot.potmap"})
    EXPECT_GT(fs::file_size(out + f), 500u) << f;
  // RePOT's persistent map is a regular grid of one width: its kernel picture is one colour
  // and compresses to little, but it is written.
  EXPECT_GT(fs::file_size(out + "_repot_kernels.png"), 100u);
  // The true town beside POT's and RePOT's estimates: three panels of one window and scale,
  // 1200 pixels along the long side, 4 white columns apart, titled above, a legend below.
  const auto [width, height] = test::png_size(out + "_repot_compare.png");
  ASSERT_GE(width, 8u);
  EXPECT_EQ((width - 8) % 3, 0u) << width;
  const std::uint32_t panel = (width - 8) / 3;
  ASSERT_GT(height, experiment::kComparisonTitleRows + experiment::kComparisonLegendRows);
  const std::uint32_t panel_height =
      height - experiment::kComparisonTitleRows - experiment::kComparisonLegendRows;
  EXPECT_NEAR(std::max(panel, panel_height), 1200, 1) << panel << " x " << panel_height;
  // Every picture of the map carries its caption: a title above and a legend below the map's
  // own pixels, so it is taller than the map (and at least as wide).
  const std::uint32_t map_w = j["picture_pixels"][0], map_h = j["picture_pixels"][1];
  for (const char* f : {"_repot_prob.png", "_repot_var.png", "_repot_kernels.png"}) {
    const auto [w, h] = test::png_size(out + f);
    EXPECT_GE(w, map_w) << f;
    EXPECT_GT(h, map_h + 60) << f;
  }
  const auto [town_w, town_h] = test::png_size(out + "_town.png");
  EXPECT_GE(town_w, experiment::kCaptionMinWidth);
  EXPECT_GT(town_h, 60u);
}

// The demo maps with `potmap map`'s settings, which must beat the paper's rules it would get
// from the library's defaults (6 scans, 4 rotations, measured: AUC / NLL 0.973 / 0.043 against
// 0.936 / 0.156).
TEST(DemoCli, PotDemoWithMapDefaultsBeatsThePapersRules) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  auto overall = [](const std::string& defaults) {
    const std::string out = test::temp_dir("demo-pot-" + defaults) + "/p";
    const test::CliResult r =
        test::run_cli("demo --scans 6 --rotations 4 --method pot --json - --map-defaults " +
                          defaults + " --out " + test::quoted(out),
                      "2>/dev/null");
    EXPECT_EQ(r.status, 0) << r.out;
    return nlohmann::json::parse(r.out)["pot"]["overall"];
  };
  const nlohmann::json mine = overall("true"), papers = overall("false");
  EXPECT_GT(mine["auc"].get<double>(), papers["auc"].get<double>() + 0.02) << mine << papers;
  EXPECT_LT(mine["nll"].get<double>(), papers["nll"].get<double>() - 0.05) << mine << papers;
}

TEST(DemoCli, PotDemoRejectsABadMethod) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const test::CliResult r = test::run_cli("demo --method sinkhorn --scans 1", "2>&1");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("--method"), std::string::npos) << r.out;
}
