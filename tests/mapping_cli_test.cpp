// `potmap mapping LOG`: a real log to a map, pictures, a ROS map and scores in one command, with
// the built-in default dictionary (README, "Map your own 2D log").
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>

#include "potmap/io/map_io.hpp"
#include "potmap/learn/bhm_joint_merge.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace potmap;

namespace {

// The default dictionary is built once per build tree, in its own cache folder (the commands
// inherit the variable).
test::CliResult run_mapping_cli(const std::string& args, const std::string& redirect = "2>&1") {
  ::setenv("XDG_CACHE_HOME", (std::string(POTMAP_BINARY_DIR) + "/user-cache").c_str(), 1);
  return test::run_cli(args, redirect);
}

}  // namespace

TEST(MappingCli, RealLogToMapPicturesRosMapAndScores) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("mapping-cli");
  const test::CliResult r = run_mapping_cli(
      "mapping " + test::quoted(test::shared_data("radish/intel-corrected.log.gz")) +
          " --max-scans 15 -q -o " + test::quoted(d) + " --json -",
      "2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["method"], "RePOT");
  EXPECT_EQ(j["scans"], 15);
  // Held-out beams of a real building, mapped with atoms of the simulated towns.
  EXPECT_GT(j["overall"]["auc"].get<double>(), 0.9) << r.out;
  EXPECT_LT(j["overall"]["nll"].get<double>(), 0.35) << r.out;
  for (const char* f : {"map.potmap", "map_prob.png", "map_var.png", "map_kernels.png", "map.yaml",
                        "map.pgm", "scores.json"})
    EXPECT_TRUE(fs::exists(fs::path(d) / f)) << f;
  EXPECT_FALSE(read_map(d + "/map.potmap").empty());
  EXPECT_EQ(nlohmann::json::parse(test::file_bytes(d + "/scores.json"))["overall"], j["overall"]);
  // The ROS map: a building has walls, free floor and unknown beyond.
  const std::string pgm = test::file_bytes(d + "/map.pgm");
  std::size_t counts[256] = {0};
  const std::size_t header = pgm.find("\n255\n") + 5;
  for (std::size_t i = header; i < pgm.size(); ++i) ++counts[static_cast<unsigned char>(pgm[i])];
  EXPECT_GT(counts[0], 1000u);
  EXPECT_GT(counts[254], 10000u);
  EXPECT_GT(counts[205], 1000u);
  EXPECT_NE(test::file_bytes(d + "/map.yaml").find("image: map.pgm\n"), std::string::npos);
}

// --lookahead on a 2D log: every scan but the first scored on RePOT's map before it.
TEST(MappingCli, LookAheadScoresEachScanBeforeItIsLearned) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("mapping-lookahead");
  const test::CliResult r = run_mapping_cli(
      "mapping " + test::quoted(test::shared_data("radish/intel-corrected.log.gz")) +
          " --max-scans 15 --lookahead -q -o " + test::quoted(d) + " --json -",
      "2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  ASSERT_TRUE(j.contains("lookahead")) << r.out;
  const nlohmann::json& all = j["lookahead"]["all"];
  const nlohmann::json& far = j["lookahead"]["beyond_reach"];
  const std::size_t n = j["overall"]["points"].get<std::size_t>();
  EXPECT_LT(all["n"].get<std::size_t>(), n);          // the first scan's are not scored
  EXPECT_GT(all["n"].get<std::size_t>(), n * 4 / 5);  // the 14 others are
  EXPECT_LT(far["n"].get<std::size_t>(), all["n"].get<std::size_t>());
  // Ahead of the data the map is worse than behind it, and far better than chance.
  EXPECT_GT(all["nll"].get<double>(), j["overall"]["nll"].get<double>()) << all;
  EXPECT_GT(all["auc"].get<double>(), 0.85) << all;
  EXPECT_GE(j["lookahead_ms_per_scan"].get<double>(), 0.0);
}

// RePOT's seed rule reaches the mapper: the two rules give different maps of the same scans,
// and scores.json says which one made it.
TEST(MappingCli, SeedRuleFlagChoosesTheRule) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string log = test::quoted(test::shared_data("radish/intel-corrected.log.gz"));
  std::string maps[2];
  const char* rules[2] = {"yield-fully", "keep-start"};
  for (int k = 0; k < 2; ++k) {
    const std::string d = test::temp_dir(std::string("mapping-seed-") + rules[k]);
    const test::CliResult r = run_mapping_cli("mapping " + log + " --max-scans 6 -q --seeds-" +
                                                  rules[k] + " -o " + test::quoted(d) + " --json -",
                                              "2>/dev/null");
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_EQ(nlohmann::json::parse(r.out)["seed_rule"], rules[k]);
    maps[k] = test::file_bytes(d + "/map.potmap");
    ASSERT_FALSE(maps[k].empty());
  }
  EXPECT_TRUE(maps[0] != maps[1]) << "both seed rules wrote the same map";
}

// --half-life reaches RePOT's persistent map: over 40 scans of Intel (about two minutes of the
// log) a 2 s half-life leaves the final map little of the early scans (measured: overall AUC
// 0.66 against 0.98 without), the map file carries the half-life and the clock, and POT's map,
// which does not forget, refuses it.
TEST(MappingCli, HalfLifeFadesThePersistentMap) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string log = test::quoted(test::shared_data("radish/intel-corrected.log.gz"));
  double auc[2] = {0, 0};
  const char* half_lives[2] = {"0", "2"};
  for (int k = 0; k < 2; ++k) {
    const std::string d = test::temp_dir(std::string("mapping-half-life-") + half_lives[k]);
    const test::CliResult r =
        run_mapping_cli("mapping " + log + " --max-scans 40 -q --half-life " + half_lives[k] +
                            " -o " + test::quoted(d) + " --json -",
                        "2>/dev/null");
    ASSERT_EQ(r.status, 0) << r.out;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["half_life_s"].get<double>(), std::stod(half_lives[k]));
    auc[k] = j["overall"]["auc"].get<double>();
    const std::optional<JointBhm> m = read_joint_bhm_information(d + "/map.potmap");
    ASSERT_TRUE(m.has_value());
    EXPECT_EQ(m->options().half_life, std::stod(half_lives[k]));
    EXPECT_GT(m->time(), 0.0) << "the clock is the scans' timestamps";
  }
  EXPECT_GT(auc[0], 0.95);
  EXPECT_LT(auc[1], 0.8) << "a 2 s half-life forgets most of two minutes of scans";
  const test::CliResult pot =
      run_mapping_cli("mapping " + log + " --max-scans 4 --method pot " + "--half-life 3 -o " +
                      test::quoted(test::temp_dir("mapping-pot-hl")));
  EXPECT_NE(pot.status, 0);
  EXPECT_NE(pot.out.find("--half-life"), std::string::npos) << pot.out;
}

TEST(MappingCli, DefaultDictionaryIsCachedAndVersioned) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("default-dict");
  const test::CliResult first =
      run_mapping_cli("dict default --out " + test::quoted(d + "/a.potdict"));
  ASSERT_EQ(first.status, 0) << first.out;
  const test::CliResult second =
      run_mapping_cli("dict default --out " + test::quoted(d + "/b.potdict"));
  ASSERT_EQ(second.status, 0) << second.out;
  EXPECT_EQ(second.out.find("building the default dictionary"), std::string::npos) << second.out;
  EXPECT_NE(second.out.find("default-v"), std::string::npos) << second.out;
  const std::string a = test::file_bytes(d + "/a.potdict");
  ASSERT_GT(a.size(), 1000u);
  EXPECT_EQ(a, test::file_bytes(d + "/b.potdict"));
  EXPECT_NE(second.out.find("town1+town2+town3"), std::string::npos) << second.out;
}
