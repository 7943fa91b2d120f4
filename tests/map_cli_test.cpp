// `potmap map` end to end: simulate -> learn bhm -> dict build -> map, as a user would.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "potmap/io/map_io.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace potmap;

namespace {

void must_map(const std::string& args) {
  const test::CliResult r = test::run_cli(args, "2>&1");
  ASSERT_EQ(r.status, 0) << args << "\n" << r.out;
}

}  // namespace

TEST(MapCli, MapsAnotherTownWithADictionary) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("map-cli");
  const std::string q = test::quoted(d);
  must_map("data simulate --town town1 --seed 1 --scans 4 --spacing 3 --out " + q + "/src");
  must_map("learn bhm " + q + "/src/train.csv -o " + q + "/src.potmap --gamma 4 --sequential");
  must_map("dict build --scans " + q + "/src/scans.log --map " + q + "/src.potmap --out " + q +
           "/d.potdict");
  must_map("data simulate --town town2 --seed 7 --scans 3 --spacing 3 --out " + q + "/tgt");
  const test::CliResult r =
      test::run_cli("map --dict " + q + "/d.potdict --scans " + q + "/tgt/scans.log --out " + q +
                        "/m.potmap --refine --rotations 4 --instantaneous " + q +
                        "/inst --picture " + q + "/pic --res 1 --json -",
                    "2>/dev/null");
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["method"], "RePOT");
  EXPECT_EQ(j["scans"], 3);
  const KernelMap m = read_map(d + "/m.potmap");
  EXPECT_EQ(m.size(), j["overall_kernels"].get<std::size_t>());
  EXPECT_GT(m.size(), 100u);
  for (int i = 0; i < 3; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "/inst/scan_%06d.potmap", i);
    EXPECT_GT(read_map(d + name).size(), 0u) << name;
  }
  for (const char* f : {"/pic_prob.png", "/pic_var.png", "/pic_kernels.png"})
    EXPECT_TRUE(fs::exists(d + f)) << f;
  for (const char* k : {"ranking", "transport", "placement", "refine"})
    EXPECT_GE(j["ms_per_scan"][k].get<double>(), 0) << k;
  EXPECT_GT(j["ms_per_scan"]["refine"].get<double>(), 0);
  const double acc = j["overall"]["acc"].get<double>();
  EXPECT_TRUE(acc > 0.5 && acc <= 1) << acc;
  // --seeds-keep-start reaches RePOT's persistent map: the seeded means start the bound, so the
  // map is another one than the default rule's (seeds that yield fully).
  must_map("map --dict " + q + "/d.potdict --scans " + q + "/tgt/scans.log --out " + q +
           "/kept.potmap --refine --rotations 4 --seeds-keep-start");
  const KernelMap kept = read_map(d + "/kept.potmap");
  EXPECT_EQ(kept.size(), m.size());
  EXPECT_NE(kept.w_mean, m.w_mean);
  // --refine-spacing sets the persistent map's pitch (0.5 m by default).
  must_map("map --dict " + q + "/d.potdict --scans " + q + "/tgt/scans.log --out " + q +
           "/coarse.potmap --refine --rotations 4 --refine-spacing 1 --refine-prior-var 5");
  auto pitch = [](const KernelMap& km) {
    double p = HUGE_VAL;
    for (std::size_t a = 1; a < km.size(); ++a)
      if (km.position[2 * a + 1] == km.position[1] && km.position[2 * a] != km.position[0])
        p = std::min(p, std::abs(km.position[2 * a] - km.position[0]));
    return p;
  };
  EXPECT_NEAR(pitch(read_map(d + "/coarse.potmap")), 1.0, 1e-9);
  EXPECT_NEAR(pitch(m), 0.5, 1e-9);
  // --lookahead: scans 2 and 3 scored on the persistent map before them, the same map written.
  const test::CliResult ahead =
      test::run_cli("map --dict " + q + "/d.potdict --scans " + q + "/tgt/scans.log --out " + q +
                        "/ahead.potmap --refine --rotations 4 --lookahead --json -",
                    "2>/dev/null");
  ASSERT_EQ(ahead.status, 0) << ahead.out;
  const nlohmann::json ja = nlohmann::json::parse(ahead.out);
  ASSERT_TRUE(ja.contains("lookahead")) << ahead.out;
  EXPECT_GT(ja["lookahead"]["all"]["n"].get<std::size_t>(), 0u);
  EXPECT_LT(ja["lookahead"]["all"]["n"].get<std::size_t>(),
            ja["overall"]["points"].get<std::size_t>());
  EXPECT_EQ(ja["overall"], j["overall"]);
  const test::CliResult pot =
      test::run_cli("map --dict " + q + "/d.potdict --scans " + q + "/tgt/scans.log --out " + q +
                    "/pot.potmap --rotations 4 --lookahead");
  EXPECT_NE(pot.status, 0);
  EXPECT_NE(pot.out.find("--lookahead scores RePOT's persistent map"), std::string::npos)
      << pot.out;
  const test::CliResult bad =
      test::run_cli("map --dict " + q + "/d.potdict --scans " + q + "/tgt/scans.log --out " + q +
                    "/bad.potmap --refine --refine-spacing 0");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.out.find("--refine-spacing"), std::string::npos) << bad.out;
}

TEST(MapCli, ClearErrors) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("map-cli-errors");
  const std::string q = test::quoted(d);
  test::CliResult r =
      test::run_cli("map --dict " + q + "/none.potdict --scans x.log --out " + q + "/m.potmap");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("none.potdict"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(d + "/m.potmap"));
  r = test::run_cli("map --help");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("--refine"), std::string::npos);
}
