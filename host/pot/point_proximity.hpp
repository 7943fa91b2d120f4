#pragma once
// "Is any of these points within r of p?" for many queries, r fixed: a PointGrid with cell edge
// r (a dense grid over the points' box; a hash map of per-cell vectors was most of the
// placement's lookups).

#include <vector>

#include "spatial/point_grid.hpp"

namespace potmap::detail {

class PointProximity {
 public:
  /// `points`: n * dim coordinates (dim 2 or 3), kept by pointer (they must outlive this);
  /// `radius` > 0, in the points' units.
  PointProximity(const std::vector<double>& points, int dim, double radius)
      : r_(radius), grid_(points, dim, radius) {}
  /// Whether a point lies within the radius of p (dim coordinates).
  bool near(const double* p) const { return grid_.any_within(p, r_); }

 private:
  double r_;
  PointGrid grid_;
};

}  // namespace potmap::detail
