// Voxel blocks: the device's values at every voxel of 16^3 blocks against the exact double sums,
// on a drive-like lattice map and on kernels of widths over a factor of 10, far from the origin;
// which blocks hold kernels; bad arguments. Measured: p within 1e-6, variance and support within
// 6e-7 relative (the bounds below leave ten times that).
#include "potmap/map/voxel_blocks.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "potmap/error.hpp"
#include "potmap/map/evaluate.hpp"
#include "test_support.hpp"

using namespace potmap;

namespace {

// The joint BHM's 3D drive map: kernels 1 m apart (gamma 1.66), weights of both signs, over
// 14 x 10 x 6 m, shifted by `offset` metres on x and y.
KernelMap block_lattice_map(std::uint32_t seed, double offset) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> w(-6, 6), lv(std::log(1e-3), std::log(10.0));
  KernelMap map;
  map.dim = 3;
  for (int k = 0; k < 6; ++k)
    for (int j = 0; j < 10; ++j)
      for (int i = 0; i < 14; ++i) {
        const double p[3] = {offset + i - 3.5, offset + j + 0.5, k - 2.5};
        map.push_back(p, 1.66, w(rng), std::exp(lv(rng)));
      }
  map.has_bias = true;
  map.bias_mean = -0.4;
  map.bias_var = 2.0;
  return map;
}

// Kernels at random places and widths (0.5 to 5).
KernelMap block_random_map(std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(-5, 12), z(-3, 4), lg(std::log(0.5), std::log(5.0)),
      w(-6, 6), lv(std::log(1e-3), std::log(10.0));
  KernelMap map;
  map.dim = 3;
  for (int k = 0; k < 300; ++k) {
    const double p[3] = {xy(rng), xy(rng), z(rng)};
    map.push_back(p, std::exp(lg(rng)), w(rng), std::exp(lv(rng)));
  }
  return map;
}

// Largest differences between the device's blocks and the exact reference.
struct BlockWorst {
  double prob = 0, var = 0, support = 0;
};

BlockWorst compare_blocks(const KernelMap& map, const VoxelBlocks& blocks) {
  MapEvaluator ev(test::context(), map);
  const std::size_t n = blocks.size() * VoxelBlocks::kVoxels;
  std::vector<float> var(n), prob(n), support(n);
  ev.evaluate_blocks(blocks, var.data(), prob.data(), support.data());
  EXPECT_GT(ev.last_pairs(), 0u);
  const BlockValues exact = evaluate_blocks_exact(map, blocks);
  BlockWorst w;
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_TRUE(std::isfinite(prob[i])) << i;
    w.prob = std::max(w.prob, std::abs(prob[i] - exact.prob[i]));
    w.var = std::max(w.var, std::abs(var[i] - exact.var[i]) / (1 + exact.var[i]));
    w.support =
        std::max(w.support, std::abs(support[i] - exact.support[i]) / (1 + exact.support[i]));
  }
  return w;
}

}  // namespace

TEST(VoxelBlocks, BlocksHoldingKernelsAreFoundOnceInZyxOrder) {
  KernelMap map;
  map.dim = 3;
  const double a[3] = {0.1, 0.1, 0.1}, b[3] = {6.3, 0.2, 0.0}, c[3] = {6.5, -0.1, 0.0},
               d[3] = {-0.1, 7.0, -7.0};
  for (const double* p : {a, b, c, d}) map.push_back(p, 1.0, 0.0, 1.0);
  const VoxelBlocks blocks = blocks_holding_kernels(map, 0.4);  // 6.4 m blocks
  ASSERT_EQ(blocks.size(), 3u);                                 // a and b share one
  const std::vector<std::int64_t> expected = {-1, 1, -2, 1, -1, 0, 0, 0, 0};
  EXPECT_EQ(blocks.index, expected);  // d (lowest z); c (lower y); a and b
  EXPECT_DOUBLE_EQ(blocks.corner(1, 1), -6.4);
}

TEST(VoxelBlocks, DeviceMatchesTheExactSumsOnADriveLatticeFarFromTheOrigin) {
  // Kernels 500 km from the origin (UTM): positions split hi + lo keep micrometres.
  const KernelMap map = block_lattice_map(31, 500000.0);
  const VoxelBlocks blocks = blocks_holding_kernels(map, 0.4);
  ASSERT_GE(blocks.size(), 8u);
  const BlockWorst w = compare_blocks(map, blocks);
  EXPECT_LT(w.prob, 1e-5);
  EXPECT_LT(w.var, 1e-5);
  EXPECT_LT(w.support, 1e-5);
}

TEST(VoxelBlocks, DeviceMatchesTheExactSumsForKernelsOfManyWidths) {
  const KernelMap map = block_random_map(32);
  VoxelBlocks blocks = blocks_holding_kernels(map, 0.25);  // 4 m blocks
  ASSERT_GE(blocks.size(), 20u);
  // And a block no kernel reaches: zero support, the prior's probability.
  blocks.index.insert(blocks.index.end(), {40, 40, 40});
  const BlockWorst w = compare_blocks(map, blocks);
  EXPECT_LT(w.prob, 1e-5);
  EXPECT_LT(w.var, 1e-5);
  EXPECT_LT(w.support, 1e-5);
}

TEST(VoxelBlocks, BadArgumentsAreRefused) {
  KernelMap flat;
  flat.dim = 2;
  const double p[2] = {0, 0};
  flat.push_back(p, 1.0, 0.0, 1.0);
  EXPECT_THROW(blocks_holding_kernels(flat, 0.4), ArgumentError);
  const KernelMap map = block_random_map(33);
  EXPECT_THROW(blocks_holding_kernels(map, 0.0), ArgumentError);
  MapEvaluator ev(test::context(), map);
  VoxelBlocks bad;
  bad.voxel = -1;
  bad.index = {0, 0, 0};
  float v[VoxelBlocks::kVoxels];
  EXPECT_THROW(ev.evaluate_blocks(bad, v, nullptr, nullptr), ArgumentError);
  bad.voxel = 0.4;
  bad.index = {0, 0};
  EXPECT_THROW(ev.evaluate_blocks(bad, v, nullptr, nullptr), ArgumentError);
}
