// Double-precision CPU reference for the device solver: dense cost, log-domain updates, error
// checked every iteration. Slow and plain on purpose: tests compare against it.

#include <cmath>

#include "potmap/error.hpp"
#include "potmap/ot/sinkhorn.hpp"

namespace potmap {

namespace {

Eigen::MatrixXd transformed_source(const SinkhornProblem& q) {
  Eigen::MatrixXd x = q.source;
  const double c = std::cos(q.angle), s = std::sin(q.angle);
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    const double ux = q.source(i, 0) - q.centre.x(), uy = q.source(i, 1) - q.centre.y();
    x(i, 0) = q.centre.x() + c * ux - s * uy;
    x(i, 1) = q.centre.y() + s * ux + c * uy;
  }
  return x * q.scale;
}

double lse(const Eigen::ArrayXd& v) {
  const double m = v.maxCoeff();
  return m + std::log((v - m).exp().sum());
}

}  // namespace

Eigen::MatrixXd sinkhorn_cost(const SinkhornProblem& q) {
  if (q.source.rows() == 0 || q.target.rows() == 0)
    throw ArgumentError("sinkhorn_cost: empty point set");
  const Eigen::MatrixXd x = transformed_source(q);
  const Eigen::MatrixXd y = q.target * q.scale;
  Eigen::MatrixXd C(x.rows(), y.rows());
  for (Eigen::Index i = 0; i < x.rows(); ++i)
    C.row(i) = (y.rowwise() - x.row(i)).rowwise().squaredNorm().transpose();
  if (q.normalise_cost && C.maxCoeff() > 0) C /= C.maxCoeff();
  return C;
}

SinkhornResult sinkhorn_reference(const SinkhornProblem& q) {
  const Eigen::MatrixXd C = sinkhorn_cost(q);
  const Eigen::Index n = C.rows(), m = C.cols();
  const Eigen::ArrayXd a = q.source_weights.size() ? Eigen::ArrayXd(q.source_weights)
                                                   : Eigen::ArrayXd::Constant(n, 1.0 / n);
  const Eigen::ArrayXd b = q.target_weights.size() ? Eigen::ArrayXd(q.target_weights)
                                                   : Eigen::ArrayXd::Constant(m, 1.0 / m);
  const Eigen::ArrayXd la = a.log(), lb = b.log();
  const double eps = q.epsilon;
  Eigen::ArrayXd f = Eigen::ArrayXd::Zero(n), g = Eigen::ArrayXd::Zero(m);
  SinkhornResult r;
  // Work rows for lse(), reused: the same values as a temporary a row every iteration, whose
  // allocations cost a fifth of the reference's time under AddressSanitizer.
  Eigen::ArrayXd along_m(m), along_n(n);
  auto row_error = [&](Eigen::ArrayXd* lse_rows) {
    double e = 0;
    for (Eigen::Index i = 0; i < n; ++i) {
      along_m = (g - C.row(i).transpose().array()) / eps + lb;
      const double l = lse(along_m);
      if (lse_rows) (*lse_rows)(i) = l;
      e += std::abs(std::exp(f(i) / eps + la(i) + l) - a(i));
    }
    return e;
  };
  int it = 0;
  Eigen::ArrayXd lrows(n);
  for (;;) {
    if (it > 0) {
      r.marginal_error = row_error(&lrows);
      if (r.marginal_error < q.tolerance) {
        r.converged = true;
        break;
      }
    } else {
      row_error(&lrows);
    }
    if (it >= q.max_iterations) break;
    f = -eps * lrows;
    for (Eigen::Index j = 0; j < m; ++j) {
      along_n = (f - C.col(j).array()) / eps + la;
      g(j) = -eps * lse(along_n);
    }
    ++it;
  }
  if (!r.converged) {
    r.marginal_error = row_error(nullptr);
    r.converged = r.marginal_error < q.tolerance;
  }
  r.iterations = it;
  r.f = f.matrix();
  r.g = g.matrix();
  r.coupling.resize(n, m);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < m; ++j)
      r.coupling(i, j) = std::exp((f(i) + g(j) - C(i, j)) / eps + la(i) + lb(j));
  r.cost = (r.coupling.array() * C.array()).sum();
  const Eigen::VectorXd rows = r.coupling.rowwise().sum();
  r.barycentric = (r.coupling * q.target).array().colwise() / rows.array();
  r.extra_mapped = out_of_sample_map(q, r.barycentric, q.extra_points);
  return r;
}

}  // namespace potmap
