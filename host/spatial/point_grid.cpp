#include "point_grid.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace potmap::detail {

PointGrid::PointGrid(const std::vector<double>& points, int dim, double cell)
    : dim_(dim), n_(points.size() / std::size_t(dim)), pts_(&points) {
  if (n_ == 0) {
    start_.assign(2, 0);
    return;
  }
  double max_[3] = {0, 0, 0};
  for (int d = 0; d < dim_; ++d) min_[d] = max_[d] = points[d];
  for (std::size_t i = 0; i < n_; ++i)
    for (int d = 0; d < dim_; ++d) {
      min_[d] = std::min(min_[d], points[i * dim_ + d]);
      max_[d] = std::max(max_[d], points[i * dim_ + d]);
    }
  double widest = 0, volume = 1;
  for (int d = 0; d < dim_; ++d) widest = std::max(widest, max_[d] - min_[d]);
  if (!(widest > 0)) widest = 1;
  for (int d = 0; d < dim_; ++d) volume *= std::max(max_[d] - min_[d], widest * 1e-3);
  cell_ = cell > 0 ? cell : std::pow(2 * volume / double(n_), 1.0 / dim_);
  // A cloud along a line or a plane would otherwise ask for far more cells than points.
  auto cells = [&] {
    double c = 1;
    for (int d = 0; d < dim_; ++d) c *= std::floor((max_[d] - min_[d]) / cell_) + 1;
    return c;
  };
  while (cells() > 4.0 * double(n_) + 64) cell_ *= 2;
  for (int d = 0; d < dim_; ++d)
    extent_[d] = static_cast<std::int64_t>(std::floor((max_[d] - min_[d]) / cell_)) + 1;
  std::vector<std::uint32_t> of(n_);
  start_.assign(std::size_t(extent_[0] * extent_[1] * extent_[2]) + 1, 0);
  for (std::size_t i = 0; i < n_; ++i) {
    std::int64_t c[3] = {0, 0, 0};
    for (int d = 0; d < dim_; ++d) c[d] = clamp_cell(d, (points[i * dim_ + d] - min_[d]) / cell_);
    of[i] = std::uint32_t(cell_index(c[0], c[1], c[2]));
    ++start_[of[i] + 1];
  }
  for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
  order_.resize(n_);
  std::vector<std::uint32_t> fill(start_.begin(), start_.end() - 1);
  for (std::size_t i = 0; i < n_; ++i) order_[fill[of[i]]++] = std::uint32_t(i);
}

std::int64_t PointGrid::clamp_cell(int d, double v) const {
  if (!(v > 0)) return 0;  // NaN lands in the first cell too
  return std::min<std::int64_t>(static_cast<std::int64_t>(v), extent_[d] - 1);
}

long PointGrid::nearest(const double* p, double& d2) const {
  d2 = HUGE_VAL;
  if (n_ == 0) return -1;
  std::int64_t c0[3] = {0, 0, 0};
  for (int d = 0; d < dim_; ++d) c0[d] = clamp_cell(d, (p[d] - min_[d]) / cell_);
  const std::int64_t most = std::max({extent_[0], extent_[1], extent_[2]});
  long best = -1;
  for (std::int64_t k = 0; k <= most; ++k) {
    // Ring k: the cells k steps (Chebyshev) from the query's cell, the union of 2 dim slabs (one
    // axis k steps off). No point of ring k or beyond is nearer than the nearest slab's box (the
    // query may lie outside the grid); once `best` is nearer, no later ring can win. Rings grow
    // outward, so a ring's slabs are never nearer than the last ring's.
    if (k > 0) {
      double bound2 = HUGE_VAL;
      for (int d = 0; d < dim_; ++d)
        for (const std::int64_t side : {c0[d] + k, c0[d] - k}) {
          if (side < 0 || side >= extent_[d]) continue;
          double g2 = 0;  // squared distance from p to this slab's box of cells
          for (int e = 0; e < dim_; ++e) {
            const std::int64_t lo = e == d ? side : std::max<std::int64_t>(0, c0[e] - k);
            const std::int64_t hi = e == d ? side : std::min(extent_[e] - 1, c0[e] + k);
            const double gap = std::max({0.0, min_[e] + double(lo) * cell_ - p[e],
                                         p[e] - (min_[e] + double(hi + 1) * cell_)});
            g2 += gap * gap;
          }
          bound2 = std::min(bound2, g2);
        }
      if (bound2 == HUGE_VAL || (best >= 0 && d2 < bound2)) break;
    }
    const std::int64_t kz = dim_ == 3 ? k : 0;
    for (std::int64_t dz = -kz; dz <= kz; ++dz) {
      const std::int64_t z = c0[2] + dz;
      if (z < 0 || z >= extent_[2]) continue;
      for (std::int64_t dy = -k; dy <= k; ++dy) {
        const std::int64_t y = c0[1] + dy;
        if (y < 0 || y >= extent_[1]) continue;
        const bool edge = std::abs(dz) == k || std::abs(dy) == k;
        for (std::int64_t dx = -k; dx <= k; dx += (edge || k == 0) ? 1 : 2 * k) {
          const std::int64_t x = c0[0] + dx;
          if (x < 0 || x >= extent_[0]) continue;
          const std::size_t c = cell_index(x, y, z);
          for (std::uint32_t m = start_[c]; m < start_[c + 1]; ++m) {
            const std::uint32_t i = order_[m];
            const double e = dist2(p, i);
            if (e < d2 || (e == d2 && long(i) < best)) {
              d2 = e;
              best = long(i);
            }
          }
        }
      }
    }
  }
  return best;
}

}  // namespace potmap::detail
