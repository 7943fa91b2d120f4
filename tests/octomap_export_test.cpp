// `potmap export octomap`: the files read back with OctoMap's own readers and checked against
// the map's exact probabilities.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <sstream>

#include "potmap/io/known_cells.hpp"
#include "potmap/io/map_io.hpp"
#include "potmap/map/evaluate.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

// A wall at (0, 0), free space at (3, 0), a kernel still at its prior at (0, 3).
KernelMap small_map() {
  KernelMap m;
  const double pts[3][2] = {{0, 0}, {3, 0}, {0, 3}};
  m.push_back(pts[0], 4.0, 5.0, 0.1);
  m.push_back(pts[1], 4.0, -5.0, 0.1);
  m.push_back(pts[2], 4.0, 0.0, 10.0);
  return m;
}

}  // namespace

TEST(OctomapExport, OtHoldsTheMapsProbabilityOnKnownVoxelsOnly) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("octomap-ot");
  const KernelMap map = small_map();
  write_map(map, d + "/m.potmap");
  const test::CliResult r = test::run_cli("export octomap " + test::quoted(d + "/m.potmap") +
                                          " -o " + test::quoted(d + "/m.ot") + " --res 0.1 --cpu");
  ASSERT_EQ(r.status, 0) << r.out;
  std::unique_ptr<octomap::AbstractOcTree> any(octomap::AbstractOcTree::read(d + "/m.ot"));
  ASSERT_TRUE(any);
  auto* tree = dynamic_cast<octomap::OcTree*>(any.get());
  ASSERT_NE(tree, nullptr);
  EXPECT_DOUBLE_EQ(tree->getResolution(), 0.1);

  std::size_t leaves = 0, checked = 0;
  for (auto it = tree->begin_leafs(); it != tree->end_leafs(); ++it) {
    ++leaves;
    const double pt[2] = {it.getX(), it.getY()};
    EXPECT_NEAR(it.getZ(), 0.05, 1e-6);
    const double p = std::clamp(evaluate_exact(map, pt, 1).prob[0], 1e-3, 1 - 1e-3);
    ASSERT_NEAR(it->getOccupancy(), p, 2e-4) << pt[0] << ", " << pt[1];
    ++checked;
  }
  EXPECT_GT(checked, 100u);  // two kernels of reach 0.54 m at support 0.1: about 180 cells
  // Every known cell is a leaf, and no unknown one (beyond the 1 m margin no kernel reaches).
  const KnownValues kv = known_values(nullptr, map, [&] {
    std::vector<double> pts;
    for (int j = -20; j < 50; ++j)
      for (int i = -20; i < 50; ++i) {
        pts.push_back((i + 0.5) * 0.1);
        pts.push_back((j + 0.5) * 0.1);
      }
    return pts;
  }());
  EXPECT_EQ(leaves, static_cast<std::size_t>(std::count(kv.known.begin(), kv.known.end(), 1)));
  EXPECT_EQ(tree->search(0.05, 3.05, 0.05), nullptr);   // prior variance: unknown
  EXPECT_EQ(tree->search(-1.95, 3.95, 0.05), nullptr);  // no kernel
}

TEST(OctomapExport, BtMarksTheWallOccupiedAndTheFloorFree) {
  if (!test::cli_built()) GTEST_SKIP() << "potmap command not built";
  const std::string d = test::temp_dir("octomap-bt");
  write_map(small_map(), d + "/m.potmap");
  const test::CliResult r = test::run_cli("export octomap " + test::quoted(d + "/m.potmap") +
                                          " -o " + test::quoted(d + "/m.bt") + " --res 0.1");
  ASSERT_EQ(r.status, 0) << r.out;
  octomap::OcTree tree(0.1);
  ASSERT_TRUE(tree.readBinary(d + "/m.bt"));
  const octomap::OcTreeNode* wall = tree.search(0.05, 0.05, 0.05);
  const octomap::OcTreeNode* floor = tree.search(3.05, 0.05, 0.05);
  ASSERT_NE(wall, nullptr);
  ASSERT_NE(floor, nullptr);
  EXPECT_TRUE(tree.isNodeOccupied(wall));
  EXPECT_FALSE(tree.isNodeOccupied(floor));
  EXPECT_EQ(tree.search(0.05, 3.05, 0.05), nullptr);
  // potmap's own encoder wrote it: the bytes must be those liboctomap writes for the same tree.
  std::ostringstream again;
  ASSERT_TRUE(tree.writeBinary(again));
  EXPECT_EQ(again.str(), test::file_bytes(d + "/m.bt"));
  const test::CliResult bad = test::run_cli("export octomap " + test::quoted(d + "/m.potmap") +
                                            " -o " + test::quoted(d + "/m.oct"));
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.out.find("m.oct"), std::string::npos) << bad.out;
}
