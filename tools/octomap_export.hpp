#pragma once
// Kernel maps as OctoMap files: `.bt` (occupied and free voxels, the maximum likelihood; the
// library's encoder, io/octomap_binary.hpp) or `.ot` (every known voxel with its log-odds;
// liboctomap). Known voxels follow
// io/known_cells.hpp; unknown ones are left out of the tree, as OctoMap itself leaves space no
// beam crossed.
#include <cstddef>
#include <string>

#include "potmap/io/known_cells.hpp"
#include "potmap/map/kernel_map.hpp"
#include "potmap/runtime/context.hpp"

namespace potmap::cli {

struct OctomapExportOptions {
  double resolution = 0.1;  ///< voxel edge, metres (default 0.1, the experiments' OGM cell)
  double margin = 1.0;      ///< metres around the kernel bounds (one joint-BHM kernel reach)
  double z = 0;             ///< 2D maps: height of the single voxel layer, metres
  // Probabilities are stored clamped to [0.001, 0.999] (OctoMap clamps log-odds).
  KnownRule known;  ///< which voxels are known
  /// Most voxels evaluated (default 2^27, about 3 GB of points in 3D at once is avoided: 3D
  /// maps are evaluated one layer at a time); a larger volume is refused.
  std::size_t max_voxels = std::size_t(1) << 27;
};

struct OctomapExportSummary {
  std::size_t occupied = 0, free = 0, unknown = 0;  ///< voxels of the evaluated volume
  std::size_t leaves = 0;                           ///< leaves of the written (pruned) tree
};

/// Writes `path` (.bt or .ot, by its extension) atomically. `ctx` null: exact CPU sums.
/// Throws ArgumentError for another extension, an empty map or too large a volume.
OctomapExportSummary write_octomap(Context* ctx, const KernelMap& map, const std::string& path,
                                   const OctomapExportOptions& options = {});

}  // namespace potmap::cli
