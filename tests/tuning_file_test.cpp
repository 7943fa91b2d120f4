// Per-device tuning files (potmap/runtime/tuning_file.hpp): a Context reads the file of its
// device in place of the defaults, the overrides apply after it, a stale or corrupt file is
// ignored with a warning naming the file and what is wrong, and results under a tuning read from
// a file match those under the defaults.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "potmap/ot/sinkhorn.hpp"
#include "potmap/runtime/tuning_file.hpp"
#include "potmap/version.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

// Every routine's fields moved off the CPU defaults, to values the kernels accept.
const char* kFileTuning =
    "map_eval.vector_width=8, map_eval.work_group=4, map_eval.chunks_per_query=2,"
    "raster.rows_per_item=4, sinkhorn.work_group=8, sinkhorn.chunk_slots=300";

// The device's file in a fresh folder, written with `tuning`, then `edit` applied to its text.
struct TuningDir {
  std::string dir, path;
  TuningDir(const std::string& name, const Tuning& tuning) {
    dir = test::temp_dir(name);
    path = tuning_file_path(dir, test::context().info());
    write_tuning_file(path, test::context().info(), tuning);
  }
  void replace(const std::string& from, const std::string& to) const {
    std::string text = potmap::test::file_bytes(path);
    const std::size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from << " not in\n" << text;
    text.replace(at, from.size(), to);
    std::ofstream(path, std::ios::trunc) << text;
  }
  ContextOptions options() const {
    ContextOptions o;
    o.device = test::context().info().name;
    o.tuning_dir = dir;
    return o;
  }
};

Tuning file_tuning() {
  return parse_tuning(kFileTuning, default_tuning(test::context().info()));
}

// The Context's tuning and what it printed on stderr while being built.
std::pair<std::string, std::string> open_context(const ContextOptions& o) {
  testing::internal::CaptureStderr();
  std::string tuning;
  try {
    Context c(o);
    tuning = to_string(c.tuning());
  } catch (...) {
    testing::internal::GetCapturedStderr();
    throw;
  }
  return {tuning, testing::internal::GetCapturedStderr()};
}

const std::string& defaults() {
  static const std::string s = to_string(default_tuning(test::context().info()));
  return s;
}

}  // namespace

TEST(TuningFile, ContextReadsTheDevicesFile) {
  const TuningDir d("tuning-file-read", file_tuning());
  Context c(d.options());
  EXPECT_EQ(to_string(c.tuning()), to_string(file_tuning()));
  EXPECT_EQ(c.tuning_source(), d.path);
  ASSERT_NE(to_string(file_tuning()), defaults());
  // The file is keyed by platform and device: another folder has none.
  ContextOptions elsewhere = d.options();
  elsewhere.tuning_dir = test::temp_dir("tuning-file-empty");
  const auto [tuning, err] = open_context(elsewhere);
  EXPECT_EQ(tuning, defaults());
  EXPECT_EQ(err, "");
  ContextOptions off = d.options();
  off.tuning_file = false;
  EXPECT_EQ(open_context(off).first, defaults());
}

TEST(TuningFile, OverridesApplyAfterTheFile) {
  const TuningDir d("tuning-file-override", file_tuning());
  ContextOptions o = d.options();
  o.tuning = "sinkhorn.work_group=16";
  Context c(o);
  EXPECT_EQ(c.tuning().sinkhorn.work_group, 16);
  EXPECT_EQ(c.tuning().map_eval.vector_width, 8);  // from the file
  ::setenv("POTMAP_TUNING", "map_eval.vector_width=4", 1);
  const std::string with_env = open_context(o).first;
  ::unsetenv("POTMAP_TUNING");
  const Tuning t = parse_tuning(with_env, Tuning{});
  EXPECT_EQ(t.map_eval.vector_width, 4);
  EXPECT_EQ(t.sinkhorn.work_group, 16);
  EXPECT_EQ(t.raster.rows_per_item, 4);  // from the file
}

TEST(TuningFile, StaleFileIsIgnoredWithAWarning) {
  const DeviceInfo& info = test::context().info();
  struct Case {
    std::string key, value;
  };
  for (const Case& k : {Case{"driver", info.driver_version},
                        Case{"potmap_version", std::string(POTMAP_VERSION_STRING)},
                        Case{"platform_version", info.platform_version}}) {
    const TuningDir d("tuning-file-stale", file_tuning());
    d.replace(k.key + " " + k.value + "\n", k.key + " 0.0-other\n");
    const auto [tuning, err] = open_context(d.options());
    EXPECT_EQ(tuning, defaults()) << k.key;
    EXPECT_NE(err.find("'" + d.path + "' ignored: stale"), std::string::npos) << err;
    EXPECT_NE(err.find(k.key + " '0.0-other'"), std::string::npos) << err;
  }
}

TEST(TuningFile, CorruptFileIsIgnoredWithAWarning) {
  struct Case {
    std::string from, to, says;
  };
  for (const Case& k : {Case{"potmap-tuning 1", "potmap-tuning 9", "line 1"},
                        Case{"raster.rows_per_item=4", "raster.rows_per_item=5", "=5"},
                        Case{"tuning map_eval", "tunings map_eval", "unknown key 'tunings'"},
                        Case{"driver ", "# driver ", "no 'driver' line"}}) {
    const TuningDir d("tuning-file-corrupt", file_tuning());
    d.replace(k.from, k.to);
    const auto [tuning, err] = open_context(d.options());
    EXPECT_EQ(tuning, defaults()) << k.to;
    EXPECT_NE(err.find("'" + d.path + "' ignored: corrupt"), std::string::npos) << err;
    EXPECT_NE(err.find(k.says), std::string::npos) << err;
  }
  const TuningDir empty("tuning-file-empty-file", file_tuning());
  std::ofstream(empty.path, std::ios::trunc).flush();
  EXPECT_NE(open_context(empty.options()).second.find("empty file"), std::string::npos);
}

TEST(TuningFile, ResultsMatchTheDefaultsUnderATuningReadFromAFile) {
  const TuningDir d("tuning-file-results", file_tuning());
  Context tuned(d.options());
  ASSERT_EQ(tuned.tuning_source(), d.path);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> pos(0, 40), w(-8, 8), u(-2, 42);
  KernelMap map;
  map.dim = 2;
  for (int k = 0; k < 1500; ++k) {
    const double p[3] = {pos(rng), pos(rng), 0};
    map.push_back(p, 1.5, w(rng), 0.1);
  }
  std::vector<double> pts(2 * 5000);
  for (double& x : pts) x = u(rng);
  MapEvaluator a(test::context(), map), b(tuned, map);
  const MapValues va = a.evaluate(pts), vb = b.evaluate(pts);
  EXPECT_NE(a.last_pairs(), b.last_pairs());  // the file's chunking reached the evaluator
  GridSpec grid;
  grid.dim = 2;
  grid.origin[0] = grid.origin[1] = -1;
  grid.resolution = 0.3;
  grid.count[0] = 140;
  grid.count[1] = 120;
  const MapValues ga = a.evaluate_grid(grid), gb = b.evaluate_grid(grid);
  for (const auto* pair : {&va, &ga}) {
    const MapValues& x = *pair;
    const MapValues& y = pair == &va ? vb : gb;
    ASSERT_EQ(x.prob.size(), y.prob.size());
    for (std::size_t i = 0; i < x.prob.size(); ++i) {
      ASSERT_NEAR(x.prob[i], y.prob[i], 2e-6) << i;
      ASSERT_NEAR(x.mean[i], y.mean[i], 2e-5 * (1 + std::abs(x.mean[i]))) << i;
      ASSERT_NEAR(x.var[i], y.var[i], 2e-5 * (1 + x.var[i])) << i;
    }
  }
  SinkhornBatch batch;
  for (int p = 0; p < 10; ++p) {
    SinkhornProblem q;
    q.source = Eigen::MatrixXd::NullaryExpr(20 + p % 7, 2, [&] { return u(rng) / 40; });
    q.target = Eigen::MatrixXd::NullaryExpr(18 + p % 4, 2, [&] { return u(rng) / 40; });
    q.epsilon = 0.05;
    q.tolerance = 1e-5;
    q.max_iterations = 2000;
    batch.add(q);
  }
  const auto sa = batch.run(test::context()), sb = batch.run(tuned);  // 300 slots: 5 launches
  ASSERT_EQ(sa.size(), sb.size());
  for (std::size_t p = 0; p < sa.size(); ++p) {
    EXPECT_TRUE(sa[p].converged && sb[p].converged) << p;
    EXPECT_NEAR(sa[p].cost, sb[p].cost, 1e-4 * sa[p].cost) << p;
  }
}

TEST(TuningFile, WriteNamesAFolderItCannotCreate) {
  const std::string dir = test::temp_dir("tuning-file-blocked");
  std::ofstream(dir + "/file") << "x";
  try {
    write_tuning_file(dir + "/file/sub/tuning.txt", test::context().info(), file_tuning());
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(dir + "/file/sub/tuning.txt"), std::string::npos)
        << e.what();
  }
}
