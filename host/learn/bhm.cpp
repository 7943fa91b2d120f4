#include "potmap/learn/bhm.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include "bhm_detail.hpp"
#include "map/kernel_index.hpp"
#include "potmap/error.hpp"

namespace potmap {

namespace detail {

double jj_lambda(double xi) {
  xi = std::abs(xi);
  // The limit at 0 is 1/8; the series keeps full precision where (sigmoid - 1/2) cancels.
  if (xi < 1e-4) return 0.125 - xi * xi / 96.0;
  return (1.0 / (1.0 + std::exp(-xi)) - 0.5) / (2.0 * xi);
}

void check_bhm_inputs(const KernelMap& map, const LabelledPoints& samples,
                      const BhmOptions& options) {
  map.validate("BHM prior");
  if (samples.dim != map.dim)
    throw ArgumentError("BHM: samples are " + std::to_string(samples.dim) + "D, the map " +
                        std::to_string(map.dim) + "D");
  if (samples.position.size() != samples.size() * samples.dim)
    throw ArgumentError("BHM: sample positions and labels disagree in number");
  if (options.em_iterations < 1) throw ArgumentError("BHM: em_iterations must be at least 1");
  if (!(options.xi_init > 0) || !std::isfinite(options.xi_init))
    throw ArgumentError("BHM: xi_init must be positive and finite");
  if (!(options.tau > 0)) throw ArgumentError("BHM: tau must be positive");
  for (std::size_t k = 0; k < map.size(); ++k)
    if (!(map.w_var[k] > 0))
      throw ArgumentError("BHM: kernel " + std::to_string(k) + " has prior variance 0");
  if (map.has_bias && !(map.bias_var > 0))
    throw ArgumentError("BHM: the bias weight has prior variance 0");
}

SampleKernelPairs build_pairs(const KernelMap& map, const LabelledPoints& samples, double tau) {
  SampleKernelPairs p;
  const std::size_t n = samples.size();
  p.sample_start.assign(n + 1, 0);
  KernelIndex index(map, tau);
  std::vector<std::uint32_t> found;
  for (std::size_t i = 0; i < n; ++i) {
    double x[3] = {0, 0, 0};
    for (int d = 0; d < map.dim; ++d) x[d] = samples.position[i * map.dim + d];
    found.clear();
    index.query_box(x, x, found);
    p.sample_kernels.insert(p.sample_kernels.end(), found.begin(), found.end());
    p.sample_start[i + 1] = static_cast<std::uint32_t>(p.sample_kernels.size());
  }
  // Transpose: per kernel, the samples it reaches (in sample order, so sums are reproducible).
  const std::size_t m = map.size();
  p.kernel_start.assign(m + 1, 0);
  for (std::uint32_t k : p.sample_kernels) ++p.kernel_start[k + 1];
  for (std::size_t k = 0; k < m; ++k) p.kernel_start[k + 1] += p.kernel_start[k];
  p.kernel_samples.resize(p.sample_kernels.size());
  std::vector<std::uint32_t> fill(p.kernel_start.begin(), p.kernel_start.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    for (std::uint32_t j = p.sample_start[i]; j < p.sample_start[i + 1]; ++j)
      p.kernel_samples[fill[p.sample_kernels[j]]++] = static_cast<std::uint32_t>(i);
  return p;
}

std::vector<double> pair_features(const KernelMap& map, const LabelledPoints& samples,
                                  const SampleKernelPairs& pairs) {
  const std::size_t n = samples.size();
  const int dim = map.dim;
  std::vector<double> phi(pairs.sample_kernels.size());
  for (std::size_t i = 0; i < n; ++i)
    for (std::uint32_t j = pairs.sample_start[i]; j < pairs.sample_start[i + 1]; ++j) {
      const std::uint32_t k = pairs.sample_kernels[j];
      double d2 = 0;
      for (int d = 0; d < dim; ++d) {
        const double t = samples.position[i * dim + d] - map.position[k * dim + d];
        d2 += t * t;
      }
      phi[j] = std::exp(-map.gamma[k] * d2);
    }
  return phi;
}

void bhm_posterior(KernelMap& map, const std::vector<double>& prior_mean,
                   const std::vector<double>& prior_var, const double* sum_lambda_phi2,
                   const double* sum_y_phi, double bias_lambda, double bias_y, double bias_mean0,
                   double bias_var0) {
  for (std::size_t k = 0; k < map.size(); ++k) {
    const double prec = 1.0 / prior_var[k] + 2.0 * sum_lambda_phi2[k];
    map.w_var[k] = 1.0 / prec;
    map.w_mean[k] = map.w_var[k] * (prior_mean[k] / prior_var[k] + sum_y_phi[k]);
  }
  if (map.has_bias) {
    map.bias_var = 1.0 / (1.0 / bias_var0 + 2.0 * bias_lambda);
    map.bias_mean = map.bias_var * (bias_mean0 / bias_var0 + bias_y);
  }
}

}  // namespace detail

KernelMap bhm_grid_prior(int dim, const double lo[3], const double hi[3], double spacing,
                         double gamma, double w_mean0, double w_var0, bool bias) {
  if (dim != 2 && dim != 3) throw ArgumentError("BHM grid: dimension must be 2 or 3");
  if (!(spacing > 0) || !std::isfinite(spacing))
    throw ArgumentError("BHM grid: spacing must be positive");
  if (!(gamma > 0) || !std::isfinite(gamma)) throw ArgumentError("BHM grid: gamma must be > 0");
  if (!(w_var0 > 0) || !std::isfinite(w_var0))
    throw ArgumentError("BHM grid: prior variance must be > 0");
  std::int64_t n[3] = {1, 1, 1};
  std::int64_t total = 1;
  for (int d = 0; d < dim; ++d) {
    if (!(hi[d] >= lo[d])) throw ArgumentError("BHM grid: bounds must satisfy lo <= hi");
    // The small slack keeps hi on the grid when (hi - lo) / spacing is an integer up to rounding.
    n[d] = static_cast<std::int64_t>(std::floor((hi[d] - lo[d]) / spacing + 1e-9)) + 1;
    total *= n[d];
    if (total > (std::int64_t(1) << 28)) throw ArgumentError("BHM grid: too many kernels");
  }
  KernelMap map;
  map.dim = dim;
  map.reserve(static_cast<std::size_t>(total));
  for (std::int64_t k = 0; k < n[2]; ++k)
    for (std::int64_t j = 0; j < n[1]; ++j)
      for (std::int64_t i = 0; i < n[0]; ++i) {
        const double p[3] = {lo[0] + i * spacing, lo[1] + j * spacing, lo[2] + k * spacing};
        map.push_back(p, gamma, w_mean0, w_var0);
      }
  map.has_bias = bias;
  if (bias) {
    map.bias_mean = w_mean0;
    map.bias_var = w_var0;
  }
  return map;
}

void bhm_update_reference(KernelMap& map, const LabelledPoints& samples,
                          const BhmOptions& options) {
  detail::check_bhm_inputs(map, samples, options);
  const std::size_t n = samples.size(), m = map.size();
  const detail::SampleKernelPairs pairs = detail::build_pairs(map, samples, options.tau);
  const std::vector<double> phi = detail::pair_features(map, samples, pairs);
  const std::vector<double> mean0 = map.w_mean, var0 = map.w_var;
  const double bmean0 = map.bias_mean, bvar0 = map.bias_var;
  Eigen::VectorXd lambda = Eigen::VectorXd::Constant(n, detail::jj_lambda(options.xi_init));
  Eigen::VectorXd a(m), b(m);
  for (int it = 0; it < options.em_iterations; ++it) {
    // E-step.
    a.setZero();
    b.setZero();
    double ba = 0, bb = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double y = samples.label[i] ? 0.5 : -0.5;
      for (std::uint32_t j = pairs.sample_start[i]; j < pairs.sample_start[i + 1]; ++j) {
        const std::uint32_t k = pairs.sample_kernels[j];
        a[k] += lambda[i] * phi[j] * phi[j];
        b[k] += y * phi[j];
      }
      ba += lambda[i];
      bb += y;
    }
    detail::bhm_posterior(map, mean0, var0, a.data(), b.data(), ba, bb, bmean0, bvar0);
    if (it + 1 == options.em_iterations) break;
    // M-step.
    for (std::size_t i = 0; i < n; ++i) {
      double mu = map.has_bias ? map.bias_mean : 0.0, s2 = map.has_bias ? map.bias_var : 0.0;
      for (std::uint32_t j = pairs.sample_start[i]; j < pairs.sample_start[i + 1]; ++j) {
        const std::uint32_t k = pairs.sample_kernels[j];
        mu += map.w_mean[k] * phi[j];
        s2 += map.w_var[k] * phi[j] * phi[j];
      }
      lambda[i] = detail::jj_lambda(std::sqrt(s2 + mu * mu));
    }
  }
}

void bhm_update_sequential(Context* ctx, KernelMap& map, const LabelledPoints& samples,
                           const BhmOptions& options) {
  std::map<std::int64_t, std::vector<std::size_t>> by_scan;
  for (std::size_t i = 0; i < samples.size(); ++i)
    by_scan[samples.scan.size() == samples.size() ? samples.scan[i] : 0].push_back(i);
  for (const auto& [t, idx] : by_scan) {
    (void)t;
    LabelledPoints s;
    s.dim = samples.dim;
    for (std::size_t i : idx) {
      for (int d = 0; d < s.dim; ++d) s.position.push_back(samples.position[i * s.dim + d]);
      s.label.push_back(samples.label[i]);
      s.scan.push_back(t);
    }
    if (ctx)
      bhm_update(*ctx, map, s, options);
    else
      bhm_update_reference(map, s, options);
  }
}

}  // namespace potmap
