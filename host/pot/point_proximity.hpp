#pragma once
// "Is any of these points within r of p?" for many queries: a hash grid with cell edge r.

#include <cmath>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "cell_key.hpp"

namespace potmap::detail {

class PointProximity {
 public:
  /// `points`: n * dim coordinates (dim 2 or 3); `radius` > 0, in the points' units.
  PointProximity(const std::vector<double>& points, int dim, double radius)
      : dim_(dim), r_(radius), pts_(&points) {
    const std::size_t n = points.size() / std::size_t(dim);
    for (std::size_t i = 0; i < n; ++i) grid_[key(&points[i * dim])].push_back(std::uint32_t(i));
  }
  /// Whether a point lies within the radius of p (dim coordinates).
  bool near(const double* p) const {
    std::int64_t c[3] = {0, 0, 0};
    for (int d = 0; d < dim_; ++d) c[d] = static_cast<std::int64_t>(std::floor(p[d] / r_));
    const int dz = dim_ == 3 ? 1 : 0;
    for (int k = -dz; k <= dz; ++k)
      for (int j = -1; j <= 1; ++j)
        for (int i = -1; i <= 1; ++i) {
          const std::int64_t q[3] = {c[0] + i, c[1] + j, c[2] + k};
          const auto it = grid_.find(pack(q));
          if (it == grid_.end()) continue;
          for (std::uint32_t m : it->second) {
            double d2 = 0;
            for (int d = 0; d < dim_; ++d) {
              const double t = p[d] - (*pts_)[m * dim_ + d];
              d2 += t * t;
            }
            if (d2 <= r_ * r_) return true;
          }
        }
    return false;
  }

 private:
  static std::uint64_t pack(const std::int64_t c[3]) { return pack_cell(c); }
  std::uint64_t key(const double* p) const {
    std::int64_t c[3] = {0, 0, 0};
    for (int d = 0; d < dim_; ++d) c[d] = static_cast<std::int64_t>(std::floor(p[d] / r_));
    return pack(c);
  }
  int dim_;
  double r_;
  const std::vector<double>* pts_;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> grid_;
};

}  // namespace potmap::detail
