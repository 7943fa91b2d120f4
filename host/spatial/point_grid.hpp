#pragma once
// Nearest-point and fixed-radius queries over one small cloud (a sector's samples, an atom's
// kernels, a transport's source samples): a dense grid over the cloud's bounding box, about two
// points a cell. POT's placements and the out-of-sample map ask thousands of such questions a
// sector; a scan of every point per question was most of their time at 360 beams.

#include <cstdint>
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

  /// Calls f(index, squared distance) for every point within `r` of p (any order).
  template <class F>
  void for_each_within(const double* p, double r, F&& f) const {
    if (n_ == 0) return;
    std::int64_t lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
    for (int d = 0; d < dim_; ++d) {
      lo[d] = clamp_cell(d, (p[d] - r - min_[d]) / cell_);
      hi[d] = clamp_cell(d, (p[d] + r - min_[d]) / cell_);
      if ((p[d] + r) < min_[d] || (p[d] - r) > min_[d] + cell_ * double(extent_[d])) return;
    }
    const double r2 = r * r;
    for (std::int64_t z = lo[2]; z <= hi[2]; ++z)
      for (std::int64_t y = lo[1]; y <= hi[1]; ++y)
        for (std::int64_t x = lo[0]; x <= hi[0]; ++x) {
          const std::size_t c = cell_index(x, y, z);
          for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k) {
            const std::uint32_t i = order_[k];
            const double d2 = dist2(p, i);
            if (d2 <= r2) f(std::size_t(i), d2);
          }
        }
  }

 private:
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
