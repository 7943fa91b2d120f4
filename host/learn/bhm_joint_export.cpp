// What the joint BHM gives out: predictive variances, the exported map, seeds from another
// map, and the exact posterior for tests.
#include "potmap/learn/bhm_joint.hpp"

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "bhm_joint_grid.hpp"
#include "map/kernel_index.hpp"
#include "potmap/error.hpp"
#include "runtime/host_team.hpp"

namespace potmap {

using namespace joint_grid;

bool JointBhm::near_data(const std::int64_t g[3], std::int64_t hint) const {
  // Whether a sample or a seed reached a kernel of g's block.
  const std::int64_t hz = dim_ == 3 ? hb_ : 0;
  for (std::int64_t dk = -hz; dk <= hz; ++dk)
    for (std::int64_t dj = -hb_; dj <= hb_; ++dj)
      for (std::int64_t di = -hb_; di <= hb_; ++di) {
        const std::int64_t c[3] = {g[0] + di, g[1] + dj, g[2] + dk};
        const std::int64_t s = find_cell(c, hint);
        if (s >= 0 && (touched_[std::size_t(s)] || seeded_[std::size_t(s)])) return true;
      }
  return false;
}

namespace {

// phi^T A^-1 phi for the block's precision A (its prior's where A is not positive definite).
double block_variance(const Eigen::Map<Eigen::MatrixXd>& A, const double* phi, std::size_t n,
                      double prior_var) {
  Eigen::Map<const Eigen::VectorXd> ph(phi, Eigen::Index(n));
  const Eigen::LLT<Eigen::MatrixXd> llt(A);
  if (llt.info() != Eigen::Success) return prior_var * ph.squaredNorm();
  return ph.dot(llt.solve(ph));
}

}  // namespace

double JointBhm::predictive_var_at(const std::int64_t g[3], std::int64_t hint,
                                   std::vector<double>& scratch) const {
  // phi(h_k)^T (P_BB)^-1 phi(h_k) on the block B of kernels that reach h_k: the variance with
  // the kernels outside the block held at their means (a slight underestimate). Kernels of the
  // block that are not stored hold their prior. Where the whole block lies in the grid, its
  // pairs' places come from init()'s tables; at a bounded grid's border, as coupling() finds
  // them (the same matrix either way).
  const std::size_t nb = vb_phi_.size();
  thread_local std::vector<std::int64_t> at_cell;
  at_cell.resize(nb);
  bool whole = true;
  for (std::size_t u = 0; u < nb && whole; ++u) {
    const std::int64_t c[3] = {g[0] + vb_off_[3 * u], g[1] + vb_off_[3 * u + 1],
                               g[2] + vb_off_[3 * u + 2]};
    whole = in_grid(c);
    if (whole) at_cell[u] = find_cell(c, hint);
  }
  if (whole) {
    const auto hs = static_cast<std::size_t>(half_slots_);
    scratch.assign(nb * nb, 0.0);
    Eigen::Map<Eigen::MatrixXd> A(scratch.data(), Eigen::Index(nb), Eigen::Index(nb));
    for (std::size_t u = 0; u < nb; ++u) {
      if (at_cell[u] < 0) {
        A(Eigen::Index(u), Eigen::Index(u)) = 1.0 / o_.prior_var;
        continue;
      }
      const double* row_u = &prec_[std::size_t(at_cell[u]) * hs];
      for (std::size_t v = 0; v < nb; ++v) {
        const std::int32_t at = vb_at_[u * nb + v];
        if (at < 0 || at_cell[v] < 0) continue;
        A(Eigen::Index(u), Eigen::Index(v)) =
            vb_u_first_[u * nb + v] ? row_u[at]
                                    : prec_[std::size_t(at_cell[v]) * hs + std::size_t(at)];
      }
    }
    return block_variance(A, vb_phi_.data(), nb, o_.prior_var);
  }
  std::vector<std::int64_t> block;
  std::vector<std::int64_t> cells;
  std::vector<double> phi;
  const std::int64_t hz = dim_ == 3 ? hb_ : 0;
  for (std::int64_t dk = -hz; dk <= hz; ++dk)
    for (std::int64_t dj = -hb_; dj <= hb_; ++dj)
      for (std::int64_t di = -hb_; di <= hb_; ++di) {
        const std::int64_t c[3] = {g[0] + di, g[1] + dj, g[2] + dk};
        if (!in_grid(c)) continue;
        const double d2 =
            (double(di * di) + double(dj * dj) + double(dk * dk)) * o_.spacing * o_.spacing;
        if (gamma_ * d2 > o_.tau) continue;
        block.push_back(find_cell(c, hint));
        cells.insert(cells.end(), {c[0], c[1], c[2]});
        phi.push_back(std::exp(-gamma_ * d2));
      }
  const std::size_t b = block.size();
  scratch.assign(b * b, 0.0);
  Eigen::Map<Eigen::MatrixXd> A(scratch.data(), Eigen::Index(b), Eigen::Index(b));
  for (std::size_t u = 0; u < b; ++u) {
    if (block[u] < 0) {
      A(Eigen::Index(u), Eigen::Index(u)) = 1.0 / o_.prior_var;
      continue;
    }
    for (std::size_t v = 0; v < b; ++v) {
      const std::int64_t o[3] = {cells[3 * v] - cells[3 * u], cells[3 * v + 1] - cells[3 * u + 1],
                                 cells[3 * v + 2] - cells[3 * u + 2]};
      A(Eigen::Index(u), Eigen::Index(v)) = coupling(block[u], block[v], o);
    }
  }
  return block_variance(A, phi.data(), b, o_.prior_var);
}

double JointBhm::exported_var(const std::int64_t g[3], std::int64_t s,
                              std::vector<double>& scratch) const {
  const std::int64_t hint = s >= 0 ? s / tile_cells_ : -1;
  if (!near_data(g, hint)) return o_.prior_var;
  return std::min(o_.prior_var, predictive_var_at(g, hint, scratch) / sum_phi2_);
}

std::size_t JointBhm::seed_unreached(const KernelMap& field, double min_var, double min_support) {
  if (field.dim != dim_)
    throw ArgumentError("joint BHM: the seed map is " + std::to_string(field.dim) + "D, the map " +
                        std::to_string(dim_) + "D");
  field.validate("joint BHM seed");
  if (field.empty()) return 0;
  const detail::KernelIndex index(field, o_.tau);
  double lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  field.bounds(lo, hi);
  const double reach = index.max_reach();
  std::int64_t a[3] = {0, 0, 0}, b[3] = {0, 0, 0};
  for (int d = 0; d < dim_; ++d) {
    double ua = std::floor((lo[d] - reach - lo_[d]) / o_.spacing);
    double ub = std::ceil((hi[d] + reach - lo_[d]) / o_.spacing);
    ua = std::max(ua, bounded_ ? 0.0 : double(1 - kCellLimit));
    ub = std::min(ub, bounded_ ? double(n_[d] - 1) : double(kCellLimit - 1));
    if (!(ua <= ub)) return 0;
    a[d] = static_cast<std::int64_t>(ua);
    b[d] = static_cast<std::int64_t>(ub);
  }
  const double floor_var = std::min(std::max(min_var, 1e-12), o_.prior_var);
  std::vector<std::uint32_t> near;
  std::size_t seeded = 0;
  std::int64_t hint = -1;
  for (std::int64_t k = a[2]; k <= b[2]; ++k)
    for (std::int64_t j = a[1]; j <= b[1]; ++j)
      for (std::int64_t i = a[0]; i <= b[0]; ++i) {
        const std::int64_t g[3] = {i, j, dim_ == 3 ? k : 0};
        std::int64_t s = find_cell(g, hint);
        if (s >= 0) {
          hint = s / tile_cells_;
          if (touched_[std::size_t(s)] || seeded_[std::size_t(s)]) continue;
        }
        const double x[3] = {lo_[0] + double(i) * o_.spacing, lo_[1] + double(j) * o_.spacing,
                             lo_[2] + double(k) * o_.spacing};
        const detail::LocalSums ls = detail::local_sums(field, index, x, near);
        const double mu = ls.mu, s2 = ls.s2, support = ls.sum;
        if (support < min_support) continue;
        if (s < 0) {
          std::int64_t t[3] = {0, 0, 0};
          for (int d = 0; d < dim_; ++d) t[d] = floor_div(g[d], tile_);
          make_tile(t);
          s = find_cell(g, -1);
          hint = s / tile_cells_;
        }
        const auto su = static_cast<std::size_t>(s);
        const double m0 = mu / grid_sum_;
        const double v0 = std::min(o_.prior_var, std::max(floor_var, s2 / grid_sum2_));
        // Replace the prior's part of the natural parameters: precision 1/v0, eta m0/v0.
        prec_[su * static_cast<std::size_t>(half_slots_)] += 1.0 / v0 - 1.0 / o_.prior_var;
        eta_[su] += m0 / v0;
        mean_[su] = m0;
        seeded_[su] = 1;
        mark_dirty(static_cast<std::uint32_t>(s));
        ++seeded;
      }
  return seeded;
}

KernelMap JointBhm::map(Context* ctx, double polish_tolerance) const {
  if (!(polish_tolerance > 0) || !std::isfinite(polish_tolerance))
    throw ArgumentError("joint BHM: the polish tolerance must be positive, got " +
                        std::to_string(polish_tolerance));
  if (!behind()) return map_current(ctx, polish_tolerance);
  // Forgetting: the tiles no scan has faded to now, faded on a copy (the learner's state is
  // left as it is, as the polish below leaves it).
  JointBhm now = *this;
  now.catch_up();
  return now.map_current(ctx, polish_tolerance);
}

KernelMap JointBhm::map_current(Context* ctx, double polish_tolerance) const {
  // Polish the means over every kernel a sample or a seed reached, on a copy.
  std::vector<std::uint32_t> rows;
  for (std::size_t a = 0; a < touched_.size(); ++a)
    if (touched_[a] || seeded_[a]) rows.push_back(static_cast<std::uint32_t>(a));
  std::vector<double> mean = mean_;
  double meanb = meanb_;
  if (!rows.empty()) {
    Scratch sc;
    const detail::HelperHold hold(ctx);
    solve(rows, mean, meanb, polish_tolerance, 4 * o_.cg_max_iterations, nullptr, sc, false, ctx);
  }
  // Variances of the tiles whose precision changed since the last export: a small dense solve
  // a kernel, each tile's on its own, so on every core (the same values on any number).
  std::vector<std::size_t> dirty;
  for (std::size_t t = 0; t < tiles_.size(); ++t)
    if (tile_dirty_[t]) dirty.push_back(t);
  detail::for_each_on_cores(dirty.size(), [&](std::size_t u) {
    thread_local std::vector<double> tile_scratch;
    const std::size_t t = dirty[u];
    for (std::int64_t l = 0; l < tile_cells_; ++l) {
      const auto s = static_cast<std::uint32_t>(std::int64_t(t) * tile_cells_ + l);
      std::int64_t g[3];
      cell_of(s, g);
      var_[s] = in_grid(g) ? exported_var(g, s, tile_scratch) : o_.prior_var;
    }
    tile_dirty_[t] = 0;
  });
  std::vector<double> scratch;
  KernelMap m;
  m.dim = dim_;
  m.reserve(size());
  auto position = [&](const std::int64_t g[3], double p[3]) {
    for (int d = 0; d < 3; ++d) p[d] = d < dim_ ? lo_[d] + double(g[d]) * o_.spacing : 0.0;
  };
  if (bounded_) {
    std::int64_t hint = -1;
    for (std::int64_t k = 0; k < (dim_ == 3 ? n_[2] : 1); ++k)
      for (std::int64_t j = 0; j < n_[1]; ++j)
        for (std::int64_t i = 0; i < n_[0]; ++i) {
          const std::int64_t g[3] = {i, j, k};
          double p[3];
          position(g, p);
          const std::int64_t s = find_cell(g, hint);
          if (s >= 0) {
            hint = s / tile_cells_;
            m.push_back(p, gamma_, mean[std::size_t(s)], var_[std::size_t(s)]);
          } else {
            // Not stored: its prior mean, and the variance of its block (which may hold a
            // stored neighbour).
            m.push_back(p, gamma_, 0.0, exported_var(g, -1, scratch));
          }
        }
  } else {
    for (std::uint32_t s = 0; s < mean.size(); ++s) {
      std::int64_t g[3];
      cell_of(s, g);
      double p[3];
      position(g, p);
      m.push_back(p, gamma_, mean[s], var_[s]);
    }
    // Retired tiles, as they were left (retire_far()), faded since (as revive() would).
    for (const RetiredTile& r : retired_) {
      const double a = fade_since(r.clock);
      for (std::int64_t l = 0; l < tile_cells_; ++l) {
        std::int64_t g[3] = {0, 0, 0}, rest = l;
        for (int d = 0; d < dim_; ++d) {
          g[d] = std::int64_t(r.coord[d]) * tile_ + rest % tile_;
          rest /= tile_;
        }
        double p[3];
        position(g, p);
        double mean = r.mean[std::size_t(l)], var = r.var[std::size_t(l)];
        fade_retired(a, mean, var);
        m.push_back(p, gamma_, mean, var);
      }
    }
  }
  m.has_bias = o_.bias;
  if (o_.bias) {
    m.bias_mean = meanb;
    m.bias_var = 1.0 / pbb_;
  }
  return m;
}

void JointBhm::predict_exact(const double* points, std::size_t n, double* mean, double* var) const {
  if (behind()) {  // forgetting: the posterior at time(), faded on a copy
    JointBhm now = *this;
    now.catch_up();
    now.predict_exact(points, n, mean, var);
    return;
  }
  // P over the stored kernels of the grid (and the bias, last) as a sparse matrix; one
  // factorisation. Kernels not stored are independent at their prior (mean 0, prior_var).
  std::vector<std::int64_t> index(mean_.size(), -1);
  std::vector<std::uint32_t> stored;
  for (std::uint32_t s = 0; s < mean_.size(); ++s) {
    std::int64_t g[3];
    cell_of(s, g);
    if (!in_grid(g)) continue;
    index[s] = std::int64_t(stored.size());
    stored.push_back(s);
  }
  const auto m = Eigen::Index(stored.size());
  const Eigen::Index dimp = m + (o_.bias ? 1 : 0);
  std::vector<Eigen::Triplet<double>> t;
  for (Eigen::Index u = 0; u < m; ++u) {
    const std::uint32_t a = stored[std::size_t(u)];
    std::int64_t g[3];
    cell_of(a, g);
    const double* row = &prec_[std::size_t(a) * static_cast<std::size_t>(half_slots_)];
    const std::int64_t home = a / tile_cells_;
    t.emplace_back(u, u, row[0]);
    for (const HalfRun& h : half_)
      for (std::int32_t j = 0; j < h.len; ++j) {
        const double p = row[h.at + j];
        if (p == 0) continue;
        const std::int64_t c[3] = {g[0] + h.d[0] + j, g[1] + h.d[1], g[2] + h.d[2]};
        const std::int64_t b = in_grid(c) ? find_cell(c, home) : -1;
        if (b < 0 || index[std::size_t(b)] < 0) continue;
        t.emplace_back(u, Eigen::Index(index[std::size_t(b)]), p);
        t.emplace_back(Eigen::Index(index[std::size_t(b)]), u, p);
      }
    if (o_.bias && bcoup_[a] != 0) {
      t.emplace_back(u, m, bcoup_[a]);
      t.emplace_back(m, u, bcoup_[a]);
    }
  }
  if (o_.bias) t.emplace_back(m, m, pbb_);
  Eigen::SparseMatrix<double> P(dimp, dimp);
  P.setFromTriplets(t.begin(), t.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt(P);
  if (ldlt.info() != Eigen::Success) throw Error("joint BHM: precision not positive definite");
  Eigen::VectorXd eta(dimp);
  for (Eigen::Index u = 0; u < m; ++u) eta[u] = eta_[stored[std::size_t(u)]];
  if (o_.bias) eta[m] = etab_;
  const Eigen::VectorXd w = ldlt.solve(eta);
  std::vector<Feature> f;
  Eigen::VectorXd phi(dimp);
  for (std::size_t i = 0; i < n; ++i) {
    features(points + i * dim_, f);
    phi.setZero();
    double prior_part = 0;
    for (const Feature& x : f) {
      if (x.kernel == kNone)
        prior_part += o_.prior_var * x.phi * x.phi;
      else
        phi[index[x.kernel]] = x.phi;
    }
    if (o_.bias) phi[m] = 1.0;
    mean[i] = phi.dot(w);
    var[i] = phi.dot(ldlt.solve(phi)) + prior_part;
  }
}

}  // namespace potmap
