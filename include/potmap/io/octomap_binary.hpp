#pragma once
// OctoMap's binary tree file (.bt) written from voxel blocks (map/voxel_blocks.hpp), without
// building the tree node by node: a block of 16^3 voxels at the OctoMap's resolution is one
// node of its octree four levels above the leaves, so each block's subtree is encoded on its
// own (encode_octomap_block, any thread) and the levels above the blocks are joined at the
// end (octomap_binary_file). The bytes are those liboctomap's OcTree::writeBinary writes for a
// tree holding the same voxels, each at its most likely state (tests/octomap_binary_test.cpp
// holds them to it byte for byte): the tree is pruned (eight leaves of one state are their
// parent) and each node is written as two bytes of its children's states, depth first.
//
// Why not liboctomap itself: inserting a drive's tens of millions of voxels one at a time took
// longer than mapping the drive, on one core; octovis, octomap_server and
// OcTree::readBinary read this file as they read theirs.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

/// A voxel's state in an OctoMap: not in the tree, a free leaf, an occupied leaf.
enum class OctomapState : std::uint8_t { unknown = 0, free = 1, occupied = 2 };

/// One block's subtree: what its node is (unknown: absent from the tree; free or occupied: one
/// leaf, its voxels all of that state; else inner), its nodes (the block's own included), and
/// the depth-first bytes of its inner nodes (empty unless inner).
struct OctomapBlockCode {
  std::uint8_t type = 0;  ///< 0 absent, 1 free leaf, 2 occupied leaf, 3 inner node
  std::uint32_t nodes = 0;
  std::string bytes;
};

/// Encodes a block from its 4096 voxel states (i + 16 (j + 16 k), VoxelBlocks's order).
OctomapBlockCode encode_octomap_block(const OctomapState* states);

/// A .bt file's bytes and what its tree holds.
struct OctomapFile {
  std::string bytes;
  std::uint64_t nodes = 0;   ///< every node, inner ones included (the header's "size")
  std::uint64_t leaves = 0;  ///< free and occupied leaves, pruned ones counted once
};

/// The whole .bt file: the header (resolution in metres, printed as OctoMap prints it), then the
/// tree above the blocks and each block's code. `block_index`: three block coordinates a block
/// (VoxelBlocks::index, each block 16 voxels of `resolution` a side), distinct, any order;
/// `codes[b]` is block b's. Throws ArgumentError when a block lies outside OctoMap's key range
/// (+-32768 voxels from the origin on each axis) or the sizes disagree.
OctomapFile octomap_binary_file(double resolution, const std::vector<std::int64_t>& block_index,
                                const std::vector<OctomapBlockCode>& codes);

}  // namespace potmap
POTMAP_CXX_API_END
