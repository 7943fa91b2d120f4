// `potmap bench` and `potmap tune` end to end, on one routine of a small map so that the sweep
// takes seconds: the table, JSON and plot of bench; the file tune writes, read back by a Context.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <utility>

#include "potmap/runtime/tuning.hpp"
#include "potmap/runtime/tuning_file.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace potmap;

namespace {

// Nine kernels over 20 x 20 m: the raster of the quick sweep (2^20 cells) takes milliseconds.
std::string small_map(const std::string& dir) {
  const std::string path = dir + "/map.csv";
  std::ofstream f(path);
  f << "x,y,gamma,w_mean,w_var\n";
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) f << i * 10 << "," << j * 10 << ",0.5," << (i - j) << ",0.2\n";
  return path;
}

std::string device_args() {
  return " --device " + test::quoted(test::context().info().name);
}

// The test device's built-in tuning, where every sweep starts (PoCL's CPU device has its own).
const Tuning& device_defaults() {
  static const Tuning t = default_tuning(test::context().info());
  return t;
}

}  // namespace

TEST(BenchCli, SweepsARoutineAndWritesTableJsonAndPlot) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string dir = test::temp_dir("bench-cli");
  const test::CliResult r = test::run_cli("bench --quick --repeats 2 --routines raster --map " +
                                          test::quoted(small_map(dir)) + " --out " +
                                          test::quoted(dir + "/b") + device_args());
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("best: raster.rows_per_item="), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("* raster.rows_per_item=8,band=4194304"), std::string::npos) << r.out;
  ASSERT_TRUE(fs::exists(dir + "/b.png"));
  EXPECT_GT(fs::file_size(dir + "/b.png"), 500u);
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(dir + "/b.json"));
  EXPECT_EQ(j["device"]["name"], test::context().info().name);
  EXPECT_EQ(j["device"]["driver"], test::context().info().driver_version);
  ASSERT_EQ(j["routines"].size(), 1u);
  const auto& points = j["routines"][0]["points"];
  EXPECT_EQ(points.size(), 12u);  // 3 rows per item x 4 bands
  for (const auto& p : points) {
    ASSERT_EQ(p["seconds"].size(), 2u);
    EXPECT_LE(p["min_s"].get<double>(), p["median_s"].get<double>());
    EXPECT_LE(p["median_s"].get<double>(), p["max_s"].get<double>());
    EXPECT_GT(p["throughput"].get<double>(), 0);
  }
}

TEST(BenchCli, EachRoutineStartsFromTheContextsTuning) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string dir = test::temp_dir("bench-cli-start");
  const test::CliResult r = test::run_cli(
      "bench --quick --repeats 1 --routines map_eval,raster --map " + test::quoted(small_map(dir)) +
      " --out " + test::quoted(dir + "/b") + device_args());
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(dir + "/b.json"));
  ASSERT_EQ(j["routines"].size(), 2u);
  // Not the last point of the map_eval sweep: the raster's default is the untuned library's.
  for (const auto& routine : j["routines"]) EXPECT_EQ(routine["start"], j["tuning_before"]);
  EXPECT_EQ(j["tuning_source"], "built-in defaults");
}

// POT's scans in flight (MapperOptions::pipeline off: 1, on: 2) by sinkhorn.work_group, on the
// built-in simulated drive: scans per second, the default (the device's built-in work-group,
// pipeline on) marked and the best named, every point in the JSON.
TEST(BenchCli, SweepsPotScansInFlight) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string dir = test::temp_dir("bench-cli-pot");
  const test::CliResult r = test::run_cli("bench --quick --repeats 1 --routines pot --out " +
                                          test::quoted(dir + "/b") + device_args());
  ASSERT_EQ(r.status, 0) << r.out;
  const std::string def =
      "sinkhorn.work_group=" + std::to_string(device_defaults().sinkhorn.work_group) +
      ",pipeline=on";
  EXPECT_NE(r.out.find("* " + def), std::string::npos) << r.out;
  const std::size_t at = r.out.find("best: sinkhorn.work_group=");
  ASSERT_NE(at, std::string::npos) << r.out;
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(dir + "/b.json"));
  ASSERT_EQ(j["routines"].size(), 1u);
  const auto& pot = j["routines"][0];
  EXPECT_EQ(pot["name"], "pot");
  EXPECT_EQ(pot["unit"], "scans/s");
  EXPECT_EQ(pot["default"], def);
  EXPECT_EQ(r.out.substr(at + 6, pot["best"].get<std::string>().size()), pot["best"]);
  const auto& points = pot["points"];
  ASSERT_EQ(points.size(), 6u);  // work-groups 1, 2, 4 x pipeline off, on
  std::set<std::pair<long long, long long>> seen;
  int defaults = 0;
  bool best_found = false;
  for (const auto& p : points) {
    const long long x = p["x"], series = p["series"];
    EXPECT_TRUE(x == 1 || x == 2) << x;
    const std::string setting = p["setting"];
    EXPECT_EQ(setting, "sinkhorn.work_group=" + std::to_string(series) +
                           ",pipeline=" + (x == 2 ? "on" : "off"));
    seen.insert({x, series});
    defaults += p["default"].get<bool>();
    ASSERT_EQ(p["seconds"].size(), 1u);
    EXPECT_GT(p["throughput"].get<double>(), 0);
    // Throughput is scans per second of the whole drive: the same number of scans each time.
    EXPECT_NEAR(p["throughput"].get<double>() * p["median_s"].get<double>(),
                points[0]["throughput"].get<double>() * points[0]["median_s"].get<double>(), 1e-6);
    if (setting == pot["best"]) {
      best_found = true;
      for (const auto& q : points)
        EXPECT_LE(q["throughput"].get<double>(), p["throughput"].get<double>());
    }
  }
  EXPECT_EQ(seen.size(), 6u);
  EXPECT_EQ(defaults, 1);
  EXPECT_TRUE(best_found);
}

// raster.tile (16, 32, 64) by raster.rows_per_item (8, 16 with --quick) at the default band.
TEST(BenchCli, SweepsTheRasterTile) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string dir = test::temp_dir("bench-cli-tile");
  const test::CliResult r = test::run_cli(
      "bench --quick --repeats 1 --routines raster_tile --map " + test::quoted(small_map(dir)) +
      " --out " + test::quoted(dir + "/b") + device_args());
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("* raster.rows_per_item=8,raster.tile=64"), std::string::npos) << r.out;
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(dir + "/b.json"));
  ASSERT_EQ(j["routines"].size(), 1u);
  const auto& routine = j["routines"][0];
  EXPECT_EQ(routine["name"], "raster_tile");
  EXPECT_EQ(routine["default"], "raster.rows_per_item=8,raster.tile=64");
  EXPECT_NE(r.out.find("best: " + routine["best"].get<std::string>() + " ("), std::string::npos)
      << r.out;
  std::set<std::pair<long long, long long>> seen;
  double best = 0;
  for (const auto& p : routine["points"]) {
    const long long tile = p["x"], rows = p["series"];
    EXPECT_TRUE(tile == 16 || tile == 32 || tile == 64) << tile;
    EXPECT_EQ(p["setting"], "raster.rows_per_item=" + std::to_string(rows) +
                                ",raster.tile=" + std::to_string(tile));
    seen.insert({tile, rows});
    best = std::max(best, p["throughput"].get<double>());
  }
  EXPECT_EQ(seen.size(), 6u);
  EXPECT_EQ(routine["points"].size(), 6u);
  for (const auto& p : routine["points"])
    if (p["setting"] == routine["best"]) EXPECT_EQ(p["throughput"].get<double>(), best);
}

// The one-field sweeps: each routine's points are its field's values, one of them the default,
// the best named in the table and the JSON with the highest throughput.
TEST(BenchCli, SweepsTheRemainingTuningFields) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string dir = test::temp_dir("bench-cli-fields");
  const test::CliResult r = test::run_cli(
      "bench --quick --repeats 1 --routines "
      "map_eval_query,map_eval_device,sinkhorn_groups,bhm,abhm --map " +
      test::quoted(small_map(dir)) + " --out " + test::quoted(dir + "/b") + device_args());
  ASSERT_EQ(r.status, 0) << r.out;
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(dir + "/b.json"));
  const std::map<std::string, std::pair<std::string, std::string>> want = {
      {"map_eval_query", {"map_eval.chunks_per_query", "16"}},
      {"map_eval_device", {"map_eval.cells_work_group", "16"}},
      {"sinkhorn_groups", {"sinkhorn.groups_per_compute_unit", "4"}},
      {"bhm", {"learn.bhm_work_group", "64"}},
      {"abhm", {"learn.abhm_work_group", "64"}}};
  ASSERT_EQ(j["routines"].size(), want.size());
  for (const auto& routine : j["routines"]) {
    const std::string name = routine["name"];
    SCOPED_TRACE(name);
    ASSERT_EQ(want.count(name), 1u);
    const auto& [field, def] = want.at(name);
    EXPECT_EQ(routine["series"], field);
    EXPECT_EQ(routine["default"], field + "=" + def);
    EXPECT_NE(r.out.find("best: " + routine["best"].get<std::string>() + " ("), std::string::npos)
        << r.out;
    ASSERT_EQ(routine["points"].size(), 3u);
    double best = 0;
    int defaults = 0;
    for (const auto& p : routine["points"]) {
      EXPECT_EQ(p["setting"], field + "=" + std::to_string(p["x"].get<long long>()));
      defaults += p["default"].get<bool>();
      EXPECT_GT(p["throughput"].get<double>(), 0);
      best = std::max(best, p["throughput"].get<double>());
    }
    EXPECT_EQ(defaults, 1);
    for (const auto& p : routine["points"])
      if (p["setting"] == routine["best"]) EXPECT_EQ(p["throughput"].get<double>(), best);
  }
}

TEST(BenchCli, UnknownRoutineIsNamed) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const test::CliResult r =
      test::run_cli("bench --quick --routines rastr --out ''" + device_args());
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("'rastr'"), std::string::npos) << r.out;
}

TEST(BenchCli, TuneWritesTheFileAContextReads) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string dir = test::temp_dir("tune-cli");
  // --min-gain 0: the best point is taken whatever its margin, so the file holds what the
  // table names best.
  const test::CliResult r = test::run_cli(
      "tune --quick --repeats 1 --routines raster --min-gain 0 --map " +
      test::quoted(small_map(dir)) + " --dir " + test::quoted(dir + "/t") + device_args());
  ASSERT_EQ(r.status, 0) << r.out;
  const std::string path = tuning_file_path(dir + "/t", test::context().info());
  ASSERT_TRUE(fs::exists(path)) << r.out;
  const std::size_t at = r.out.find("best: raster.rows_per_item=");
  ASSERT_NE(at, std::string::npos) << r.out;
  const int best_rows = std::stoi(r.out.substr(at + 27));
  ContextOptions o;
  o.device = test::context().info().name;
  o.tuning_dir = dir + "/t";
  Context c(o);
  EXPECT_EQ(c.tuning_source(), path);
  EXPECT_EQ(c.tuning().raster.rows_per_item, best_rows);
}
