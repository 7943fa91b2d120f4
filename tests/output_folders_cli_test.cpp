// Commands that write files make the folders of their outputs, and print only their own lines:
// no third-party library (liboctomap, GDAL, PCL, OpenMPI, PoCL) writes into the output.
#include <gtest/gtest.h>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "potmap/io/map_io.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;
using namespace potmap;

namespace {

// A wall at (0, 0) and free space at (3, 0).
KernelMap wall_and_floor_map() {
  KernelMap m;
  const double pts[2][2] = {{0, 0}, {3, 0}};
  m.push_back(pts[0], 4.0, 5.0, 0.1);
  m.push_back(pts[1], 4.0, -5.0, 0.1);
  return m;
}

// Every line of `out` that starts with none of `own` (the command's own line starts).
std::vector<std::string> foreign_lines(const std::string& out,
                                       const std::vector<std::string>& own) {
  std::vector<std::string> foreign;
  std::istringstream in(out);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    bool ours = false;
    for (const std::string& o : own) ours = ours || line.rfind(o, 0) == 0;
    if (!ours) foreign.push_back(line);
  }
  return foreign;
}

std::string joined(const std::vector<std::string>& lines) {
  std::string s;
  for (const auto& l : lines) s += l + "\n";
  return s;
}

}  // namespace

TEST(OutputFolders, ExportsMakeTheirFolderAndPrintOnlyTheirOwnLines) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("output-folders-export");
  write_map(wall_and_floor_map(), d + "/m.potmap");
  const std::string map = test::quoted(d + "/m.potmap");
  for (const char* ext : {"bt", "ot"}) {
    const std::string out = d + "/octo-" + ext + "/deeper/m." + ext;
    // stdout and stderr together: liboctomap's writer prints on stderr.
    const test::CliResult r =
        test::run_cli("export octomap " + map + " -o " + test::quoted(out) + " --res 0.1", "2>&1");
    ASSERT_EQ(r.status, 0) << r.out;
    EXPECT_TRUE(fs::exists(out)) << out;
    EXPECT_EQ(joined(foreign_lines(r.out, {"potmap: ", "OctoMap at ", "wrote "})), "") << ext;
  }
  const std::string yaml = d + "/ros/deeper/m.yaml";
  const test::CliResult r =
      test::run_cli("export ros " + map + " -o " + test::quoted(yaml), "2>&1");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(fs::exists(yaml));
  EXPECT_TRUE(fs::exists(d + "/ros/deeper/m.pgm"));
  EXPECT_EQ(joined(foreign_lines(r.out, {"potmap: ", "ROS map ", "wrote "})), "");
  // A folder that cannot be made (a file stands where it would go) is an error naming it.
  test::write_file(d, "file", "x");
  const test::CliResult bad =
      test::run_cli("export ros " + map + " -o " + test::quoted(d + "/file/m.yaml"), "2>&1");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.out.find(d + "/file"), std::string::npos) << bad.out;
}

TEST(OutputFolders, DataLabelMakesTheFoldersOfBothFiles) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("output-folders-label");
  const std::string q = test::quoted(d);
  const test::CliResult sim = test::run_cli(
      "data simulate --town town2 --seed 2 --scans 2 --spacing 3 --out " + q + "/sim");
  ASSERT_EQ(sim.status, 0) << sim.out;
  const test::CliResult r =
      test::run_cli("data label " + q + "/sim/scans.log -o " + q +
                    "/train/a/s.csv --holdout 0.2 --test " + q + "/test/b/t.csv");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_GT(fs::file_size(d + "/train/a/s.csv"), 100u);
  EXPECT_GT(fs::file_size(d + "/test/b/t.csv"), 100u);
}
