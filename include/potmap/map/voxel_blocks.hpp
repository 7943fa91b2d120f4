#pragma once
// A 3D map's volume as cubic blocks of 16 x 16 x 16 voxels: the unit in which a drive's map is
// evaluated for its OctoMap, point cloud and height band (MapEvaluator::evaluate_blocks on the
// device, evaluate_blocks_exact as the reference), only where the map has kernels.
//
// Why 16 a side: a block's x rows are one float16 on the device (kernels/map/blocks.cl), and a
// block whose voxel is an OctoMap's resolution is one node of its octree four levels above the
// leaves (OctoMap's keys count voxels from a multiple of 16), so blocks encode into the octree
// one at a time (io/octomap_binary.hpp).

#include <cstddef>
#include <cstdint>
#include <vector>

#include "potmap/export.h"
#include "potmap/map/kernel_map.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct VoxelBlocks {
  static constexpr int kSide = 16;                      ///< voxels along each edge of a block
  static constexpr std::size_t kVoxels = 16 * 16 * 16;  ///< voxels in a block
  /// Voxel edge, metres (> 0). Block b spans [c_d * 16 * voxel, (c_d + 1) * 16 * voxel) on
  /// axis d, c_d = index[3 b + d]; its voxel (i, j, k) has its centre at c_d * 16 * voxel +
  /// (i + 0.5) * voxel (and j, k on y, z), and its values at i + 16 (j + 16 k) of the block's
  /// 4096.
  double voxel = 0.4;
  std::vector<std::int64_t> index;  ///< three block coordinates a block
  std::size_t size() const { return index.size() / 3; }
  /// The block's lower corner on axis d, metres.
  double corner(std::size_t b, int d) const { return double(index[3 * b + d]) * kSide * voxel; }
};

/// The blocks at `voxel` metres that hold at least one kernel of `map` (3D), sorted by z, then
/// y, then x. Throws ArgumentError for a 2D map or a voxel that is not positive.
VoxelBlocks blocks_holding_kernels(const KernelMap& map, double voxel);

/// Per voxel of every block (4096 a block, block after block): the logit's variance s2, the
/// probability, and the support sum_m phi_m^2 (io/known_cells.hpp's rule reads the last two).
struct BlockValues {
  std::vector<double> var, prob, support;
};

/// The exact reference: every kernel in double (evaluate_exact) at every voxel centre.
BlockValues evaluate_blocks_exact(const KernelMap& map, const VoxelBlocks& blocks);

}  // namespace potmap
POTMAP_CXX_API_END
