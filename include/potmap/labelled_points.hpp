#pragma once
// Labelled points: positions with an occupancy label (1 = LIDAR hit, 0 = free), optionally with
// the scan index they came from. The test sets and the labelled-sample CSV of Bayesian Hilbert
// maps (`t,x,y[,z],occupied`) use this type.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace potmap {

struct LabelledPoints {
  int dim = 2;                      ///< 2 or 3
  std::vector<double> position;     ///< size() * dim coordinates, row-major, metres
  std::vector<std::uint8_t> label;  ///< 1 = occupied (hit), 0 = free
  std::vector<std::int64_t> scan;   ///< scan index t of each point (0 when the source has none)
  std::size_t size() const { return label.size(); }
  bool empty() const { return label.empty(); }
};

/// Reads `t,x,y,occupied` (2D) or `t,x,y,z,occupied` (3D) CSV with a header line; the dimension
/// follows the header. `occupied` must be 0 or 1 (1.0 and 0.0 accepted). Throws InputError
/// naming file, line and value for a missing column, a non-numeric or non-finite value, or a
/// wrong field count.
LabelledPoints read_labelled_csv(const std::string& path);

/// Writes the same format (atomically: temporary file, then rename).
void write_labelled_csv(const LabelledPoints& points, const std::string& path);

}  // namespace potmap
