#pragma once
// The box of a row-major point array, shared by KernelMap::bounds and LabelledPoints::bounds.

#include <algorithm>
#include <cstddef>
#include <limits>
#include <vector>

namespace potmap::detail {

/// lo[d] <= x_d <= hi[d] over the `n` points of `dim` coordinates in `position`; the unused
/// axes and an empty set give 0.
inline void point_bounds(const std::vector<double>& position, std::size_t n, int dim, double lo[3],
                         double hi[3]) {
  for (int d = 0; d < 3; ++d) lo[d] = hi[d] = 0;
  if (n == 0) return;
  for (int d = 0; d < dim; ++d) {
    lo[d] = std::numeric_limits<double>::infinity();
    hi[d] = -std::numeric_limits<double>::infinity();
  }
  for (std::size_t i = 0; i < n; ++i)
    for (int d = 0; d < dim; ++d) {
      lo[d] = std::min(lo[d], position[i * dim + d]);
      hi[d] = std::max(hi[d], position[i * dim + d]);
    }
}

}  // namespace potmap::detail
