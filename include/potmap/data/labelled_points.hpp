#pragma once
// Labelled points: positions with an occupancy label (1 = LIDAR hit, 0 = free), optionally with
// the scan index they came from. The test sets and the labelled-sample CSV of Bayesian Hilbert
// maps (`t,x,y[,z],occupied`) use this type.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "potmap/error.hpp"  // the exceptions documented below
#include "potmap/export.h"

POTMAP_CXX_API_BEGIN
namespace potmap {

struct LabelledPoints {
  int dim = 2;                      ///< 2 or 3
  std::vector<double> position;     ///< size() * dim coordinates, row-major, metres
  std::vector<std::uint8_t> label;  ///< 1 = occupied (hit), 0 = free
  std::vector<std::int64_t> scan;   ///< scan index t of each point (0 when the source has none)
  /// How many samples each point stands for (empty, the default: one each). A point that
  /// gathers the samples of a small voxel (aggregate_voxels) carries their number, so a
  /// learner adds it once with that weight instead of once per sample: the Jaakkola-Jordan
  /// bound of n samples at one place is n times one sample's.
  std::vector<double> weight;
  std::size_t size() const { return label.size(); }
  bool empty() const { return label.empty(); }
  /// Smallest box holding every point, metres: lo[d] <= x_d <= hi[d] for d < dim; the unused
  /// axes and an empty set give 0 (as KernelMap::bounds).
  void bounds(double lo[3], double hi[3]) const;
};

/// Reads `t,x,y,occupied` (2D) or `t,x,y,z,occupied` (3D) CSV with a header line; the dimension
/// follows the header (3D if a `z` column is present). Columns are found by name
/// (case-insensitive, any order); `t` is optional (scan 0 when absent) and must be an integer;
/// extra columns are ignored; blank lines and lines starting with `#` are skipped. `occupied`
/// must be 0 or 1 (1.0 and 0.0 accepted). Throws InputError naming file, line and value for a
/// missing column, a non-numeric or non-finite value, or a wrong field count.
LabelledPoints read_labelled_csv(const std::string& path);

/// Writes the same format (atomically: temporary file, then rename), numbers as the shortest text
/// that reads back exactly. Throws ArgumentError for inconsistent sizes, labels other than 0/1 or
/// non-finite coordinates; an empty `scan` writes t = 0.
void write_labelled_csv(const LabelledPoints& points, const std::string& path);

}  // namespace potmap
POTMAP_CXX_API_END
