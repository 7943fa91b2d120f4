#pragma once
// Nearest-point and fixed-radius queries over one small cloud (a sector's samples, an atom's
// kernels, a transport's source samples): a dense grid over the cloud's bounding box, about two
// points a cell. POT's placements and the out-of-sample map ask thousands of such questions a
// sector; a scan of every point per question was most of their time at 360 beams.

#include <cstdint>
#include <stdexcept>
#include <vector>

namespace potmap::detail {

class PointGrid {
 public:
  /// `points`: n * dim coordinates (dim 2 or 3), kept by pointer: they must outlive the grid.
  /// `cell` > 0 sets the cell edge (in the points' units); 0 picks one from the density.
  PointGrid(const std::vector<double>& points, int dim, double cell = 0);

  std::size_t size() const { return n_; }

  /// Index of the point nearest `p` (the lowest index among equally near ones, as a scan in
  /// order finds) and its squared distance in `d2`; -1 when the cloud is empty.
  long nearest(const double* p, double& d2) const;

  /// Calls f(i, j, squared distance) once for every pair of points i != j within `r` of each
  /// other, `r` at most the cell edge (then a cell's partners lie in it and its ring of
  /// neighbours): each cell with itself and the half of its neighbours after it in the grid's
  /// order, points in index order within a cell. Throws std::invalid_argument for a larger r.
  template <class F>
  void for_each_pair_within(double r, F&& f) const {
    if (n_ == 0) return;
    if (r > cell_) throw std::invalid_argument("PointGrid::for_each_pair_within: r above the cell");
    const double r2 = r * r;
    const std::int64_t rz = dim_ == 3 ? 1 : 0;
    for (std::int64_t z = 0; z < extent_[2]; ++z)
      for (std::int64_t y = 0; y < extent_[1]; ++y)
        for (std::int64_t x = 0; x < extent_[0]; ++x) {
          const std::size_t c = cell_index(x, y, z);
          for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k) {
            const std::uint32_t i = order_[k];
            const double* p = &(*pts_)[std::size_t(i) * dim_];
            auto visit = [&](std::uint32_t from, std::uint32_t to) {
              for (std::uint32_t l = from; l < to; ++l) {
                const double d2 = dist2(p, order_[l]);
                if (d2 <= r2) f(std::size_t(i), std::size_t(order_[l]), d2);
              }
            };
            visit(k + 1, start_[c + 1]);
            // The neighbours after this cell in (z, y, x) order: 4 in 2D, 13 in 3D.
            for (std::int64_t dz = 0; dz <= rz; ++dz)
              for (std::int64_t dy = dz == 0 ? 0 : -1; dy <= 1; ++dy)
                for (std::int64_t dx = dz == 0 && dy == 0 ? 1 : -1; dx <= 1; ++dx) {
                  const std::int64_t nx = x + dx, ny = y + dy, nz = z + dz;
                  if (nx < 0 || nx >= extent_[0] || ny < 0 || ny >= extent_[1] || nz >= extent_[2])
                    continue;
                  const std::size_t e = cell_index(nx, ny, nz);
                  visit(start_[e], start_[e + 1]);
                }
          }
        }
  }

  /// Calls f(index, squared distance) for every point within `r` of p (any order).
  template <class F>
  void for_each_within(const double* p, double r, F&& f) const {
    find_within(p, r, [&f](std::size_t i, double d2) {
      f(i, d2);
      return false;
    });
  }

  /// Whether any point lies within `r` of p (it stops at the first one found).
  bool any_within(const double* p, double r) const {
    return find_within(p, r, [](std::size_t, double) { return true; });
  }

 private:
  // Calls f(index, squared distance) for the points within `r` of p until f returns true;
  // whether one did.
  template <class F>
  bool find_within(const double* p, double r, F&& f) const {
    if (n_ == 0) return false;
    std::int64_t lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
    for (int d = 0; d < dim_; ++d) {
      lo[d] = clamp_cell(d, (p[d] - r - min_[d]) / cell_);
      hi[d] = clamp_cell(d, (p[d] + r - min_[d]) / cell_);
      if ((p[d] + r) < min_[d] || (p[d] - r) > min_[d] + cell_ * double(extent_[d])) return false;
    }
    const double r2 = r * r;
    for (std::int64_t z = lo[2]; z <= hi[2]; ++z)
      for (std::int64_t y = lo[1]; y <= hi[1]; ++y)
        for (std::int64_t x = lo[0]; x <= hi[0]; ++x) {
          const std::size_t c = cell_index(x, y, z);
          for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k) {
            const std::uint32_t i = order_[k];
            const double d2 = dist2(p, i);
            if (d2 <= r2 && f(std::size_t(i), d2)) return true;
          }
        }
    return false;
  }
  double dist2(const double* p, std::uint32_t i) const {
    double s = 0;
    for (int d = 0; d < dim_; ++d) {
      const double t = p[d] - (*pts_)[std::size_t(i) * dim_ + d];
      s += t * t;
    }
    return s;
  }
  std::int64_t clamp_cell(int d, double v) const;
  std::size_t cell_index(std::int64_t x, std::int64_t y, std::int64_t z) const {
    return std::size_t((z * extent_[1] + y) * extent_[0] + x);
  }

  int dim_;
  std::size_t n_;
  const std::vector<double>* pts_;
  double cell_ = 1;
  double min_[3] = {0, 0, 0};
  std::int64_t extent_[3] = {1, 1, 1};  // cells an axis
  std::vector<std::uint32_t> start_;    // per cell, its first entry in order_ (CSR)
  std::vector<std::uint32_t> order_;    // point indices by cell, ascending within a cell
};

}  // namespace potmap::detail
