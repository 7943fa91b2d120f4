#pragma once
// The joint BHM's grid (host/learn/bhm_joint*.cpp): its limits, the tile arithmetic and the
// member templates that walk tiles, stored lines and a sample's features, shared by the files
// that list features, multiply and solve.
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "potmap/learn/bhm_joint.hpp"

namespace potmap {

namespace joint_grid {

// Grid cells farther than this from the origin are out of reach (tile coordinates, and those of
// their neighbours' neighbours, then fit in 21 bits each of the hash key).
constexpr std::int64_t kCellLimit = std::int64_t(1) << 22;
constexpr std::int64_t kMaxKernels = std::int64_t(1) << 26;

inline std::int64_t floor_div(std::int64_t a, std::int64_t b) {
  const std::int64_t q = a / b;
  return (a % b != 0 && (a < 0) != (b < 0)) ? q - 1 : q;
}

// A neighbour tile's place in Tile::nb: (dx+1) + 3 (dy+1) + 9 (dz+1).
inline int nb_slot(const std::int64_t dt[3]) {
  return int((dt[0] + 1) + 3 * (dt[1] + 1) + 9 * (dt[2] + 1));
}

}  // namespace joint_grid

template <class F>
void JointBhm::for_each_tile_part(const std::int64_t a[3], const std::int64_t b[3], F f) const {
  std::int64_t ta[3] = {0, 0, 0}, tb[3] = {0, 0, 0};
  for (int d = 0; d < dim_; ++d) {
    ta[d] = joint_grid::floor_div(a[d], tile_);
    tb[d] = joint_grid::floor_div(b[d], tile_);
  }
  for (std::int64_t tz = ta[2]; tz <= tb[2]; ++tz)
    for (std::int64_t ty = ta[1]; ty <= tb[1]; ++ty)
      for (std::int64_t tx = ta[0]; tx <= tb[0]; ++tx) {
        const std::int64_t t[3] = {tx, ty, tz};
        std::int64_t ca[3] = {0, 0, 0}, cb[3] = {0, 0, 0};
        for (int d = 0; d < dim_; ++d) {
          ca[d] = std::max(a[d], t[d] * tile_);
          cb[d] = std::min(b[d], t[d] * tile_ + tile_ - 1);
        }
        f(t, ca, cb);
      }
}

template <class F>
void JointBhm::for_each_stored_line(const std::int64_t a[3], const std::int64_t b[3], F f) const {
  for_each_tile_part(
      a, b, [&](const std::int64_t t[3], const std::int64_t ca[3], const std::int64_t cb[3]) {
        const std::int64_t id = find_tile(t);
        if (id < 0) return;
        for (std::int64_t k = ca[2]; k <= cb[2]; ++k)
          for (std::int64_t j = ca[1]; j <= cb[1]; ++j) {
            const std::int64_t local =
                ((k - t[2] * tile_) * tile_ + (j - t[1] * tile_)) * tile_ + (ca[0] - t[0] * tile_);
            const std::int64_t g[3] = {ca[0], j, k};
            f(id * tile_cells_ + local, g, cb[0] - ca[0] + 1);
          }
      });
}

template <class Emit>
void JointBhm::span_features(const double* x, const std::int64_t a[3], const std::int64_t b[3],
                             const std::int32_t tile_id[8], Emit emit) const {
  // phi is separable, exp(-gamma d^2) = prod_d exp(-gamma s_d^2), and along an axis, with s
  // the offset from the span's first cell, exp(-gamma (s - c h)^2) is the previous cell's
  // value times R_c, with R_0 = exp(gamma h (2 s - h)) and R_c = R_(c-1) exp(-2 gamma h^2):
  // two exps an axis instead of one per kernel (a few ulps apart; the cut-off test below
  // stays on d^2).
  constexpr std::int64_t kSpan = 72;  // > 2 rcut / spacing + 1, as pad < 64
  double ex[3][kSpan];
  ex[2][0] = 1.0;
  const double h = o_.spacing;
  for (int d = 0; d < dim_; ++d) {
    const double s = x[d] - (lo_[d] + double(a[d]) * h);
    double e = std::exp(-gamma_ * (s * s)), r = std::exp(gamma_ * h * (2 * s - h));
    for (std::int64_t c = 0; c <= b[d] - a[d]; ++c) {
      ex[d][c] = e;
      e *= r;
      r *= step_q_;
    }
  }
  std::int64_t ta[3] = {0, 0, 0};
  for (int d = 0; d < dim_; ++d) ta[d] = joint_grid::floor_div(a[d], tile_);
  // The kernels within the cut-off in raster order (z, y, x): add_outer() adds each pair of a
  // sample's features once, to the first of the two.
  for (std::int64_t k = a[2]; k <= b[2]; ++k) {
    const std::int64_t tz = dim_ == 3 ? joint_grid::floor_div(k, tile_) : 0;
    for (std::int64_t j = a[1]; j <= b[1]; ++j) {
      const std::int64_t ty = joint_grid::floor_div(j, tile_);
      for (std::int64_t tx = ta[0]; tx * tile_ <= b[0]; ++tx) {
        const std::int64_t id = tile_id[((tz - ta[2]) * 2 + (ty - ta[1])) * 2 + (tx - ta[0])];
        const std::int64_t row = ((k - tz * tile_) * tile_ + (j - ty * tile_)) * tile_ - tx * tile_;
        for (std::int64_t i = std::max(a[0], tx * tile_);
             i <= std::min(b[0], tx * tile_ + tile_ - 1); ++i) {
          const std::int64_t g[3] = {i, j, k};
          double d2 = 0;
          for (int d = 0; d < dim_; ++d) {
            const double sd = x[d] - (lo_[d] + double(g[d]) * o_.spacing);
            d2 += sd * sd;
          }
          if (gamma_ * d2 > o_.tau) continue;
          emit(id < 0 ? kNone : static_cast<std::uint32_t>(id * tile_cells_ + row + i), g,
               ex[0][i - a[0]] * ex[1][j - a[1]] * ex[2][k - a[2]]);
        }
      }
    }
  }
}

}  // namespace potmap
