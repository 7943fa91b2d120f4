#pragma once
// Occupancy grid baseline (paper Sec. IV-C, Table VI "OGM"): an OctoMap octree updated beam by
// beam with the usual log-odds inverse sensor model. 2D scans become a one-cell-thick slab: every
// point and the sensor are put at z = 0, so rays stay in that layer.

#include <cstddef>
#include <cstdint>
#include <memory>
#include "potmap/export.h"

#include "potmap/data/scan.hpp"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct OgmOptions {
  double resolution = 0.5;  ///< cell edge, metres (> 0); default 0.5
  /// Rays are cut at this range, metres: a beam at or beyond it (and every no-return beam)
  /// carves free space up to it with no occupied end cell. 0 (default): each scan's max_range.
  double max_range = 0;
  double prob_hit = 0.7;   ///< OctoMap's default hit probability
  double prob_miss = 0.4;  ///< OctoMap's default miss probability
};

/// An occupancy grid in 2D (a z = 0 slab) or 3D.
class OccupancyGrid {
 public:
  /// Throws ArgumentError for dim not 2 or 3, resolution <= 0 or probabilities outside (0, 1).
  OccupancyGrid(int dim, const OgmOptions& options = {});
  ~OccupancyGrid();
  OccupancyGrid(OccupancyGrid&&) noexcept;
  OccupancyGrid& operator=(OccupancyGrid&&) noexcept;

  /// Inserts every beam of `scan` (same dim as the grid): hits within range as end points with
  /// the free ray before them, no-return beams as free rays out to the maximum range. Pass only
  /// training beams (split_beams) when the grid is to be scored on held-out ones.
  void insert(const Scan& scan);

  /// Occupancy probability at n points (n * dim coordinates, metres): the cell's probability,
  /// 0.5 for a cell no beam has touched. `prob` receives n values.
  void probability(const double* points, std::size_t n, double* prob) const;
  /// Whether a beam has touched the cell at each of n points (1) or not (0): `observed`
  /// receives n flags.
  void observed(const double* points, std::size_t n, std::uint8_t* observed) const;

  int dim() const;
  double resolution() const;
  std::size_t leaf_count() const;    ///< cells the octree stores (memory grows with it)
  std::size_t memory_bytes() const;  ///< the octree's own count (OcTree::memoryUsage)

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace potmap
POTMAP_CXX_API_END
