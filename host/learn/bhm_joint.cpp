#include "potmap/bhm_joint.hpp"

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include "../kernel_index.hpp"
#include "bhm_detail.hpp"
#include "potmap/error.hpp"

namespace potmap {

namespace {

// Half-width, in kernels, of the block whose precision gives a kernel's exported variance: the
// kernels that share a sample with it at its centre.
std::int64_t block_half_width(double rcut, double spacing) {
  return static_cast<std::int64_t>(std::ceil(rcut / spacing));
}

}  // namespace

JointBhm::JointBhm(int dim, const double lo[3], const double hi[3], const JointBhmOptions& o)
    : o_(o), dim_(dim) {
  if (dim != 2 && dim != 3) throw ArgumentError("joint BHM: dimension must be 2 or 3");
  if (!(o.spacing > 0) || !std::isfinite(o.spacing))
    throw ArgumentError("joint BHM: spacing must be positive, got " + std::to_string(o.spacing));
  if (o.gamma < 0 || !std::isfinite(o.gamma)) throw ArgumentError("joint BHM: gamma must be >= 0");
  if (o.gamma == 0 && !(o.neighbour_phi > 0 && o.neighbour_phi < 1))
    throw ArgumentError("joint BHM: neighbour_phi must be in (0, 1)");
  if (!(o.prior_var > 0) || !std::isfinite(o.prior_var))
    throw ArgumentError("joint BHM: prior_var must be positive");
  if (o.em_iterations < 1) throw ArgumentError("joint BHM: em_iterations must be at least 1");
  if (!(o.tau > 0)) throw ArgumentError("joint BHM: tau must be positive");
  if (!(o.cg_tolerance > 0) || o.cg_max_iterations < 1 || o.solve_margin < 0)
    throw ArgumentError("joint BHM: bad conjugate-gradient settings");
  gamma_ = o.gamma > 0 ? o.gamma : -std::log(o.neighbour_phi) / (o.spacing * o.spacing);
  rcut_ = std::sqrt(o.tau / gamma_);
  // Two kernels couple when one sample reaches both: at most 2 rcut apart.
  pad_ = static_cast<std::int64_t>(std::ceil(2 * rcut_ / o.spacing));
  box_ = 2 * pad_ + 1;
  std::int64_t total = 1;
  for (int d = 0; d < dim; ++d) {
    if (!std::isfinite(lo[d]) || !std::isfinite(hi[d]) || !(hi[d] >= lo[d]))
      throw ArgumentError("joint BHM: bounds must be finite with lo <= hi");
    lo_[d] = lo[d];
    n_[d] = static_cast<std::int64_t>(std::floor((hi[d] - lo[d]) / o.spacing + 1e-9)) + 1;
    sn_[d] = n_[d] + 2 * pad_;
    total *= sn_[d];
    if (total > (std::int64_t(1) << 26)) throw ArgumentError("joint BHM: too many kernels");
  }
  slots_ = 1;
  for (int d = 0; d < dim; ++d) slots_ *= box_;
  offset_.resize(static_cast<std::size_t>(slots_));
  for (std::int64_t s = 0; s < slots_; ++s) {
    std::int64_t rest = s, off = 0, stride = 1;
    for (int d = 0; d < dim; ++d) {
      const std::int64_t delta = rest % box_ - pad_;
      rest /= box_;
      off += delta * stride;
      stride *= sn_[d];
    }
    offset_[static_cast<std::size_t>(s)] = off;
  }
  const auto st = static_cast<std::size_t>(total);
  prec_.assign(st * static_cast<std::size_t>(slots_), 0.0);
  eta_.assign(st, 0.0);
  mean_.assign(st, 0.0);
  bcoup_.assign(st, 0.0);
  touched_.assign(st, 0);
  seeded_.assign(st, 0);
  {
    const std::int64_t hb = block_half_width(rcut_, o.spacing);
    grid_sum_ = grid_sum2_ = 0;
    for (std::int64_t dk = -(dim == 3 ? hb : 0); dk <= (dim == 3 ? hb : 0); ++dk)
      for (std::int64_t dj = -hb; dj <= hb; ++dj)
        for (std::int64_t di = -hb; di <= hb; ++di) {
          const double d2 =
              (double(di * di) + double(dj * dj) + double(dk * dk)) * o.spacing * o.spacing;
          if (gamma_ * d2 > o.tau) continue;
          grid_sum_ += std::exp(-gamma_ * d2);
          grid_sum2_ += std::exp(-2 * gamma_ * d2);
        }
  }
  const std::size_t centre = static_cast<std::size_t>(slots_ / 2);
  for (std::int64_t k = 0; k < sn_[2]; ++k)
    for (std::int64_t j = 0; j < sn_[1]; ++j)
      for (std::int64_t i = 0; i < sn_[0]; ++i) {
        const bool inside = (i >= pad_ && i < pad_ + n_[0]) &&
                            (dim < 2 || (j >= pad_ && j < pad_ + n_[1])) &&
                            (dim < 3 || (k >= pad_ && k < pad_ + n_[2]));
        if (!inside) continue;
        const std::size_t s = static_cast<std::size_t>((k * sn_[1] + j) * sn_[0] + i);
        prec_[s * slots_ + centre] = 1.0 / o.prior_var;
      }
  if (o.bias) pbb_ = 1.0 / o.prior_var;
}

std::size_t JointBhm::size() const {
  std::size_t m = 1;
  for (int d = 0; d < dim_; ++d) m *= static_cast<std::size_t>(n_[d]);
  return m;
}

void JointBhm::features(const double* x, std::vector<Feature>& out) const {
  out.clear();
  std::int64_t a[3] = {0, 0, 0}, b[3] = {0, 0, 0};
  for (int d = 0; d < dim_; ++d) {
    const double u = (x[d] - lo_[d]) / o_.spacing;
    a[d] = std::max<std::int64_t>(0, static_cast<std::int64_t>(std::ceil(u - rcut_ / o_.spacing)));
    b[d] = std::min<std::int64_t>(n_[d] - 1,
                                  static_cast<std::int64_t>(std::floor(u + rcut_ / o_.spacing)));
    if (a[d] > b[d]) return;
  }
  for (std::int64_t k = a[2]; k <= b[2]; ++k)
    for (std::int64_t j = a[1]; j <= b[1]; ++j)
      for (std::int64_t i = a[0]; i <= b[0]; ++i) {
        const std::int64_t g[3] = {i, j, k};
        double d2 = 0;
        for (int d = 0; d < dim_; ++d) {
          const double t = x[d] - (lo_[d] + double(g[d]) * o_.spacing);
          d2 += t * t;
        }
        if (gamma_ * d2 > o_.tau) continue;
        Feature f;
        for (int d = 0; d < 3; ++d)
          f.cell[d] = static_cast<std::int32_t>(d < dim_ ? g[d] + pad_ : 0);
        f.kernel = static_cast<std::uint32_t>(
            (std::int64_t(f.cell[2]) * sn_[1] + f.cell[1]) * sn_[0] + f.cell[0]);
        f.phi = std::exp(-gamma_ * d2);
        out.push_back(f);
      }
}

void JointBhm::add_outer(const std::vector<Feature>& f, double c) {
  for (const Feature& fa : f) {
    double* row = &prec_[std::size_t(fa.kernel) * slots_];
    const double ca = c * fa.phi;
    for (const Feature& fb : f) {
      std::int64_t slot = 0;
      for (int d = dim_ - 1; d >= 0; --d) slot = slot * box_ + (fb.cell[d] - fa.cell[d] + pad_);
      row[slot] += ca * fb.phi;
    }
    bcoup_[fa.kernel] += ca;
  }
  pbb_ += c;
}

void JointBhm::multiply(const std::vector<double>& x, double xb,
                        const std::vector<std::uint32_t>& rows, std::vector<double>& y,
                        double& yb) const {
  yb = o_.bias ? pbb_ * xb : 0.0;
  const std::int64_t* off = offset_.data();
  for (std::uint32_t a : rows) {
    const double* row = &prec_[std::size_t(a) * slots_];
    const double* xa = &x[a];
    double s0 = 0, s1 = 0;
    std::int64_t s = 0;
    for (; s + 1 < slots_; s += 2) {
      s0 += row[s] * xa[off[s]];
      s1 += row[s + 1] * xa[off[s + 1]];
    }
    if (s < slots_) s0 += row[s] * xa[off[s]];
    double v = s0 + s1;
    if (o_.bias) {
      v += bcoup_[a] * xb;
      yb += bcoup_[a] * x[a];
    }
    y[a] = v;
  }
}

double JointBhm::solve(const std::vector<std::uint32_t>& rows, double tol, int max_it,
                       std::size_t* its) {
  // Conjugate gradients on the rows `rows` (and the bias), the other means held fixed, from
  // the current means. Jacobi preconditioner.
  const std::size_t st = mean_.size();
  const std::size_t centre = static_cast<std::size_t>(slots_ / 2);
  std::vector<double> r(st, 0.0), z(st, 0.0), p(st, 0.0), q(st, 0.0);
  double rb = 0, zb = 0, pb = 0, qb = 0;
  double yb = 0;
  multiply(mean_, meanb_, rows, q, yb);
  // The bias row reads every mean, not only those of `rows`.
  if (o_.bias) {
    yb = pbb_ * meanb_;
    for (std::size_t a = 0; a < st; ++a) yb += bcoup_[a] * mean_[a];
    rb = etab_ - yb;
  }
  double rr = rb * rb, ee = etab_ * etab_;
  for (std::uint32_t a : rows) {
    r[a] = eta_[a] - q[a];
    rr += r[a] * r[a];
    ee += eta_[a] * eta_[a];
  }
  const double stop = tol * tol * std::max(ee, 1e-300);
  auto precondition = [&] {
    double rz = 0;
    for (std::uint32_t a : rows) {
      z[a] = r[a] / prec_[std::size_t(a) * slots_ + centre];
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
    multiply(p, pb, rows, q, qb);
    double pq = pb * qb;
    for (std::uint32_t a : rows) pq += p[a] * q[a];
    if (!(pq > 0)) break;
    const double alpha = rz / pq;
    rr = 0;
    for (std::uint32_t a : rows) {
      mean_[a] += alpha * p[a];
      r[a] -= alpha * q[a];
      rr += r[a] * r[a];
    }
    if (o_.bias) {
      meanb_ += alpha * pb;
      rb -= alpha * qb;
      rr += rb * rb;
    }
    const double rz_new = precondition();
    const double beta = rz_new / rz;
    rz = rz_new;
    for (std::uint32_t a : rows) p[a] = z[a] + beta * p[a];
    pb = zb + beta * pb;
  }
  if (its) *its += static_cast<std::size_t>(it);
  return std::sqrt(rr / std::max(ee, 1e-300));
}

void JointBhm::update(const LabelledPoints& samples) {
  if (samples.dim != dim_)
    throw ArgumentError("joint BHM: samples are " + std::to_string(samples.dim) + "D, the map " +
                        std::to_string(dim_) + "D");
  if (samples.position.size() != samples.size() * std::size_t(dim_))
    throw ArgumentError("joint BHM: sample positions and labels disagree in number");
  stats_ = {};
  if (samples.empty()) return;
  const std::size_t centre = static_cast<std::size_t>(slots_ / 2);
  std::vector<std::vector<Feature>> feats;
  std::vector<double> yc;
  feats.reserve(samples.size());
  std::vector<Feature> f;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const double* x = &samples.position[i * dim_];
    bool finite = true;
    for (int d = 0; d < dim_; ++d) finite = finite && std::isfinite(x[d]);
    if (!finite) continue;
    features(x, f);
    if (f.empty()) continue;
    feats.push_back(f);
    yc.push_back(samples.label[i] ? 0.5 : -0.5);
  }
  const std::size_t n = feats.size();
  stats_.samples = n;
  if (n == 0) return;

  // Rows to solve: the kernels the scan reaches, grown by the margin.
  std::vector<std::uint8_t> mark(mean_.size(), 0);
  std::vector<std::uint32_t> reached;
  for (const auto& fs : feats)
    for (const Feature& x : fs)
      if (!mark[x.kernel]) {
        mark[x.kernel] = 1;
        touched_[x.kernel] = 1;
        reached.push_back(x.kernel);
      }
  std::vector<std::uint32_t> rows;
  const std::int64_t mg = o_.solve_margin;
  for (std::uint32_t a : reached) {
    std::int64_t c[3] = {0, 0, 0};
    std::int64_t rest = a;
    for (int d = 0; d < 3; ++d) {
      c[d] = rest % sn_[d];
      rest /= sn_[d];
    }
    const std::int64_t mz = dim_ == 3 ? mg : 0;
    for (std::int64_t dk = -mz; dk <= mz; ++dk)
      for (std::int64_t dj = -mg; dj <= mg; ++dj)
        for (std::int64_t di = -mg; di <= mg; ++di) {
          const std::int64_t g[3] = {c[0] + di, c[1] + dj, c[2] + dk};
          bool inside = true;
          for (int d = 0; d < dim_; ++d) inside = inside && g[d] >= pad_ && g[d] < pad_ + n_[d];
          if (!inside) continue;
          const std::size_t s = static_cast<std::size_t>((g[2] * sn_[1] + g[1]) * sn_[0] + g[0]);
          if (mark[s] == 2) continue;
          mark[s] = 2;
          rows.push_back(static_cast<std::uint32_t>(s));
        }
  }
  std::sort(rows.begin(), rows.end());
  stats_.active = rows.size();

  for (std::size_t i = 0; i < n; ++i) {
    for (const Feature& x : feats[i]) eta_[x.kernel] += yc[i] * x.phi;
    if (o_.bias) etab_ += yc[i];
  }
  // xi from the posterior before this scan; variances by the diagonal of the precision (a lower
  // bound of the marginal ones, cheap, and enough for the bound's curvature).
  auto xi_of = [&](const std::vector<Feature>& fs) {
    double mu = o_.bias ? meanb_ : 0.0, s2 = o_.bias ? 1.0 / pbb_ : 0.0;
    for (const Feature& x : fs) {
      mu += mean_[x.kernel] * x.phi;
      s2 += x.phi * x.phi / prec_[std::size_t(x.kernel) * slots_ + centre];
    }
    return std::sqrt(mu * mu + s2);
  };
  std::vector<double> lambda(n, 0.0), next(n);
  for (int it = 0; it < o_.em_iterations; ++it) {
    // Every xi from the same posterior, then the precision.
    for (std::size_t i = 0; i < n; ++i) next[i] = detail::jj_lambda(xi_of(feats[i]));
    for (std::size_t i = 0; i < n; ++i) {
      add_outer(feats[i], 2.0 * (next[i] - lambda[i]));
      lambda[i] = next[i];
    }
    stats_.residual = solve(rows, o_.cg_tolerance, o_.cg_max_iterations, &stats_.cg_iterations);
  }
}

void JointBhm::update_by_scan(const LabelledPoints& samples) {
  std::map<std::int64_t, std::vector<std::size_t>> by_scan;
  const bool has_scan = samples.scan.size() == samples.size();
  for (std::size_t i = 0; i < samples.size(); ++i)
    by_scan[has_scan ? samples.scan[i] : 0].push_back(i);
  LabelledPoints s;
  s.dim = samples.dim;
  for (const auto& [t, idx] : by_scan) {
    s.position.clear();
    s.label.clear();
    s.scan.clear();
    for (std::size_t i : idx) {
      for (int d = 0; d < s.dim; ++d) s.position.push_back(samples.position[i * s.dim + d]);
      s.label.push_back(samples.label[i]);
      s.scan.push_back(t);
    }
    update(s);
  }
}

double JointBhm::predictive_var_at(std::uint32_t k, std::vector<double>& scratch) const {
  // phi(h_k)^T (P_BB)^-1 phi(h_k) on the block B of kernels that reach h_k: the variance with
  // the kernels outside the block held at their means (a slight underestimate).
  const std::int64_t hb = block_half_width(rcut_, o_.spacing);
  std::int64_t c[3] = {0, 0, 0};
  std::int64_t rest = k;
  for (int d = 0; d < 3; ++d) {
    c[d] = rest % sn_[d];
    rest /= sn_[d];
  }
  std::vector<std::uint32_t> block;
  std::vector<std::int64_t> slot_base;
  std::vector<double> phi;
  const std::int64_t hz = dim_ == 3 ? hb : 0;
  for (std::int64_t dk = -hz; dk <= hz; ++dk)
    for (std::int64_t dj = -hb; dj <= hb; ++dj)
      for (std::int64_t di = -hb; di <= hb; ++di) {
        const std::int64_t g[3] = {c[0] + di, c[1] + dj, c[2] + dk};
        bool inside = true;
        for (int d = 0; d < dim_; ++d) inside = inside && g[d] >= pad_ && g[d] < pad_ + n_[d];
        if (!inside) continue;
        const double d2 =
            (double(di * di) + double(dj * dj) + double(dk * dk)) * o_.spacing * o_.spacing;
        if (gamma_ * d2 > o_.tau) continue;
        block.push_back(static_cast<std::uint32_t>((g[2] * sn_[1] + g[1]) * sn_[0] + g[0]));
        phi.push_back(std::exp(-gamma_ * d2));
      }
  const std::size_t b = block.size();
  scratch.assign(b * b, 0.0);
  Eigen::Map<Eigen::MatrixXd> A(scratch.data(), Eigen::Index(b), Eigen::Index(b));
  std::int64_t cell[3];
  for (std::size_t u = 0; u < b; ++u) {
    std::int64_t ru = block[u];
    for (int d = 0; d < 3; ++d) {
      cell[d] = ru % sn_[d];
      ru /= sn_[d];
    }
    const double* row = &prec_[std::size_t(block[u]) * slots_];
    for (std::size_t v = 0; v < b; ++v) {
      std::int64_t rv = block[v], slot = 0;
      std::int64_t cv[3];
      for (int d = 0; d < 3; ++d) {
        cv[d] = rv % sn_[d];
        rv /= sn_[d];
      }
      for (int d = dim_ - 1; d >= 0; --d) slot = slot * box_ + (cv[d] - cell[d] + pad_);
      A(Eigen::Index(u), Eigen::Index(v)) = row[slot];
    }
  }
  Eigen::Map<const Eigen::VectorXd> ph(phi.data(), Eigen::Index(b));
  const Eigen::LLT<Eigen::MatrixXd> llt(A);
  if (llt.info() != Eigen::Success) return o_.prior_var * ph.squaredNorm();
  return ph.dot(llt.solve(ph));
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
    a[d] = std::max<std::int64_t>(
        0, static_cast<std::int64_t>(std::floor((lo[d] - reach - lo_[d]) / o_.spacing)));
    b[d] = std::min<std::int64_t>(
        n_[d] - 1, static_cast<std::int64_t>(std::ceil((hi[d] + reach - lo_[d]) / o_.spacing)));
    if (a[d] > b[d]) return 0;
  }
  const std::size_t centre = static_cast<std::size_t>(slots_ / 2);
  const double floor_var = std::min(std::max(min_var, 1e-12), o_.prior_var);
  std::vector<std::uint32_t> near;
  std::size_t seeded = 0;
  for (std::int64_t k = a[2]; k <= b[2]; ++k)
    for (std::int64_t j = a[1]; j <= b[1]; ++j)
      for (std::int64_t i = a[0]; i <= b[0]; ++i) {
        const std::int64_t g[3] = {i + pad_, j + pad_, dim_ == 3 ? k + pad_ : 0};
        const std::size_t s = static_cast<std::size_t>((g[2] * sn_[1] + g[1]) * sn_[0] + g[0]);
        if (touched_[s] || seeded_[s]) continue;
        const double x[3] = {lo_[0] + double(i) * o_.spacing, lo_[1] + double(j) * o_.spacing,
                             lo_[2] + double(k) * o_.spacing};
        near.clear();
        index.query_box(x, x, near);
        double mu = 0, s2 = 0, support = 0;
        for (std::uint32_t m : near) {
          double d2 = 0;
          for (int d = 0; d < dim_; ++d) {
            const double t = x[d] - field.position[m * dim_ + d];
            d2 += t * t;
          }
          const double phi = std::exp(-field.gamma[m] * d2);
          mu += field.w_mean[m] * phi;
          s2 += field.w_var[m] * phi * phi;
          support += phi;
        }
        if (support < min_support) continue;
        const double m0 = mu / grid_sum_;
        const double v0 = std::min(o_.prior_var, std::max(floor_var, s2 / grid_sum2_));
        // Replace the prior's part of the natural parameters: precision 1/v0, eta m0/v0.
        prec_[s * slots_ + centre] += 1.0 / v0 - 1.0 / o_.prior_var;
        eta_[s] += m0 / v0;
        mean_[s] = m0;
        seeded_[s] = 1;
        ++seeded;
      }
  return seeded;
}

KernelMap JointBhm::map() {
  // Polish the means over every kernel a sample reached (and the margin).
  std::vector<std::uint32_t> rows;
  for (std::size_t a = 0; a < touched_.size(); ++a)
    if (touched_[a] || seeded_[a]) rows.push_back(static_cast<std::uint32_t>(a));
  if (!rows.empty()) solve(rows, 1e-8, 4 * o_.cg_max_iterations, nullptr);

  const std::int64_t hb = block_half_width(rcut_, o_.spacing);
  double sum_phi2 = 0;  // sum over the block of phi(h_k)^2 (the same for every interior kernel)
  for (std::int64_t dk = -(dim_ == 3 ? hb : 0); dk <= (dim_ == 3 ? hb : 0); ++dk)
    for (std::int64_t dj = -hb; dj <= hb; ++dj)
      for (std::int64_t di = -hb; di <= hb; ++di) {
        const double d2 =
            (double(di * di) + double(dj * dj) + double(dk * dk)) * o_.spacing * o_.spacing;
        if (gamma_ * d2 <= o_.tau) sum_phi2 += std::exp(-2 * gamma_ * d2);
      }
  KernelMap m;
  m.dim = dim_;
  m.reserve(size());
  std::vector<double> scratch;
  for (std::int64_t k = 0; k < n_[2]; ++k)
    for (std::int64_t j = 0; j < n_[1]; ++j)
      for (std::int64_t i = 0; i < n_[0]; ++i) {
        const std::int64_t g[3] = {i + pad_, dim_ >= 2 ? j + pad_ : j, dim_ == 3 ? k + pad_ : k};
        const auto s = static_cast<std::uint32_t>((g[2] * sn_[1] + g[1]) * sn_[0] + g[0]);
        const double p[3] = {lo_[0] + double(i) * o_.spacing, lo_[1] + double(j) * o_.spacing,
                             lo_[2] + double(k) * o_.spacing};
        // A kernel whose block no sample reached keeps its prior.
        bool near_data = false;
        for (std::int64_t dk = -(dim_ == 3 ? hb : 0); dk <= (dim_ == 3 ? hb : 0) && !near_data;
             ++dk)
          for (std::int64_t dj = -hb; dj <= hb && !near_data; ++dj)
            for (std::int64_t di = -hb; di <= hb && !near_data; ++di) {
              const std::int64_t idx = s + (dk * sn_[1] + dj) * sn_[0] + di;
              near_data = touched_[std::size_t(idx)] != 0 || seeded_[std::size_t(idx)] != 0;
            }
        double var = o_.prior_var;
        if (near_data) var = std::min(o_.prior_var, predictive_var_at(s, scratch) / sum_phi2);
        m.push_back(p, gamma_, mean_[s], var);
      }
  m.has_bias = o_.bias;
  if (o_.bias) {
    m.bias_mean = meanb_;
    m.bias_var = 1.0 / pbb_;
  }
  return m;
}

void JointBhm::predict_exact(const double* points, std::size_t n, double* mean, double* var) {
  // P over the interior kernels (and the bias, last) as a sparse matrix; one factorisation.
  std::vector<std::int64_t> index(mean_.size(), -1);
  std::vector<std::uint32_t> interior;
  for (std::int64_t k = 0; k < n_[2]; ++k)
    for (std::int64_t j = 0; j < n_[1]; ++j)
      for (std::int64_t i = 0; i < n_[0]; ++i) {
        const std::int64_t g[3] = {i + pad_, j + pad_, dim_ == 3 ? k + pad_ : 0};
        const std::size_t s = static_cast<std::size_t>((g[2] * sn_[1] + g[1]) * sn_[0] + g[0]);
        index[s] = std::int64_t(interior.size());
        interior.push_back(static_cast<std::uint32_t>(s));
      }
  const auto m = Eigen::Index(interior.size());
  const Eigen::Index dimp = m + (o_.bias ? 1 : 0);
  std::vector<Eigen::Triplet<double>> t;
  for (Eigen::Index u = 0; u < m; ++u) {
    const std::uint32_t a = interior[std::size_t(u)];
    const double* row = &prec_[std::size_t(a) * slots_];
    for (std::int64_t s = 0; s < slots_; ++s)
      if (row[s] != 0) {
        const std::int64_t b = std::int64_t(a) + offset_[std::size_t(s)];
        if (b >= 0 && std::size_t(b) < index.size() && index[std::size_t(b)] >= 0)
          t.emplace_back(u, Eigen::Index(index[std::size_t(b)]), row[s]);
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
  for (Eigen::Index u = 0; u < m; ++u) eta[u] = eta_[interior[std::size_t(u)]];
  if (o_.bias) eta[m] = etab_;
  const Eigen::VectorXd w = ldlt.solve(eta);
  std::vector<Feature> f;
  Eigen::VectorXd phi(dimp);
  for (std::size_t i = 0; i < n; ++i) {
    features(points + i * dim_, f);
    phi.setZero();
    for (const Feature& x : f) phi[index[x.kernel]] = x.phi;
    if (o_.bias) phi[m] = 1.0;
    mean[i] = phi.dot(w);
    var[i] = phi.dot(ldlt.solve(phi));
  }
}

}  // namespace potmap
