// OctoMap's .bt written from voxel blocks: the same bytes as liboctomap's own writeBinary of a
// tree holding the same voxels (pruning inside blocks, across blocks and up to the root's
// children, blocks on both sides of the origin), the empty tree, bad blocks.
#include "potmap/io/octomap_binary.hpp"

#include <octomap/OcTree.h>

#include <gtest/gtest.h>

#include <random>
#include <sstream>

#include "potmap/error.hpp"

using namespace potmap;

namespace {

constexpr std::size_t kBlockVoxels = 4096;

// Voxel states of a block: uniform cells of `cell` voxels a side (1: every voxel its own), each
// unknown, free or occupied at random with the given weights.
std::vector<OctomapState> block_states(std::mt19937& rng, int cell, std::array<double, 3> w) {
  std::discrete_distribution<int> pick(w.begin(), w.end());
  const int s = 16 / cell;
  std::vector<int> cells(std::size_t(s) * s * s);
  for (int& c : cells) c = pick(rng);
  std::vector<OctomapState> v(kBlockVoxels);
  for (int k = 0; k < 16; ++k)
    for (int j = 0; j < 16; ++j)
      for (int i = 0; i < 16; ++i)
        v[std::size_t(i + 16 * (j + 16 * k))] =
            OctomapState(cells[std::size_t(i / cell + s * (j / cell + s * (k / cell)))]);
  return v;
}

struct TestBlocks {
  double res = 0.4;
  std::vector<std::int64_t> index;
  std::vector<std::vector<OctomapState>> states;
};

// liboctomap's bytes for the same voxels, each set to its state's clamping value; `leaves`
// gets its tree's leaves.
std::string liboctomap_bytes(const TestBlocks& t, std::size_t* leaves = nullptr) {
  octomap::OcTree tree(t.res);
  for (std::size_t b = 0; b < t.states.size(); ++b)
    for (int k = 0; k < 16; ++k)
      for (int j = 0; j < 16; ++j)
        for (int i = 0; i < 16; ++i) {
          const OctomapState s = t.states[b][std::size_t(i + 16 * (j + 16 * k))];
          if (s == OctomapState::unknown) continue;
          const int at[3] = {i, j, k};
          octomap::OcTreeKey key;
          for (int d = 0; d < 3; ++d)
            key[d] = static_cast<octomap::key_type>(32768 + 16 * t.index[3 * b + d] + at[d]);
          tree.setNodeValue(key,
                            s == OctomapState::occupied ? tree.getClampingThresMaxLog()
                                                        : tree.getClampingThresMinLog(),
                            true);
        }
  tree.updateInnerOccupancy();
  std::ostringstream out;
  EXPECT_TRUE(tree.writeBinary(out));
  if (leaves) *leaves = tree.getNumLeafNodes();
  return out.str();
}

std::string our_bytes(const TestBlocks& t) {
  std::vector<OctomapBlockCode> codes;
  for (const auto& s : t.states) codes.push_back(encode_octomap_block(s.data()));
  return octomap_binary_file(t.res, t.index, codes).bytes;
}

}  // namespace

TEST(OctomapBinary, BytesAreLiboctomapsForBlocksOfEveryKind) {
  std::mt19937 rng(7);
  TestBlocks t;
  auto add = [&](std::int64_t x, std::int64_t y, std::int64_t z, std::vector<OctomapState> s) {
    t.index.insert(t.index.end(), {x, y, z});
    t.states.push_back(std::move(s));
  };
  // Voxel by voxel, in cells of 2, 4 and 8 (pruning at every level inside a block).
  add(0, 0, 0, block_states(rng, 1, {0.3, 0.5, 0.2}));
  add(-1, 0, 0, block_states(rng, 2, {0.2, 0.6, 0.2}));
  add(0, -1, -1, block_states(rng, 4, {0.3, 0.4, 0.3}));
  add(5, -7, 2, block_states(rng, 8, {0.2, 0.4, 0.4}));
  // Whole blocks of one state; eight of them free make one leaf two levels up.
  add(3, 3, 3, std::vector<OctomapState>(kBlockVoxels, OctomapState::occupied));
  for (int c = 0; c < 8; ++c)
    add(10 + (c & 1), 10 + (c >> 1 & 1), -2 + (c >> 2 & 1),
        std::vector<OctomapState>(kBlockVoxels, OctomapState::free));
  // A block with nothing known is no node at all.
  add(-20, 4, 0, std::vector<OctomapState>(kBlockVoxels, OctomapState::unknown));
  // Far from the origin on every axis, each side.
  add(2040, -2047, 100, block_states(rng, 1, {0.5, 0.3, 0.2}));
  add(-2048, 2047, -100, block_states(rng, 2, {0.5, 0.3, 0.2}));
  std::size_t leaves = 0;
  const std::string expected = liboctomap_bytes(t, &leaves);
  const std::string got = our_bytes(t);
  std::vector<OctomapBlockCode> codes;
  for (const auto& s : t.states) codes.push_back(encode_octomap_block(s.data()));
  EXPECT_EQ(octomap_binary_file(t.res, t.index, codes).leaves, leaves);
  ASSERT_GT(expected.size(), 2000u);
  EXPECT_EQ(got.size(), expected.size());
  EXPECT_TRUE(got == expected) << "the files differ";
  // And the blocks' order does not matter.
  std::swap(t.states[0], t.states[5]);
  for (int d = 0; d < 3; ++d) std::swap(t.index[d], t.index[15 + d]);
  EXPECT_TRUE(our_bytes(t) == expected);
}

TEST(OctomapBinary, ResolutionIsPrintedAsLiboctomapPrintsIt) {
  std::mt19937 rng(8);
  TestBlocks t;
  t.res = 0.123456789;
  t.index = {1, 2, 3};
  t.states.push_back(block_states(rng, 1, {0.2, 0.5, 0.3}));
  EXPECT_TRUE(our_bytes(t) == liboctomap_bytes(t));
}

TEST(OctomapBinary, NoKnownVoxelIsTheEmptyTree) {
  TestBlocks t;
  t.index = {0, 0, 0};
  t.states.push_back(std::vector<OctomapState>(kBlockVoxels, OctomapState::unknown));
  EXPECT_TRUE(our_bytes(t) == liboctomap_bytes(t));
  EXPECT_TRUE(octomap_binary_file(0.4, {}, {}).bytes == liboctomap_bytes(TestBlocks{}));
}

TEST(OctomapBinary, BlocksOutsideTheKeysOrGivenTwiceAreRefused) {
  std::vector<OctomapBlockCode> one(1);
  one[0].type = 1;
  one[0].nodes = 1;
  EXPECT_THROW(octomap_binary_file(0.4, {2048, 0, 0}, one), ArgumentError);
  EXPECT_THROW(octomap_binary_file(0.4, {0, -2049, 0}, one), ArgumentError);
  EXPECT_THROW(octomap_binary_file(0.4, {0, 0}, one), ArgumentError);
  std::vector<OctomapBlockCode> two(2, one[0]);
  EXPECT_THROW(octomap_binary_file(0.4, {1, 1, 1, 1, 1, 1}, two), ArgumentError);
}
