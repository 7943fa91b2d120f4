// The joint BHM's solves: the rows a scan moves (the kernels it reaches, grown by the margin)
// and the conjugate gradients on them.
#include "potmap/learn/bhm_joint.hpp"

#include <algorithm>
#include <cmath>

#include "bhm_joint_grid.hpp"
#include "runtime/host_team.hpp"

namespace potmap {

using namespace joint_grid;

void JointBhm::dilate_rows(std::vector<std::uint32_t>& rows,
                           const std::vector<std::uint32_t>& reached, std::int64_t mg,
                           std::int64_t mz, Scratch& sc) {
  // The stored kernels within mg cells (mz in z) of a reached one, along every axis at once
  // (the box around each): on a bitmap of the reached kernels' bounding box, dilated one axis
  // at a time, when the box is small beside the kernels' own boxes; otherwise kernel by
  // kernel. The same set either way.
  const std::int64_t r[3] = {mg, mg, mz};
  std::int64_t lo[3], hi[3];
  cell_bounds(reached, lo, hi);
  std::int64_t n[3] = {1, 1, 1}, volume = 1, per = 1;
  for (int d = 0; d < dim_; ++d) {
    const std::int64_t glo = bounded_ ? 0 : 1 - kCellLimit;
    const std::int64_t ghi = bounded_ ? n_[d] - 1 : kCellLimit - 1;
    lo[d] = std::max(lo[d] - r[d], glo);
    hi[d] = std::min(hi[d] + r[d], ghi);
    n[d] = hi[d] - lo[d] + 1;
    volume *= n[d];
    per *= 2 * r[d] + 1;
  }
  if (volume > 4 * per * std::int64_t(reached.size()) + 65536) {
    for (std::uint32_t a : reached) {
      std::int64_t c[3];
      cell_of(a, c);
      const std::int64_t home = a / tile_cells_;
      for (std::int64_t dk = -r[2]; dk <= r[2]; ++dk)
        for (std::int64_t dj = -r[1]; dj <= r[1]; ++dj)
          for (std::int64_t di = -r[0]; di <= r[0]; ++di) {
            const std::int64_t g[3] = {c[0] + di, c[1] + dj, c[2] + dk};
            if (!in_grid(g)) continue;
            const std::int64_t s = find_cell(g, home);
            if (s < 0 || mark_[std::size_t(s)] == 2) continue;
            mark_[std::size_t(s)] = 2;
            rows.push_back(static_cast<std::uint32_t>(s));
          }
    }
    for (std::uint32_t a : rows) mark_[a] = 0;
    std::sort(rows.begin(), rows.end());
    return;
  }
  std::vector<std::uint8_t>&bits = sc.bits, &tmp = sc.bits_tmp;
  bits.assign(std::size_t(volume), 0);
  for (std::uint32_t a : reached) {
    std::int64_t c[3];
    cell_of(a, c);
    bits[std::size_t(((c[2] - lo[2]) * n[1] + (c[1] - lo[1])) * n[0] + (c[0] - lo[0]))] = 1;
  }
  const std::int64_t stride[3] = {1, n[0], n[0] * n[1]};
  for (int axis = 0; axis < dim_; ++axis) {
    const std::int64_t w = r[axis], len = n[axis], st = stride[axis];
    if (w == 0) continue;
    tmp.assign(bits.size(), 0);
    // Lines along `axis`: every cell whose coordinate on it is 0.
    const int p = axis == 0 ? 1 : 0, q = axis == 2 ? 1 : 2;
    for (std::int64_t cq = 0; cq < n[q]; ++cq)
      for (std::int64_t cp = 0; cp < n[p]; ++cp) {
        const std::int64_t start = cp * stride[p] + cq * stride[q];
        const std::uint8_t* in = bits.data() + start;
        std::uint8_t* out = tmp.data() + start;
        std::int64_t count = 0;  // set cells in [i - w, i + w]
        for (std::int64_t k = 0; k < std::min(w, len); ++k) count += in[k * st];
        for (std::int64_t i = 0; i < len; ++i) {
          if (i + w < len) count += in[(i + w) * st];
          if (i - w - 1 >= 0) count -= in[(i - w - 1) * st];
          out[i * st] = count > 0;
        }
      }
    bits.swap(tmp);
  }
  // The stored cells of the box, a run along x at a time (a tile found once, not per cell),
  // tile by tile. A tile's rows come out in storage order and its storage is one range, so
  // putting the tiles in order sorts the rows.
  struct Chunk {
    std::uint32_t tile;
    std::size_t begin, end;
  };
  std::vector<Chunk> chunks;
  const std::size_t base = rows.size();
  for_each_stored_line(lo, hi, [&](std::int64_t s, const std::int64_t g[3], std::int64_t l) {
    const auto tile = static_cast<std::uint32_t>(s / tile_cells_);
    if (chunks.empty() || chunks.back().tile != tile)
      chunks.push_back({tile, rows.size(), rows.size()});
    const std::uint8_t* line =
        bits.data() + ((g[2] - lo[2]) * n[1] + (g[1] - lo[1])) * n[0] + (g[0] - lo[0]);
    for (std::int64_t i = 0; i < l; ++i)
      if (line[i]) rows.push_back(static_cast<std::uint32_t>(s + i));
    chunks.back().end = rows.size();
  });
  auto by_tile = [](const Chunk& x, const Chunk& y) { return x.tile < y.tile; };
  if (std::is_sorted(chunks.begin(), chunks.end(), by_tile)) return;
  std::sort(chunks.begin(), chunks.end(), by_tile);
  std::vector<std::uint32_t>& tmp_rows = sc.rows_tmp;
  tmp_rows.assign(rows.begin() + std::ptrdiff_t(base), rows.end());
  std::size_t at = base;
  for (const Chunk& c : chunks)
    for (std::size_t k = c.begin; k < c.end; ++k) rows[at++] = tmp_rows[k - base];
}

double JointBhm::solve(const std::vector<std::uint32_t>& rows, std::vector<double>& x, double& xb,
                       double tol, int max_it, std::size_t* its, Scratch& sc, bool rows_boxed,
                       Context* ctx, const double* bias_outside, bool residual_given) const {
  // Conjugate gradients on the rows `rows` (and the bias), the other means held fixed, from
  // the current x. Jacobi preconditioner. sc.p is zero outside `rows` on entry and on exit.
  const std::size_t st = x.size();
  const auto hs = static_cast<std::size_t>(half_slots_);
  for (std::vector<double>* v : {&sc.r, &sc.z, &sc.p, &sc.q})
    if (v->size() < st) v->resize(st, 0.0);
  std::vector<double>&r = sc.r, &z = sc.z, &p = sc.p, &q = sc.q;
  double rb = 0, zb = 0, pb = 0, qb = 0;
  const bool boxed = rows_boxed ? sc.boxed : box_rows(rows, sc);
  if (residual_given) {
    rb = o_.bias ? sc.rb : 0.0;
  } else {
    double yb = 0;
    if (boxed)
      multiply_box(x, xb, true, rows, q, yb, sc, ctx);
    else
      multiply_sparse(x, xb, rows, q, yb);
    // The bias row reads every mean, not only those of `rows`.
    if (o_.bias) {
      yb = pbb_ * xb;
      if (bias_outside) {
        yb += *bias_outside;
        for (std::uint32_t a : rows) yb += bcoup_[a] * x[a];
      } else {
        for (std::size_t a = 0; a < st; ++a) yb += bcoup_[a] * x[a];
      }
      rb = etab_ - yb;
    }
    for (std::uint32_t a : rows) r[a] = eta_[a] - q[a];
  }
  double rr = rb * rb, ee = etab_ * etab_;
  for (std::uint32_t a : rows) {
    rr += r[a] * r[a];
    ee += eta_[a] * eta_[a];
  }
  const double stop = tol * tol * std::max(ee, 1e-300);
  auto precondition = [&] {
    double rz = 0;
    for (std::uint32_t a : rows) {
      z[a] = r[a] / prec_[std::size_t(a) * hs];
      rz += r[a] * z[a];
    }
    if (o_.bias) {
      zb = rb / pbb_;
      rz += rb * zb;
    }
    return rz;
  };
  double rz = precondition();
  for (std::uint32_t a : rows) p[a] = z[a];
  pb = zb;
  int it = 0;
  for (; it < max_it && rr > stop; ++it) {
    if (boxed)
      multiply_box(p, pb, false, rows, q, qb, sc, ctx);
    else
      multiply_sparse(p, pb, rows, q, qb);
    double pq = pb * qb;
    for (std::uint32_t a : rows) pq += p[a] * q[a];
    if (!(pq > 0)) break;
    const double alpha = rz / pq;
    rr = 0;
    for (std::uint32_t a : rows) {
      x[a] += alpha * p[a];
      r[a] -= alpha * q[a];
      rr += r[a] * r[a];
    }
    if (o_.bias) {
      xb += alpha * pb;
      rb -= alpha * qb;
      rr += rb * rb;
    }
    const double rz_new = precondition();
    const double beta = rz_new / rz;
    rz = rz_new;
    for (std::uint32_t a : rows) p[a] = z[a] + beta * p[a];
    pb = zb + beta * pb;
  }
  for (std::uint32_t a : rows) p[a] = 0;
  sc.rb = rb;
  if (its) *its += static_cast<std::size_t>(it);
  return std::sqrt(rr / std::max(ee, 1e-300));
}

}  // namespace potmap
