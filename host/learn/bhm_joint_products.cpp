// The joint BHM's precision: a sample's outer products added to the half stencils, the
// couplings read back, and the products P x of the solves (in a box of cells around the rows,
// or through the tiles where the rows lie far apart).
#include "potmap/learn/bhm_joint.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "bhm_joint_grid.hpp"
#include "runtime/host_team.hpp"

namespace potmap {

using namespace joint_grid;

void JointBhm::add_outer(const Scratch& f, std::size_t i, double c, int part) {
  // The sample's features are in raster order, in runs of consecutive cells along x (a run a
  // line of cells: the cut-off's span is far narrower than the stencil's box). Each feature u
  // adds its products with itself and the features after it to its own half stencil:
  // slot(v - u) = lin(v) - lin(u) + lin(pad, pad, pad). A later run lands on consecutive slots
  // of one of the half's runs, and one cell further along u's run, one slot earlier: its slot
  // is found once per run pair, not once per feature.
  const std::uint32_t r0 = f.run_start[i], r1 = f.run_start[i + 1];
  const double* phi = f.phi.data();
  const std::int64_t* lin = f.lin.data();
  const std::uint32_t* run = f.runs.data();
  const std::int32_t* half_at = half_at_.data() + centre_lin_;
  const auto hs = static_cast<std::size_t>(half_slots_);
  const std::int32_t next_at = half_at[1];
  for (std::uint32_t ra = r0; ra < r1; ++ra) {
    const std::uint32_t u0 = run[2 * ra], la = run[2 * ra + 1];
    for (std::uint32_t k = 0; k < la; ++k) {
      const std::uint32_t u = u0 + k;
      const std::uint32_t ku = f.kernel[u];
      if (part >= 0 && mark_[ku] != part) continue;
      double* row = &prec_[std::size_t(ku) * hs];
      const double ca = c * phi[u];
      row[0] += ca * phi[u];
      // The rest of u's own run: dx = 1, 2, ... on the centre row.
      {
        double* dst = row + next_at;
        const double* src = phi + u + 1;
        for (std::uint32_t m = 0; m + k + 1 < la; ++m) dst[m] += ca * src[m];
      }
      for (std::uint32_t rb = ra + 1; rb < r1; ++rb) {
        const std::uint32_t v0 = run[2 * rb], lb = run[2 * rb + 1];
        double* dst = row + (half_at[lin[v0] - lin[u0]] - std::int32_t(k));
        const double* src = phi + v0;
        for (std::uint32_t m = 0; m < lb; ++m) dst[m] += ca * src[m];
      }
      bcoup_[ku] += ca;
    }
  }
}

double JointBhm::coupling(std::int64_t a, std::int64_t b, const std::int64_t o[3]) const {
  if (b < 0) return 0.0;  // a kernel no sample reached couples to nothing
  std::int64_t slot = 0;
  for (int d = dim_ - 1; d >= 0; --d) slot = slot * box_ + o[d];
  if (slot == 0) return prec_[std::size_t(a) * static_cast<std::size_t>(half_slots_)];
  const std::int64_t first = slot > 0 ? a : b;
  const std::int32_t at =
      half_at_[static_cast<std::size_t>(centre_lin_ + (slot > 0 ? slot : -slot))];
  return at < 0
             ? 0.0
             : prec_[std::size_t(first) * static_cast<std::size_t>(half_slots_) + std::size_t(at)];
}

bool JointBhm::box_rows(const std::vector<std::uint32_t>& rows, Scratch& sc) const {
  // A dense box of cells around the rows: the rows' bounds grown by the stencil's reach twice,
  // so that every kernel whose stencil reaches a row (within pad) has its own stencil inside.
  // The products then stream each kernel's half stencil against x and y in the box (the solve
  // is bound by those reads). False when the box would be much larger than the rows.
  sc.boxed = false;
  if (rows.empty()) return false;
  std::int64_t lo[3], hi[3];
  cell_bounds(rows, lo, hi);
  std::int64_t volume = 1;
  for (int d = 0; d < 3; ++d) {
    const std::int64_t r = d < dim_ ? 2 * pad_ : 0;
    sc.box_lo[d] = lo[d] - r;
    sc.box_n[d] = hi[d] - lo[d] + 1 + 2 * r;
    volume *= sc.box_n[d];
  }
  if (volume > 64 * std::int64_t(rows.size()) + 65536) return false;
  const std::int64_t* n = sc.box_n;
  std::vector<std::int64_t>& at = sc.part_around_at[0];  // scratch here
  at.resize(rows.size());
  for (std::size_t u = 0; u < rows.size(); ++u) {
    std::int64_t c[3];
    cell_of(rows[u], c);
    at[u] = ((c[2] - sc.box_lo[2]) * n[1] + (c[1] - sc.box_lo[1])) * n[0] + (c[0] - sc.box_lo[0]);
  }
  sc.box_off.resize(half_.size());
  sc.box_len.resize(half_.size());
  sc.box_reach = 1;
  for (std::size_t h = 0; h < half_.size(); ++h) {
    sc.box_off[h] = (std::int64_t(half_[h].d[2]) * n[1] + half_[h].d[1]) * n[0] + half_[h].d[0];
    sc.box_len[h] = half_[h].len;
    sc.box_reach = std::max(sc.box_reach, sc.box_off[h] + half_[h].len);
  }
  // The parts: the rows before and after the median row's cell, each in storage order.
  std::vector<std::int64_t>& sorted = sc.part_around_at[1];
  sorted = at;
  std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(sorted.size() / 2),
                   sorted.end());
  sc.box_split = sorted[sorted.size() / 2];
  for (int p = 0; p < 2; ++p) {
    sc.part_rows[p].clear();
    sc.part_at[p].clear();
  }
  for (std::size_t u = 0; u < rows.size(); ++u) {
    const int p = at[u] < sc.box_split ? 0 : 1;
    sc.part_rows[p].push_back(rows[u]);
    sc.part_at[p].push_back(at[u]);
  }
  sc.pbox.assign(std::size_t(volume), 0.0);
  for (int p = 0; p < 2; ++p) sc.ybox[p].assign(std::size_t(volume), 0.0);
  sc.boxed = true;
  return true;
}

namespace {

// ybox += P xbox over the listed kernels' half stencils (`hs` doubles each, from `prec`): each
// gives its own row's products with the kernels after it and, mirrored, theirs with it.
void half_products(const double* prec, std::size_t hs, const std::int32_t* len,
                   const std::int64_t* off, std::size_t nh, const std::uint32_t* kernel,
                   const std::int64_t* at, std::size_t m, const double* xbox, double* ybox) {
  for (std::size_t u = 0; u < m; ++u) {
    const double* v = prec + std::size_t(kernel[u]) * hs;
    const std::int64_t a = at[u];
    const double xa = xbox[a];
    double s0 = v[0] * xa, s1 = 0;
    ++v;
    for (std::size_t h = 0; h < nh; ++h) {
      const double* __restrict px = xbox + a + off[h];
      double* __restrict py = ybox + a + off[h];
      const std::int32_t n = len[h];
      for (std::int32_t j = 0; j < n; ++j) {
        s1 += v[j] * px[j];
        py[j] += v[j] * xa;
      }
      v += n;
    }
    ybox[a] += s0 + s1;
  }
}

// One half run of compile-time length L: the same sums in the same order as half_products()'s
// loop, unrolled.
template <int L>
inline void half_run(const double* __restrict v, const double* __restrict px, double* __restrict py,
                     double xa, double& s1) {
  for (int j = 0; j < L; ++j) {
    s1 += v[j] * px[j];
    py[j] += v[j] * xa;
  }
}

// half_products() for a stencil whose half runs have the lengths L..., known when compiled: the
// same result bit for bit. The runs are a few doubles long (3, 7, 7 and 5 at the 2D defaults), so
// the general loop spends as much on its bounds as on its products.
template <int... L>
void half_products_fixed(const double* prec, std::size_t hs, const std::int64_t* off,
                         const std::uint32_t* kernel, const std::int64_t* at, std::size_t m,
                         const double* xbox, double* ybox) {
  constexpr int lens[] = {L...};
  constexpr int nh = sizeof...(L);
  int first[nh] = {};
  for (int h = 1; h < nh; ++h) first[h] = first[h - 1] + lens[h - 1];
  for (std::size_t u = 0; u < m; ++u) {
    const double* v = prec + std::size_t(kernel[u]) * hs;
    const std::int64_t a = at[u];
    const double xa = xbox[a];
    const double s0 = v[0] * xa;
    double s1 = 0;
    ++v;
    int h = 0;
    ((half_run<L>(v + first[h], xbox + a + off[h], ybox + a + off[h], xa, s1), ++h), ...);
    ybox[a] += s0 + s1;
  }
}

// The products through half_products_fixed() where the stencil is one it was compiled for (the
// 2D default), else half_products().
void half_products_any(const double* prec, std::size_t hs, const std::int32_t* len,
                       const std::int64_t* off, std::size_t nh, const std::uint32_t* kernel,
                       const std::int64_t* at, std::size_t m, const double* xbox, double* ybox) {
  if (nh == 4 && len[0] == 3 && len[1] == 7 && len[2] == 7 && len[3] == 5)
    half_products_fixed<3, 7, 7, 5>(prec, hs, off, kernel, at, m, xbox, ybox);
  else
    half_products(prec, hs, len, off, nh, kernel, at, m, xbox, ybox);
}

}  // namespace

void JointBhm::multiply_box(const std::vector<double>& x, double xb, bool x_outside,
                            const std::vector<std::uint32_t>& rows, std::vector<double>& y,
                            double& yb, Scratch& sc, Context* ctx) const {
  (void)rows;  // the parts hold them
  double* xbx = sc.pbox.data();
  const std::int64_t* n = sc.box_n;
  const std::int64_t* lo = sc.box_lo;
  const std::int64_t volume = n[0] * n[1] * n[2];
  const std::int64_t split = sc.box_split;
  const std::int64_t spill = std::min(volume, split + sc.box_reach);  // part 0's y ends here
  const auto hs = static_cast<std::size_t>(half_slots_);
  if (x_outside) {
    // x over the whole box, and every stored kernel within pad of the rows' bounds: their
    // stencils may reach a row.
    const std::int64_t hi[3] = {lo[0] + n[0] - 1, lo[1] + n[1] - 1, lo[2] + n[2] - 1};
    for_each_stored_line(lo, hi, [&](std::int64_t s, const std::int64_t g[3], std::int64_t l) {
      const std::int64_t at = ((g[2] - lo[2]) * n[1] + (g[1] - lo[1])) * n[0] + (g[0] - lo[0]);
      std::memcpy(xbx + at, x.data() + s, sizeof(double) * std::size_t(l));
    });
    std::int64_t a[3], b[3];
    for (int d = 0; d < 3; ++d) {
      const std::int64_t r = d < dim_ ? pad_ : 0;
      a[d] = lo[d] + r;
      b[d] = lo[d] + n[d] - 1 - r;
    }
    for (int p = 0; p < 2; ++p) {
      sc.part_around[p].clear();
      sc.part_around_at[p].clear();
    }
    for_each_stored_line(a, b, [&](std::int64_t s, const std::int64_t g[3], std::int64_t l) {
      const std::int64_t at = ((g[2] - lo[2]) * n[1] + (g[1] - lo[1])) * n[0] + (g[0] - lo[0]);
      for (std::int64_t i = 0; i < l; ++i) {
        const int p = at + i < split ? 0 : 1;
        sc.part_around[p].push_back(static_cast<std::uint32_t>(s + i));
        sc.part_around_at[p].push_back(at + i);
      }
    });
  } else {
    for (int p = 0; p < 2; ++p)
      for (std::size_t u = 0; u < sc.part_rows[p].size(); ++u)
        xbx[sc.part_at[p][u]] = x[sc.part_rows[p][u]];
  }
  // The parts' products, each into its own box of y (cleared first: part 0 writes cells before
  // `spill`, part 1 cells from `split` on), then each part's rows gathered, part 1's adding
  // part 0's spill. The same two parts with or without a helper: the sums do not depend on
  // the threads.
  double bias_part[2] = {0, 0};
  detail::for_each_item(ctx, 2, [&](std::size_t p) {
    double* ybx = sc.ybox[p].data();
    const std::int64_t first = p == 0 ? 0 : split, last = p == 0 ? spill : volume;
    std::fill(ybx + first, ybx + last, 0.0);
    const std::vector<std::uint32_t>& k = x_outside ? sc.part_around[p] : sc.part_rows[p];
    const std::vector<std::int64_t>& at = x_outside ? sc.part_around_at[p] : sc.part_at[p];
    half_products_any(prec_.data(), hs, sc.box_len.data(), sc.box_off.data(), half_.size(),
                      k.data(), at.data(), k.size(), xbx, ybx);
  });
  detail::for_each_item(ctx, 2, [&](std::size_t p) {
    const double* y0 = sc.ybox[0].data();
    const double* y1 = sc.ybox[1].data();
    const std::uint32_t* k = sc.part_rows[p].data();
    const std::int64_t* at = sc.part_at[p].data();
    const std::size_t m = sc.part_rows[p].size();
    // The bias row summed in a local: through the reference, every term would be a store and
    // a load in one dependent chain.
    double sb = 0;
    for (std::size_t u = 0; u < m; ++u) {
      const std::uint32_t a = k[u];
      const std::int64_t c = at[u];
      double v = p == 0 ? y0[c] : (c < spill ? y0[c] + y1[c] : y1[c]);
      if (o_.bias) {
        v += bcoup_[a] * xb;
        sb += bcoup_[a] * x[a];
      }
      y[a] = v;
    }
    bias_part[p] = sb;
    // Leave x's box zero for the next product.
    if (x_outside) {
      const std::int64_t half = volume / 2;
      std::fill(xbx + (p == 0 ? 0 : half), xbx + (p == 0 ? half : volume), 0.0);
    } else {
      for (std::size_t u = 0; u < m; ++u) xbx[at[u]] = 0;
    }
  });
  yb = (o_.bias ? pbb_ * xb : 0.0) + bias_part[0] + bias_part[1];
}

void JointBhm::multiply_sparse(const std::vector<double>& x, double xb,
                               const std::vector<std::uint32_t>& rows, std::vector<double>& y,
                               double& yb) const {
  double sb = o_.bias ? pbb_ * xb : 0.0;
  const auto hs = static_cast<std::size_t>(half_slots_);
  for (const std::uint32_t a : rows) {
    std::int64_t g[3];
    cell_of(a, g);
    const std::int64_t home = a / tile_cells_;
    const double* row = &prec_[std::size_t(a) * hs];
    double v = row[0] * x[a];
    for (const HalfRun& h : half_)
      for (std::int32_t j = 0; j < h.len; ++j) {
        const std::int64_t o[3] = {h.d[0] + j, h.d[1], h.d[2]};
        const std::int64_t after[3] = {g[0] + o[0], g[1] + o[1], g[2] + o[2]};
        const std::int64_t before[3] = {g[0] - o[0], g[1] - o[1], g[2] - o[2]};
        const std::int64_t b = in_grid(after) ? find_cell(after, home) : -1;
        if (b >= 0) v += row[h.at + j] * x[std::size_t(b)];
        const std::int64_t c = in_grid(before) ? find_cell(before, home) : -1;
        if (c >= 0) v += prec_[std::size_t(c) * hs + std::size_t(h.at + j)] * x[std::size_t(c)];
      }
    if (o_.bias) {
      v += bcoup_[a] * xb;
      sb += bcoup_[a] * x[a];
    }
    y[a] = v;
  }
  yb = sb;
}

}  // namespace potmap
