#include "refine.hpp"

#include <Eigen/Core>
#include <cmath>

#include "../learn/bhm_detail.hpp"
#include "potmap/error.hpp"

namespace potmap::detail {

namespace {

// Conjugate-gradient iterations per E-step and the relative residual they stop at. Warm starts
// from the previous EM round need a few tens; tightening 1e-4 to 1e-8 changed held-out scores
// by less than 1e-3 on the simulated towns and doubled the time.
constexpr int kMaxCg = 100;
constexpr double kCgTolerance = 1e-4;

}  // namespace

void refine_joint(KernelMap& map, const LabelledPoints& samples, const BhmOptions& options) {
  check_bhm_inputs(map, samples, options);
  if (map.has_bias) throw ArgumentError("refine_joint: maps with a bias weight are not supported");
  const std::size_t n = samples.size(), m = map.size();
  if (n == 0 || m == 0) return;
  const SampleKernelPairs pairs = build_pairs(map, samples, options.tau);
  const std::vector<double> phi = pair_features(map, samples, pairs);
  const Eigen::VectorXd mean0 = Eigen::Map<const Eigen::VectorXd>(map.w_mean.data(), m);
  const Eigen::VectorXd prec0 =
      Eigen::Map<const Eigen::VectorXd>(map.w_var.data(), m).cwiseInverse();

  // Phi x (per sample) and Phi^T u (per kernel).
  auto phi_x = [&](const Eigen::VectorXd& x, Eigen::VectorXd& out) {
    out.setZero(n);
    for (std::size_t i = 0; i < n; ++i)
      for (std::uint32_t j = pairs.sample_start[i]; j < pairs.sample_start[i + 1]; ++j)
        out[i] += phi[j] * x[pairs.sample_kernels[j]];
  };
  auto phit_u = [&](const Eigen::VectorXd& u, Eigen::VectorXd& out) {
    out.setZero(m);
    for (std::size_t i = 0; i < n; ++i)
      for (std::uint32_t j = pairs.sample_start[i]; j < pairs.sample_start[i + 1]; ++j)
        out[pairs.sample_kernels[j]] += phi[j] * u[i];
  };

  Eigen::VectorXd yc(n);
  for (std::size_t i = 0; i < n; ++i) yc[i] = samples.label[i] ? 0.5 : -0.5;
  Eigen::VectorXd rhs;
  phit_u(yc, rhs);
  rhs += mean0.cwiseProduct(prec0);

  Eigen::VectorXd lambda = Eigen::VectorXd::Constant(n, jj_lambda(options.xi_init));
  Eigen::VectorXd mean = mean0, diag(m), tmp_n, tmp_m;
  for (int it = 0; it < options.em_iterations; ++it) {
    // A = diag(prec0) + 2 Phi^T Lambda Phi; its diagonal is the mean-field precision.
    diag = prec0;
    for (std::size_t i = 0; i < n; ++i)
      for (std::uint32_t j = pairs.sample_start[i]; j < pairs.sample_start[i + 1]; ++j)
        diag[pairs.sample_kernels[j]] += 2.0 * lambda[i] * phi[j] * phi[j];
    auto apply = [&](const Eigen::VectorXd& x, Eigen::VectorXd& out) {
      phi_x(x, tmp_n);
      tmp_n = 2.0 * lambda.cwiseProduct(tmp_n);
      phit_u(tmp_n, out);
      out += prec0.cwiseProduct(x);
    };
    // Jacobi-preconditioned CG from the current mean.
    Eigen::VectorXd r, z, p, q;
    apply(mean, tmp_m);
    r = rhs - tmp_m;
    const double stop = kCgTolerance * kCgTolerance * rhs.squaredNorm();
    z = r.cwiseQuotient(diag);
    p = z;
    double rz = r.dot(z);
    for (int c = 0; c < kMaxCg && r.squaredNorm() > stop; ++c) {
      apply(p, q);
      const double alpha = rz / p.dot(q);
      mean += alpha * p;
      r -= alpha * q;
      z = r.cwiseQuotient(diag);
      const double rz_new = r.dot(z);
      p = z + (rz_new / rz) * p;
      rz = rz_new;
    }
    const Eigen::VectorXd var = diag.cwiseInverse();
    if (it + 1 < options.em_iterations) {
      // M-step: xi_n^2 = (phi_n . wbar)^2 + sum_m phi_nm^2 wvar_m.
      phi_x(mean, tmp_n);
      for (std::size_t i = 0; i < n; ++i) {
        double s2 = 0;
        for (std::uint32_t j = pairs.sample_start[i]; j < pairs.sample_start[i + 1]; ++j)
          s2 += phi[j] * phi[j] * var[pairs.sample_kernels[j]];
        lambda[i] = jj_lambda(std::sqrt(tmp_n[i] * tmp_n[i] + s2));
      }
    }
    for (std::size_t k = 0; k < m; ++k) {
      map.w_mean[k] = mean[k];
      map.w_var[k] = var[k];
    }
  }
}

}  // namespace potmap::detail
