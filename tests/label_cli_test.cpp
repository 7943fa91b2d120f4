// Learning and building from raw datasets (`data label`, `learn` and `dict build` on logs, KITTI
// folders read as sequences), run as a user would.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "potmap/data/labelled_points.hpp"
#include "potmap/data/labelling.hpp"
#include "potmap/data/scan.hpp"
#include "potmap/experiments/experiment.hpp"
#include "potmap/io/map_io.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

test::CliResult must_label(const std::string& args) {
  const test::CliResult r = test::run_cli(args, "2>&1");
  EXPECT_EQ(r.status, 0) << args << "\n" << r.out;
  return r;
}

}  // namespace

TEST(LabelCli, LabelsARealLogAsTheLibraryDoes) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("label-cli");
  const std::string log = test::shared_data("radish/intel-corrected.log.gz");
  must_label("data label " + test::quoted(log) + " -o " + test::quoted(d + "/train.csv") +
             " --test " + test::quoted(d + "/test.csv") + " --holdout 0.2 --range-cut 20 --seed 3");
  const LabelledPoints train = read_labelled_csv(d + "/train.csv");
  const LabelledPoints test = read_labelled_csv(d + "/test.csv");

  // The same labels, made here with the experiments' range cut and the library's labelling.
  Dataset ds = read_dataset(log);
  for (Scan& s : ds.scans) s = experiment::limit_range(s, 20);
  LabelOptions lo;
  lo.holdout_fraction = 0.2;
  lo.seed = 3;
  const LabelledSplit want = label_scans(ds.scans, lo);
  ASSERT_EQ(train.size(), want.train.size());
  ASSERT_EQ(test.size(), want.test.size());
  EXPECT_GT(test.size(), train.size() / 8);
  for (std::size_t i = 0; i < train.size(); i += 997) {
    EXPECT_EQ(train.label[i], want.train.label[i]) << i;
    EXPECT_EQ(train.scan[i], want.train.scan[i]) << i;
    for (int k = 0; k < 2; ++k)
      EXPECT_EQ(train.position[2 * i + k], want.train.position[2 * i + k]) << i;
  }
  // Cut at 20 m: no sample farther than that from its scan's sensor.
  for (std::size_t i = 0; i < train.size(); i += 101) {
    const auto o = ds.scans[static_cast<std::size_t>(train.scan[i])].origin();
    EXPECT_LE(std::hypot(train.position[2 * i] - o[0], train.position[2 * i + 1] - o[1]),
              20.0 + 1e-9);
  }
}

TEST(LabelCli, HoldOutWithoutATestFileIsRefused) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("label-cli-refused");
  const test::CliResult r = test::run_cli(
      "data label " + test::quoted(test::shared_data("radish/aces-corrected.log.gz")) + " -o " +
      test::quoted(d + "/s.csv") + " --holdout 0.2");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("--test"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(d + "/s.csv"));
}

TEST(LabelCli, LearnFromALogEqualsLearningFromItsLabels) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("learn-log");
  const std::string q = test::quoted(d);
  must_label("data simulate --town town2 --seed 2 --scans 4 --spacing 3 --out " + q + "/sim");
  must_label("data label " + q + "/sim/scans.log -o " + q + "/s.csv --free-per-metre 0.5");
  must_label("learn bhm " + q + "/s.csv -o " + q + "/from_csv.potmap --spacing 1");
  must_label("learn bhm " + q + "/sim/scans.log -o " + q +
             "/from_log.potmap --spacing 1 "
             "--free-per-metre 0.5");
  const std::string a = test::file_bytes(d + "/from_csv.potmap"),
                    b = test::file_bytes(d + "/from_log.potmap");
  ASSERT_GT(a.size(), 100u);
  EXPECT_EQ(a, b);
  // Another labelling gives another map: the options reach the labelling.
  must_label("learn bhm " + q + "/sim/scans.log -o " + q + "/other.potmap --spacing 1");
  EXPECT_NE(test::file_bytes(d + "/other.potmap"), a);
}

TEST(LabelCli, DictBuildLearnsItsOwnSourceMapFromALog) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("dict-log");
  const std::string q = test::quoted(d);
  must_label("data simulate --town town1 --seed 1 --scans 3 --spacing 3 --out " + q + "/sim");
  const test::CliResult r =
      must_label("dict build --scans " + q + "/sim/scans.log --out " + q + "/d.potdict --json -");
  EXPECT_NE(r.out.find("\"atoms\""), std::string::npos) << r.out;
  const test::CliResult info = must_label("dict info " + q + "/d.potdict");
  EXPECT_NE(info.out.find("joint BHM"), std::string::npos) << info.out;
  EXPECT_EQ(info.out.find("atoms             0\n"), std::string::npos) << info.out;
}

TEST(LabelCli, KittiFolderIsReadAsItsSequence) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("kitti-folder");
  const std::string q = test::quoted(d);
  must_label("data simulate --town town3 --3d --scans 3 --spacing 4 --out " + q + "/seq");
  const test::CliResult info = must_label("data info " + q + "/seq");
  EXPECT_NE(info.out.find("\nscans: 3\n"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("\ndimension: 3\n"), std::string::npos) << info.out;
  const test::CliResult label = must_label("data label " + q + "/seq -o " + q + "/s.csv");
  EXPECT_EQ(read_labelled_csv(d + "/s.csv").dim, 3);
  // A folder that is no sequence is named, not read as an empty log.
  std::filesystem::create_directories(d + "/empty");
  const test::CliResult bad = test::run_cli("data info " + q + "/empty");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.out.find("poses.txt"), std::string::npos) << bad.out;
}
